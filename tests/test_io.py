"""Tests of the iwp data format (iwp.io) and of ``iwp convert``."""

from __future__ import annotations

import dataclasses
import math
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.io

import iwp.cli
from iwp import data as io
from iwp.data import write_experiment, write_static_curve
from iwp.errors import DataFormatError, InputError, OutputExistsError

REAL_LOG = Path(__file__).resolve().parents[2] / "shared/data/real/pendulum_free_swing_data_01.txt"


# --------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------
def make_data(n=50, Ts=0.01, input_name="u", velocities=True, extra=True, metadata=None, seed=0):
    rng = np.random.default_rng(seed)
    t = 0.5 + Ts * np.arange(n)
    kw = dict(t=t, q1=rng.normal(size=n), q2=np.cumsum(rng.normal(size=n)))
    if velocities:
        kw.update(q3=rng.normal(size=n) * 3, q4=rng.normal(size=n) * 100)
    if input_name:
        kw[input_name] = rng.normal(size=n) * 60
    if extra:
        kw["extra"] = {"current": rng.normal(size=n), "mode": np.arange(n) % 3}
    return io.ExperimentData(
        **kw,
        metadata={"rig": "IWP-1", "note": "a: b, c", "Ts": "0.01"} if metadata is None else metadata,
        source="mem",
    )


def assert_same(a: io.ExperimentData, b: io.ExperimentData, metadata=True):
    """Bit-exact equality of every column (and the metadata)."""
    assert a.as_columns().keys() == b.as_columns().keys()
    for name, arr in a.as_columns().items():
        other = b.as_columns()[name]
        assert arr.dtype == other.dtype == np.float64
        assert np.array_equal(arr.view(np.uint64), other.view(np.uint64)), name
    if metadata:
        assert a.metadata == b.metadata


def write_lines(path: Path, lines) -> Path:
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def csv_lines(n=20, Ts=0.01, cols=("t", "q1", "q2"), start=0.0):
    rows = [",".join(cols)]
    for k in range(n):
        t = start + k * Ts
        vals = {"t": t, "q1": 0.1 * math.sin(t), "q2": 2.0 * t, "q3": 0.1, "q4": 3.0, "u": 1.0, "v": 2.0}
        vals.update(time=vals["t"], theta=vals["q1"], phi=vals["q2"])
        rows.append(",".join(repr(vals.get(c, 7.0)) for c in cols))
    return rows


def m(*parts):
    """A match pattern requiring every part, in order, anywhere in the message."""
    return ".*".join(re.escape(p) for p in parts)


@pytest.fixture
def cli(monkeypatch):
    """``iwp.cli.main`` with only the convert subcommand (independent of the others)."""
    monkeypatch.setattr(iwp.cli, "_COMMANDS", ["convert"])
    return iwp.cli.main


# --------------------------------------------------------------------------
# ExperimentData
# --------------------------------------------------------------------------
def test_experiment_data_properties():
    d = make_data(n=40, Ts=0.005, input_name="v")
    assert d.n_samples == 40
    assert d.Ts == pytest.approx(0.005, rel=1e-12)
    assert d.input_name == "v" and d.input is d.v
    free = make_data(input_name=None)
    assert free.input_name is None
    assert np.array_equal(free.input, np.zeros(free.n_samples))
    assert d.q1.flags.writeable is False
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.q1 = d.q2


def test_experiment_data_copies_input():
    q1 = np.zeros(5)
    d = io.ExperimentData(t=np.arange(5.0), q1=q1, q2=np.zeros(5))
    q1[0] = 1.0
    assert d.q1[0] == 0.0


@pytest.mark.parametrize(
    "kw, pattern",
    [
        (dict(q1=np.zeros(4)), "q1 has 4 samples but t has 5"),
        (dict(q4=np.zeros(6)), "q4 has 6 samples but t has 5"),
        (dict(u=np.zeros(5), v=np.zeros(5)), "both u and v"),
        (dict(q2=np.zeros((5, 1))), "q2 must be a 1-D array"),
        (dict(t=np.array([0, 1, 1, 2, 3.0])), "t must be strictly increasing"),
        (dict(q3=np.array([0, 1, np.nan, 2, 3.0])), "q3[2]"),
        (dict(extra={"q1": np.zeros(5)}), "reserved iwp name"),
        (dict(extra={"x": np.zeros(3)}), "extra['x'] has 3 samples"),
        (dict(metadata={"a:b": "c"}), "must not contain ':'"),
    ],
)
def test_experiment_data_validates(kw, pattern):
    base = dict(t=np.arange(5.0), q1=np.zeros(5), q2=np.zeros(5))
    base.update(kw)
    with pytest.raises(InputError, match=re.escape(pattern)):
        io.ExperimentData(**base)


def test_window_cuts_and_names_argument():
    d = make_data(n=100, Ts=0.01)  # t from 0.5 to 1.49
    w = d.window(0.7, 0.8)
    assert w.t[0] >= 0.7 - 1e-12 and w.t[-1] <= 0.8 + 1e-12
    assert w.n_samples == 11
    assert np.array_equal(w.q4, d.q4[20:31]) and np.array_equal(w.extra["current"], d.extra["current"][20:31])
    assert w.metadata == d.metadata and w.input_name == "u"
    assert d.window(t_end=0.6).n_samples == 11
    with pytest.raises(InputError, match=m("t_start", "must be < t_end")):
        d.window(1.0, 0.9)
    with pytest.raises(InputError, match=m("t_start=1.49", "keeps 1 sample")):
        d.window(t_start=1.49)
    with pytest.raises(InputError, match=m("t_end=0.1", "keeps 0 sample")):
        d.window(t_end=0.1)


# --------------------------------------------------------------------------
# round trips
# --------------------------------------------------------------------------
def test_csv_round_trip_bit_exact(tmp_path):
    d = make_data()
    # awkward values: repr-exact writing must keep every bit (the largest double in an extra column:
    # the readers refuse it in a state column, see test_reader_refuses_magnitudes_beyond_any_rig)
    q2 = d.q2.copy()
    q2[:6] = [0.1, 1 / 3, -0.0, 5e-324, 987654.3210987654, -2.220446049250313e-16]
    mode = np.asarray(d.extra["mode"], dtype=float).copy()
    mode[:2] = [1.7976931348623157e308, -1.7976931348623157e308]
    d = dataclasses.replace(d, q2=q2, extra={**d.extra, "mode": mode})
    path = write_experiment(d, tmp_path / "log.csv")
    text = path.read_text()
    assert text.startswith("# rig: IWP-1\n# note: a: b, c\n# Ts: 0.01\nt,q1,q2,q3,q4,u,current,mode\n")
    back = io.read_csv(path)
    assert_same(d, back)
    assert back.source == str(path)
    assert np.signbit(back.q2[2])  # -0.0 survived
    assert back.extra.keys() == {"current", "mode"}


@pytest.mark.parametrize("input_name", ["v", None])
def test_csv_round_trip_inputs(tmp_path, input_name):
    d = make_data(input_name=input_name, velocities=False, extra=False, metadata={})
    back = io.read_experiment(write_experiment(d, tmp_path / "x.txt"))
    assert back.input_name == input_name
    assert back.q3 is None and back.q4 is None and back.extra == {}
    assert_same(d, back)


def test_csv_metadata_anywhere_and_comments(tmp_path):
    lines = csv_lines(12)
    lines = ["# a: 1", "#", "# just a remark", ""] + lines[:5] + ["# b: two: 2", ""] + lines[5:] + ["# c:3"]
    d = io.read_csv(write_lines(tmp_path / "c.csv", lines))
    assert d.metadata == {"a": "1", "b": "two: 2", "c": "3"}
    assert d.n_samples == 12


def test_csv_whitespace_delimited(tmp_path):
    lines = [ln.replace(",", "  ") for ln in csv_lines(12)]
    d = io.read_csv(write_lines(tmp_path / "w.txt", lines))
    assert d.n_samples == 12 and d.Ts == pytest.approx(0.01)


def test_static_curve_round_trip(tmp_path):
    c = io.StaticCurve("v", input=[-60, -40, -31, 0, 31.5, 40, 60], q4=[-300.25, -120.0, 0, 0, 0, 118.1, 1 / 3],
                       metadata={"fig": "2a"})
    path = io.write_static_curve(c, tmp_path / "dz.csv")
    assert path.read_text().splitlines()[:2] == ["# fig: 2a", "v,q4"]
    back = io.read_static_curve(path)
    assert back.input_name == "v" and back.metadata == {"fig": "2a"}
    assert np.array_equal(back.input, c.input) and np.array_equal(back.q4, c.q4)
    u = io.read_static_curve(write_static_curve(io.StaticCurve("u", [1.0, 2.0], [3.0, 4.0]), tmp_path / "u.csv"))
    assert u.input_name == "u" and list(u.q4) == [3.0, 4.0]
    with pytest.raises(OutputExistsError):
        io.write_static_curve(c, path)


def test_mat_round_trip(tmp_path):
    d = make_data(input_name="v")
    path = write_experiment(d, tmp_path / "log.mat")
    back = io.read_mat(path)
    assert_same(d, back)
    assert io.read_experiment(path).input_name == "v"
    # variables are top-level with the canonical names
    raw = scipy.io.loadmat(path)
    assert {"t", "q1", "q2", "q3", "q4", "v", "current", "mode", "iwp_metadata"} <= set(raw)


def test_mat_write_refuses_bad_extra_name(tmp_path):
    d = dataclasses.replace(make_data(extra=False), extra={"motor current": np.zeros(50)})
    with pytest.raises(InputError, match="'motor current'"):
        write_experiment(d, tmp_path / "x.mat")


def test_mat_struct_with_mapping(tmp_path):
    n = 30
    t = np.arange(n) * 0.005
    log = {"time": t, "theta": np.sin(t)[None, :], "phi": (2 * t)[:, None], "volts": 3 * t, "note": "hello"}
    scipy.io.savemat(tmp_path / "s.mat", {"log": log, "gain": 2.0})
    mapping = {"t": "time", "q1": "theta", "q2": "phi", "u": "volts"}
    d = io.read_mat(tmp_path / "s.mat", mapping=mapping, struct="log")
    assert np.array_equal(d.q1, np.sin(t)) and np.array_equal(d.u, 3 * t)
    # the only struct is found without struct=
    d2 = io.read_experiment(tmp_path / "s.mat", mapping=mapping)
    assert_same(d, d2)
    with pytest.raises(DataFormatError, match=m("s.mat", "'angle' (mapped to q1) not found", "theta")):
        io.read_mat(tmp_path / "s.mat", mapping={"t": "time", "q1": "angle", "q2": "phi"})
    with pytest.raises(DataFormatError, match=m("s.mat", "no variable 'nope'")):
        io.read_mat(tmp_path / "s.mat", struct="nope")


def test_mat_simulink_structure_with_time(tmp_path):
    n = 25
    t = np.arange(n) * 0.01
    sig = np.zeros(2, dtype=[("values", object), ("label", object)])
    sig[0] = (np.sin(t)[:, None], "theta")
    sig[1] = (np.cos(t)[:, None], "phi")
    scipy.io.savemat(tmp_path / "sl.mat", {"out": {"time": t[:, None], "signals": sig}})
    d = io.read_mat(tmp_path / "sl.mat", mapping={"q1": "theta", "q2": "phi"})
    assert np.array_equal(d.t, t) and np.array_equal(d.q2, np.cos(t))


def test_parquet_round_trip(tmp_path):
    pytest.importorskip("pyarrow")
    d = make_data(metadata={"rig": "IWP-1", "empty": ""})
    path = write_experiment(d, tmp_path / "log.parquet")
    back = io.read_parquet(path)
    assert_same(d, back)
    assert_same(d, io.read_experiment(path))


def test_parquet_without_pyarrow(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(InputError, match=m("pip install pyarrow", "iwp[parquet]")):
        write_experiment(make_data(), tmp_path / "x.parquet")
    (tmp_path / "y.pq").write_bytes(b"PAR1")
    with pytest.raises(InputError, match="pip install pyarrow"):
        io.read_experiment(tmp_path / "y.pq")


def test_parquet_bad_inputs(tmp_path):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    n = 20
    t = list(np.arange(n) * 0.01)
    q1 = [0.0] * n
    q1[7] = None
    pq.write_table(pa.table({"t": t, "q1": q1, "q2": [0.0] * n}), tmp_path / "null.parquet")
    with pytest.raises(DataFormatError, match=m("null.parquet", "row 8", "'q1'", "null")):
        io.read_parquet(tmp_path / "null.parquet")
    pq.write_table(pa.table({"t": t, "q1": ["a"] * n, "q2": [0.0] * n}), tmp_path / "text.parquet")
    with pytest.raises(DataFormatError, match=m("text.parquet", "'q1'", "string")):
        io.read_parquet(tmp_path / "text.parquet")
    q2 = [0.0] * n
    q2[3] = float("inf")
    pq.write_table(pa.table({"t": t, "q1": [0.0] * n, "q2": q2}), tmp_path / "inf.parquet")
    with pytest.raises(DataFormatError, match=m("inf.parquet", "row 4", "'q2'", "not a finite")):
        io.read_parquet(tmp_path / "inf.parquet")
    (tmp_path / "junk.parquet").write_text("t,q1,q2\n")
    with pytest.raises(DataFormatError, match=m("junk.parquet", "not a readable Parquet")):
        io.read_parquet(tmp_path / "junk.parquet")


def test_output_never_overwritten_without_force(tmp_path):
    d = make_data()
    for name in ("a.csv", "a.mat", "a.parquet"):
        path = tmp_path / name
        path.write_text("precious")
        with pytest.raises(OutputExistsError, match=re.escape(name)):
            io.write_experiment(d, path)
        assert path.read_text() == "precious"
        io.write_experiment(d, path, force=True)
        assert_same(d, io.read_experiment(path))


def test_read_experiment_dispatch_errors(tmp_path):
    path = write_lines(tmp_path / "log.dat", csv_lines())
    with pytest.raises(InputError, match=m("log.dat", "'.dat'")):
        io.read_experiment(path)
    assert io.read_experiment(path, format="csv").n_samples == 20
    with pytest.raises(InputError, match=m("struct", "do not apply to csv")):
        io.read_experiment(path, format="csv", struct="log")
    with pytest.raises(InputError, match="format must be one of"):
        io.read_experiment(path, format="xlsx")


# --------------------------------------------------------------------------
# bad CSV inputs: one line naming file, line and column
# --------------------------------------------------------------------------
BAD_CSV = {
    # name: (lines, pattern parts)
    "missing": (csv_lines(cols=("t", "q1", "u")), ("missing.csv", "line 1", "missing required column q2", "found: t, q1, u")),
    "text": (csv_lines()[:6] + ["0.05,abc,0.1"] + csv_lines(start=0.06)[1:], ("text.csv", "line 7", "column 'q1'", "'abc' is not a number")),
    "empty_field": (csv_lines()[:4] + ["0.03,,0.1"] + csv_lines(start=0.04)[1:], ("empty_field.csv", "line 5", "column 'q1'", "empty value")),
    "nan": (csv_lines()[:3] + ["0.02,0.0,nan"] + csv_lines(start=0.03)[1:], ("nan.csv", "line 4", "column 'q2'", "NaN or inf")),
    "inf": (csv_lines()[:10] + ["0.09,-inf,0.0"] + csv_lines(start=0.1)[1:], ("inf.csv", "line 11", "column 'q1'", "NaN or inf")),
    "nonincreasing": (csv_lines(5) + ["0.04,0,0"] + csv_lines(start=0.05)[1:], ("nonincreasing.csv", "line 7", "column 't'", "not strictly increasing")),
    "irregular": (csv_lines(8) + csv_lines(start=0.085)[1:], ("irregular.csv", "line 10", "column 't'", "irregular sampling", "iwp convert --resample", "resample=True")),
    "few": (csv_lines(5), ("few.csv", "5 sample(s)", "at least 10", "min_samples")),
    "duplicate": (["t,q1,q2,q1"] + [r + ",0" for r in csv_lines()[1:]], ("duplicate.csv", "line 1", "duplicated column name 'q1'")),
    "both_inputs": (csv_lines(cols=("t", "q1", "q2", "u", "v")), ("both_inputs.csv", "line 1", "both input columns u", "v", "at most one input")),
    "short_row": (csv_lines()[:3] + ["0.02,0.1"] + csv_lines(start=0.03)[1:], ("short_row.csv", "line 4", "2 value(s)", "3 columns")),
    "no_rows": (["# a: 1", "t,q1,q2"], ("no_rows.csv", "no data rows", "line 2")),
    "no_header": (["# a: 1", "#"], ("no_header.csv", "no header row")),
}


@pytest.mark.parametrize("name", sorted(BAD_CSV))
def test_bad_csv_gives_one_line_error(tmp_path, name):
    lines, parts = BAD_CSV[name]
    path = write_lines(tmp_path / f"{name}.csv", lines)
    with pytest.raises(DataFormatError, match=m(*parts)) as info:
        io.read_csv(path)
    assert "\n" not in str(info.value)


def test_csv_line_numbers_count_comments_and_blank_lines(tmp_path):
    lines = ["# a: 1", "", "# b: 2"] + csv_lines()[:3] + ["# mid: x", "", "0.03,oops,0.06"] + csv_lines(start=0.04)[1:]
    with pytest.raises(DataFormatError, match=m("lines.csv", "line 9", "column 'q1'", "'oops'")):
        io.read_csv(write_lines(tmp_path / "lines.csv", lines))


def test_empty_and_binary_files(tmp_path):
    (tmp_path / "empty.csv").write_bytes(b"")
    with pytest.raises(DataFormatError, match=m("empty.csv", "file is empty")):
        io.read_csv(tmp_path / "empty.csv")
    (tmp_path / "blank.csv").write_text("\n  \n")
    with pytest.raises(DataFormatError, match=m("blank.csv", "file is empty")):
        io.read_csv(tmp_path / "blank.csv")
    (tmp_path / "nul.csv").write_bytes(b"t,q1,q2\n0,0\x00,0\n")
    with pytest.raises(DataFormatError, match=m("nul.csv", "line 2", "binary file")):
        io.read_csv(tmp_path / "nul.csv")
    (tmp_path / "latin.csv").write_bytes(b"# a: 1\nt,q1,q2,\xe9\n")
    with pytest.raises(DataFormatError, match=m("latin.csv", "line 2", "not UTF-8")):
        io.read_csv(tmp_path / "latin.csv")
    with pytest.raises(DataFormatError, match=m("missing.csv", "no such file")):
        io.read_csv(tmp_path / "missing.csv")
    (tmp_path / "empty.mat").write_bytes(b"")
    with pytest.raises(DataFormatError, match=m("empty.mat", "file is empty")):
        io.read_mat(tmp_path / "empty.mat")


def test_min_samples_and_tolerance_options(tmp_path):
    path = write_lines(tmp_path / "five.csv", csv_lines(5))
    assert io.read_csv(path, min_samples=5).n_samples == 5
    # a 5% jitter passes with a 10% tolerance, fails with the default 1%
    lines = csv_lines(12)
    lines[4] = "0.0305,0,0"
    path = write_lines(tmp_path / "jitter.csv", lines)
    assert io.read_csv(path, sampling_tol=0.1).n_samples == 12
    with pytest.raises(DataFormatError, match=m("jitter.csv", "line 5", "irregular")):
        io.read_csv(path)


def test_mapping_for_csv(tmp_path):
    path = write_lines(tmp_path / "named.csv", csv_lines(cols=("time", "theta", "phi", "volts")))
    d = io.read_csv(path, mapping={"t": "time", "q1": "theta", "q2": "phi", "v": "volts"})
    assert d.input_name == "v" and d.extra == {}
    with pytest.raises(DataFormatError, match=m("named.csv", "missing required column", "t, q1, q2", "found: time, theta")):
        io.read_csv(path)
    with pytest.raises(InputError, match="mapping key 'angle'"):
        io.read_csv(path, mapping={"angle": "theta"})


def test_bad_mat_inputs(tmp_path):
    n = 20
    t = np.arange(n) * 0.01
    q1 = np.zeros(n)
    q1[12] = np.nan
    scipy.io.savemat(tmp_path / "nan.mat", {"t": t, "q1": q1, "q2": t})
    with pytest.raises(DataFormatError, match=m("nan.mat", "variable 'q1'", "sample 13", "NaN or inf")):
        io.read_mat(tmp_path / "nan.mat")
    scipy.io.savemat(tmp_path / "len.mat", {"t": t, "q1": t[:-1], "q2": t})
    with pytest.raises(DataFormatError, match=m("len.mat", "variable 'q1'", "19 samples", "has 20")):
        io.read_mat(tmp_path / "len.mat")
    scipy.io.savemat(tmp_path / "miss.mat", {"t": t, "q1": t})
    with pytest.raises(DataFormatError, match=m("miss.mat", "missing required variable q2", "found: t, q1")):
        io.read_mat(tmp_path / "miss.mat")
    scipy.io.savemat(tmp_path / "uv.mat", {"t": t, "q1": t, "q2": t, "u": t, "v": t})
    with pytest.raises(DataFormatError, match=m("uv.mat", "both input variables u", "v")):
        io.read_mat(tmp_path / "uv.mat")
    scipy.io.savemat(tmp_path / "text.mat", {"t": t, "q1": "abc", "q2": t})
    with pytest.raises(DataFormatError, match=m("text.mat", "variable 'q1'", "text")):
        io.read_mat(tmp_path / "text.mat")
    scipy.io.savemat(tmp_path / "back.mat", {"t": t[::-1], "q1": t, "q2": t})
    with pytest.raises(DataFormatError, match=m("back.mat", "variable 't'", "sample 2", "not strictly increasing")):
        io.read_mat(tmp_path / "back.mat")
    (tmp_path / "fake.mat").write_text("t,q1,q2\n1,2,3\n")
    with pytest.raises(DataFormatError, match=m("fake.mat", "not a readable MATLAB")):
        io.read_mat(tmp_path / "fake.mat")


def test_bad_static_curves(tmp_path):
    cases = {
        "noq4": (["v,omega", "1,2", "3,4"], ("noq4.csv", "line 1", "missing required column", "q4", "found: v, omega")),
        "series": (["t,v,q4", "0,1,2", "1,3,4"], ("series.csv", "line 1", "unexpected column 't'", "time series")),
        "both": (["u,v,q4", "0,1,2", "1,3,4"], ("both.csv", "both input columns")),
        "text": (["# a: b", "v,q4", "1,2", "x,4"], ("text.csv", "line 4", "column 'v'", "'x' is not a number")),
        "nan": (["u,q4", "1,2", "3,nan"], ("nan.csv", "line 3", "column 'q4'", "NaN or inf")),
        "one": (["u,q4", "1,2"], ("one.csv", "1 point(s)", "at least 2")),
    }
    for name, (lines, parts) in cases.items():
        with pytest.raises(DataFormatError, match=m(*parts)):
            io.read_static_curve(write_lines(tmp_path / f"{name}.csv", lines))


# --------------------------------------------------------------------------
# degrees and resampling
# --------------------------------------------------------------------------
def _swing(n=200, Ts=0.01, amplitude=1.2):
    t = np.arange(n) * Ts
    return t, amplitude * np.cos(5 * t) * np.exp(-0.2 * t)


def test_degrees_warning_and_conversion(tmp_path):
    t, q1 = _swing()
    deg = io.ExperimentData(t=t, q1=np.rad2deg(q1), q2=np.rad2deg(3 * t), q3=np.rad2deg(-6 * np.sin(5 * t)))
    rad = io.ExperimentData(t=t, q1=q1, q2=3 * t)
    with pytest.warns(UserWarning, match=m("deg.csv", "'q1'", "looks like degrees", "iwp convert --degrees (degrees=True in Python)")):
        io.read_csv(write_experiment(deg, tmp_path / "deg.csv"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        io.read_csv(write_experiment(rad, tmp_path / "rad.csv"))
        converted = io.read_csv(tmp_path / "deg.csv", degrees=True)
    assert np.allclose(converted.q1, q1, rtol=1e-14, atol=1e-15)
    assert np.allclose(converted.q2, 3 * t, rtol=1e-14)
    assert np.allclose(converted.q3, -6 * np.sin(5 * t), rtol=1e-14, atol=1e-14)


def test_degrees_warning_for_mat(tmp_path):
    t, q1 = _swing()
    scipy.io.savemat(tmp_path / "deg.mat", {"t": t, "q1": np.rad2deg(q1), "q2": t})
    with pytest.warns(UserWarning, match=m("deg.mat", "looks like degrees")):
        io.read_mat(tmp_path / "deg.mat")


def test_resample_uniform_grid_and_linear_exact(tmp_path):
    rng = np.random.default_rng(1)
    t = np.cumsum(0.01 * (1 + 0.2 * rng.uniform(-1, 1, size=100)))
    d = io.ExperimentData(t=t, q1=2 * t + 1, q2=-3 * t, u=0.5 * t, extra={"x": 4 * t - 2})
    path = write_experiment(d, tmp_path / "jitter.csv")
    with pytest.raises(DataFormatError, match=m("jitter.csv", "column 't'", "irregular", "resample=True")):
        io.read_csv(path)
    r = io.read_csv(path, resample=True)
    med = float(np.median(np.diff(t)))
    steps = np.diff(r.t)
    assert np.allclose(steps, med, rtol=1e-9, atol=0)
    assert r.t[0] == t[0] and r.t[-1] <= t[-1] + 1e-12 and r.t[-1] > t[-1] - med
    assert np.allclose(r.q1, 2 * r.t + 1, rtol=1e-13, atol=1e-13)
    assert np.allclose(r.q2, -3 * r.t, rtol=1e-13, atol=1e-13)
    assert np.allclose(r.u, 0.5 * r.t, rtol=1e-13, atol=1e-13)
    assert np.allclose(r.extra["x"], 4 * r.t - 2, rtol=1e-13, atol=1e-13)
    # resample=True still refuses time going backwards
    lines = path.read_text().splitlines()
    lines[5], lines[6] = lines[6], lines[5]
    with pytest.raises(DataFormatError, match=m("swapped.csv", "line 7", "not strictly increasing")):
        io.read_csv(write_lines(tmp_path / "swapped.csv", lines), resample=True)


def test_resample_method_with_given_step():
    d = io.ExperimentData(t=np.arange(11) * 0.1, q1=np.arange(11.0), q2=np.zeros(11))
    r = d.resample(Ts=0.05)
    assert r.n_samples == 21 and r.Ts == pytest.approx(0.05)
    assert np.allclose(r.q1, np.arange(21) * 0.5)


# --------------------------------------------------------------------------
# third-party angle log
# --------------------------------------------------------------------------
def _angle_log(path, angles_deg, header="trigger_start_deg, sample_rate, duration_sec", values="90, 1000, 5 "):
    return write_lines(path, [header, values] + [f"{a:.2f}" for a in angles_deg])


def test_angle_log_synthetic(tmp_path):
    n = 300
    angles = 120 * np.cos(11 * np.arange(n) * 1e-3)
    path = _angle_log(tmp_path / "swing.txt", angles)
    d = io.read_angle_log(path)
    assert d.n_samples == n
    assert np.array_equal(d.t, np.arange(n) / 1000.0)
    assert d.Ts == pytest.approx(1e-3, rel=1e-12)
    assert np.allclose(d.q1, np.deg2rad(np.round(angles, 2)), rtol=0, atol=1e-15)
    assert np.array_equal(d.q2, np.zeros(n)) and d.input_name is None and d.q3 is None
    assert d.metadata["sample_rate"] == "1000" and d.metadata["trigger_start_deg"] == "90"
    assert d.metadata["duration_sec"] == "5"
    up = io.read_angle_log(path, zero="up", sample_rate=500)
    assert np.allclose(up.q1, d.q1 + np.pi) and up.Ts == pytest.approx(2e-3)
    assert io.read_experiment(path, format="angle-log").n_samples == n


def test_angle_log_rad_unit_warns_on_degrees(tmp_path):
    path = _angle_log(tmp_path / "swing.txt", 100 * np.ones(20))
    with pytest.warns(UserWarning, match=m("swing.txt", "looks like degrees", "angle_unit='deg'")):
        io.read_angle_log(path, angle_unit="rad")


def test_angle_log_errors(tmp_path):
    ok = list(np.linspace(-90, 90, 20))
    bad_text = _angle_log(tmp_path / "text.txt", ok)
    lines = bad_text.read_text().splitlines()
    lines[8] = "12,5"
    lines[15] = "oops"
    write_lines(bad_text, lines)
    with pytest.raises(DataFormatError, match=m("text.txt", "line 9", "column 'angle'", "one angle a line")):
        io.read_angle_log(bad_text)
    lines[8] = "nan"
    write_lines(bad_text, lines)
    with pytest.raises(DataFormatError, match=m("text.txt", "line 9", "column 'angle'", "NaN or inf")):
        io.read_angle_log(bad_text)
    no_rate = _angle_log(tmp_path / "norate.txt", ok, header="trigger_start_deg, duration_sec", values="90, 5")
    with pytest.raises(DataFormatError, match=m("norate.txt", "line 1", "sample_rate", "--sample-rate")):
        io.read_angle_log(no_rate)
    assert io.read_angle_log(no_rate, sample_rate=100).Ts == pytest.approx(0.01)
    numbers = write_lines(tmp_path / "numbers.txt", [f"{a}" for a in ok])
    with pytest.raises(DataFormatError, match=m("numbers.txt", "line 1", "expected a header of names")):
        io.read_angle_log(numbers)
    short = _angle_log(tmp_path / "short.txt", ok[:4])
    with pytest.raises(DataFormatError, match=m("short.txt", "4 sample(s)", "at least 10")):
        io.read_angle_log(short)


@pytest.mark.skipif(not REAL_LOG.exists(), reason="real log not available")
def test_angle_log_real_file():
    d = io.read_angle_log(REAL_LOG)
    assert d.n_samples == 5000
    assert d.Ts == pytest.approx(1e-3, rel=1e-9)
    assert d.duration == pytest.approx(4.999, rel=1e-12)
    # radians, zero down: starts at the 90-degree trigger, peaks at 135.82 deg while
    # being let go by hand (README), then swings freely with decaying amplitude
    assert d.q1[0] == pytest.approx(np.deg2rad(-90.36))
    assert np.max(np.abs(d.q1)) == pytest.approx(np.deg2rad(135.82), abs=np.deg2rad(2))
    assert np.max(np.abs(d.window(t_start=0.5).q1)) < np.deg2rad(100)
    assert d.metadata["sample_rate"] == "1000"


# --------------------------------------------------------------------------
# iwp convert
# --------------------------------------------------------------------------
def test_cli_convert_angle_log(tmp_path, cli, capsys):
    n = 400
    src = _angle_log(tmp_path / "swing.txt", 60 * np.cos(11 * np.arange(n) * 1e-3))
    out = tmp_path / "swing.csv"
    assert cli(["convert", str(src), "--from", "angle-log", "--out", str(out)]) == 0
    printed = capsys.readouterr().out.strip()
    assert "\n" not in printed
    assert re.search(r"400 samples, Ts = 0\.001 s, duration 0\.399 s", printed)
    d = io.read_csv(out)
    assert_same(d, io.read_angle_log(src))
    # window and parquet by the extension
    pytest.importorskip("pyarrow")
    pq = tmp_path / "part.parquet"
    assert cli(["convert", str(out), "--t-start", "0.1", "--t-end", "0.2", "--out", str(pq)]) == 0
    part = io.read_parquet(pq)
    assert part.n_samples == 101 and part.t[0] == pytest.approx(0.1)


def test_cli_convert_mat_with_map(tmp_path, cli, capsys):
    n = 50
    t = np.arange(n) * 0.005
    scipy.io.savemat(tmp_path / "run.mat", {"time": t, "theta": 0.1 * t, "phi": 5 * t, "uin": np.sin(t)})
    out = tmp_path / "run.csv"
    code = cli(["convert", str(tmp_path / "run.mat"), "--from", "mat", "--map", "t=time,q1=theta,q2=phi,u=uin",
                "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    assert "50 samples" in capsys.readouterr().out
    d = io.read_csv(out)
    assert d.input_name == "u" and np.array_equal(d.u, np.sin(t)) and np.array_equal(d.t, t)


def test_cli_bad_file_exit_2_one_line(tmp_path, cli, capsys):
    lines = csv_lines()
    lines[6] = "0.05,abc,0.1"
    src = write_lines(tmp_path / "bad.csv", lines)
    code = cli(["convert", str(src), "--out", str(tmp_path / "out.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert re.search(r"^iwp: error: .*bad\.csv, line 7, column 'q1': 'abc' is not a number", err)
    assert not (tmp_path / "out.csv").exists()
    # binary input
    (tmp_path / "bin.csv").write_bytes(b"\x00\x01\x02")
    assert cli(["convert", str(tmp_path / "bin.csv"), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "binary file" in err and "Traceback" not in err
    # bad --map and flags that do not apply
    good = write_lines(tmp_path / "good.csv", csv_lines())
    assert cli(["convert", str(good), "--map", "q1", "--out", str(tmp_path / "o.csv")]) == 2
    assert "--map" in capsys.readouterr().err
    assert cli(["convert", str(good), "--struct", "s", "--out", str(tmp_path / "o.csv")]) == 2
    assert "--struct does not apply to --from csv" in capsys.readouterr().err


def test_cli_refuses_overwrite_without_force(tmp_path, cli, capsys):
    src = write_lines(tmp_path / "in.csv", csv_lines())
    out = tmp_path / "out.csv"
    out.write_text("keep me")
    assert cli(["convert", str(src), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "out.csv" in err and "--force" in err and err.count("\n") == 1
    assert out.read_text() == "keep me"
    assert cli(["convert", str(src), "--out", str(out), "--force"]) == 0
    assert io.read_csv(out).n_samples == 20


def test_cli_degrees_and_resample_flags(tmp_path, cli, capsys):
    t, q1 = _swing(n=60)
    rng = np.random.default_rng(3)
    tj = t + rng.uniform(-2e-3, 2e-3, size=t.size)
    src = write_lines(tmp_path / "deg.csv", ["t,q1,q2"] + [f"{a!r},{b!r},0.0" for a, b in zip(tj.tolist(), np.rad2deg(q1).tolist())])
    out = tmp_path / "o.csv"
    assert cli(["convert", str(src), "--out", str(out)]) == 2
    assert "--resample" in capsys.readouterr().err
    assert cli(["convert", str(src), "--resample", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "iwp: warning:" in captured.err and "looks like degrees" in captured.err
    assert cli(["convert", str(src), "--resample", "--degrees", "--out", str(out), "--force"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    d = io.read_csv(out)
    assert np.max(np.abs(d.q1)) < 1.3 and np.allclose(np.diff(d.t), d.Ts, rtol=1e-9)


def test_degrees_swing_is_refused_but_a_pendulum_that_turned_over_is_read(tmp_path):
    """Beyond 3 pi: a swing across zero is degrees (refused, naming the column); a turning pendulum is not."""
    t = 0.005 * np.arange(2000)
    swing = np.rad2deg(0.6 * np.cos(5.1 * t))  # a 0.6 rad swing logged in degrees: 34 "rad", 16 zero crossings
    path = write_experiment(io.ExperimentData(t=t, q1=swing, q2=np.zeros_like(t)), tmp_path / "deg.csv")
    with pytest.raises(DataFormatError, match=r"column 'q1' looks like degrees .* swings across zero 16 times"):
        io.read_csv(path)
    spin = 2.0 * t + 0.3 * np.sin(5.0 * t)  # turns over and over: 20 rad after 10 s, never back across zero
    path = write_experiment(io.ExperimentData(t=t, q1=spin, q2=np.zeros_like(t)), tmp_path / "spin.csv")
    with pytest.warns(UserWarning, match="looks like degrees"):
        back = io.read_csv(path)
    np.testing.assert_array_equal(back.q1, spin)


def test_reader_refuses_magnitudes_beyond_any_rig_and_implausible_sample_periods(tmp_path):
    t = 0.005 * np.arange(500)
    q1 = 0.1 * np.cos(5 * t)
    ok = io.ExperimentData(t=t, q1=q1, q2=np.zeros_like(t))
    bad = dataclasses.replace(ok, q2=np.where(np.arange(500) == 57, 1e308, 0.0))
    with pytest.raises(DataFormatError, match=r"line 59, column 'q2': 1e\+308 rad is beyond any rig"):
        io.read_csv(write_experiment(bad, tmp_path / "big.csv"))
    ms = dataclasses.replace(ok, t=t * 1000.0)
    with pytest.raises(DataFormatError, match=r"sample period 5 s is implausible .* milliseconds"):
        io.read_csv(write_experiment(ms, tmp_path / "ms.csv"))
    fast = dataclasses.replace(ok, t=t * 1e-9)
    with pytest.raises(DataFormatError, match="sample period 5e-12 s is implausible"):
        io.read_csv(write_experiment(fast, tmp_path / "fast.csv"))
    far = dataclasses.replace(ok, t=t + 1e9)  # absolute UNIX-like times: 1e9 s keeps 5 ms with 12 digits
    assert io.read_csv(write_experiment(far, tmp_path / "far.csv")).n_samples == 500


def test_a_folder_given_as_a_log_is_named_as_a_folder(tmp_path):
    from iwp.data import read_experiment

    with pytest.raises(InputError, match=r": is a folder; give a log file in it \(\.csv"):
        read_experiment(tmp_path)
    with pytest.raises(InputError, match="from a name without an extension"):
        read_experiment(tmp_path / "chirp")

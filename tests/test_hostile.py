"""Hostile input: every command on every broken input exits 2 with one line, writes nothing, hangs never.

The corpus (tests/hostile_corpus.py, about 300 cases) covers broken logs,
broken parameter files, arguments beyond any sense and the output policy;
property-based tests (hypothesis) cover CSV contents, parameter values and
the numeric arguments of ``iwp simulate``.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import math
import signal
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from iwp.cli import main
from iwp.sim import Feedforward, SimOptions

from .hostile_corpus import cases, good_log_text

#: No case may run longer than this [s] (a hang fails the test instead of the suite).
CASE_TIMEOUT = 60


class _Hang(Exception):
    pass


def _on_alarm(signum, frame):
    raise _Hang()


def _snapshot(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): (hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir")
            for p in sorted(folder.rglob("*"))}


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    """Run ``iwp argv`` in this process; return (status, stdout, stderr); a hang raises."""
    out, err = io.StringIO(), io.StringIO()
    old = signal.signal(signal.SIGALRM, _on_alarm)
    signal.alarm(CASE_TIMEOUT)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                status = main(argv)
            except SystemExit as exc:  # argparse's usage errors
                status = exc.code if isinstance(exc.code, int) else 2
    except _Hang:
        pytest.fail(f"iwp {' '.join(argv)} did not return within {CASE_TIMEOUT} s")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    return status, out.getvalue(), err.getvalue()


def _other_lines(err: str) -> list[str]:
    """The lines of stderr that are neither iwp's own (error, warning, compiling) nor argparse's usage block."""
    other, in_usage = [], False
    for ln in err.splitlines():
        if ln.startswith("usage:"):
            in_usage = True
        elif in_usage and ln.startswith(" "):
            continue  # the usage line's continuation, indented by argparse
        else:
            in_usage = False
            if not ln.startswith(("iwp: error:", "iwp: warning:", "iwp: compiling")):
                other.append(ln)
    return other


def assert_refused(argv: list[str], folder: Path, names=()) -> str:
    """The command exits 2 with one error line (naming ``names``), writes nothing, changes no input."""
    before = _snapshot(folder)
    status, _, err = run_cli(argv)
    errors = [ln for ln in err.splitlines() if ln.startswith("iwp: error:")]
    assert "Traceback" not in err, err
    assert status == 2, f"exit {status}; stderr: {err[-2000:]}"
    assert len(errors) == 1, err[-2000:]
    assert _other_lines(err) == [], err[-2000:]
    assert len(errors[0]) < 600, errors[0][:700]
    for n in names:
        assert n in errors[0], f"{n!r} not named in: {errors[0]}"
    assert _snapshot(folder) == before, "files written or changed"
    return errors[0]


CASES = cases()


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_corpus_case_is_refused_with_one_line(case, tmp_path):
    for rel, data in case.files.items():
        p = tmp_path / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    argv = [a.replace("{d}", str(tmp_path)) for a in case.argv]
    assert_refused(argv, tmp_path, case.names)


def test_corpus_is_large_and_covers_every_reading_command():
    commands = {c.argv[0] for c in CASES}
    assert len(CASES) >= 250
    assert {"identify", "validate", "convert", "simulate", "design", "report", "rig"} <= commands


# --------------------------------------------------------------------------
# properties
# --------------------------------------------------------------------------
_cell = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64).map(repr),
    st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=8),
    st.sampled_from(["", " ", "nan", "1e999", "-0", "0x10", "1,5", "∞"]),
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(header=st.lists(st.sampled_from(["t", "q1", "q2", "u", "v", "q3", "q4", "x", "T", " q1 ", ""]),
                       min_size=0, max_size=6),
       rows=st.lists(st.lists(_cell, min_size=0, max_size=6), min_size=0, max_size=6))
def test_any_small_csv_is_read_or_refused_in_one_line(tmp_path_factory, header, rows):
    """A few rows of anything: identify and convert read them or refuse them, never crash."""
    d = tmp_path_factory.mktemp("csv")
    text = ",".join(header) + "\n" + "\n".join(",".join(r) for r in rows) + "\n"
    (d / "log.csv").write_text(text, encoding="utf-8")
    for argv in (["identify", str(d / "log.csv"), "--setup", "full"],
                 ["convert", str(d / "log.csv"), "--out", str(d / "o.parquet")]):
        # at most 6 rows: never enough for a result, so every one of them must be refused
        assert_refused(argv, d)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(["p1", "p2", "p3", "rho", "sigma_a1", "sigma_v1", "sigma_b1", "v_dz_pos"]),
       value=st.one_of(st.floats(allow_nan=False, allow_infinity=False).filter(lambda x: abs(x) > 1e9 or x < 0),
                       st.just(0.0)))
def test_parameter_values_beyond_any_rig_are_refused(tmp_path_factory, name, value):
    """Negative, zero (where it must be positive) or astronomically large parameters: refused by every command."""
    if value == 0.0 and name not in ("p1", "p3", "rho"):
        return  # zero friction or dead zone is a valid value
    d = tmp_path_factory.mktemp("params")
    params = {"p1": 26.0, "p2": 0.01, "p3": 0.03, "rho": 247.0, "sigma_a1": 0.005, "sigma_v1": 0.008,
              "sigma_b1": 0.0005}
    params[name] = value
    (d / "P.json").write_text(json.dumps(params))
    (d / "log.csv").write_bytes(good_log_text())
    for argv in (["simulate", "--params", str(d / "P.json"), "--t-end", "1", "--out", str(d / "s.csv")],
                 ["design", "hopf", "--params", str(d / "P.json"), "--amplitude", "0.5"],
                 ["validate", str(d / "log.csv"), "--params", str(d / "P.json")]):
        assert_refused(argv, d, ("P.json",))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(t_end=st.floats(allow_nan=True, allow_infinity=True), ts=st.floats(allow_nan=True, allow_infinity=True),
       x0=st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=4, max_size=4))
def test_simulate_arguments_run_or_are_refused(tmp_path_factory, t_end, ts, x0):
    """Any numbers for --t-end, --ts, --x0: a short valid run succeeds, anything else is refused in one line."""
    d = tmp_path_factory.mktemp("sim")
    argv = ["simulate", "--t-end", repr(t_end), "--ts", repr(ts), "--x0", ",".join(map(repr, x0)),
            "--out", str(d / "s.csv")]
    valid = (math.isfinite(t_end) and math.isfinite(ts) and ts > 0 and t_end > 0
             and 2 <= t_end / ts + 1 <= 20_000 and all(math.isfinite(v) and abs(v) < 1e7 for v in x0))
    if valid:
        return  # the valid region is tested elsewhere; here: the invalid one
    assert_refused(argv, d)


def test_raw_model_with_feedforward_writes_a_log_every_reader_takes(tmp_path):
    """simulate --model raw --feedforward writes one input column, v, that identify/validate/convert read back."""
    out = tmp_path / "raw.csv"
    status, _, err = run_cli(["simulate", "--model", "raw", "--feedforward", "--input", "sine", "--amplitude", "40",
                              "--t-end", "3", "--out", str(out)])
    assert status == 0, err
    header = [ln for ln in out.read_text().splitlines() if not ln.startswith("#")][0]
    assert header == "t,q1,q2,q3,q4,v"
    from iwp.data import read_experiment
    from iwp.models import Plant, table1
    from iwp.sim import Sine, simulate

    log = read_experiment(out)
    ref = simulate(Plant(table1(), model="raw"), t_end=3.0, input=Sine(40.0),
                   options=SimOptions(feedforward=Feedforward.of_plant(Plant(table1(), model="raw"))))
    # the logged v is what reached the raw model: u + 31 sgn(u) of (7)-(8)
    np.testing.assert_array_equal(log.v, ref.command)
    np.testing.assert_allclose(np.abs(log.v[np.abs(ref.u) > 0]), np.abs(ref.u[np.abs(ref.u) > 0]) + 31.0, rtol=1e-12)
    status, _, err = run_cli(["convert", str(out), "--out", str(tmp_path / "raw.mat")])
    assert status == 0, err


@pytest.mark.parametrize("ext", [".parquet", ".mat", ".csv"])
def test_simulate_writes_the_format_of_its_extension(tmp_path, ext):
    out = tmp_path / f"s{ext}"
    status, _, err = run_cli(["simulate", "--model", "motor-disk", "--input", "sine", "--t-end", "1",
                              "--out", str(out)])
    assert status == 0, err
    from iwp.data import read_experiment
    from iwp.models import Plant, table1
    from iwp.sim import Sine, simulate

    log = read_experiment(out)
    ref = simulate(Plant(table1(), model="motor-disk"), t_end=1.0, input=Sine(60.0))
    np.testing.assert_array_equal(log.q4, ref.q4)  # bit-exact in every format
    assert log.metadata["pendulum"] == "locked"
    if ext == ".parquet":
        assert out.read_bytes()[:4] == b"PAR1"
    if ext == ".mat":
        assert out.read_bytes()[:6] == b"MATLAB"


def test_negative_release_angle_needs_no_equals_sign(tmp_path):
    """--x0 -0.1,0,0,0 (the paper's release angle is negative) is a value, not an option."""
    status, _, err = run_cli(["simulate", "--x0", "-0.1,0,0,0", "--t-end", "1", "--out", str(tmp_path / "s.csv")])
    assert status == 0, err
    from iwp.data import read_experiment

    assert read_experiment(tmp_path / "s.csv").q1[0] == -0.1


# --------------------------------------------------------------------------
# issue 23: messages and warnings
# --------------------------------------------------------------------------
def test_file_names_are_never_turned_into_flags(tmp_path):
    """--rig rig.json and --truth truth.json: the file is named as typed, not as '--rig.json'."""
    (tmp_path / "log.csv").write_bytes(good_log_text())
    (tmp_path / "rig.json").write_text(json.dumps({
        "kind": "iwp-rig", "sample_period": 0.005, "time": {"column": "t"},
        "pendulum": {"column": "q1", "sign": 2}, "wheel": {"column": "q2", "quantity": "angle"}}))
    (tmp_path / "truth.json").write_text(json.dumps({"p1": "x"}))
    line = assert_refused(["fit", str(tmp_path / "log.csv"), "--rig", str(tmp_path / "rig.json"), "--out",
                           str(tmp_path / "F")], tmp_path, ("rig.json", "pendulum.sign"))
    assert "--rig.json" not in line
    line = assert_refused(["rig", "run", "free-pendulum", "--truth", str(tmp_path / "truth.json"), "--out",
                           str(tmp_path / "r.csv")], tmp_path, ("truth.json",))
    assert "--truth.json" not in line


def test_numpy_reprs_never_reach_a_message():
    from iwp.cli import user_message

    exc = ValueError(f"x must be > 0, got {np.float64(0.5)!r}; n = {np.int64(3)!r}; {[np.float64(1.5)]}")
    assert user_message(exc, None) == "x must be > 0, got 0.5; n = 3; [1.5]"


@pytest.mark.parametrize("kind", ["noise", "zeros"])
def test_validate_warns_on_a_log_that_says_nothing(tmp_path, kind):
    """Pure noise (the model explains less than the mean: exit 1, the prediction is poor) and a log of zeros
    (nothing moves, nothing judged: exit 0), each with a warning that says so."""
    rng = np.random.default_rng(0)
    t = 0.005 * np.arange(2000)
    if kind == "noise":
        cols = [t, rng.normal(0, 0.3, t.size), rng.normal(0, 5, t.size), rng.normal(0, 20, t.size)]
    else:
        cols = [t, np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)]
    np.savetxt(tmp_path / "log.csv", np.column_stack(cols), delimiter=",", header="t,q1,q2,u", comments="")
    status, out, err = run_cli(["validate", str(tmp_path / "log.csv"), "--params", "table1"])
    warnings = [ln for ln in err.splitlines() if ln.startswith("iwp: warning:")]
    assert status == (1 if kind == "noise" else 0), err
    if kind == "noise":
        assert err.splitlines()[-1].startswith("iwp: the model predicts") and "--accept-poor" in err
    expect = "less of the log than the log's mean" if kind == "noise" else "constant (no motion in the log)"
    assert len(warnings) == 1 and expect in warnings[0] and "log.csv" in warnings[0], err
    # a log the model explains gets no such warning
    status, _, err = run_cli(["validate", str(_simulated_log(tmp_path)), "--params", "table1"])
    assert status == 0 and "iwp: warning:" not in err, err


def _simulated_log(folder: Path) -> Path:
    out = folder / "sim.csv"
    status, _, err = run_cli(["simulate", "--input", "sine", "--amplitude", "40", "--t-end", "5", "--x0",
                              "0.3,0,0,0", "--out", str(out)])
    assert status == 0, err
    return out


def test_a_second_reproduction_into_a_file_name_is_refused_before_any_work(tmp_path):
    """reproduce --out report.html made a folder of that name; now it is refused at once."""
    line = assert_refused(["reproduce", "--out", str(tmp_path / "report.html")], tmp_path, ("--out",))
    assert "--out " + str(tmp_path / "report") in line


def test_identify_refine_says_each_warning_once_and_its_json_names_the_covariance_used(tmp_path):
    log = tmp_path / "free.csv"
    status, _, err = run_cli(["rig", "run", "free-pendulum", "--duration", "20", "--out", str(log)])
    assert status == 0, err
    status, out, err = run_cli(["identify", str(log), "--setup", "free", "--refine"])
    assert status == 0, err
    warned = [ln[len("iwp: warning: "):] for ln in err.splitlines() if ln.startswith("iwp: warning: ")]
    assert warned, "the refinement of a free swing warns of its correlated frictions"
    for w in warned:
        assert (out + err).count(w) == 1, w  # on stderr, not again in the summary
    status, out, err = run_cli(["identify", str(log), "--setup", "free", "--json"])
    doc = json.loads(out)
    assert doc["covariance"] == doc["details"]["covariance"] == "noise"  # the top said 'ols'

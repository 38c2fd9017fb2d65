"""Other rigs: rig descriptions, their logs, glitches, and ``iwp fit`` on the virtual rig with known truth."""

from __future__ import annotations

import json
import math
import re
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, optimize, stats

from iwp.cli import main
from iwp.data import ExperimentData
from iwp.data.glitches import find_glitches
from iwp.data.rig_description import RigDescription
from iwp.data.rig_log import read_rig_log
from iwp.errors import DataFormatError, InputError
from iwp.ident.logfit import LogFitOptions, fit_logs, inferred_kind, kind_mismatches, least_squares_start, load_logs
from iwp.ident.refinement import as_experiments, refine
from iwp.models.parameters import LumpedParameters, table1
from iwp.models.plant import Plant
from iwp.rig.described import DescribedRig, prbs, write_rig_csv
from iwp.sim import SimOptions, Tolerances
from iwp.sim.inputs import Chirp, HopfController

#: a direct-drive rig unlike the paper's: shorter pendulum, heavy wheel, PWM duty input
TRUTH = LumpedParameters(p1=40.0, p2=0.06, p3=12.0, rho=30.0, sigma_a1=0.02, sigma_v1=0.05, sigma_b1=1e-4)

BASE = {
    "kind": "iwp-rig", "name": "virtual direct-drive rig", "sample_period": 0.02,
    "time": {"column": "t", "unit": "s"},
    "pendulum": {"column": "theta", "unit": "counts", "counts_per_rev": 4096},
    "wheel": {"column": "phidot", "quantity": "speed", "unit": "rad/s", "sampling": "mean", "counts_per_rev": 1200},
    "current": {"column": "I", "unit": "A"},
    "input": {"column": "u", "kind": "duty"},
    "drive": {"kind": "direct"},
}


def rig_of(**changes) -> RigDescription:
    doc = json.loads(json.dumps(BASE))
    for key, val in changes.items():
        if isinstance(val, dict) and isinstance(doc.get(key), dict):
            doc[key].update(val)
        else:
            doc[key] = val
    return RigDescription.from_dict(doc, where="rig.json")


def write_logs(tmp_path, rig, *, amplitude=0.3, q1_offset=0.0, first_sample=None, dropouts=(), jumps=(),
               duration=30.0):
    """Two chirps for training and one PRBS held out, written as the rig's CSV logs."""
    vr = DescribedRig(rig, TRUTH, q1_offset=q1_offset, first_sample=first_sample, dropouts=dropouts, jumps=jumps)
    files = []
    for i, inp in enumerate((Chirp(amplitude, 2.0, 15.0), Chirp(0.7 * amplitude, 3.0, 20.0))):
        files.append(write_rig_csv(vr.run(inp, duration=duration), tmp_path / f"chirp{i}.csv"))
    n = int(round(20.0 / rig.sample_period)) + 1
    held = write_rig_csv(vr.run(prbs(n, hold=max(1, int(round(0.3 / rig.sample_period))), amplitude=0.6 * amplitude,
                                     seed=3), duration=20.0), tmp_path / "prbs.csv")
    return files, held


def fit(tmp_path, rig, **kw):
    files, held = write_logs(tmp_path, rig, **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fit_logs(files, rig=rig, validate=[held], warn=False)


def check_truth(p: LumpedParameters):
    """The tolerances of the identification: p1 1 %, p2 (1 + rho) and p3 (1 + rho) 3 %, rho 5 %,
    small-angle damping sigma_a1 + sigma_v1 15 %."""
    assert p.p1 == pytest.approx(TRUTH.p1, rel=0.01)
    assert p.p2_1rho == pytest.approx(TRUTH.p2_1rho, rel=0.03)
    assert p.p3_1rho == pytest.approx(TRUTH.p3_1rho, rel=0.03)
    assert p.rho == pytest.approx(TRUTH.rho, rel=0.05)
    assert p.sigma_a1 + p.sigma_v1 == pytest.approx(TRUTH.sigma_a1 + TRUTH.sigma_v1, rel=0.15)


# --------------------------------------------------------------------------
# the rig description and the mapping of a log
# --------------------------------------------------------------------------
@pytest.mark.parametrize("doc, words", [
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w"}, "inputs": {}}, ["unknown key 'inputs'"]),
    ({"wheel": {"column": "w"}}, ["'pendulum' is required"]),
    ({"pendulum": {"column": "theta", "unit": "grad"}, "wheel": {"column": "w"}}, ["'pendulum.unit'", "rad, deg"]),
    ({"pendulum": {"column": "theta", "unit": "counts"}, "wheel": {"column": "w"}},
     ["'pendulum.counts_per_rev' is required"]),
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w", "sampling": "avg"}}, ["'wheel.sampling'"]),
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w"}, "input": {"kind": "duty", "limits": [-2, 2]}},
     ["'input.limits'", "within [-1, 1]"]),
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w"}, "drive": {"kind": "gear"}}, ["'drive.ratio'"]),
    ({"pendulum": {"column": "theta", "offset": 1.2}, "wheel": {"column": "w"}}, ["'pendulum.offset'"]),
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w"}, "experiments": {"clamped": "c*.mat"}},
     ["'experiments' must be a list"]),
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w"}, "experiments": [{"files": "c*.mat",
                                                                                   "kind": "clamp"}]},
     ["'experiments[0].kind'", "clamped", "wheel-locked"]),
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w"}, "experiments": [{"kind": "clamped"}]},
     ["'experiments[0].files'", "pattern"]),
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w"}, "experiments": [{"files": "c", "kind": "free"},
                                                                                  {"files": "h*",
                                                                                   "kind": "closed-loop"}]},
     ["'experiments[1].controller' is required"]),
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w"},
      "experiments": [{"files": "h*", "kind": "closed-loop", "controller": {"law": "hopf", "k1": -1}}]},
     ["'experiments[0].controller.k2' is required"]),
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w"},
      "experiments": [{"files": "h*", "kind": "clamped", "controller": {"law": "hopf", "k1": -1, "k2": 0}}]},
     ["'experiments[0].controller'", "closed-loop logs", "these are clamped"]),
    ({"pendulum": {"column": "theta"}, "wheel": {"column": "w"},
      "experiments": [{"files": "h*", "kind": "closed-loop", "controller": {"law": "lqr", "k1": -1, "k2": 0}}]},
     ["'experiments[0].controller.law'", "hopf"]),
])
def test_bad_rig_description_is_one_line_naming_the_key(doc, words):
    with pytest.raises(InputError) as exc:
        RigDescription.from_dict(doc, where="rig.json")
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith("rig.json")
    for w in words:
        assert w in msg


def _csv(path, header, rows):
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    return path


def _columns(n=200, Ts=0.02):
    t = Ts * np.arange(n)
    return {"t": t, "theta": np.round(300 * np.sin(3 * t)), "phidot": 20 * np.sin(2 * t), "I": 0.2 * np.cos(t),
            "u": 0.3 * np.sin(2 * t)}


@pytest.mark.parametrize("change, rig_change, words", [
    ("drop phidot", {}, ["column 'phidot'", "key 'wheel.column'", "not found", "found: t, theta, I, u"]),
    ("theta in rad", {}, ["column 'theta'", "encoder counts must be whole numbers", "pendulum.unit"]),
    ("theta in deg declared rad", {"pendulum": {"unit": "rad", "counts_per_rev": None}},
     ["column 'theta'", "looks like degrees"]),
    ("t in ms", {}, ["column 't'", "cannot be the sample period", "time.unit"]),
    ("phidot in rpm*100", {}, ["column 'phidot'", "cannot be right", "rpm"]),
    ("I in mA", {}, ["column 'I'", "cannot be right", "mA"]),
    ("u in percent", {}, ["column 'u'", "PWM duty"]),
])
def test_mapping_error_is_one_line_naming_the_column(tmp_path, change, rig_change, words):
    cols = _columns()
    if change == "drop phidot":
        del cols["phidot"]
    elif change == "theta in rad":
        cols["theta"] = 0.3 * np.sin(3 * cols["t"])
    elif change == "theta in deg declared rad":
        cols["theta"] = 90 * np.sin(3 * cols["t"])
    elif change == "t in ms":
        cols["t"] = 1000 * cols["t"]
    elif change == "phidot in rpm*100":
        cols["phidot"] = 1e4 * np.sin(2 * cols["t"])
    elif change == "I in mA":
        cols["I"] = 200 * np.cos(cols["t"])
    elif change == "u in percent":
        cols["u"] = 30 * np.sin(2 * cols["t"])
    path = _csv(tmp_path / "log.csv", list(cols), np.column_stack(list(cols.values())))
    rig = rig_of(**rig_change) if not rig_change.get("pendulum") else RigDescription.from_dict(
        {**BASE, "pendulum": {"column": "theta", "unit": "rad"}}, where="rig.json")
    with pytest.raises(DataFormatError) as exc:
        read_rig_log(path, rig)
    msg = str(exc.value)
    assert "\n" not in msg and str(path) in msg
    for w in words:
        assert w in msg


def test_log_maps_units_zero_sign_and_input(tmp_path):
    """Every conversion of the reader against its definition: counts, upright zero with wrap, gear at the motor,
    rpm, mA, DAC counts with clipping."""
    rig = RigDescription.from_dict({
        "sample_period": 0.01, "time": {"column": "time_ms", "unit": "ms"},
        "pendulum": {"column": "ang", "unit": "deg", "zero": "up", "offset": 0.02, "sign": -1},
        "wheel": {"column": "rpm", "quantity": "speed", "unit": "rpm", "at": "motor"},
        "current": {"column": "i_ma", "unit": "mA"},
        "input": {"column": "dac", "kind": "dac", "bits": 12, "offset": 2048, "scale": 0.005, "limits": [48, 4048]},
        "drive": {"kind": "gear", "ratio": 5.0}}, where="rig.json")
    n = 300
    t = 0.01 * np.arange(n)
    q1 = 0.5 * np.sin(4 * t)  # true angle, hanging down
    ang = -(np.degrees(q1 + 0.02 - math.pi) + 180) % 360 + 180  # upright zero, reversed, within (-180, 180]
    ang = np.where(ang > 180, ang - 360, ang)
    q4 = 30 * np.cos(t)
    dac = np.clip(2048 + 2500 * np.sin(t), 0, 4095)
    path = _csv(tmp_path / "gear.csv", ["time_ms", "ang", "rpm", "i_ma", "dac"],
                np.column_stack([1000 * t, ang, q4 * 5 * 60 / (2 * math.pi), 150 * np.ones(n), dac]))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = read_rig_log(path, rig, glitches=False)
    said = " ".join(str(w.message) for w in caught)
    assert "exceeds its limits" in said and "q1 unwrapped" in said
    np.testing.assert_allclose(d.t, t, atol=1e-12)
    np.testing.assert_allclose(d.q1, q1, atol=1e-9)
    np.testing.assert_allclose(d.q4, q4, atol=1e-9)
    np.testing.assert_allclose(d.current, 0.15, atol=1e-12)
    np.testing.assert_allclose(d.v, 0.005 * (np.clip(dac, 48, 4048) - 2048), atol=1e-12)
    assert d.q2 is None and d.input_name == "v"
    np.testing.assert_array_equal(d.extra["input_logged"], dac)
    assert d.metadata["input_saturated"].startswith(f"{int(np.sum((dac < 48) | (dac > 4048)))} samples")


def test_counts_declared_as_degrees_are_refused_but_a_wrapping_sensor_is_not(tmp_path):
    rig = rig_of(sample_period=0.05, pendulum={"counts_per_rev": 20000})
    run = DescribedRig(rig, TRUTH).run(Chirp(0.4, 3.0, 10.0), duration=20.0)  # swings of about half a turn
    counts = write_rig_csv(run, tmp_path / "counts.csv")
    assert read_rig_log(counts, rig).q1.size == 401  # as described (its fast swings no "jumps")
    as_deg = rig_of(sample_period=0.05, pendulum={"unit": "deg"})
    with pytest.raises(DataFormatError) as err:
        read_rig_log(counts, as_deg)
    msg = str(err.value)
    assert "column 'theta'" in msg and "steps by" in msg and "deg in one sample" in msg
    assert "'pendulum.unit' in rig.json" in msg
    # a pendulum spun over the top, logged in degrees that wrap at +-180: unwrapped, not refused
    t = 0.05 * np.arange(401)
    q1 = 6.0 * t  # a steady spin, 0.3 rad a sample
    deg = (np.degrees(q1) + 180.0) % 360.0 - 180.0
    spun = _csv(tmp_path / "spun.csv", ["t", "theta", "phidot", "I", "u"],
                np.column_stack([t, deg, np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)]))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = read_rig_log(spun, as_deg, glitches=False)
    assert any("q1 unwrapped at" in str(w.message) for w in caught)
    np.testing.assert_allclose(d.q1 - d.q1[0], q1 - q1[0], atol=1e-9)


def test_a_sample_period_in_ms_and_an_empty_or_cell_matrix_are_named_as_a_user_knows_them(tmp_path):
    from scipy.io import savemat

    with pytest.raises(InputError, match=r"rig.json: key 'sample_period' is 10 s, .*0.01 for 10 ms"):
        rig_of(sample_period=10, time={"column": None})
    rig = rig_of(matrix={"variable": "data", "columns": ["t", "theta", "phidot", "I", "u"]})
    savemat(tmp_path / "empty.mat", {"data": np.zeros((0, 5))})
    savemat(tmp_path / "cell.mat", {"data": np.array(["a", "bc"], dtype=object)})
    with pytest.raises(DataFormatError, match=r"variable 'data' is not a numeric matrix \(an empty array\)$"):
        read_rig_log(tmp_path / "empty.mat", rig)
    with pytest.raises(DataFormatError, match=r"variable 'data' is not a numeric matrix \(a 1x2 cell array\)$"):
        read_rig_log(tmp_path / "cell.mat", rig)


def test_mat_log_and_classdef_objects_are_refused_clearly(tmp_path, monkeypatch):
    from scipy.io import savemat
    from scipy.io.matlab import MatlabOpaque

    cols = _columns()
    savemat(tmp_path / "log.mat", {"run": {k: v for k, v in cols.items()}})
    d = read_rig_log(tmp_path / "log.mat", rig_of())
    np.testing.assert_allclose(d.q1, cols["theta"] * 2 * math.pi / 4096)
    # a MATLAB timeseries object comes out of scipy.io.loadmat as opaque data
    rec = np.zeros(1, dtype=[("s0", "O"), ("s1", "O"), ("s2", "O"), ("arr", "O")])
    rec[0] = (b"theta", b"MCOS", b"timeseries", np.zeros(3))
    import scipy.io

    monkeypatch.setattr(scipy.io, "loadmat", lambda *a, **k: {"t": cols["t"], "theta": MatlabOpaque(rec)})
    with pytest.raises(DataFormatError) as exc:
        read_rig_log(tmp_path / "log.mat", rig_of())
    msg = str(exc.value)
    assert "'theta' is a MATLAB 'timeseries' object" in msg and "save(" in msg and "\n" not in msg


# --------------------------------------------------------------------------
# the data model: what is measured
# --------------------------------------------------------------------------
def test_q2_optional_when_q4_is_measured_and_current_is_a_signal():
    t = np.arange(20) * 0.01
    d = ExperimentData(t=t, q1=np.zeros(20), q4=np.ones(20), extra={"current": np.full(20, 0.3)},
                       metadata={"q4_sampling": "mean"})
    assert d.q2 is None and d.q4_sampling == "mean" and np.all(d.current == 0.3)
    with pytest.raises(InputError, match="q2 is required .or the wheel speed q4."):
        ExperimentData(t=t, q1=np.zeros(20))
    with pytest.raises(InputError, match="q4_sampling"):
        ExperimentData(t=t, q1=np.zeros(20), q4=np.ones(20), metadata={"q4_sampling": "average"})


def test_glitches_are_found_replaced_recorded_and_survive_a_file(tmp_path):
    t = 0.02 * np.arange(500)
    q1 = 0.6 * np.sin(5.0 * t) * np.exp(-0.05 * t)
    q4 = 40 * np.sin(1.3 * t) + 5 * np.sin(7 * t)
    clean = find_glitches(t, {"q1": q1, "q4": q4})
    assert clean == []  # a smooth log has none
    q4g = q4.copy()
    q4g[0], q4g[250] = 2345.0, 0.0
    q1g = q1.copy()
    q1g[300:] += 0.03
    d = ExperimentData(t=t, q1=q1g, q4=q4g).with_glitches_found(warn=False)
    kinds = {(g.column, g.index, g.kind) for g in d.glitches}
    assert kinds == {("q4", 0, "spike"), ("q4", 250, "dropout"), ("q1", 300, "jump")}
    jump = next(g for g in d.glitches if g.kind == "jump")
    assert jump.value == pytest.approx(0.03, abs=0.003) and jump.replacement is None
    assert d.q4[250] == pytest.approx(q4[250], abs=0.3)  # replaced by the neighbours' mean
    assert d.q4[0] == pytest.approx(q4[0], abs=0.5)
    assert d.q1[300] == q1g[300]  # a jump is kept
    with pytest.warns(UserWarning, match="3 glitches"):
        ExperimentData(t=t, q1=q1g, q4=q4g).with_glitches_found()
    back = ExperimentData(**{k: v for k, v in d.as_columns().items()}, metadata=d.metadata)
    assert back.glitches == d.glitches
    w = d.window(1.0, 8.0)
    assert [(g.index, g.column) for g in w.glitches] == [(250 - 50, "q4"), (300 - 50, "q1")]


# --------------------------------------------------------------------------
# the virtual rig as other rigs: truth recovered by iwp fit
# --------------------------------------------------------------------------
SETUPS = {
    # sensor set-up: (rig changes, run options)
    "wheel speed only, 20 ms": ({}, {}),
    "50 ms sampling": ({"sample_period": 0.05}, {}),
    "saturating normalised input": ({"input": {"scale": 0.25}}, {"amplitude": 1.6}),
    "upright zero": ({"pendulum": {"zero": "up"}}, {"q1_offset": 0.025}),
    "degrees (IMU)": ({"pendulum": {"unit": "deg", "counts_per_rev": None}}, {"q1_offset": -0.03}),
    "first-sample glitch": ({}, {"first_sample": 2345.0, "dropouts": (400,), "jumps": ((900, 0.02),)}),
}


@pytest.mark.parametrize("name", list(SETUPS))
def test_virtual_rig_of_other_sensors_gives_back_its_truth(tmp_path, name):
    changes, opts = SETUPS[name]
    doc = json.loads(json.dumps(BASE))
    for k, v in changes.items():
        if isinstance(v, dict):
            doc[k].update(v)
            doc[k] = {kk: vv for kk, vv in doc[k].items() if vv is not None}
        else:
            doc[k] = v
    rig = RigDescription.from_dict(doc, where="rig.json")
    r = fit(tmp_path, rig, **opts)
    check_truth(r.params)
    if "q1_offset" in opts:
        for f in r.train:
            assert f.q1_offset == pytest.approx(opts["q1_offset"], abs=2e-3)
    if name == "saturating normalised input":
        assert any("exceeds its limits" in w for w in r.warnings)
    if name == "first-sample glitch":
        assert all(any("q4 spike at t = 0 s" in g for g in f.glitches) for f in r.train)
    # held out, simulated from the measured initial state without re-fitting
    for o in ("q1", "q4"):
        assert r.validation[0].fit[o] > 90.0, (o, r.validation[0].fit)


def test_data_that_cannot_separate_parameters_are_reported(tmp_path):
    r = fit(tmp_path, rig_of())
    # the one of the pair the fit says nothing of is held at 0, where the fit drove it, and said so; the other
    # carries the pair's damping (not Table 1's value, another rig's: issue 50), its spread in the bands scaled to it
    held = set(r.options.get("fixed", {})) & {"sigma_a1", "sigma_v1"}
    assert len(held) == 1
    (name,) = held
    (other,) = {"sigma_a1", "sigma_v1"} - held
    assert getattr(r.params, name) == 0.0 and getattr(r.params, other) > 0.0
    (w,) = [w for w in r.warnings if w.startswith(f"{name} is not identified by these logs")]
    assert "held there, its partners carrying the damping" in w
    t1 = table1()
    damping = r.params.sigma_a1 + r.params.sigma_v1
    assert r.held_priors[name] == pytest.approx(getattr(t1, name) / (t1.sigma_a1 + t1.sigma_v1) * damping)


# --------------------------------------------------------------------------
# cross-check: an independent reference fit (scipy least_squares + solve_ivp)
# --------------------------------------------------------------------------
def _reference_fit(d: ExperimentData, start: LumpedParameters, free, x0):
    """An independent reference: model (9) written out here in numpy, integrated by scipy's solve_ivp (RK45)
    sample by sample with the input held, fitted by scipy's least_squares with 2-point differences."""
    u = np.asarray(d.input)
    Ts = d.Ts
    y1, y4 = d.q1, d.q4

    def simulate(theta):
        p = start.replace(**dict(zip(free, theta)))

        def f(t, x, uk):
            q1, q2, q3, q4 = x
            xi = (p.p1 * math.sin(q1) + p.sigma_a1 * abs(math.cos(q1)) * q3 + p.sigma_v1 * q3
                  + p.sigma_b1 * q3 ** 3)
            m = p.p3 * uk - p.p2 * q4
            return [q3, q4, -xi - m, xi + (1 + p.rho) * m]

        X = np.empty((d.n_samples, 4))
        X[0] = x
        for k in range(d.n_samples - 1):
            sol = integrate.solve_ivp(f, (d.t[k], d.t[k + 1]), X[k], args=(u[k],), rtol=1e-10, atol=1e-10)
            X[k + 1] = sol.y[:, -1]
        return X.T

    x = np.asarray(x0, dtype=float)

    def res(theta):
        X = simulate(theta)
        mean4 = np.diff(X[1]) / Ts  # the board's mean speed over each period
        return np.concatenate([(X[0] - y1) / np.std(y1), (mean4 - y4[1:]) / np.std(y4[1:])])

    th0 = np.array([getattr(start, n) for n in free])
    sol = optimize.least_squares(res, th0, x_scale=np.maximum(np.abs(th0), 1e-3), diff_step=1e-6, xtol=1e-10,
                                 ftol=1e-10, bounds=(1e-9, np.inf))
    X = simulate(sol.x)
    mean4 = np.diff(X[1]) / Ts
    fit = {"q1": 100 * (1 - np.linalg.norm(y1 - X[0]) / np.linalg.norm(y1 - y1.mean())),
           "q4": 100 * (1 - np.linalg.norm(y4[1:] - mean4) / np.linalg.norm(y4[1:] - y4[1:].mean()))}
    return dict(zip(free, sol.x)), fit


def test_iwp_fit_matches_an_independent_scipy_reference_fit(tmp_path):
    rig = rig_of(pendulum={"offset": 0.0})  # zero given: both fits have the same unknowns
    vr = DescribedRig(rig, TRUTH.replace(sigma_a1=0.0), noise_std=0.002, seed=5)
    path = write_rig_csv(vr.run(Chirp(0.3, 3.0, 5.0), duration=6.0), tmp_path / "chirp.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        log = load_logs([path], rig)[0]
        ref_log = ExperimentData(t=log.t, q1=log.q1, q4=log.q4, u=log.v, metadata=log.metadata)
        start = least_squares_start([ref_log]).params.replace(sigma_a1=0.0, sigma_b1=TRUTH.sigma_b1)
        free = ("p1", "p2", "p3", "rho", "sigma_v1")
        ours = refine(as_experiments(ref_log, estimate_x0=False, x0=[np.zeros(4)]), start, free=free,
                      outputs=("q1", "q4"), warn=False)
    ref, ref_fit = _reference_fit(ref_log, start, free, np.zeros(4))
    for n in free:
        assert ours.params.to_dict()[n] == pytest.approx(ref[n], rel=1e-5), n
    for o in ("q1", "q4"):
        assert ours.fit[0][o] == pytest.approx(ref_fit[o], abs=1e-3), o


# --------------------------------------------------------------------------
# the command
# --------------------------------------------------------------------------
def test_iwp_fit_command_writes_the_report_and_refuses_bad_input(tmp_path, capsys):
    rig = rig_of()
    rig_path = tmp_path / "rig.json"
    rig_path.write_text(json.dumps(BASE))
    files, held = write_logs(tmp_path, rig, duration=20.0, first_sample=2345.0)
    out = tmp_path / "out"
    status = main(["fit", *map(str, files), "--rig", str(rig_path), "--validate", str(held), "--out", str(out)])
    assert status == 0
    doc = json.loads((out / "fit.json").read_text())
    assert doc["validation"][0]["fit"]["q1"] > 90 and doc["parameters"]["p1"]["stderr"] > 0
    # by default the ladder of structures, ranked on the one held-out log and the two training logs' folds (fewer
    # than five held out), in the JSON and the report
    lad = doc["structures"]
    assert [r["name"] for r in lad["rungs"]] == ["9", "coulomb", "pendulum-coulomb", "widths", "offset", "dead-zone"]
    assert lad["method"].startswith("paired scores, Student t") and lad["n_scored"] == 3
    assert lad["chosen"] == "9"  # the truth is model (9): richer structures predict no better
    assert ("Model structures, ranked on held-out logs and leave-one-log-out cross-validation (3 logs)"
            in (out / "report.html").read_text())
    assert (out / "report.html").read_text().count("<img") == 4  # correlation, 2 training logs, 1 held out
    assert json.loads((out / "parameters.json").read_text())["parameters"]["p1"] == pytest.approx(40, rel=0.01)
    err = capsys.readouterr().err
    assert "q4 spike at t = 0 s" in err
    # the folder is not overwritten, and a mapping error is one line naming the column
    assert main(["fit", str(files[0]), "--rig", str(rig_path), "--out", str(out)]) == 2
    assert "--force" in capsys.readouterr().err
    bad = dict(BASE, pendulum={"column": "angle", "unit": "counts", "counts_per_rev": 4096})
    rig_path.write_text(json.dumps(bad))
    assert main(["fit", str(files[0]), "--rig", str(rig_path), "--out", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "column 'angle'" in err[0] and "pendulum.column" in err[0]
    assert not (tmp_path / "o2").exists()


def test_a_window_that_leaves_too_few_samples_names_the_flag(tmp_path, capsys):
    rig_path = tmp_path / "rig.json"
    rig_path.write_text(json.dumps(BASE))
    files, _held = write_logs(tmp_path, rig_of(), duration=10.0)
    assert main(["fit", str(files[0]), "--rig", str(rig_path), "--out", str(tmp_path / "o"), "--model", "9",
                 "--t-start", "9.95"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "too few" in err[0] and "--t-start=9.95 s keeps 3 of chirp0.csv" in err[0], err
    assert not (tmp_path / "o").exists()


def test_iwp_validate_of_a_held_out_log_gives_the_fits_own_numbers(tmp_path, capsys):
    # the rig's pendulum offset is estimated per log and its input is a duty (a raw v that the fit reads as u):
    # validate takes the fit's offset and input as the fit did, and the same one-sided initial state
    rig = rig_of()
    rig_path = tmp_path / "rig.json"
    rig_path.write_text(json.dumps(BASE))
    files, held = write_logs(tmp_path, rig, duration=20.0, q1_offset=0.02)
    out = tmp_path / "out"
    assert main(["fit", *map(str, files), "--rig", str(rig_path), "--validate", str(held), "--out", str(out),
                 "--model", "9"]) == 0
    stored = json.loads((out / "parameters.json").read_text())
    assert stored["q1_offset"] == pytest.approx(0.02, abs=2e-3) and stored["reads_v_as_u"] is True
    expected = json.loads((out / "fit.json").read_text())["validation"][0]["fit"]
    converted = tmp_path / "held.csv"
    assert main(["convert", str(held), "--rig", str(rig_path), "--out", str(converted)]) == 0
    capsys.readouterr()
    assert main(["validate", str(converted), "--params", str(out / "parameters.json"), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["fit"]  # q1 and, the log holding only the wheel's speed, q4
    assert got["q1"] == pytest.approx(expected["q1"], abs=1e-6) and got["q4"] == pytest.approx(expected["q4"], abs=1e-6)
    assert expected["q1"] > 95.0
    assert stored["q1_offset_logs"] == 2 and stored["q1_offset_spread"] > 0
    assert main(["validate", str(converted), "--params", str(out / "parameters.json"), "--signals", "q1,q2"]) == 2
    err = capsys.readouterr().err
    assert "has no wheel angle q2" in err and "compare q4 instead: --signals=q1,q4" in err
    # and iwp report, on a rig that logs the wheel's speed only
    assert main(["report", str(converted), "--params", str(out / "parameters.json"), "--out", str(tmp_path / "r")]) == 0
    compared = json.loads((tmp_path / "r" / "comparison.json").read_text())["logs"][0]
    assert compared["model"] == "compensated" and set(compared["fit"]) == {"q1", "q4"}
    assert compared["fit"]["q1"] == pytest.approx(expected["q1"], abs=1e-6)
    assert compared["fit"]["q4"] == pytest.approx(expected["q4"], abs=1e-6)


def test_iwp_validate_band_carries_the_held_out_zero_as_iwp_fit_does(tmp_path, capsys):
    """Three training logs zeroed each its own way: iwp fit's held-out band and iwp validate's on the converted
    log hold the same share of samples, both carrying the spread of a run's zero about the training mean."""
    doc = {**BASE, "wheel": {"column": "phi", "quantity": "angle", "unit": "counts", "counts_per_rev": 1200}}
    rig = RigDescription.from_dict(doc, where="rig.json")
    rig_path = tmp_path / "rig.json"
    rig_path.write_text(json.dumps(doc))
    files = []
    for i, (q1_offset, inp) in enumerate(((0.020, Chirp(0.3, 2.0, 15.0)), (0.030, Chirp(0.21, 3.0, 20.0)),
                                          (0.015, Chirp(0.25, 2.5, 18.0)))):
        vr = DescribedRig(rig, TRUTH, q1_offset=q1_offset)
        files.append(write_rig_csv(vr.run(inp, duration=20.0), tmp_path / f"chirp{i}.csv"))
    n = int(round(20.0 / rig.sample_period)) + 1
    held = write_rig_csv(DescribedRig(rig, TRUTH, q1_offset=0.032).run(prbs(n, hold=15, amplitude=0.18, seed=3),
                                                                       duration=20.0), tmp_path / "prbs.csv")
    out = tmp_path / "out"
    assert main(["fit", *map(str, files), "--rig", str(rig_path), "--validate", str(held), "--out", str(out),
                 "--model", "9"]) == 0
    stored = json.loads((out / "parameters.json").read_text())
    # the three zeros, estimated: their mean and sample variance (5.8e-5 rad^2, far above a count's 1.9e-7)
    zeros = [0.020, 0.030, 0.015]
    assert stored["q1_offset"] == pytest.approx(np.mean(zeros), abs=2e-4) and stored["q1_offset_logs"] == 3
    assert stored["q1_offset_spread"] == pytest.approx(np.var(zeros, ddof=1), rel=0.05)
    coverage = json.loads((out / "fit.json").read_text())["validation"][0]["band_coverage"]
    converted = tmp_path / "held.csv"
    assert main(["convert", str(held), "--rig", str(rig_path), "--out", str(converted)]) == 0
    capsys.readouterr()
    assert main(["validate", str(converted), "--params", str(out / "parameters.json"), "--band", "--json"]) == 0
    banded = json.loads(capsys.readouterr().out)["band"]["coverage"]
    # the held-out log was zeroed 10 mrad from the training mean: a band without that spread held 60 % of its q1
    assert {"q1", "q4"} <= set(coverage) and coverage["q1"] > 0.95
    for s in ("q1", "q4"):
        assert banded[s] == pytest.approx(coverage[s], abs=1e-9), s


# --------------------------------------------------------------------------
# model options of other rigs, against analytic references
# --------------------------------------------------------------------------
def test_pendulum_coulomb_friction_decays_the_swing_linearly():
    """Free pendulum with Coulomb friction only: in the linear range each half swing loses 2 sigma_c1 / p1."""
    from iwp.sim.simulate import simulate

    p = LumpedParameters(p1=26.0, p2=0.0, p3=1.0, rho=100.0, sigma_a1=0.0, sigma_v1=0.0, sigma_b1=0.0, sigma_c1=0.2)
    res = simulate(Plant(p, model="free-nowheel", coulomb_eps=1e-5), x0=[0.02, 0, 0, 0], t_end=2.0, Ts=1e-4,
                   options=SimOptions(tolerances=Tolerances(rtol=1e-10, atol=1e-12)))
    q1, q3 = res.x[:, 0], res.x[:, 2]
    turns = np.flatnonzero(np.sign(q3[1:]) != np.sign(q3[:-1]))
    peaks = np.abs(q1[turns[:4]])
    drops = -np.diff(peaks)
    assert drops == pytest.approx(2 * 0.2 / 26.0, rel=2e-3)
    # without it, no loss at all
    res0 = simulate(Plant(p.replace(sigma_c1=0.0), model="free-nowheel"), x0=[0.02, 0, 0, 0], t_end=2.0, Ts=1e-3,
                    options=SimOptions(tolerances=Tolerances(rtol=1e-10, atol=1e-12)))
    assert np.max(np.abs(res0.x[:, 0])) == pytest.approx(0.02, rel=1e-6)


def test_input_offset_shifts_the_input():
    """u_offset c with input U is the plant driven by U + c: the disk settles at p3 (U + c) / p2 (model (14))."""
    from iwp.sim.inputs import Constant
    from iwp.sim.simulate import simulate

    p = TRUTH.replace(u_offset=0.05)
    res = simulate(Plant(p, model="motor-disk"), input=Constant(0.2), t_end=20.0,
                   options=SimOptions(tolerances=Tolerances(rtol=1e-10, atol=1e-10)))
    assert res.x[-1, 3] == pytest.approx(p.p3 * 0.25 / p.p2, rel=1e-8)
    a = simulate(Plant(p), input=Chirp(0.3, 2.0, 10.0), t_end=5.0,
                 options=SimOptions(tolerances=Tolerances(rtol=1e-11, atol=1e-11)))
    b = simulate(Plant(p.replace(u_offset=0.0)), input=Chirp(0.3, 2.0, 10.0, offset=0.05), t_end=5.0,
                 options=SimOptions(tolerances=Tolerances(rtol=1e-11, atol=1e-11)))
    np.testing.assert_allclose(a.x, b.x, atol=1e-9)


# --------------------------------------------------------------------------
# the files users have (issue 21): a matrix in a MATLAB file, scales, messages with numbers
# --------------------------------------------------------------------------
def _matrix_log(tmp_path, rig, *, transpose=False, name="data"):
    from scipy.io import savemat

    run = DescribedRig(rig, TRUTH).run(Chirp(0.3, 2.0, 15.0), duration=16.0)
    cols = ["t", "u", "theta", "phidot", "I"]
    m = np.column_stack([run.columns[c] for c in cols])
    path = tmp_path / "log.mat"
    savemat(path, {name: m.T if transpose else m})
    return path, run


def test_a_matlab_matrix_is_read_by_the_columns_the_description_names(tmp_path):
    rig = rig_of()
    path, run = _matrix_log(tmp_path, rig)
    # without 'matrix' the error says what the file holds
    with pytest.raises(DataFormatError, match=r"found: a 801x5 matrix 'data'; name a matrix's columns with the "
                                              r"key 'matrix'"):
        read_rig_log(path, rig)
    mrig = rig_of(matrix={"variable": "data", "columns": ["t", "u", "theta", "phidot", "I"]})
    d = read_rig_log(path, mrig, glitches=False)
    ref = read_rig_log(write_rig_csv(run, tmp_path / "log.csv"), rig, glitches=False)
    np.testing.assert_allclose(d.q1, ref.q1, atol=1e-12)
    np.testing.assert_allclose(d.q4, ref.q4, atol=1e-12)
    np.testing.assert_allclose(d.input, ref.input, atol=1e-12)
    # one row per signal is read too; the only matrix needs no name
    (tmp_path / "x").mkdir()
    path2, _ = _matrix_log(tmp_path / "x", rig, transpose=True, name="M")
    d2 = read_rig_log(path2, rig_of(matrix={"columns": ["t", "u", "theta", "phidot", "I"]}), glitches=False)
    np.testing.assert_allclose(d2.q1, ref.q1, atol=1e-12)
    with pytest.raises(DataFormatError, match=r"variable 'data' is a 801x5 matrix but rig.json key "
                                              r"'matrix.columns' names 4 columns"):
        read_rig_log(path, rig_of(matrix={"columns": ["t", "u", "theta", "phidot"]},
                                  current=None))


def test_a_rig_description_refuses_two_signals_on_one_column_and_unnamed_matrix_columns():
    with pytest.raises(InputError, match=r"'pendulum.column' and 'wheel.column' both name the column 'theta'"):
        rig_of(wheel={"column": "theta"})
    with pytest.raises(InputError, match=r"'current.column' names the column 'I', which 'matrix.columns' does not "
                                         r"list"):
        rig_of(matrix={"columns": ["t", "u", "theta", "phidot"]})
    with pytest.raises(InputError, match=r"'pendulum.scale' must not be 0"):
        rig_of(pendulum={"scale": 0})


def test_a_scale_corrects_a_wrong_encoder_gain(tmp_path):
    rig = rig_of()
    run = DescribedRig(rig, TRUTH).run(Chirp(0.3, 2.0, 15.0), duration=10.0)
    good = read_rig_log(write_rig_csv(run, tmp_path / "a.csv"), rig, glitches=False)
    # a lab whose encoder logs 20 % too few counts corrects the angle by 1.25
    cols = dict(run.columns)
    cols["theta"] = np.round(cols["theta"] * 0.8)
    import csv

    with open(tmp_path / "b.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(cols))
        w.writerows(zip(*cols.values()))
    wrong = read_rig_log(tmp_path / "b.csv", rig, glitches=False)
    fixed = read_rig_log(tmp_path / "b.csv", rig_of(pendulum={"scale": 1.25}), glitches=False)
    assert np.max(np.abs(wrong.q1 - good.q1)) > 0.1 * np.max(np.abs(good.q1))
    np.testing.assert_allclose(fixed.q1, good.q1, atol=1.25 * 2 * math.pi / 4096)


def test_counts_with_fractions_are_named_with_a_number_not_a_repr(tmp_path):
    rig = rig_of()
    run = DescribedRig(rig, TRUTH).run(Chirp(0.3, 2.0, 15.0), duration=2.0)
    cols = dict(run.columns)
    cols["theta"] = cols["theta"] * 2 * math.pi / 4096  # radians logged under a counts description
    import csv

    with open(tmp_path / "c.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(cols))
        w.writerows(zip(*cols.values()))
    with pytest.raises(DataFormatError) as e:
        read_rig_log(tmp_path / "c.csv", rig)
    assert "np.float64" not in str(e.value) and "whole numbers, found" in str(e.value)


# --------------------------------------------------------------------------
# every experiment a user has, in one fit (issue 21)
# --------------------------------------------------------------------------
def test_clamped_and_wheel_locked_logs_join_the_fit_through_the_cli(tmp_path):
    rig = rig_of(sample_period=0.05, pendulum={"counts_per_rev": 20000})
    truth = TRUTH.replace(sigma_c2=0.5, sigma_c1=0.4)
    vr = DescribedRig(rig, truth, noise_std=0.002, seed=1)
    chirp = write_rig_csv(vr.run(Chirp(0.4, 2.0, 6.0), duration=20.0), tmp_path / "c.csv")
    clamp = write_rig_csv(vr.run(Chirp(0.4, 2.0, 6.0), duration=20.0, kind="clamped"), tmp_path / "clamp.csv")
    swing = write_rig_csv(vr.run(None, duration=20.0, kind="wheel-locked", x0=[0.8, 0, 0, 0]), tmp_path / "wl.csv")
    rig_path = tmp_path / "rig.json"
    rig_path.write_text(json.dumps(rig.to_dict()))
    out = tmp_path / "out"
    assert main(["fit", str(chirp), "--clamped", str(clamp), "--wheel-locked", str(swing), "--rig", str(rig_path),
                 "--model", "pendulum-coulomb", "--out", str(out)]) == 0
    doc = json.loads((out / "fit.json").read_text())
    kinds = {Path(f["source"]).name: (f["kind"], set(f["fit"])) for f in doc["train"]}
    # each set-up compares what it moves: the clamped log the wheel, the locked wheel's swing the angle
    assert kinds == {"c.csv": ("free", {"q1", "q4"}), "clamp.csv": ("clamped", {"q4"}),
                     "wl.csv": ("wheel-locked", {"q1"})}
    for f in doc["train"]:
        assert min(f["fit"].values()) > 99.0
    # the same logs all given as training logs: their motion shows their set-ups, and the fit is the same
    auto = tmp_path / "auto"
    held = write_rig_csv(vr.run(Chirp(0.3, 2.5, 6.0), duration=10.0, kind="clamped", seed=5), tmp_path / "h.csv")
    # (the held-out log is clamped, simulated as a free pendulum: predicted poorly, exit 1 without --accept-poor)
    argv = ["fit", str(chirp), str(clamp), str(swing), "--rig", str(rig_path), "--model", "pendulum-coulomb",
            "--validate", str(held)]
    assert main(argv + ["--out", str(tmp_path / "strict")]) == 1
    assert main(argv + ["--accept-poor", "--out", str(auto)]) == 0
    doc_auto = json.loads((auto / "fit.json").read_text())
    assert {Path(f["source"]).name: (f["kind"], set(f["fit"])) for f in doc_auto["train"]} == kinds
    assert doc_auto["parameters"] == doc["parameters"]
    for name, kind in (("clamp.csv", "clamped"), ("wl.csv", "wheel-locked")):
        assert sum(w.startswith("train ") and name in w and f"fitted as a {kind} log" in w
                   for w in doc_auto["warnings"]) == 1
    # a held-out log is simulated as a free pendulum: one whose motion shows another set-up is named
    assert sum(w.startswith("validate ") and "h.csv" in w and "a log of the clamped set-up?" in w
               for w in doc_auto["warnings"]) == 1
    # one realisation: accuracy, not coverage. The standard errors are small; the intervals are several of them
    # wide, for each set-up informs the parameters unequally (sigma_c1 rests on two of the three experiments:
    # Bell-McCaffrey's degrees of freedom, 1.1 here, not G - 1 = 2)
    for name in ("p1", "p2", "p3", "rho", "sigma_c2", "sigma_c1"):
        p = doc["parameters"][name]
        assert p["value"] == pytest.approx(getattr(truth, name), rel=0.01), name
        assert p["stderr"] < 0.01 * getattr(truth, name), name
        half = 0.5 * (p["ci95"][1] - p["ci95"][0])
        assert stats.t.ppf(0.975, 2) * p["stderr"] <= half * (1 + 1e-9), name  # never narrower than G - 1 dof


def test_a_closed_loop_log_joins_the_fit_simulated_with_its_law(tmp_path, capsys):
    # the Hopf law on the rig's 50 ms clock (sampled and held): an orbit of 0.7 rad, duty within +-0.45
    rig = rig_of(sample_period=0.05, pendulum={"counts_per_rev": 20000}, input={"limits": [-1, 1]})
    truth = TRUTH.replace(sigma_c2=0.5, sigma_c1=0.4)
    vr = DescribedRig(rig, truth, noise_std=0.002, seed=1)
    law = HopfController(-0.3, 0.02, 0.05)
    chirp = write_rig_csv(vr.run(Chirp(0.4, 2.0, 6.0), duration=20.0), tmp_path / "c.csv")
    loop = vr.run(None, duration=20.0, kind="closed-loop", x0=[0.3, 0.0, 0.0, 0.0], controller=law, seed=2)
    assert 0.6 < np.max(np.abs(loop.x[-100:, 0])) < 0.8 and np.max(np.abs(loop.w)) < 0.5
    cl = write_rig_csv(loop, tmp_path / "loop.csv")
    rig_path = tmp_path / "rig.json"
    rig_path.write_text(json.dumps(rig.to_dict()))
    out = tmp_path / "out"
    gains = ["--controller", "hopf", "--k1", "-0.3", "--k2", "0.02", "--controller-ts", "0.05"]
    assert main(["fit", str(chirp), "--closed-loop", str(cl), *gains, "--rig", str(rig_path),
                 "--model", "pendulum-coulomb", "--out", str(out)]) == 0
    doc = json.loads((out / "fit.json").read_text())
    kinds = {Path(f["source"]).name: (f["kind"], set(f["fit"])) for f in doc["train"]}
    assert kinds == {"c.csv": ("free", {"q1", "q4"}), "loop.csv": ("closed-loop", {"q1", "q4"})}
    # simulated with the law from its estimated start, the loop's orbit is the logged one
    assert min(next(f for f in doc["train"] if f["kind"] == "closed-loop")["fit"].values()) > 97.0
    for name in ("p1", "p3", "rho", "sigma_c2", "sigma_c1"):
        assert doc["parameters"][name]["value"] == pytest.approx(getattr(truth, name), rel=0.02), name
    capsys.readouterr()
    # the law and its logs come together: each alone is one line naming --controller, exit 2, nothing written
    for args, what in (([str(chirp), "--closed-loop", str(cl)], "need their feedback law"),
                       ([str(chirp), *gains], "none is given")):
        assert main(["fit", *args, "--rig", str(rig_path), "--out", str(tmp_path / "o2")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("iwp: error: --controller") and what in err[0], err
        assert not (tmp_path / "o2").exists()


def test_the_rig_descriptions_experiments_give_each_log_its_set_up(tmp_path, capsys):
    """A rig description's ``experiments`` name the set-up of each log by its file name, so that all of a rig's
    logs join one fit with only ``iwp fit LOGS... --rig rig.json`` (issue 21), a closed-loop one with its law."""
    law = {"law": "hopf", "k1": -0.3, "k2": 0.02, "ts": 0.05}
    experiments = [{"files": ["clamp_*.csv"], "kind": "clamped"}, {"files": "run/wl.csv", "kind": "wheel-locked"},
                   {"files": "loop?.csv", "kind": "closed-loop", "controller": law},
                   {"files": "quiet.csv", "kind": "free"}]
    rig = rig_of(sample_period=0.05, pendulum={"counts_per_rev": 20000}, input={"limits": [-1, 1]},
                 experiments=experiments)
    assert RigDescription.from_dict(rig.to_dict(), where="rig.json") == rig  # the key survives a file
    assert [rig.experiment_of(f) for f in ("x/clamp_1.csv", "wl.csv", "x/run/wl.csv", "loop1.csv", "c.csv")] == [
        rig.experiments[0], None, rig.experiments[1], rig.experiments[2], None]
    truth = TRUTH.replace(sigma_c2=0.5, sigma_c1=0.4)
    vr = DescribedRig(rig, truth, noise_std=0.002, seed=1)
    (tmp_path / "run").mkdir()
    chirp = write_rig_csv(vr.run(Chirp(0.4, 2.0, 6.0), duration=20.0), tmp_path / "c.csv")
    clamp = write_rig_csv(vr.run(Chirp(0.4, 2.0, 6.0), duration=20.0, kind="clamped"), tmp_path / "clamp_1.csv")
    swing = write_rig_csv(vr.run(None, duration=20.0, kind="wheel-locked", x0=[0.8, 0, 0, 0]),
                          tmp_path / "run" / "wl.csv")
    loop = write_rig_csv(vr.run(None, duration=20.0, kind="closed-loop", x0=[0.3, 0.0, 0.0, 0.0], seed=2,
                                controller=HopfController(-0.3, 0.02, 0.05)), tmp_path / "loop1.csv")
    # a free log declared free is not second-guessed: this one hangs still while the wheel turns slowly
    quiet = write_rig_csv(vr.run(Chirp(0.05, 0.05, 0.1), duration=20.0, seed=4), tmp_path / "quiet.csv")
    assert inferred_kind(read_rig_log(quiet, rig)) == "clamped"
    rig_path = tmp_path / "rig.json"
    rig_path.write_text(json.dumps(rig.to_dict()))
    out = tmp_path / "out"
    assert main(["fit", *map(str, (chirp, clamp, swing, loop, quiet)), "--rig", str(rig_path),
                 "--model", "pendulum-coulomb", "--out", str(out)]) == 0
    doc = json.loads((out / "fit.json").read_text())
    kinds = {Path(f["source"]).name: (f["kind"], set(f["fit"])) for f in doc["train"]}
    assert kinds == {"c.csv": ("free", {"q1", "q4"}), "clamp_1.csv": ("clamped", {"q4"}),
                     "wl.csv": ("wheel-locked", {"q1"}), "loop1.csv": ("closed-loop", {"q1", "q4"}),
                     "quiet.csv": ("free", {"q1", "q4"})}
    assert not any("fitted as a" in w for w in doc["warnings"])  # declared, not inferred
    # the closed loop is simulated with the description's law: its orbit is the logged one
    assert min(next(f for f in doc["train"] if f["kind"] == "closed-loop")["fit"].values()) > 97.0
    for name in ("p1", "p3", "rho", "sigma_c2", "sigma_c1"):
        assert doc["parameters"][name]["value"] == pytest.approx(getattr(truth, name), rel=0.02), name
    capsys.readouterr()
    # the command line's kind comes first: a clamped log given as --wheel-locked is taken as wheel-locked, and as
    # its wheel turns, refused by that flag (a fit that compared only its still pendulum would learn nothing from
    # it); a fit of no free log is one line naming the training logs
    assert main(["fit", str(chirp), "--wheel-locked", str(clamp), "--rig", str(rig_path), "--model", "9",
                 "--out", str(tmp_path / "o1")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("iwp: error: --wheel-locked ") and "the wheel turns" in err[0], err
    assert not (tmp_path / "o1").exists()
    assert main(["fit", str(clamp), str(loop), "--rig", str(rig_path), "--out", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("iwp: error: train") and "clamp_1.csv: clamped" in err[0], err
    assert not (tmp_path / "o2").exists()


def test_a_swing_released_from_rest_starts_its_fit_at_its_measured_state(tmp_path):
    """At 50 ms a swing of 1.3 rad: the edge of a 21-sample filter (a second) once gave 1.62 rad and -6.1 rad/s
    as the start, and a joint fit with a clamped log beside it stopped there (2,600 times the truth's cost)."""
    from iwp.ident.output_error import Experiment, OutputError
    from iwp.ident.validation import model_input

    rig = rig_of(sample_period=0.05, pendulum={"counts_per_rev": 20000})
    truth = TRUTH.replace(sigma_c2=0.5, sigma_c1=0.4)
    vr = DescribedRig(rig, truth, noise_std=0.002, seed=1)
    x0 = [1.3, 0.0, 0.0, 0.0]
    files = {"train": write_rig_csv(vr.run(Chirp(0.4, 2.0, 6.0), duration=20.0, seed=2), tmp_path / "c.csv"),
             "clamped": write_rig_csv(vr.run(Chirp(0.4, 2.0, 6.0), duration=20.0, kind="clamped", seed=3),
                                      tmp_path / "clamp.csv"),
             "wheel-locked": write_rig_csv(vr.run(None, duration=20.0, kind="wheel-locked", x0=x0, seed=4),
                                           tmp_path / "wl.csv")}
    swing = model_input(load_logs([files["wheel-locked"]], rig)[0], "compensated", "wl")
    model = OutputError(Plant(truth, model="compensated"), [Experiment(swing, kind="wheel-locked")], ("q1",))
    start = model.prepared[0].x0
    # a quadratic over the first 0.2 s of cos(6.3 t): 0.3 % of the angle, a few hundredths of a rad/s
    assert start[0] == pytest.approx(x0[0], abs=0.01) and start[2] == pytest.approx(0.0, abs=0.15)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fit_logs([files["train"]], rig=rig, kinds={k: [v] for k, v in files.items() if k != "train"},
                       options=LogFitOptions(terms={"coulomb", "pendulum_coulomb"},
                                             start=truth.replace(sigma_c1=0.0, sigma_a1=0.2, sigma_v1=0.0)), warn=False)
    assert min(min(f.fit.values()) for f in res.train) > 99.0
    assert res.params.sigma_c1 == pytest.approx(0.4, rel=0.02) and res.params.p1 == pytest.approx(40.0, rel=0.002)


@pytest.mark.parametrize("stalls", [1, 99])
def test_a_ladder_fit_that_ends_above_the_structure_it_extends_is_fitted_again_or_not_chosen(tmp_path, monkeypatch,
                                                                                            stalls):
    """The pendulum's Coulomb structure holds model (9) plus the disk's (its sigma_c1 at 0): its fit cannot end
    above that one's cost. Its first fit (``stalls`` 1) or every fit (99) is made to end there, as one did: it is
    fitted again next to that optimum, then from the simpler structure's below it (model (9)'s)."""
    import iwp.ident.fit_ladder as logfit  # where the ladder looks them up

    vr = DescribedRig(rig_of(), TRUTH.replace(sigma_c2=0.5, sigma_c1=0.4), noise_std=0.002, seed=4)
    logs = [write_rig_csv(vr.run(Chirp(0.3, 1.0 + i, 6.0), duration=6.0, seed=i), tmp_path / f"c{i}.csv")
            for i in range(2)]
    real, calls = logfit.refine, []

    def refine(exps, plant, **kw):
        r = real(exps, plant, **kw)
        if "sigma_c1" in kw["free"] and "eps_c1" not in kw["free"] and len(exps) == 2:  # the rung's fits on all logs
            calls.append(r.cost)
            if len(calls) <= stalls:
                return replace(r, cost=1e3 * r.cost)
        return r

    monkeypatch.setattr(logfit, "refine", refine)
    monkeypatch.setattr(logfit, "hold_unidentified", lambda fitting, fitted: fitted)  # the ladder's fits alone
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fit_logs(logs, rig=rig_of(), options=LogFitOptions(select=True), warn=False)
    by = {o.rung.name: o for o in res.structures.outcomes}
    pc, parent = by["pendulum-coulomb"], by["coulomb"]
    if stalls == 1:  # fitted again from next to the simpler optimum, which ends below it
        assert len(calls) == 2 and pc.success and pc.result.cost == calls[1] <= parent.result.cost
    else:  # next to it, then from model (9)'s optimum: none ends below
        assert len(calls) == 3 and not pc.success and "not a minimum" in pc.message and res.structures.chosen.rung.name != \
            "pendulum-coulomb"


def test_logs_of_two_set_ups_are_named_before_the_joint_fit(tmp_path):
    from iwp.ident.fit_plan import disagreeing_logs

    rig = rig_of()
    a = DescribedRig(rig, TRUTH).run(Chirp(0.3, 2.0, 15.0), duration=20.0)
    b = DescribedRig(rig, TRUTH.replace(p1=TRUTH.p1 / 7)).run(Chirp(0.3, 1.0, 15.0), duration=20.0)
    c = DescribedRig(rig, TRUTH).run(Chirp(0.25, 3.0, 10.0), duration=20.0)
    logs = load_logs([write_rig_csv(r, tmp_path / f"{n}.csv") for n, r in (("a", a), ("b", b), ("c", c))], rig)
    msg = disagreeing_logs(logs)
    assert len(msg) == 1 and "disagree on the gravity term p1" in msg[0]
    values = {m[0]: float(m[1]) for m in re.findall(r"(\w)\.csv ([\d.]+) \+-", msg[0])}
    assert values["a"] == pytest.approx(TRUTH.p1, rel=0.03) and values["c"] == pytest.approx(TRUTH.p1, rel=0.03)
    assert values["b"] == pytest.approx(TRUTH.p1 / 7, rel=0.03)
    assert disagreeing_logs([logs[0], logs[2]]) == []  # one set-up, two excitations: no warning


def test_a_fast_wheels_real_corners_are_no_glitches_but_a_garbage_first_sample_is(tmp_path):
    # a direct drive whose wheel speed settles within a sample: at every reversal of a pseudo-random input
    # and at its start the speed turns a sharp corner (without the input, the first one was taken for a dropout)
    rig = rig_of(sample_period=0.05, wheel={"sampling": "instant"})
    truth = TRUTH.replace(p2=3.0, p3=600.0)
    run = DescribedRig(rig, truth).run(prbs(801, hold=6, amplitude=0.1, seed=3), duration=40.0)
    d = read_rig_log(write_rig_csv(run, tmp_path / "fast.csv"), rig, glitches=False)
    assert [g.describe() for g in find_glitches(d.t, {"q4": d.q4})] != []  # the input is what tells them apart
    assert find_glitches(d.t, {"q1": d.q1, "q4": d.q4}, input=d.input) == []
    q4 = d.q4.copy()
    q4[0], q4[333] = 2345.0, q4[333] + 0.5 * np.ptp(d.q4)
    found = find_glitches(d.t, {"q1": d.q1, "q4": q4}, input=d.input)
    assert [(g.index, g.kind) for g in found] == [(0, "spike"), (333, "spike")]


def test_a_chirps_quiet_start_is_no_glitch_but_a_spike_in_it_is(tmp_path):
    # a smooth input leaves the regression on its steps ill-conditioned: extrapolated to the log's start it
    # once made the second sample of every such chirp a "q1 spike" of a count or two
    rig = rig_of(sample_period=0.05, pendulum={"counts_per_rev": 20000})
    truth = TRUTH.replace(sigma_c1=0.4, sigma_c2=0.3, eps_c1=0.1, eps_c2=0.5)
    for seed in range(4):
        run = DescribedRig(rig, truth, q1_offset=0.02, noise_std=0.001, seed=seed).run(Chirp(0.2, 3.0, 20.0),
                                                                                         duration=40.0)
        d = read_rig_log(write_rig_csv(run, tmp_path / f"c{seed}.csv"), rig, glitches=False)
        assert find_glitches(d.t, {"q1": d.q1, "q4": d.q4}, input=d.input) == [], seed
    q1 = d.q1.copy()
    q1[200] += 0.3 * np.ptp(d.q1)
    found = find_glitches(d.t, {"q1": q1, "q4": d.q4}, input=d.input)
    assert [(g.column, g.index, g.kind) for g in found] == [("q1", 200, "spike")]


def test_runs_draw_the_rigs_noise_unless_given_their_own_seed():
    """The same seed reproduces a run bitwise; runs given their own seeds have independent noise."""
    vr = DescribedRig(rig_of(), TRUTH, noise_std=0.002, seed=3)
    runs = [vr.run(None, duration=20.0, x0=[0.5, 0, 0, 0], seed=s) for s in (None, None, 4, 5)]
    q = [r.columns["theta"] * (2 * math.pi / 4096) - r.x[:, 0] for r in runs]  # the reading's error [rad]
    np.testing.assert_array_equal(q[0], q[1])
    # the noise of 0.002 rad dominates the quantum of 0.0015 / sqrt(12) rad: independent draws correlate ~0
    c = np.corrcoef(q[2], q[3])[0, 1]
    assert abs(c) < 4 / math.sqrt(q[2].size) and np.corrcoef(q[0], q[1])[0, 1] == pytest.approx(1.0)
    with pytest.raises(InputError, match="seed must be an integer >= 0"):
        vr.run(None, duration=1.0, seed=-1)


def test_a_log_whose_motion_contradicts_its_kind_is_named(tmp_path):
    rig = rig_of()
    vr = DescribedRig(rig, TRUTH, noise_std=0.001, seed=2)
    free = write_rig_csv(vr.run(Chirp(0.3, 2.0, 15.0), duration=20.0), tmp_path / "free.csv")
    clamp = write_rig_csv(vr.run(Chirp(0.4, 2.0, 6.0), duration=20.0, kind="clamped"), tmp_path / "clamp.csv")
    locked = write_rig_csv(vr.run(None, duration=20.0, kind="wheel-locked", x0=[0.8, 0, 0, 0]), tmp_path / "wl.csv")
    free_log, clamp_log, locked_log = load_logs([free, clamp, locked], rig)
    # each log's motion shows its set-up (the clamped log's angle: noise of 0.001 rad, a span of about 0.006)
    assert [inferred_kind(d) for d in (free_log, clamp_log, locked_log)] == ["free", "clamped", "wheel-locked"]
    given_free = kind_mismatches([locked_log], [("wheel-locked", free_log)])
    assert len(given_free) == 2 and "wl.csv: its wheel does not turn while its pendulum swings" in given_free[0]
    assert given_free[1].startswith("--wheel-locked ") and "free.csv: the wheel turns" in given_free[1]
    assert kind_mismatches([free_log], [("clamped", clamp_log)]) == []  # each as it is
    swapped = kind_mismatches([clamp_log], [("clamped", free_log)])
    assert len(swapped) == 2
    assert swapped[0].startswith("train ") and "clamp.csv: its pendulum angle does not move while" in swapped[0]
    assert "--clamped" in swapped[0]
    assert swapped[1].startswith("--clamped ") and "free.csv" in swapped[1] and "was not clamped" in swapped[1]
    span = float(re.search(r"spans ([\d.]+) rad", swapped[1]).group(1))
    assert span == pytest.approx(float(np.ptp(free_log.q1)), rel=1e-2) and span > 0.1


@pytest.mark.parametrize("noise", [0.0, 0.001])
def test_a_coarsely_sampled_fast_swing_is_no_jump_but_a_step_in_it_is(tmp_path, noise):
    # half-turn swings at 50 ms: the angle's curvature changes fast, alike at a sample and beside it (without
    # noise, five such samples were once "jumps")
    rig = rig_of(sample_period=0.05, pendulum={"counts_per_rev": 20000})
    for jumps in ((), ((300, 0.03),)):
        run = DescribedRig(rig, TRUTH, jumps=jumps, noise_std=noise, seed=1).run(Chirp(0.4, 3.0, 10.0), duration=20.0)
        d = read_rig_log(write_rig_csv(run, tmp_path / f"swing{len(jumps)}.csv"), rig, glitches=False)
        assert np.ptp(d.q1) > 3.0  # the swings of the test: over half a turn each way
        found = find_glitches(d.t, {"q1": d.q1, "q4": d.q4}, input=d.input)
        assert [(g.index, g.kind) for g in found] == [(k, "jump") for k, _ in jumps]


def test_a_poor_held_out_prediction_is_a_warning_with_what_to_try():
    from iwp.ident.fit_ladder import LogFit
    from iwp.ident.fit_report import poor_prediction_advice

    def fit(q1, q4):
        moving = {"q1": np.array([0.0, 1.0]), "q4": np.array([0.0, 10.0])}  # both signals move: both judged
        return LogFit("h.csv", "validate", {"q1": q1, "q4": q4}, {}, {}, np.zeros(2), moving, {}, {}, np.zeros(4))

    assert poor_prediction_advice([fit(90.0, 95.0), fit(80.0, 97.0)], ("q1", "q4"), chose=True) == []
    msg = poor_prediction_advice([fit(60.0, 95.0), fit(-20.0, 97.0)], ("q1", "q4"), chose=False)
    assert len(msg) == 1 and "q1 20.0 % (below zero or failed on 1 of 2 logs)" in msg[0] and "q4" not in msg[0]
    assert "without --model" in msg[0] and "units, signs and zero" in msg[0]
    msg = poor_prediction_advice([fit(30.0, 95.0), fit(40.0, 97.0)], ("q1", "q4"), chose=True)
    assert "q1 35.0 %" in msg[0] and "--clamped" in msg[0]

"""Validation (issue 5): fit per signal, error signal, restarts (figure 9b), closed loop, the CLI."""

from __future__ import annotations

import dataclasses
import json
import math
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from iwp.cli import main
from iwp.data import write_experiment
from iwp.errors import InputError
from iwp.ident.validation import (
    UninformativeValidation,
    ValidationOptions,
    ValidationResult,
    auto_model,
    fit_percent,
    validate,
)
from iwp.models import Plant, save_params, table1
from iwp.rig import VirtualRig
from iwp.sim.inputs import HopfController


@pytest.fixture(scope="module")
def rig():
    return VirtualRig(seed=0)


@pytest.fixture(scope="module")
def free_log(rig):
    return rig.run("free-pendulum")


# ---------------------------------------------------------------------------
# fit_percent
# ---------------------------------------------------------------------------
def test_fit_percent_on_known_signals():
    t = np.linspace(0.0, 10.0, 2001)
    y = np.sin(3.0 * t) + 0.3
    assert fit_percent(y, y) == pytest.approx(100.0)
    assert fit_percent(y, np.full_like(y, y.mean())) == pytest.approx(0.0, abs=1e-12)
    # half the deviation from the mean left as error: 50 %
    assert fit_percent(y, y.mean() + 0.5 * (y - y.mean())) == pytest.approx(50.0)
    # the error has the norm of the signal's deviation, twice over: -100 %
    assert fit_percent(y, y - 2.0 * (y - y.mean())) == pytest.approx(-100.0)
    assert math.isnan(fit_percent(np.ones(10), np.zeros(10)))  # constant measurement: undefined
    with pytest.raises(InputError):
        fit_percent(y, y[:-1])


# ---------------------------------------------------------------------------
# validate
# ---------------------------------------------------------------------------
def test_validate_the_truth_on_the_free_decay(rig, free_log):
    v = validate(free_log, rig.truth.lumped, model="free",
                 options=ValidationOptions(estimate_x0=True, window=(1.0, None)))
    assert isinstance(v, ValidationResult)
    assert v.t[0] == pytest.approx(1.0) and v.t.size == free_log.n_samples - 200
    assert v.fit["q1"] > 99.0
    # the simulated pendulum is the free pendulum (wheel held) from x0, as an independent solver has it
    plant = Plant(rig.truth.lumped, model="free")
    ref = solve_ivp(lambda _t, x: plant.rhs(x), (v.t[0], v.t[-1]), v.x0, method="DOP853", t_eval=v.t, rtol=1e-11,
                    atol=1e-11)
    assert np.max(np.abs(v.simulated["q1"] - ref.y[0])) < 1e-6
    assert np.all(v.simulated["q2"] == v.x0[1])  # the wheel is held
    k = int(np.searchsorted(free_log.t, 1.0))
    # the model is not the truth plant (belt, regularised Coulomb friction): a few mrad
    assert v.x0[0] == pytest.approx(free_log.extra["true_q1"][k], abs=5e-3)
    assert v.x0[2] == pytest.approx(free_log.extra["true_q3"][k], abs=3e-2)
    d = v.to_dict()
    assert json.loads(json.dumps(d)) == d  # JSON-ready and lossless
    assert set(d["fit"]) == {"q1", "q2"} and d["samples"] == v.t.size
    assert d["fit"]["q1"] == pytest.approx(v.fit["q1"])
    assert "q1: fit" in v.summary()


def test_a_validation_that_says_nothing_warns_and_a_caller_can_filter_it(free_log):
    still = dataclasses.replace(free_log, q1=np.zeros_like(free_log.q1), q2=np.zeros_like(free_log.q2))
    with pytest.warns(UninformativeValidation, match="constant"):
        validate(still, table1(), model="free")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any other warning fails the test
        warnings.simplefilter("ignore", UninformativeValidation)
        v = validate(still, table1(), model="free")
    assert np.ptp(v.measured["q1"]) == 0.0


def test_estimated_initial_state_fits_better_than_the_measured_one(rig, free_log):
    p = rig.truth.lumped
    meas = validate(free_log, p, model="free", signals=("q1",))
    est = validate(free_log, p, model="free", signals=("q1",), options=ValidationOptions(estimate_x0=True))
    assert est.fit["q1"] >= meas.fit["q1"]
    assert meas.fit["q1"] > 95.0  # the measured state at t = 0 (differentiated at the log's edge) is close


def test_restart_reduces_the_error_of_a_long_validation(rig, free_log):
    """Figure 9(b): restarting from the measured state removes the accumulated (phase) error."""
    p = rig.truth.lumped.replace(p1=rig.truth.lumped.p1 * 1.005)  # a slightly wrong model
    plain = validate(free_log, p, model="free", signals=("q1",))
    restarted = validate(free_log, p, model="free", signals=("q1",),
                         options=ValidationOptions(restart_times=[30.0]))
    assert restarted.restart_times == (pytest.approx(30.0),)
    late = plain.t >= 30.0
    e_plain = np.sqrt(np.mean(plain.error["q1"][late] ** 2))
    e_restart = np.sqrt(np.mean(restarted.error["q1"][late] ** 2))
    assert e_restart < 0.6 * e_plain
    # before the restart the two are the same simulation
    np.testing.assert_allclose(plain.simulated["q1"][~late], restarted.simulated["q1"][~late], atol=1e-9)
    k = int(np.searchsorted(free_log.t, 30.0))
    assert restarted.simulated["q1"][k] == pytest.approx(free_log.q1[k], abs=3e-3)
    assert restarted.fit["q1"] > plain.fit["q1"]


def test_locked_motor_disk_log(rig):
    data = rig.run("sine-60", duration=10.0)
    assert auto_model(data) == "compensated"
    v = validate(data, rig.truth.lumped, signals=("q2", "q4"))
    assert v.locked
    assert np.all(v.simulated["q2"] == v.simulated["q2"])  # finite
    assert v.fit["q4"] > 80.0
    v14 = validate(data, rig.truth.lumped, model="motor-disk", signals=("q4",))
    assert v14.fit["q4"] > 80.0


def test_closed_loop_with_the_hopf_controller(rig):
    data = rig.run("closed-loop", duration=20.0)
    v = validate(data, table1(), model="compensated", controller=HopfController(-10.0, 0.1),
                 options=ValidationOptions(window=(10.0, None), estimate_x0=True), signals=("q1",))
    assert v.closed_loop
    amp_meas = np.max(np.abs(v.measured["q1"]))
    amp_sim = np.max(np.abs(v.simulated["q1"]))
    assert amp_sim == pytest.approx(amp_meas, rel=0.1)  # the limit cycle of figure 10
    assert math.isfinite(v.fit["q1"])


def test_velocity_signals_and_input_errors(rig, free_log):
    v = validate(free_log, rig.truth.lumped, model="free", signals=("q3",),
                 options=ValidationOptions(window=(None, 20.0)))
    assert v.fit["q3"] > 90.0  # against the differentiated velocity
    with pytest.raises(InputError, match="model must be one of"):
        validate(free_log, table1(), model="bogus")
    with pytest.raises(InputError, match="outside the window"):
        validate(free_log, table1(), model="free", options=ValidationOptions(restart_times=[100.0]))
    with pytest.raises(InputError, match="unknown signal"):
        validate(free_log, table1(), model="free", signals=("q5",))
    data_v = VirtualRig(seed=0).run("sine-60", duration=2.0)
    raw = dataclasses.replace(data_v, u=None, v=data_v.u)
    with pytest.raises(InputError, match="takes 'u'"):
        validate(raw, table1(), model="compensated")


def test_plot(rig, free_log):
    from iwp.plotting.validation import plot_correlation

    v = validate(free_log, rig.truth.lumped, model="free",
                 options=ValidationOptions(window=(None, 10.0), restart_times=[5.0]))
    h = v.plot()
    assert len(h["axes"]) == 4 and len(h["restart_lines"]) == 4
    h2 = plot_correlation(["a", "b"], np.array([[1.0, -0.99], [-0.99, 1.0]]))
    assert h2["image"] is not None and len(h2["texts"]) == 4


# ---------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------
@pytest.fixture()
def free_files(tmp_path, rig):
    log = tmp_path / "free.csv"
    write_experiment(rig.run("free-pendulum", duration=30.0), log)
    par = tmp_path / "p.json"
    save_params(rig.truth.lumped, par, extra={"model": "free"})
    return log, par


def test_cli_validate_json_shape(free_files, capsys):
    log, par = free_files
    status = main(["validate", str(log), "--params", str(par), "--json", "--t-start", "1", "--estimate-x0"])
    assert status == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["fit"]) == {"q1", "q2", "q4"}  # the wheel held to the arm: its speed is shown, not judged
    assert 99.0 < out["fit"]["q1"] <= 100.0  # percent, not a fraction
    assert out["model"] == "free"  # from the parameter file
    assert out["t_start"] == pytest.approx(1.0)
    assert len(out["x0"]) == 4 and out["samples"] == 5801


def test_cli_validate_restart_plot_and_errors(free_files, tmp_path, capsys):
    log, par = free_files
    fig = tmp_path / "fig.png"
    assert main(["validate", str(log), "--params", str(par), "--restart", "10,20", "--plot", str(fig)]) == 0
    assert fig.exists() and "restarts at 10, 20 s" in capsys.readouterr().out
    # no overwrite without --force, one line, exit 2
    assert main(["validate", str(log), "--params", str(par), "--plot", str(fig)]) == 2
    err = capsys.readouterr().err
    assert "--force" in err and err.count("\n") == 1
    assert main(["validate", str(log), "--params", str(par), "--plot", str(fig), "--force"]) == 0
    capsys.readouterr()
    assert main(["validate", str(tmp_path / "missing.csv"), "--params", str(par)]) == 2
    assert capsys.readouterr().err.startswith("iwp: error:")
    assert main(["validate", str(log), "--params", str(par), "--restart", "99"]) == 2


def test_cli_identify_refine_then_validate(free_files, tmp_path, capsys):
    """The identify CLI's --refine calls refine_identification; its --out feeds validate."""
    log, _ = free_files
    out = tmp_path / "P.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        status = main(["identify", str(log), "--setup", "free", "--refine", "--out", str(out), "--json"])
    assert status == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["model"] == "free" and doc["fit"][0]["q1"] > 99.0
    assert main(["validate", str(log), "--params", str(out), "--json", "--estimate-x0"]) == 0
    v = json.loads(capsys.readouterr().out)
    assert v["model"] == "free" and v["fit"]["q1"] > 99.0

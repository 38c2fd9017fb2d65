"""How an experiment runs is a field of it (ExperimentSpec.kind), and both rigs dispatch on it, not on its name."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import iwp.device.runs as device_experiments
from iwp.data import ExperimentData, StaticCurve
from iwp.device.runs import USER_INPUT_KINDS, USER_INPUTS, run_kind, run_on_rig
from iwp.device.twin import TwinRig
from iwp.errors import InputError
from iwp.rig import EXPERIMENTS, ExperimentKind, ExperimentSpec, InputLaw, RunKind, VirtualRig, check_output_path
from iwp.rig.run_settings import HostInput, law_input, open_loop_input
from iwp.sim.inputs import Chirp, Sine

OPEN, STATIC, RELEASE, CLOSED = RunKind.OPEN_LOOP, RunKind.STATIC_CURVE, RunKind.RELEASE, RunKind.CLOSED_LOOP

#: name: (run, law, compensated, locked)
PAPER_KINDS = {
    "static-curve": (STATIC, None, False, True),
    "static-curve-compensated": (STATIC, None, True, True),
    "motor-disk-chirp": (OPEN, InputLaw.CHIRP, True, True),
    "sine-60": (OPEN, InputLaw.SINE, True, True),
    "sine-40": (OPEN, InputLaw.SINE, True, True),
    "sine-20": (OPEN, InputLaw.SINE, True, True),
    "free-pendulum": (RELEASE, None, False, False),
    "full-chirp": (OPEN, InputLaw.CHIRP, True, False),
    "closed-loop": (CLOSED, None, True, False),
}


def test_every_paper_experiment_says_how_it_runs():
    assert list(EXPERIMENTS) == list(PAPER_KINDS)
    for name, spec in EXPERIMENTS.items():
        assert isinstance(spec.kind, ExperimentKind), name
        k = spec.kind
        assert (k.run, k.law, k.compensated, k.locked) == PAPER_KINDS[name], name
        assert run_kind(name) is k


def test_every_user_input_says_how_it_runs():
    assert list(USER_INPUT_KINDS) == list(USER_INPUTS)
    laws = {"chirp": InputLaw.CHIRP, "sine": InputLaw.SINE, "prbs": InputLaw.PRBS, "steps": InputLaw.STEPS}
    for name, k in USER_INPUT_KINDS.items():
        assert run_kind(name) is k
        if name == "release":
            assert (k.run, k.law, k.compensated, k.locked) == (RELEASE, None, False, False)
        else:
            assert (k.run, k.law, k.compensated, k.locked) == (OPEN, laws[name], True, False)
    with pytest.raises(InputError, match="unknown experiment or input 'nonsense'"):
        run_kind("nonsense")


def test_a_kind_that_contradicts_itself_or_its_settings_is_refused():
    with pytest.raises(InputError, match="input law"):
        ExperimentKind(RunKind.CLOSED_LOOP, InputLaw.SINE)
    with pytest.raises(InputError, match="input law"):
        ExperimentKind(RunKind.OPEN_LOOP)
    with pytest.raises(InputError, match="clamped"):
        ExperimentKind(RunKind.STATIC_CURVE)
    with pytest.raises(InputError, match="RunKind"):
        ExperimentKind("open-loop", InputLaw.SINE)
    sine = EXPERIMENTS["sine-60"]
    with pytest.raises(InputError, match="locked"):
        replace(sine, kind=replace(sine.kind, locked=False))
    with pytest.raises(InputError, match="v_dz"):
        replace(sine, kind=replace(sine.kind, compensated=False))
    with pytest.raises(InputError, match="ExperimentKind"):
        ExperimentSpec("x", "", "", {}, (), kind="sine")


def test_the_run_settings_are_built_in_one_place():
    s = {"amplitude": 60.0, "omega": 5.0, "w0": 3.0, "tau": 100.0, "hold_time": 0.05, "duration": 1.0, "seed": 3,
         "levels": (40.0, 0.0, -40.0), "step_time": 0.5}
    assert law_input(InputLaw.SINE, s) == Sine(60.0, 5.0)
    assert law_input(InputLaw.CHIRP, s) == Chirp(60.0, 3.0, 100.0)
    steps = law_input(InputLaw.STEPS, s)
    assert isinstance(steps, HostInput)
    assert [steps.evaluate(t) for t in (0.0, 0.6, 1.2, 1.6)] == [40.0, 0.0, -40.0, 40.0]
    prbs = law_input(InputLaw.PRBS, s, 0.005)
    assert {abs(prbs.evaluate(0.005 * k)) for k in range(200)} == {60.0}
    with pytest.raises(InputError, match="Ts"):
        law_input(InputLaw.PRBS, s)
    with pytest.raises(InputError, match="w0 must be > 0"):
        law_input(InputLaw.CHIRP, dict(s, w0=-1.0))
    # an experiment's input is its law's
    assert open_loop_input("sine-40", EXPERIMENTS["sine-40"].settings) == Sine(40.0, 5.0)
    assert open_loop_input("closed-loop", EXPERIMENTS["closed-loop"].settings) is None


def _renamed(monkeypatch, old: str, new: str) -> None:
    """Add the experiment ``old`` under a name that follows none of the old naming patterns."""
    monkeypatch.setitem(EXPERIMENTS, new, replace(EXPERIMENTS[old], name=new))
    monkeypatch.setattr(device_experiments, "RUN_NAMES", device_experiments.RUN_NAMES + (new,))


def _same_series(a: ExperimentData, b: ExperimentData) -> None:
    assert a.input_name == b.input_name
    for col in ("t", "q1", "q2") + ((a.input_name,) if a.input_name else ()):
        np.testing.assert_array_equal(getattr(a, col), getattr(b, col), err_msg=col)


@pytest.mark.parametrize("old, new, options", [
    ("sine-60", "wobble", dict(duration=1.0)),
    ("full-chirp", "sweep-free", dict(duration=1.0)),
    ("free-pendulum", "swing", dict(duration=1.0)),
    ("closed-loop", "hopf", dict(duration=1.0)),
])
def test_the_virtual_rig_runs_an_experiment_as_its_kind_whatever_its_name(monkeypatch, old, new, options):
    _renamed(monkeypatch, old, new)
    rig = VirtualRig(seed=2)
    got, want = rig.run(new, **options), rig.run(old, **options)
    assert got.metadata["experiment"] == new
    _same_series(got, want)
    assert check_output_path(new, "x.parquet").suffix == ".parquet"


def test_the_virtual_rig_runs_a_static_curve_as_its_kind_whatever_its_name(monkeypatch, tmp_path):
    _renamed(monkeypatch, "static-curve-compensated", "curve-u")
    rig = VirtualRig(seed=2)
    got = rig.run("curve-u", step=30.0, duration=2.0)
    want = rig.run("static-curve-compensated", step=30.0, duration=2.0)
    assert isinstance(got, StaticCurve) and got.input_name == "u" and got.metadata["compensated"] == "yes"
    np.testing.assert_array_equal(got.q4, want.q4)
    with pytest.raises(InputError, match="extension"):
        check_output_path("curve-u", tmp_path / "x.parquet")


#: Metadata a run on the twin writes from what the experiment is (not from the clock or the link).
_KIND_META = ("pendulum", "compensated", "v_dz_pos", "v_dz_neg", "x0", "k1", "k2", "filter_tau", "controller",
              "reference", "session")


@pytest.mark.parametrize("old, new", [("sine-60", "wobble"), ("free-pendulum", "swing"), ("closed-loop", "hopf")])
def test_a_rig_in_the_loop_runs_an_experiment_as_its_kind_whatever_its_name(monkeypatch, old, new):
    """(The twin's runs by the host clock are not bitwise repeatable under load: late ticks; so the runs are
    compared by what the kind decides -- the set-up, the logged input, the law -- not sample by sample.)"""
    _renamed(monkeypatch, old, new)
    logs = {}
    for name in (old, new):
        rig = TwinRig(fast=True)
        try:
            run = run_on_rig(rig, name, fast=True, duration=0.5)
        finally:
            rig.close()
        assert not run.interrupted, run.reason
        logs[name] = run.log
    got, want = logs[new], logs[old]
    assert got.metadata["experiment"] == new
    assert got.input_name == want.input_name and got.n_samples == want.n_samples
    assert {k: got.metadata.get(k) for k in _KIND_META} == {k: want.metadata.get(k) for k in _KIND_META}
    if old == "sine-60":  # the law's input, the pendulum clamped
        assert np.max(np.abs(got.u)) > 50.0 and np.all(got.q1 == 0.0)
    if old == "free-pendulum":  # released from x0, the motor off
        assert got.input_name is None and abs(got.q1[0] - EXPERIMENTS[old].settings["x0"][0]) < 0.01

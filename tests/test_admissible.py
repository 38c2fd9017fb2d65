"""Right or refused on a user's own short logs (issue 39): admissible least squares, initial states within what the
encoders saw, rungs that buy unidentified parameters refused, and exit statuses that say the truth."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from iwp.cli import main
from iwp.data import write_experiment
from iwp.errors import GoalNotReached
from iwp.ident.identification import AS_PRINTED, HELD_NOTE, HOLDABLE, identify
from iwp.ident.metrics import POOR_FIT, poor_fits
from iwp.ident.output_error import angle_quantum, initial_state_bounds
from iwp.ident.structure import RUNGS, RungOutcome, select
from iwp.models import table1
from iwp.rig import VirtualRig, default_truth
from iwp.sim.uncertainty import Z95, identified_names


@pytest.fixture(scope="module")
def short_chirp():
    """The README's training log: the twin's full chirp, 20 s (the paper's: 300 s)."""
    return VirtualRig(default_truth(), seed=0).run("full-chirp", duration=20.0)


def test_the_full_set_up_on_a_short_chirp_holds_what_it_cannot_identify_and_the_paper_procedure_does_not(short_chirp):
    printed = identify(short_chirp, "full", options=AS_PRINTED)
    # the paper's least squares as printed: sigma_a1 and sigma_v1 cannot be told apart on a +-0.14 rad swing, and
    # one comes out negative (the situation of the paper's eq. (16))
    assert printed.parameters["sigma_v1"].value < -10.0
    assert abs(printed.correlation[1, 2]) > 0.99
    res = identify(short_chirp, "full")
    held = res.details["held"]
    assert {"sigma_a1", "sigma_v1"} <= set(held) <= set(HOLDABLE)
    t1 = table1()
    for name, value in held.items():
        p = res.parameters[name]
        assert p.value == value == getattr(t1, name)  # at the prior, with no interval claimed
        assert math.isnan(p.stderr) and math.isnan(p.ci95_low) and p.note == HELD_NOTE
        assert any(w.startswith(f"{name} is not identified by these logs") and "free" in w for w in res.warnings)
    for name in ("sigma_a1", "sigma_v1", "sigma_b1"):
        assert res.parameters[name].value >= 0.0
    assert not any("unphysical" in w for w in res.warnings)
    # what the logs do identify comes out as before, with its uncertainty: p1 within 1 % of the twin's truth
    truth = default_truth().lumped
    assert abs(res.parameters["p1"].value - truth.p1) / truth.p1 < 0.01
    assert res.parameters["p1"].stderr > 0.0
    assert res.success and "held at their prior" in res.message


def test_a_long_free_release_identifies_the_pendulum_friction_and_nothing_is_held():
    free = VirtualRig(default_truth(), seed=0).run("free-pendulum")
    res = identify(free, "free", t_start=0.5)
    assert "held" not in res.details
    for name in ("sigma_a1", "sigma_v1"):
        p = res.parameters[name]
        assert p.value > Z95 * p.stderr > 0.0


def test_initial_state_bounds_hold_the_true_state_and_at_least_one_encoder_step(short_chirp):
    lo, hi = initial_state_bounds(short_chirp)
    true = np.array([short_chirp.extra[f"true_q{k}"][0] for k in range(1, 5)])
    assert np.all(lo <= true) and np.all(true <= hi)
    step = angle_quantum(short_chirp.q1)
    assert step == pytest.approx(2 * math.pi / 2000, rel=1e-9)
    assert np.all(hi[:2] - lo[:2] >= 2 * step - 1e-15)
    assert np.all(hi[2:] - lo[2:] >= 2 * step / 0.005 - 1e-12)
    # finite: a wheel cannot start at 99 rad/s when its first samples show it at rest
    assert np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))
    assert hi[3] - lo[3] < 20.0  # rad/s: the wheel reaches about 6 rad/s in the first 0.1 s


def test_identified_names_follows_the_95_percent_interval_and_the_physical_range():
    values = {"sigma_a1": 0.005, "sigma_v1": 1e-6, "u_offset": -0.5, "p1": 26.0}
    stderr = {"sigma_a1": 0.002, "sigma_v1": 2.0, "u_offset": 0.3, "p1": float("nan")}
    # sigma_a1: 0.005 - 1.96 * 0.002 > 0; sigma_v1 reaches below 0; u_offset (signed) stays on one side of 0 only
    # if 1.96 * 0.3 < 0.5; a NaN standard error identifies nothing
    assert identified_names(values, stderr) == ("sigma_a1",)
    stderr["u_offset"] = 0.2
    assert identified_names(values, stderr) == ("sigma_a1", "u_offset")


def test_a_rung_whose_added_parameters_are_not_identified_is_not_chosen_even_when_it_scores_best():
    def outcome(name, scores, unidentified=()):
        return RungOutcome(RUNGS[name], 8, np.asarray(scores, dtype=float), {}, {}, math.nan, 0.0, True, "",
                           unidentified=unidentified)

    base = outcome("9", [0.30, 0.32, 0.31, 0.29])
    better = outcome("coulomb", [0.10, 0.11, 0.09, 0.10])
    assert select([base, better]).chosen == 1
    noise = outcome("coulomb", [0.10, 0.11, 0.09, 0.10], unidentified=("sigma_c2",))
    sel = select([base, noise])
    assert sel.chosen == 0 and sel.best == 0


def test_poor_fits_names_a_signal_below_the_threshold_or_below_zero_on_one_log():
    assert poor_fits([{"q1": 90.0, "q2": 80.0}], ["q1", "q2"]) == []
    assert poor_fits([{"q1": 90.0, "q2": POOR_FIT - 1}], ["q1", "q2"]) == [f"q2 {POOR_FIT - 1:.1f} %"]
    bad = poor_fits([{"q1": 95.0}, {"q1": -3.0}, {"q1": 95.0}], ["q1"])
    assert bad == ["q1 62.3 % (below zero or failed on 1 of 3 logs)"]


def test_validate_exits_1_with_the_reason_when_it_predicts_poorly_and_0_with_accept_poor(tmp_path, capsys,
                                                                                        short_chirp):
    log = tmp_path / "chirp.csv"
    write_experiment(short_chirp, log)
    params = tmp_path / "P.json"
    # a plant with a tenth of the wheel's gain: the wheel is predicted far worse than its mean
    t1 = table1()
    params.write_text(json.dumps({**{k: getattr(t1, k) for k in ("p1", "p2", "rho", "sigma_a1", "sigma_v1",
                                                                  "sigma_b1", "v_dz_pos", "v_dz_neg")},
                                  "p3": t1.p3 / 10}))
    assert main(["validate", str(log), "--params", str(params), "--json"]) == 1
    out, err = capsys.readouterr()
    fit = json.loads(out)["fit"]
    # judged on the pendulum's angle and the wheel's speed; the wheel's angle (far below zero) is shown only
    assert fit["q2"] < 0.0 and 0.0 < fit["q1"] < POOR_FIT and 0.0 < fit["q4"] < POOR_FIT
    line = err.strip().splitlines()[-1]
    assert line.startswith(f"iwp: the model predicts {log} poorly (fit q1 {fit['q1']:.1f} %, q4 {fit['q4']:.1f} %)")
    assert "--accept-poor" in line
    assert main(["validate", str(log), "--params", str(params), "--json", "--accept-poor"]) == 0
    assert "--accept-poor" not in capsys.readouterr().err


def test_a_goal_not_reached_is_exit_status_1_with_its_reason_on_one_line(monkeypatch, capsys):
    import iwp.cli.design as design

    def fail(args):
        raise GoalNotReached("could not converge the first orbit: the parameters give the pendulum no damping")

    monkeypatch.setattr(design, "run_hopf", fail)
    assert main(["design", "hopf", "--amplitude", "1.5"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == "iwp: could not converge the first orbit: the parameters give the pendulum no damping"

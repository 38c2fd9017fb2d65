"""How a log's input acted between its samples, read from the log when the file does not say (issue 50).

Every log here comes from ``tests/independent.py`` (scipy, no iwp code), with
parameter sets unlike Table 1.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from iwp.cli import main
from iwp.data import ExperimentData, read_experiment
from iwp.ident.identification import IdentifyOptions, identify
from iwp.ident.input_hold import HOLD_CLEAR, read_input_hold, with_input_hold
from iwp.ident.logfit import LogFitOptions, plan_fit
from iwp.ident.output_error import interval_means, replay
from iwp.ident.validation import ValidationOptions, validate
from iwp.models import LumpedParameters

from . import independent as ind


def _logs(truth, hold, locked, *, duration=20.0, noise=0.0, corr=0.0, seed=0):
    rng = np.random.default_rng(seed)
    A = truth.amplitude
    inputs = [ind.Chirp(A, 2.0, 1 / 30), ind.Multisine.random(A, 0.5, 20.0, 8, rng)]
    if hold == "zoh":
        inputs.append(ind.Steps((-A, -A / 2, A / 2, A), (0.2, 1.0), seed))
    out = []
    for r in ind.simulate(truth, inputs, duration, hold=hold, locked=locked):
        q1 = np.zeros(r.t.size) if locked else ind.encode(r.X[:, 0], rng, noise=noise, corr_time=corr)
        q2 = ind.encode(r.X[:, 1], rng, noise=noise, corr_time=corr)
        meta = {"pendulum": "locked"} if locked else {}
        out.append(ExperimentData(t=r.t, q1=q1, q2=q2, u=r.u, metadata=meta))
    return out


@pytest.mark.parametrize("truth,locked,noise", [("direct", False, 0.0), ("long", True, 1e-3), ("table1", False, 1e-3)])
@pytest.mark.parametrize("hold", ["zoh", "continuous"])
def test_the_hold_is_read_right_from_chirps_multisines_and_steps_of_rigs_unlike_table1(truth, locked, noise, hold):
    for d in _logs(ind.TRUTHS[truth], hold, locked, noise=noise, corr=0.02):
        r = read_input_hold(d)
        assert (r.hold, r.how) == (hold, "data")
        # the wrong reading leaves several times the residuals: far from the threshold of a decision
        assert r.ratio > 3.0 * HOLD_CLEAR
        other = "continuous" if hold == "zoh" else "zoh"
        assert f"larger residuals read as {other}" in r.describe()


def test_metadata_and_a_forced_reading_win_and_no_input_is_no_reading():
    d = _logs(ind.TRUTHS["direct"], "continuous", True, duration=8.0)[0]
    said = ExperimentData(t=d.t, q1=d.q1, q2=d.q2, u=d.u, metadata={"input_hold": "zoh"})
    assert (read_input_hold(said).hold, read_input_hold(said).how) == ("zoh", "metadata")
    assert (read_input_hold(d, "zoh").hold, read_input_hold(d, "zoh").how) == ("zoh", "given")
    free = ExperimentData(t=d.t, q1=d.q1, q2=d.q2)
    assert (read_input_hold(free).hold, read_input_hold(free).how, read_input_hold(free).residual) == (
        "zoh", "default", {})
    (tagged,), (r,) = with_input_hold([d])
    assert tagged.metadata["input_hold"] == "continuous" and tagged.metadata["input_hold_read"] == "data"
    assert r.hold == "continuous"


def test_an_input_that_barely_moves_within_a_sample_is_undecided_and_read_as_held():
    slow = ind.Multisine(0.6, (0.05,), (0.3,))  # 0.05 rad/s: a sample's change is below the noise's reach
    r = ind.simulate(ind.TRUTHS["direct"], [slow], 20.0, hold="continuous", locked=True)[0]
    rng = np.random.default_rng(3)
    d = ExperimentData(t=r.t, q1=np.zeros(r.t.size), q2=ind.encode(r.X[:, 1], rng, noise=1e-3), u=r.u,
                       metadata={"pendulum": "locked"})
    reading = read_input_hold(d)
    assert reading.how == "default" and reading.hold == "zoh" and reading.ratio < HOLD_CLEAR
    assert "the data cannot tell" in reading.describe()


def test_identify_reads_a_users_continuous_log_and_holds_the_truth_in_its_intervals(tmp_path, capsys):
    """The user's path of ../shared/data/independent: a CSV that says nothing of its hold, model (14)."""
    truth = ind.TRUTHS["long"]
    r = ind.simulate(truth, [ind.Chirp(55.0 * truth.amplitude / 50.0, 2.5, 1 / 60)], 60.0, hold="continuous",
                     locked=True)[0]
    rng = np.random.default_rng(7)
    path = ind.write_csv(tmp_path / "disk.csv", r.t, np.zeros(r.t.size), ind.encode(r.X[:, 1], rng), r.u,
                         comments=["experiment: pendulum clamped, simulated"])
    assert main(["identify", str(path), "--setup", "motor-disk", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    for name, value in (("p2_1rho", truth.p2 * (1 + truth.rho)), ("p3_1rho", truth.p3 * (1 + truth.rho))):
        lo, hi = doc["parameters"][name]["ci95"]
        assert lo <= value <= hi, (name, value, lo, hi)
    (hold,) = doc["details"]["input_hold"]
    assert hold["hold"] == "continuous" and hold["how"] == "data"
    assert hold["residual"]["zoh"] > 10 * hold["residual"]["continuous"]
    assert not any(w.startswith("model misfit") for w in doc["warnings"])
    assert main(["identify", str(path), "--setup", "motor-disk"]) == 0
    text = capsys.readouterr().out
    assert "input read as continuous from the data (the file does not say)" in text
    # read as held (what iwp assumed before), the same log puts the truth many standard errors away
    held = identify(read_experiment(path), "motor-disk", options=IdentifyOptions(input_hold="zoh"))
    p = held.parameters["p2_1rho"]
    assert abs(p.value - truth.p2 * (1 + truth.rho)) > 10 * p.stderr


def test_a_held_input_log_still_reads_as_held_and_identifies_its_truth():
    truth = ind.TRUTHS["direct"]
    (chirp, _ms, steps) = _logs(truth, "zoh", True, duration=30.0, noise=5e-4)
    for d in (chirp, steps):
        res = identify(d, "motor-disk")
        (hold,) = res.details["input_hold"]
        assert hold["hold"] == "zoh" and hold["how"] == "data"
        for name, value in (("p2_1rho", truth.p2 * (1 + truth.rho)), ("p3_1rho", truth.p3 * (1 + truth.rho))):
            assert res.parameters[name].ci95_low <= value <= res.parameters[name].ci95_high


def test_iwp_fit_and_validate_replay_the_input_as_read():
    truth = ind.TRUTHS["direct"]
    train = _logs(truth, "continuous", False, duration=10.0)
    plan = plan_fit(train[:1], validate=train[1:], options=LogFitOptions())
    assert all(d.metadata["input_hold"] == "continuous" for d in plan.train + plan.held_out)
    assert {r.how for r in plan.holds.values()} == {"data"}
    # the replay holds each interval's mean of the continuous input (interval_means), the log as given its samples
    u = plan.train[0].u
    np.testing.assert_allclose(replay(plan.train[0], "u").values, interval_means(u))
    np.testing.assert_allclose(replay(train[0], "u").values, u)  # the log as given says nothing: held
    params = LumpedParameters(p1=truth.p1, p2=truth.p2, p3=truth.p3, rho=truth.rho, sigma_a1=truth.sigma_a1,
                              sigma_v1=truth.sigma_v1, sigma_b1=truth.sigma_b1)
    v = validate(train[0], params, signals=("q1", "q4"))
    assert v.input_hold.hold == "continuous" and v.input_hold.how == "data"
    forced = validate(train[0], params, signals=("q1", "q4"), options=ValidationOptions(input_hold="zoh"))
    # the true model, its input replayed as it acted, predicts the wheel's speed several times better than held
    rms = lambda res: math.sqrt(np.mean(res.error["q4"] ** 2))  # noqa: E731
    assert rms(v) < 0.3 * rms(forced)  # measured 0.21: the rest is the encoder's, differentiated
    assert "input read as continuous from the data" in v.summary()


def test_interval_means_are_the_continuous_inputs_average_to_fourth_order():
    """A sine sampled at 5 ms: the mean over each interval within 1.3e-6 of its amplitude at 19 rad/s, where the mean
    of the two ends is off by Ts^2 u''/12 (7.5e-4 of it); halving Ts divides the error by 16."""
    def errors(Ts, w=19.0):
        t = np.arange(0.0, 2.0, Ts)
        u = np.sin(w * t + 0.3)
        exact = (np.cos(w * t[:-1] + 0.3) - np.cos(w * t[1:] + 0.3)) / (w * Ts)
        inner = slice(1, -2)
        four = np.max(np.abs(interval_means(u)[:-1][inner] - exact[inner]))
        two = np.max(np.abs(0.5 * (u[:-1] + u[1:])[inner] - exact[inner]))
        return four, two
    four, two = errors(0.005)
    assert two == pytest.approx((19.0 * 0.005) ** 2 / 12, rel=0.05)
    assert four < 2e-6 and four < two / 300
    assert errors(0.0025)[0] == pytest.approx(four / 16, rel=0.1)

"""Robust designs (issue 20 part 3): the Hopf design, the balance LQR and the swing-up over a fit's uncertainty."""

import json
import math

import numpy as np
import pytest
from scipy import stats

from iwp.cli import main
from iwp.control import (
    design_hopf,
    find_orbit,
    hopf_point,
    lqr_balance,
    robust_balance,
    robust_hopf,
    robust_swingup,
    wilson_interval,
)
from iwp.control.robust import spread_of
from iwp.errors import InputError
from iwp.models import save_params, table1
from iwp.sim import BalanceController, CallableController, SimOptions, simulate
from iwp.sim.uncertainty import ParameterUncertainty

P = table1()
FREE = ("p1", "p2", "p3")
#: standard errors of a fit: 1 % of p1 and p3, 5 % of the pendulum's viscous friction p2
SD = np.array([0.01 * P.p1, 0.05 * P.p2, 0.01 * P.p3])


def _uncertainty(scale: float, params=P) -> ParameterUncertainty:
    return ParameterUncertainty(params, FREE, np.diag((scale * SD) ** 2))


@pytest.fixture(scope="module")
def design():
    return design_hopf(P, 1.5)


def _write_fit(path, scale=1.0):
    """A parameters.json as ``iwp fit`` writes it: the estimates and their covariance."""
    rec = {"free": list(FREE), "matrix": np.diag((scale * SD) ** 2).tolist(), "noise": {}, "method": "test",
           "reliable": True, "notes": []}
    return save_params(P, path, extra={"covariance": rec})


# --------------------------------------------------------------------------
# the Wilson interval
# --------------------------------------------------------------------------
@pytest.mark.parametrize("k, n", [(0, 20), (1, 20), (7, 20), (19, 20), (20, 20), (0, 1), (1, 1), (412, 1000)])
def test_the_wilson_interval_is_scipys(k, n):
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    w = wilson_interval(k, n)
    assert w.p == k / n
    assert w.low == pytest.approx(ci.low, abs=1e-12) and w.high == pytest.approx(ci.high, abs=1e-12)
    assert w.low <= w.p <= w.high
    ci90 = stats.binomtest(k, n).proportion_ci(confidence_level=0.9, method="wilson")
    assert wilson_interval(k, n, level=0.9).high == pytest.approx(ci90.high, abs=1e-12)


def test_the_wilson_interval_refuses_impossible_counts():
    for k, n in ((3, 2), (-1, 5), (0, 0), (1.5, 3)):
        with pytest.raises(InputError, match="successes"):
            wilson_interval(k, n)


# --------------------------------------------------------------------------
# the spread of an outcome
# --------------------------------------------------------------------------
def test_a_spread_calls_its_bounds_an_interval_only_with_an_outcome_in_each_tail():
    """At 95 % a tail of 2.5 % holds an outcome from 40 on; below that [low, high] is the range, said as such."""
    rng = np.random.default_rng(1)
    few = spread_of(rng.normal(size=39))
    assert few.needed == 40 and not few.is_interval
    assert (few.low, few.high) == (few.values[0], few.values[-1])
    assert few.interval_text(".3g", "s").startswith("range [") and "it needs 40" in few.interval_text()
    assert few.to_dict()["low_high"].startswith("range")
    one = spread_of([2.5])
    assert not one.is_interval and one.interval_text(".3g") == "range [2.5, 2.5] (too few for a 95 % interval: it needs 40)"
    many = spread_of(rng.normal(size=4000))
    assert many.is_interval and many.interval_text(".3g").startswith("95 % interval [")
    # the quantiles of 4000 normal outcomes: the normal's 2.5 % and 97.5 % points within their sampling error
    assert many.low == pytest.approx(stats.norm.ppf(0.025), abs=0.12)
    assert many.high == pytest.approx(stats.norm.ppf(0.975), abs=0.12)
    assert spread_of(rng.normal(size=10), level=0.8).needed == 10


# --------------------------------------------------------------------------
# the Hopf amplitude design
# --------------------------------------------------------------------------
def test_without_uncertainty_the_amplitude_collapses_onto_the_nominal(design):
    r = robust_hopf(_uncertainty(0.0), design=design, draws=4, t_end=30.0, window=6.0)
    # the nominal closed loop, started on the designed orbit, keeps the designed amplitude
    assert r.nominal_amplitude == pytest.approx(1.5, abs=2e-4)
    assert list(r.outcome) == ["orbit"] * 4 and r.no_orbit.successes == 0
    np.testing.assert_allclose(r.amplitudes, r.nominal_amplitude, rtol=0, atol=1e-9)
    assert r.amplitude.width == pytest.approx(0.0, abs=1e-9)
    assert r.amplitude.median == pytest.approx(r.nominal_amplitude, abs=1e-9)


def test_the_amplitude_interval_grows_with_the_uncertainty_and_each_draw_is_its_orbit(design):
    widths = {}
    for scale in (0.5, 1.0, 2.0):
        r = robust_hopf(_uncertainty(scale), design=design, draws=24, seed=3, t_end=40.0, window=8.0)
        assert r.no_orbit.successes == 0
        widths[scale] = r.amplitude.width
        assert r.amplitude.low < r.nominal_amplitude < r.amplitude.high
    assert 0.0 < widths[0.5] < widths[1.0] < widths[2.0]
    # the same normal draws scaled: the amplitude's spread about proportional to the standard errors
    assert widths[2.0] / widths[1.0] == pytest.approx(2.0, rel=0.25)
    assert widths[1.0] / widths[0.5] == pytest.approx(2.0, rel=0.25)
    # each draw's measured amplitude is that of its periodic orbit at the design's gains (shooting + continuation)
    for i in (0, 1):
        drawn = P.replace(**r.draws_params[i])
        orbit = find_orbit(drawn, design.k1, design.k2)
        assert r.amplitudes[i] == pytest.approx(orbit.amplitude, abs=2e-3)


def test_no_orbit_is_claimed_where_the_bifurcation_analysis_has_none(design):
    """The pendulum's viscous friction uncertain: draws whose Hopf point k1* lies below the design's k1 keep the
    hanging rest stable (no orbit); the others oscillate, and an orbit measured is the one continuation finds."""
    base = P.replace(sigma_v1=0.08)
    u = ParameterUncertainty(base, ("sigma_v1",), np.array([[0.04**2]]))
    r = robust_hopf(u, design=design, draws=12, seed=5, t_end=60.0, window=10.0)
    k_star = np.array([hopf_point(base.replace(**d)).k1 for d in r.draws_params])
    has_orbit = r.outcome == "orbit"
    none = k_star < design.k1 - 0.3
    assert np.count_nonzero(none) >= 2 and not np.any(has_orbit[none])
    # the rest of the draws approach orbits; those not reached within 60 s count as "unsettled", never as orbits
    assert set(r.outcome[~has_orbit]) <= {"unsettled", "decayed"}
    assert np.count_nonzero(has_orbit) >= 4 and r.no_orbit.successes == np.count_nonzero(~has_orbit)
    assert np.all(np.isnan(r.amplitudes[~has_orbit])) and np.all(np.isfinite(r.amplitudes[has_orbit]))
    for i in np.flatnonzero(has_orbit)[:3]:
        # a slow approach extrapolated along the peaks' return map: the orbit's amplitude, not the last peak
        orbit = find_orbit(base.replace(**r.draws_params[i]), design.k1, design.k2)
        assert r.amplitudes[i] == pytest.approx(orbit.amplitude, abs=3e-3)
    ci = stats.binomtest(r.no_orbit.successes, 12).proportion_ci(method="wilson")
    assert (r.no_orbit.low, r.no_orbit.high) == pytest.approx((ci.low, ci.high), abs=1e-12)


# --------------------------------------------------------------------------
# the balance LQR
# --------------------------------------------------------------------------
def test_the_compiled_balance_law_is_the_lqrs():
    L = lqr_balance(P, Ts=0.005)
    x0 = [math.pi + 0.05, 0.0, 0.1, 2.0]
    a = simulate(P, x0=x0, t_end=2.0, Ts=0.005, input=L.controller(), options=SimOptions(saturation=L.u_max))
    b = simulate(P, x0=x0, t_end=2.0, Ts=0.005, input=CallableController(lambda t, x: L(x), L.Ts))
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=1e-9)
    assert isinstance(L.controller(), BalanceController)
    # the law wraps the angle: a turn more is the same upright
    assert L([math.pi + 0.01 + 2 * math.pi, 0, 0.2, 1.0]) == pytest.approx(L([math.pi + 0.01, 0, 0.2, 1.0]),
                                                                           abs=1e-9)


def test_the_capture_probability_is_one_inside_the_basin_and_zero_far_outside():
    L = lqr_balance(P, Ts=0.005)
    near, far = 0.25 * L.capture_bound, 0.5  # rad from the upright; the capture bound is about 0.072 rad
    r = robust_balance(_uncertainty(1.0), lqr=L, angles=(near, far), draws=40, seed=1, t_end=3.0)
    first, second = r.capture_by_state
    assert first.successes == 40 and second.successes == 0
    assert list(r.nominal_captured) == [True, False]
    assert r.capture.successes == 40 and r.capture.trials == 80
    for pr in (first, second, r.capture):
        ci = stats.binomtest(pr.successes, pr.trials).proportion_ci(method="wilson")
        assert (pr.low, pr.high) == pytest.approx((ci.low, ci.high), abs=1e-12)
    assert first.low > 0.9 and second.high < 0.1
    # settling: the closed loop's slowest pole sets the time to enter 0.01 rad from 0.018 rad
    assert np.all(np.isfinite(r.settling[:, 0])) and np.all(np.isnan(r.settling[:, 1]))
    assert 0.0 < r.settling_time.median < 1.0
    doc = json.loads(json.dumps(r.to_dict()))
    assert doc["capture"]["successes"] == 40 and len(doc["runs"]) == 40


def test_without_uncertainty_the_balance_outcome_is_the_nominal():
    r = robust_balance(_uncertainty(0.0), draws=3, t_end=3.0)
    np.testing.assert_array_equal(r.captured, np.tile(r.nominal_captured, (3, 1)))
    np.testing.assert_allclose(r.settling, np.tile(r.nominal_settling, (3, 1)), rtol=0, atol=1e-12)
    # the default angles straddle the capture bound: the nominal is caught inside it, not at 1.25 times it
    assert r.nominal_captured[0] and not r.nominal_captured[-1]
    assert "UNRELIABLE" not in r.summary()
    flagged = ParameterUncertainty(P, FREE, np.zeros((3, 3)), reliable=False, notes=("one experiment",))
    r = robust_balance(flagged, draws=2, t_end=3.0)
    assert "UNRELIABLE" in r.summary() and "one experiment" in r.summary()
    assert r.to_dict()["covariance_reliable"] is False


def test_a_parameter_the_logs_do_not_identify_is_held_and_the_design_runs():
    """A fit that left a friction at 1e-6 +- 2 (its interval spans both signs): drawn, its draws would be a
    half-normal of scale 2 (a pendulum damped a thousand times the rig's); held at its estimate, the identified
    parameters are drawn and the design runs, and its summary names what was held."""
    free = (*FREE, "sigma_a1")
    cov = np.diag([*(SD ** 2), 2.0 ** 2])
    unidentified = ParameterUncertainty(P.replace(sigma_a1=1e-6), free, cov)
    assert unidentified.identified() == FREE
    assert np.median([p.sigma_a1 for p in unidentified.draws(200)]) > 0.5
    held = unidentified.identified_only()
    assert held.free == FREE and np.array_equal(held.covariance, np.diag(SD ** 2))
    # identified: the interval stays inside the physical range (0.08 +- 1.96 x 0.04 does, 0.08 +- 1.96 x 0.041
    # does not); nothing identified holds everything
    assert ParameterUncertainty(P.replace(sigma_v1=0.08), ("sigma_v1",), np.array([[0.04 ** 2]])).identified() == (
        "sigma_v1",)
    assert ParameterUncertainty(P.replace(sigma_v1=0.08), ("sigma_v1",), np.array([[0.041 ** 2]])).identified() == ()
    nothing = unidentified.identified_only().identified_only()
    assert ParameterUncertainty(P, ("sigma_a1",), np.array([[1.0]])).identified_only().free == ()
    assert nothing.free == FREE
    assert all(p.sigma_a1 == 1e-6 for p in held.draws(50))
    r = robust_balance(unidentified, draws=20, t_end=3.0)
    assert "held at their estimates" in r.summary() and "sigma_a1" in r.summary()
    assert r.capture.trials == 20 * len(r.capture_by_state)


# --------------------------------------------------------------------------
# the swing-up
# --------------------------------------------------------------------------
def test_without_uncertainty_the_swing_up_is_the_nominal():
    r = robust_swingup(_uncertainty(0.0), draws=2, t_end=13.0, hold=2.0)
    assert r.nominal_success and r.probability.successes == 2
    np.testing.assert_allclose(r.t_catch, r.nominal_t_catch, rtol=0, atol=1e-12)
    assert 5.0 < r.nominal_t_catch < 11.0
    assert r.time_to_capture.median == pytest.approx(r.nominal_t_catch, abs=1e-12)
    assert "probability of success" in r.summary()


# --------------------------------------------------------------------------
# bad input and the command line
# --------------------------------------------------------------------------
def test_bad_draws_are_refused(design):
    for bad in (0, -3, 2.5, True, 10**6):
        with pytest.raises(InputError, match="draws must be an integer"):
            robust_hopf(_uncertainty(1.0), design=design, draws=bad)
    with pytest.raises(InputError, match="ParameterUncertainty"):
        robust_balance(P, draws=3)


def _one_line_error(capsys, *needles):
    cap = capsys.readouterr()
    assert cap.out == ""
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("iwp: error:") and "Traceback" not in cap.err, cap.err
    for n in needles:
        assert n in lines[0], lines[0]


@pytest.mark.parametrize("cmd", [["design", "hopf", "--amplitude", "1.5"], ["control", "lqr"],
                                 ["control", "swingup", "--no-animation"]])
def test_cli_draws_need_a_fit_and_a_positive_count(tmp_path, capsys, cmd):
    fit = _write_fit(tmp_path / "parameters.json")
    out = tmp_path / "out"
    assert main(cmd + ["--params", str(fit), "--draws", "0", "--out", str(out)]) == 2
    _one_line_error(capsys, "--draws must be an integer from 1")
    bare = save_params(P, tmp_path / "bare.json")
    assert main(cmd + ["--params", str(bare), "--draws", "5", "--out", str(out)]) == 2
    _one_line_error(capsys, "--params", "bare.json", "holds no covariance")
    assert main(cmd + ["--draws", "5", "--out", str(out)]) == 2  # the default Table 1 carries no covariance
    _one_line_error(capsys, "--params table1", "holds no covariance")
    assert not out.exists()


def test_cli_hopf_draws_write_the_distribution(tmp_path, capsys):
    fit = _write_fit(tmp_path / "parameters.json", scale=0.0)
    out = tmp_path / "hopf"
    assert main(["design", "hopf", "--amplitude", "1.5", "--params", str(fit), "--draws", "3", "--t-end", "30",
                 "--out", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    saved = json.loads((out / "robust.json").read_text())
    assert (out / "robust.png").stat().st_size > 10_000
    # zero covariance: every draw is the nominal, which holds the designed amplitude
    assert saved["amplitude"]["median"] == pytest.approx(1.5, abs=2e-4)
    assert saved["amplitude"]["high"] - saved["amplitude"]["low"] == pytest.approx(0.0, abs=1e-9)
    assert [r["outcome"] for r in saved["runs"]] == ["orbit"] * 3 and saved["draws"] == 3
    assert doc["robust"]["no_orbit"]["successes"] == 0 and doc["k1"] == pytest.approx(saved["design"]["k1"])
    # never overwrite without --force
    assert main(["design", "hopf", "--amplitude", "1.5", "--params", str(fit), "--draws", "3", "--t-end", "30",
                 "--out", str(out)]) == 2
    _one_line_error(capsys, "--force")
    assert main(["design", "hopf", "--amplitude", "1.5", "--draws", "3"]) == 2
    _one_line_error(capsys, "--draws needs --out")
    # too short to measure an orbit over the last 20 s: refused, not a table of NaN
    assert main(["design", "hopf", "--amplitude", "1.5", "--params", str(fit), "--draws", "3", "--t-end", "2",
                 "--out", str(tmp_path / "short")]) == 2
    _one_line_error(capsys, "--t-end = 2 s must be at least twice the window (10 s)")
    assert not (tmp_path / "short").exists()


def test_cli_lqr_and_swingup_draws_write_their_probabilities(tmp_path, capsys):
    fit = _write_fit(tmp_path / "parameters.json")
    out = tmp_path / "lqr"
    assert main(["control", "lqr", "--params", str(fit), "--draws", "10", "--angles", "0.02,0.5", "--t-end", "3",
                 "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "probability of capture 0.500 (10/20" in text
    doc = json.loads((out / "robust.json").read_text())
    assert [s["capture"]["p"] for s in doc["initial_states"]] == [1.0, 0.0]
    assert (out / "robust.png").stat().st_size > 10_000
    sw = tmp_path / "swingup"
    assert main(["control", "swingup", "--params", str(fit), "--draws", "2", "--t-end", "13", "--no-animation",
                 "--out", str(sw)]) == 0
    doc = json.loads((sw / "robust.json").read_text())
    assert doc["probability"]["trials"] == 2 and len(doc["runs"]) == 2
    assert all(r["success"] == (r["t_catch"] is not None and r["t_balanced"] is not None) for r in doc["runs"])
    assert (sw / "robust.png").exists() and (sw / "swingup.csv").exists()

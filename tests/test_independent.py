"""iwp's intervals, warnings and bands on logs from a simulator that shares nothing with iwp (issue 50).

The short version of ``benchmarks/independent_study.py`` (BENCHMARKS.md gives its figures over 10 seeds): the
logs of ``tests/independent.py`` (scipy's DOP853 at 1e-10, a direct-drive rig unlike Table 1, the input held
between samples, AR(1) sensor noise of 1 mrad and 20 ms, then a 2000-count encoder).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from iwp.data import ExperimentData
from iwp.ident.identification import identify
from iwp.ident.logfit import BAND_HOLDS, LogFitOptions, fit_logs

from . import independent as ind

TRUTH = ind.TRUTHS["direct"]
#: the wheel's Coulomb friction that model (9) lacks, as a share of a typical command's acceleration
COULOMB = replace(TRUTH, sigma_c2=0.05 * TRUTH.p3 * TRUTH.amplitude)
FREE = ("p1", "p2", "p3", "rho")


def _quiet(f, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*a, **kw)


@pytest.fixture(scope="module")
def correct():
    """Three seeds of the study's logs of model (9) itself."""
    return [ind.study_logs(TRUTH, s, noise=1e-3, corr=0.02) for s in range(3)]


@pytest.fixture(scope="module")
def coulomb():
    """One seed of a rig with the wheel's Coulomb friction, which model (9) lacks."""
    return ind.study_logs(COULOMB, 0, noise=1e-3, corr=0.02)


def test_identify_warns_of_a_misfit_only_where_a_term_is_missing(correct, coulomb):
    """Correlated noise stands 2-3 times above the white level the positions' fourth difference shows, on every
    log; only a term the model lacks makes the residuals follow the state."""
    right = [_quiet(identify, d, "full") for logs in correct for d in logs.train]
    assert sum(any(w.startswith("model misfit") for w in r.warnings) for r in right) <= 1
    ratios = [max(v / r.details["noise_std"][k] for k, v in r.details["noise_std"]["from_residuals"].items())
              for r in right]
    assert min(ratios) > 2.0  # above the white level: the old check warned on each of them
    assert all("correlated in time" in r.details.get("residuals_note", "") for r in right)
    hits = sum(r.parameters[n].ci95_low <= getattr(TRUTH, n) <= r.parameters[n].ci95_high
               for r in right for n in FREE)
    assert hits >= 0.85 * len(right) * len(FREE)
    wrong = [_quiet(identify, d, "full") for d in coulomb.train]
    for r in wrong:
        (w,) = [w for w in r.warnings if w.startswith("model misfit")]
        assert "follow sgn q4" in w or "follow q4 |q4|" in w
        assert r.details["residual_structure"]["explained"]["q4"] > 0.5


@pytest.fixture(scope="module")
def fits(correct):
    return [_quiet(fit_logs, logs.train, validate=logs.held, options=LogFitOptions(), warn=False)
            for logs in correct]


def test_fit_intervals_are_two_standard_errors_wide_and_hold_the_truth(fits):
    hits = []
    for r in fits:
        rel = r.refinement.reliability
        assert not rel.structure_error and rel.reliable
        assert rel.method.startswith("HAC sandwich within 3 experiments") and "agree within their noise" in rel.method
        for n in FREE:
            p = r.refinement.parameters[n]
            half = 0.5 * (p.ci95_high - p.ci95_low) / p.stderr
            assert 1.8 <= half <= 2.6, (n, half)  # was 4.6-5.5: Student t with at most 2 dof
            hits.append(p.ci95_low <= getattr(TRUTH, n) <= p.ci95_high)
    # 92.5 % over 10 seeds (BENCHMARKS.md); here 9 of 12 (p2, p3 and rho move together: few independent draws)
    assert sum(hits) >= 9, hits


def test_fit_held_out_bands_hold_for_the_right_model(fits):
    """93-96 % over 10 seeds; a set whose estimates happen to lie two standard errors off (seed 0's p1) leaves one
    log's q1 64 % inside, which the fit then reports."""
    per_set = {o: [np.mean([v.coverage[o] for v in r.validation]) for r in fits] for o in ("q1", "q4")}
    for o, c in per_set.items():
        assert 0.88 <= float(np.mean(c)) <= 1.0, (o, c)
        assert min(c) >= 0.75, (o, c)
    for r in fits:  # a held-out log outside its band is said to be, never silently under the 95 % label
        misses = [v for v in r.validation if v.band_misses]
        assert r.band_holds is (not misses)
        assert len([w for w in r.warnings if "lie inside the 95 % prediction band" in w]) == len(misses)
        assert all(min(v.coverage[o] for o in v.band_misses) < BAND_HOLDS for v in misses)


def _mean_sampled(d):
    """The log as a rig that logs its wheel by the mean speed over each preceding period (its encoder's counts
    differenced), without the wheel's angle."""
    q4 = np.empty_like(d.q2)
    q4[1:] = np.diff(d.q2) / np.diff(d.t)
    q4[0] = q4[1]  # no preceding period: weighed 0
    return ExperimentData(t=d.t, q1=d.q1, q4=q4, u=d.u, metadata={"q4_sampling": "mean"}, source=d.source)


def test_held_out_bands_hold_with_the_wheel_speed_logged_as_a_mean(correct):
    """A mean-sampled wheel speed gets its held-out band (before, none, and no word of it), and the band holds as
    the angle-logged one does: 85-100 % of q1, 95-98 % of q4 (three seeds). Its start takes the logged speed in:
    through q1 alone the wheel's start was 8 rad/s uncertain and read 15-26 rad/s on logs from rest, and the
    bands held 41-79 % of q1 on four of the nine logs."""
    fits = [_quiet(fit_logs, [_mean_sampled(d) for d in logs.train], validate=[_mean_sampled(d) for d in logs.held],
                   options=LogFitOptions(), warn=False) for logs in correct]
    per_set = {o: [np.mean([v.coverage[o] for v in r.validation]) for r in fits] for o in ("q1", "q4")}
    for o, c in per_set.items():
        assert 0.88 <= float(np.mean(c)) <= 1.0, (o, c)
        assert min(c) >= 0.75, (o, c)
    assert min(v.coverage["q4"] for r in fits for v in r.validation) >= 0.9
    for r in fits:
        for v in r.validation:
            assert abs(v.x0[3]) < 1.0, (v.source, v.x0)  # every held-out log starts from rest


def test_a_missing_wheel_coulomb_friction_is_a_structure_error_with_wide_intervals(coulomb):
    r = _quiet(fit_logs, coulomb.train, validate=coulomb.held, options=LogFitOptions(), warn=False)
    rel = r.refinement.reliability
    assert rel.structure_error and not rel.reliable
    assert rel.method.startswith("the spread across 3 experiments")
    assert any(n.startswith("model-structure error: the experiments disagree beyond their noise (Q = ")
               for n in rel.notes)
    p = r.refinement.parameters["p2"]
    assert 0.5 * (p.ci95_high - p.ci95_low) / p.stderr > 3.0  # Student t, at most 2 dof
    assert math.isfinite(p.stderr)

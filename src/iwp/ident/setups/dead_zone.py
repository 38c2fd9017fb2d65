"""Set-up "dead-zone": the thresholds ``v+`` and ``v-`` of (5)/(8) from a static curve (figure 2a).

On each side the straight part of ``q4(v)`` is fitted by a line and
extrapolated to ``q4 = 0`` (section 5.1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...data import ExperimentData, StaticCurve
from ...errors import IdentificationError, InputError
from ..fit_parameters import Parameter
from ..lsq import LeastSquaresOptions, solve_least_squares
from .base import RefineSpec, Setup

__all__ = ["DeadZone", "StaticFit", "fit_static_curve"]

#: The line through each side's straight part: ordinary least squares, a rank deficiency reported, not raised.
_LINE_FIT = LeastSquaresOptions(covariance="ols", weights="none", allow_rank_deficient=True)


def _bend(x: np.ndarray, y: np.ndarray, sgn: float) -> float | None:
    """Difference of the thresholds of the lower and the upper half of a straight part (None: too few points)."""
    if x.size < 6:
        return None
    order = np.argsort(sgn * x)
    half = x.size // 2
    v0 = []
    for idx in (order[:half], order[half:]):
        a, b = np.polyfit(x[idx], y[idx], 1)
        if not a > 0:
            return None
        v0.append(-b / a)
    return float(v0[0] - v0[1])


@dataclass
class StaticFit:
    """The dead-zone thresholds fitted on a static curve, with their uncertainty and diagnostics."""

    parameters: dict[str, Parameter]
    covariance: np.ndarray
    correlation: np.ndarray
    condition_number: float
    residual_rms: dict[str, float]
    samples: int
    warnings: list[str] = field(default_factory=list)
    details: dict[str, Any] = field(default_factory=dict)
    message: str = ""
    sources: list[str] = field(default_factory=list)


def fit_static_curve(curve: Any, *, min_fraction: float = 0.2) -> "StaticFit":
    """Dead-zone thresholds ``v+`` and ``v-`` of (5) from a static curve (figure 2a).

    On each side separately, the *straight part* of the curve -- the points
    where the disk turns in the input's direction with ``|q4|`` at least
    ``min_fraction`` of that side's largest ``|q4|`` -- is fitted by the line
    ``q4 = a (v - v0)`` (ordinary least squares of ``q4 = a v + b``), and the
    line is extrapolated to ``q4 = 0``: ``v_dz_pos = v0`` on the positive
    side, ``v_dz_neg = -v0`` on the negative side (both positive numbers, as
    in (5)). Points with ``q4 = 0`` (the dead zone) and the break-away region
    just after the disk starts (figure 2a's discontinuity) are excluded by
    the fraction.

    Parameters
    ----------
    curve : StaticCurve or list of StaticCurve
        Input ``v`` [in] (or ``u`` for a compensated curve) and steady disk
        velocity ``q4`` [rad/s]; several curves are pooled.
    min_fraction : float
        Lower end of the straight part, as a fraction of the side's largest
        ``|q4|`` (default 0.2).

    Returns
    -------
    StaticFit
        ``v_dz_pos``, ``v_dz_neg`` [in] with standard errors from the delta
        method on the line fit (white residuals: each point is a separate
        steady state). ``details`` holds each side's slope ``a`` [rad/s/in]
        (the static gain ``p3/p2`` of (9)), intercept, points used and
        residual RMS.

    Notes
    -----
    The extrapolated threshold is where the *static* curve meets ``q4 = 0``:
    with Coulomb friction at the disk it is ``v+ + sigma~_c2/p3`` (the
    Coulomb torque acts like extra dead zone), which is what a compensation
    (7)-(8) must cancel. For a compensated curve (input ``u``) the result is
    the residual dead zone after the compensation.
    """
    curves = _checked_curves(curve)
    mf = float(min_fraction)
    if not 0.0 <= mf < 1.0:
        raise InputError(f"min_fraction must be in [0, 1), got {min_fraction!r}")
    points = _CurvePoints(x=np.concatenate([c.input for c in curves]), y=np.concatenate([c.q4 for c in curves]),
                          min_fraction=mf, source=", ".join(c.source for c in curves))
    sides = [_fit_side(points, _SIDES[0]), _fit_side(points, _SIDES[1])]
    warnings = [w for s in sides for w in s.warnings]
    warnings.append("v_dz_pos and v_dz_neg are the apparent thresholds where the straight part meets q4 = 0: "
                    "the dead zone (5) plus the disk's Coulomb friction over p3, which a static curve cannot "
                    "separate (what a compensation (7)-(8) must cancel)")
    params = {s.parameter.name: s.parameter for s in sides}
    details: dict[str, Any] = {s.side: s.details for s in sides}
    if curves[0].input_name == "u":
        comp = _compensation(curves[0])
        warnings.append("compensated curve (input u): v_dz_pos and v_dz_neg are the residual dead zone after the "
                        "compensation" + (f" v_dz = ({comp['v_dz_pos']:g}, {comp['v_dz_neg']:g})" if comp else
                                          " (its thresholds are not in the metadata)"))
        if comp:
            details["compensation"] = comp
    details["method"] = (f"straight part: |q4| >= {mf:g} x max|q4| per side; line q4 = a v + b, "
                         "threshold = -b/a; stderr by the delta method")
    used_total = sum(s.points for s in sides)
    se = np.array([params["v_dz_pos"].stderr, params["v_dz_neg"].stderr])
    message = (f"set-up 'dead-zone': v_dz_pos = {params['v_dz_pos'].value:.4g} +- {params['v_dz_pos'].stderr:.2g}, "
               f"v_dz_neg = {params['v_dz_neg'].value:.4g} +- {params['v_dz_neg'].stderr:.2g} from {used_total} points")
    return StaticFit(parameters=params, covariance=np.diag(se ** 2), correlation=np.eye(2),
                     condition_number=float(max(s.condition_number for s in sides)),
                     residual_rms={s.side: s.residual_rms for s in sides}, samples=used_total, warnings=warnings,
                     details=details, message=message, sources=[c.source for c in curves])


@dataclass(frozen=True)
class _Side:
    """One side of a static curve: its label, the sign of its inputs and the threshold's parameter name."""

    side: str
    sign: float
    name: str


_SIDES = (_Side("pos", 1.0, "v_dz_pos"), _Side("neg", -1.0, "v_dz_neg"))


@dataclass(frozen=True, eq=False)
class _CurvePoints:
    """The pooled points of the static curves: input ``x`` [in], steady disk velocity ``y`` [rad/s]."""

    x: np.ndarray
    y: np.ndarray
    min_fraction: float
    source: str


@dataclass(frozen=True, eq=False)
class _SideFit:
    """The threshold of one side with its line fit's diagnostics."""

    side: str
    parameter: Parameter
    residual_rms: float
    condition_number: float
    points: int
    details: dict[str, Any]
    warnings: tuple[str, ...]


def _checked_curves(curve: Any) -> list[StaticCurve]:
    """The static curves as a list: at least one, no time series, one kind of input (v or u)."""
    curves = list(curve) if isinstance(curve, (list, tuple)) else [curve]
    if not curves:
        raise InputError("data is empty: give at least one static curve")
    for c in curves:
        if isinstance(c, ExperimentData):
            raise InputError(f"{c.source}: is a time-series log; set-up 'dead-zone' needs a static curve "
                             "(columns v,q4 or u,q4, one row per steady state)")
        if not isinstance(c, StaticCurve):
            raise InputError(f"set-up 'dead-zone' needs a StaticCurve, got {type(c).__name__}")
    if len({c.input_name for c in curves}) > 1:
        raise InputError("the static curves mix the raw input v and the compensated input u; give one kind")
    return curves


def _straight_part(points: _CurvePoints, s: _Side) -> np.ndarray:
    """Mask of the side's straight part: moving in the input's direction with ``|q4| >= min_fraction max|q4|``."""
    x, y, sgn = points.x, points.y, s.sign
    moving = (sgn * x > 0) & (sgn * y > 0)
    if not np.any(moving):
        raise IdentificationError(f"{points.source}: the disk never turns on the "
                                  f"{'positive' if sgn > 0 else 'negative'} side; the static curve does not reach "
                                  "beyond the dead zone there")
    ymax = float(np.max(sgn * y[moving]))
    sel = moving & (sgn * y >= points.min_fraction * ymax)
    m = int(np.count_nonzero(sel))
    if m < 3:
        raise IdentificationError(
            f"{points.source}: only {m} point(s) on the straight part of the {s.side} side "
            f"(|q4| >= {points.min_fraction:g} x {ymax:.4g} rad/s); need at least 3 to fit the line and estimate its "
            "uncertainty")
    return sel


def _fit_side(points: _CurvePoints, s: _Side) -> _SideFit:
    """The line ``q4 = a v + b`` through the side's straight part and its threshold ``-b/a`` (delta-method stderr)."""
    x, y, sgn, side = points.x, points.y, s.sign, s.side
    sel = _straight_part(points, s)
    m = int(np.count_nonzero(sel))
    r = solve_least_squares(np.column_stack([x[sel], np.ones(m)]), y[sel], ["a", "b"], options=_LINE_FIT)
    a, b = r.values
    if not r.success or not a > 0:
        raise IdentificationError(f"{points.source}: the {side} side's straight part has no usable slope (a = {a:.4g})")
    v0 = -b / a
    g = np.array([b / a ** 2, -1.0 / a])  # d v0 / d(a, b)
    se = math.sqrt(max(float(g @ r.covariance @ g), 0.0))
    val = sgn * v0
    warnings = []
    bend = _bend(x[sel], y[sel], sgn)
    if bend is not None and abs(bend) > 2.0 * se:
        # the straight part is not straight: (5) does not describe the curve exactly, and where the line
        # meets q4 = 0 depends on which points are taken; the interval takes in that spread
        warnings.append(f"{side} side: the straight part bends: its lower and upper halves meet q4 = 0 "
                        f"{abs(bend):.3g} apart (stderr {se:.2g}); the interval includes that spread")
        se = math.sqrt(se * se + 0.25 * bend * bend)
    rms = float(r.residual_rms[0]) if r.residual_rms else math.nan
    moving = (sgn * x > 0) & (sgn * y > 0)
    first = x[moving][np.argmin(sgn * x[moving])]  # break-away: points between the jump and the straight part
    details = {
        "slope": float(a), "intercept": float(b), "points": m,
        "excluded_moving_points": int(np.count_nonzero(moving & ~sel)),
        "input_range": [float(np.min(x[sel])), float(np.max(x[sel]))], "first_moving_input": float(first),
        "residual_rms": rms, "jump_above_threshold": float(abs(first - val * sgn)),
    }
    if m < 5:
        warnings.append(f"{side} side: only {m} points on the straight part; the threshold's uncertainty is rough")
    warnings.extend(_low_end_bend(x[sel], y[sel] - (a * x[sel] + b), y[sel], s))
    return _SideFit(side=side, parameter=Parameter.estimate(s.name, float(val), se, r.critical_value),
                    residual_rms=rms, condition_number=r.condition_number, points=m, details=details,
                    warnings=tuple(warnings))


def _low_end_bend(xs: np.ndarray, resid: np.ndarray, ys: np.ndarray, s: _Side) -> list[str]:
    """A warning when the straight part's lowest point deviates from the line (the curve bends there)."""
    m = xs.size
    lo = np.argmin(s.sign * xs)
    others = float(np.sqrt(np.mean(np.delete(resid, lo) ** 2))) if m >= 4 else math.inf
    if m >= 4 and abs(resid[lo]) > 3.0 * others and abs(resid[lo]) > 0.01 * abs(ys[lo]):
        return [f"{s.side} side: the lowest point of the straight part (input {xs[lo]:.4g}) is off the "
                f"line by {resid[lo]:+.3g} rad/s; the curve bends there, raise min_fraction"]
    return []


def _compensation(c0: StaticCurve) -> dict[str, float]:
    """The compensation's thresholds in a compensated curve's metadata (empty when absent or not numbers)."""
    md = c0.metadata
    try:
        comp = {"v_dz_pos": float(md.get("v_dz_pos", "nan")), "v_dz_neg": float(md.get("v_dz_neg", "nan"))}
    except ValueError:
        comp = {}
    if not comp or not all(math.isfinite(v) for v in comp.values()):
        comp = {}
    return comp


class DeadZone(Setup):
    """The dead zone (5) from a static curve (section 5.1, figure 2a)."""

    name = "dead-zone"
    paper = "(5)/(8), section 5.1, figure 2a"
    columns = ("v_dz_pos", "v_dz_neg")
    parameters = columns
    static = True
    note = "all but v_dz_pos, v_dz_neg from the base set"
    refine = RefineSpec("motor-disk-raw", ("p2", "p3", "v_dz_pos", "v_dz_neg"), ("q4",))

    def row_betas(self, vals, pend, p2_known):
        return {}

    def parameter_changes(self, values, details, base):
        off = details.get("compensation") or {}
        return {"v_dz_pos": values["v_dz_pos"] + float(off.get("v_dz_pos", 0.0)),
                "v_dz_neg": values["v_dz_neg"] + float(off.get("v_dz_neg", 0.0))}

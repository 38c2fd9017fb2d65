"""The step-size controller of the integration engine, apart from the stepper.

The stepper (:mod:`iwp.sim.dop853`: the DOP853 tableau, its error estimate
and dense output) says how large the error of a trial step is; this module
says what to do next, as diffrax keeps its ``PIDController`` apart from the
solver. A single run (:func:`iwp.sim.engine.integrate`) and the runs side by
side (:mod:`iwp.sim.lanes`) call the same functions, so a run takes the same
steps in both.

* First step: Hairer's estimate (Hairer, Norsett & Wanner I, II.4), from
  ``f(t0, y0)`` and one more evaluation at ``y0 + h0 f``.
* Accepted step: proportional-integral control (Gustafsson; Hairer & Wanner
  II, IV.2), factor ``SAFETY err^-(1/8 - 0.75 BETA) err_prev^BETA`` bounded
  by ``MAX_FACTOR`` and by 1 right after a rejection.
* Rejected step: ``max(MIN_FACTOR, SAFETY err^(-1/8))``.

The factor's logarithm and exponential are :func:`~iwp.models.mathfn.log_vec`
and :func:`~iwp.models.mathfn.exp_vec` (within a few ulp of libm's), which
vectorise: the lanes compute every lane's factor after every step at once,
where libm's two calls per lane cost as much as a third of the stages.
"""

from __future__ import annotations

import math

from ..jit import jit
from ..models.mathfn import exp_vec, log_vec

SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
#: PI step-size control: the accepted-step factor is
#: ``SAFETY err^-(1/8 - 0.75 BETA) err_prev^BETA``; it damps the oscillating
#: step sizes that otherwise waste many rejected steps.
BETA = 0.04
#: ``ln err_prev`` of the first step of a run or segment, and its floor.
LERR_FLOOR = math.log(1e-4)


@jit(inline=True)
def accept_step(err, lerr_prev):
    """The step-size factor after an accepted step, and the ``lerr_prev`` of the next step.

    Parameters
    ----------
    err : float
        The step's error norm (< 1).
    lerr_prev : float
        ``ln err_prev`` of the step before (:data:`LERR_FLOOR` at the first step of a run or segment).

    Returns
    -------
    factor : float
        ``SAFETY err^-(1/8 - 0.75 BETA) err_prev^BETA``, at most ``MAX_FACTOR`` (``MAX_FACTOR`` if ``err`` is 0).
    lerr : float
        ``ln max(err, 1e-4)``: one logarithm serves both.

    Branch-free, so that a loop over lanes vectorises: an error below 1e-300
    (0 included) counts as 1e-300, whose factor is ``MAX_FACTOR`` as 0's is.
    """
    lerr = log_vec(max(err, 1e-300))
    factor = min(MAX_FACTOR, SAFETY * exp_vec(-(1.0 / 8.0 - 0.75 * BETA) * lerr + BETA * lerr_prev))
    return factor, max(lerr, LERR_FLOOR)


@jit
def reject_factor(err):
    """Step-size factor after a rejected step with error norm ``err`` (NaN: the smallest factor)."""
    if err != err:
        return MIN_FACTOR
    return max(MIN_FACTOR, SAFETY * err ** (-1.0 / 8.0))


@jit(inline=True)
def next_step_size(h, h_nat, factor, natural):
    """The natural step size after an accepted step of size ``h``.

    ``natural`` is False for a step that was clipped to a segment end,
    shortened before a kink or forced onto one: such a step keeps the
    natural size unless its own error asks for a smaller one.
    """
    if natural:
        return h * factor
    return min(h_nat, h * factor) if factor < 1.0 else h_nat


@jit
def first_trial(y, f, n_err, rtol, atol, h_max):
    """Hairer's first trial step ``h0`` from ``y`` and ``f = f(t, y)`` (scaled norms of both)."""
    d0 = 0.0
    d1 = 0.0
    for i in range(n_err):
        sc = atol[i] + abs(y[i]) * rtol
        d0 += (y[i] / sc) ** 2
        d1 += (f[i] / sc) ** 2
    d0 = math.sqrt(d0 / n_err)
    d1 = math.sqrt(d1 / n_err)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    return min(h0, h_max)


@jit
def first_step_size(y, f, f1, h0, n_err, rtol, atol, h_max):
    """Hairer's first step from ``f = f(t, y)`` and ``f1 = f(t + h0, y + h0 f)`` (8th order), at most ``h_max``."""
    d1 = 0.0
    d2 = 0.0
    for i in range(n_err):
        sc = atol[i] + abs(y[i]) * rtol
        d1 += (f[i] / sc) ** 2
        d2 += ((f1[i] - f[i]) / sc) ** 2
    d1 = math.sqrt(d1 / n_err)
    d2 = math.sqrt(d2 / n_err) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, h_max)


__all__ = [
    "BETA",
    "LERR_FLOOR",
    "MAX_FACTOR",
    "MIN_FACTOR",
    "SAFETY",
    "accept_step",
    "first_step_size",
    "first_trial",
    "next_step_size",
    "reject_factor",
]

"""From logs to a validated model in one call: least squares, joint simulation-error fit, validation.

:func:`fit_logs` (the command ``iwp fit TRAIN... --rig RIG.json --validate
HELDOUT... --out DIR``) takes a rig's logs as they are (read with its rig
description, :func:`iwp.data.rig_log.read_rig_log`, or iwp logs) and

1. finds and reports glitches (:meth:`ExperimentData.with_glitches_found`);
   replaced samples are left out of every residual and fit;
2. computes a start by **least squares** of the two rows of model (9)
   (:func:`least_squares_start`): the row sum ``q3' + q4' = -rho (p2 q4 - p3 u)``
   gives ``rho p2`` and ``rho p3`` free of the pendulum terms; the first row
   gives ``p1``, the friction, ``p2``, ``p3`` and the angle's zero offset; velocities and
   accelerations from cubic Savitzky-Golay filters over 0.15 s; a wheel speed
   sampled as the mean over the preceding period is moved to the sample
   instants first. Where the sampling does not allow it (fewer than 8
   samples per pendulum period) or the values are not physical, a start from
   the spectrum of ``q1`` and the wheel row alone is taken instead, and said so;
3. **refines** model (9) -- or (6) with its dead zone, with Coulomb friction
   of the wheel and of the pendulum and an input offset as options -- by
   simulation error on all training logs jointly (:func:`iwp.ident.refinement.refine`),
   on the pendulum's angle ``q1`` and the wheel's speed ``q4`` (logged, or
   differentiated from the wheel's angle, which enters no equation and whose
   error, the integral of the speed's, grows over a log; a mean-sampled
   speed is modelled as the mean over the period), with the
   initial state and, unless the rig gives it, the pendulum angle's zero
   offset estimated per log;
4. **validates** on held-out logs without re-fitting: each is simulated from
   its measured initial state (:func:`~iwp.ident.output_error.measured_initial_state`) with the
   pendulum offset of the rig, or else the
   mean of the training logs' offsets (one encoder reset position), and
   compared per signal (fit in percent, RMS and largest error).

The result (:class:`LogFitResult`) holds the parameters with standard errors
and correlations, the fits per log and signal, the series for the error
plots, and every warning (glitches, saturated input, parameters the data
cannot separate, a fallback start). :meth:`LogFitResult.write` writes
``fit.json``, ``parameters.json`` and a self-contained ``report.html``
(:mod:`iwp.report.fit_page`).

The steps are modules of their own, in the order the work flows: the plan
(:mod:`iwp.ident.fit_plan`: the logs read, sorted by set-up, checked), the
least-squares start (:mod:`iwp.ident.fit_start`), the fit and its ladder
(:mod:`iwp.ident.fit_ladder`, beside :mod:`iwp.ident.structure`), the
result and its report (:mod:`iwp.ident.fit_report`).
"""

from __future__ import annotations

import os
import time
import warnings as _warnings
from typing import Any, Mapping

from ..data.rig_description import RigDescription
from ..sim.inputs import Input
from .fit_ladder import BAND_HOLDS, LogFit, fit_plan
from .fit_plan import LogFitOptions, inferred_kind, kind_mismatches, load_logs, plan_fit
from .fit_report import LogFitResult, report_fit
from .fit_start import MIN_SAMPLES_PER_PERIOD, LeastSquaresStart, least_squares_start

__all__ = ["fit_logs", "LogFitOptions", "LogFitResult", "LogFit", "LeastSquaresStart", "least_squares_start",
           "BAND_HOLDS", "load_logs", "MIN_SAMPLES_PER_PERIOD", "kind_mismatches", "inferred_kind", "plan_fit",
           "fit_plan", "report_fit"]


def fit_logs(
    train,
    *,
    rig: RigDescription | str | os.PathLike | None = None,
    validate=(),
    kinds: Mapping[str, Any] | None = None,
    controller: Input | None = None,
    options: LogFitOptions | None = None,
    warn: bool = True,
) -> LogFitResult:
    """Identify model (9) (or (6)) from a rig's training logs and validate it on held-out logs.

    Parameters
    ----------
    train : path, ExperimentData or sequence of them
        Training logs (e.g. chirps), fitted jointly.
    rig : RigDescription or path, optional
        How the logs map onto iwp's signals (``--rig``); without it they must be iwp logs.
    validate : path, ExperimentData or sequence of them
        Held-out logs (e.g. pseudo-random inputs), simulated from their measured state, not fitted.
    kinds : dict of str to logs, optional
        Logs of the rig's other set-ups that join the training, by kind
        (:data:`~iwp.ident.output_error.EXPERIMENT_KINDS`): ``"clamped"``
        (the pendulum clamped, the wheel driven: section 5.1) and
        ``"wheel-locked"`` (the wheel locked to the arm, a free swing), e.g.
        ``{"clamped": ["clamp1.csv"]}``; each compares the signals its set-up
        moves, with the same parameters (``iwp fit --clamped/--wheel-locked``);
        and ``"closed-loop"`` (the input computed by ``controller``, simulated
        with the model instead of the logged input: ``--closed-loop``).
        Training logs that the rig description's ``experiments`` give
        another set-up join as that set-up (a closed-loop one with the
        description's law); a kind given here comes first.
    controller : Input, optional
        The feedback law of the ``"closed-loop"`` logs of ``kinds`` (an
        :mod:`iwp.sim.inputs` controller, e.g.
        :class:`~iwp.sim.inputs.HopfController`), its output in the logs'
        input units.
    options : LogFitOptions, optional
        The model and its options, the loss, the start, the window.
    warn : bool
        Also issue the warnings with :func:`warnings.warn`.

    Returns
    -------
    LogFitResult
    """
    t0 = time.perf_counter()
    plan = plan_fit(train, rig=rig, validate=validate, kinds=kinds, controller=controller,
                    options=options or LogFitOptions())
    fitted = fit_plan(plan)
    res = report_fit(plan, fitted, elapsed=time.perf_counter() - t0)
    if warn:
        for m in res.warnings:
            _warnings.warn(m, stacklevel=2)
    return res

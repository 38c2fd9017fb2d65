"""The result of ``iwp fit`` and its report: parameters, fits per log, the held-out logs predicted.

:func:`report_fit` makes the :class:`LogFitResult` of a
:class:`~iwp.ident.fit_plan.FitPlan` and its :class:`~iwp.ident.fit_ladder.Fitted`:
the parameters with standard errors and correlations, the fits per log and
signal, the series for the error plots, every warning and, when the
held-out logs are predicted poorly, advice (:func:`poor_prediction_advice`).
:meth:`LogFitResult.write` writes ``fit.json``, ``parameters.json`` and
``report.html`` (:mod:`iwp.report.fit_page`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..data import ExperimentData
from ..data.rig_description import RigDescription
from ..files import json_float
from ..models.encoder import EncoderZero
from ..models.parameters import PARAMETER_INFO, BeltParameters, LumpedParameters
from ..models.plant import model_info
from ..sim.uncertainty import ParameterUncertainty
from .fit_ladder import (
    HOLDABLE_FRICTION,
    Fitted,
    Fitting,
    LogFit,
    Replayed,
    band_misses,
    held_prior_spreads,
    log_fit,
    mean_fit,
    predict_held_out,
    unique_lines,
)
from .fit_plan import FitPlan
from .input_hold import InputHoldReading, describe_readings
from .metrics import JUDGED, judged_fits, poor_fits
from .refinement import RefineResult
from .structure import (
    LadderResult,
)
from .validation import model_input

__all__ = ["LogFitResult", "report_fit", "predicted_signals", "poor_prediction_advice"]


@dataclass(eq=False)
class LogFitResult:
    """The outcome of :func:`fit_logs`.

    Attributes
    ----------
    params : LumpedParameters
        The refined parameters.
    refinement : RefineResult
        The joint simulation-error fit (stderr, correlations, warnings, ...).
    start : LumpedParameters
        Its start; ``start_method`` says how it was found (``least squares`` or the fallback).
    least_squares : dict
        The least-squares values and notes.
    model : str
        ``"compensated"`` (9), ``"raw"`` (6) or ``"belt-full"`` ((4a) with the belt (15)).
    outputs : tuple of str
    options : dict
        The model options used (dead zone, Coulomb terms, widths, input offset).
    train, validation : list of LogFit
    warnings : list of str
    rig : RigDescription or None
    elapsed : float
        Wall time [s].
    structures : LadderResult or None
        The ladder of structures fitted and ranked (``select``), or None.
    held_out_zero : EncoderZero
        The pendulum zero taken off a held-out log's ``q1``: the training
        logs' mean offset when the offset is estimated per log, 0 when the rig
        description gives it (its logs are corrected when read), with the
        spread of a run's own zero about it, which the held-out bands carry.
    held_priors : dict of str to float
        The friction coefficients held at their prior (:func:`hold_unidentified`) and the prior's spread
        (:func:`held_prior_spreads`), which the held-out bands and the stored covariance carry.
    input_holds : dict of str to InputHoldReading
        How each log's input acted between its samples, by source, and why (:mod:`iwp.ident.input_hold`).

    Notes
    -----
    With the belt (15), ``p2`` and ``p3`` do not enter the model; ``params``
    holds its belt's rigid limit (:attr:`BeltParameters.rigid_p2rho` and
    :attr:`~BeltParameters.rigid_p3rho` over ``rho``) and :attr:`belt` the belt.
    """

    params: LumpedParameters
    refinement: RefineResult
    start: LumpedParameters
    start_method: str
    least_squares: dict
    model: str
    outputs: tuple[str, ...]
    options: dict
    train: list[LogFit]
    validation: list[LogFit]
    warnings: list[str]
    rig: RigDescription | None = None
    elapsed: float = 0.0
    structures: LadderResult | None = None
    held_out_zero: EncoderZero = field(default_factory=EncoderZero)
    held_priors: dict[str, float] = field(default_factory=dict)
    input_holds: dict[str, InputHoldReading] = field(default_factory=dict)

    @property
    def held_out_offset(self) -> float:
        """The pendulum zero offset [rad] taken off a held-out log's ``q1`` (:attr:`held_out_zero`'s value)."""
        return self.held_out_zero.value

    @property
    def belt(self) -> BeltParameters | None:
        """The fitted belt (15), or None for a model without it."""
        return self.refinement.belt

    def start_value(self, name: str) -> float:
        """The value parameter ``name`` started from (a belt's parameter: from the belt's start)."""
        owner = PARAMETER_INFO[name].owner
        return float(getattr(self.refinement.belt_start if owner == "belt" else self.start, name))

    def poor_prediction(self) -> str | None:
        """Why the held-out logs are predicted poorly, on one line, or None (none, or no held-out log).

        Poorly: a signal's mean fit below :data:`~iwp.ident.metrics.POOR_FIT` %, or below zero on a log
        (:func:`~iwp.ident.metrics.poor_fits`). ``iwp fit`` then exits with status 1 (``--accept-poor``: 0).
        """
        bad = poor_fits([judged_fits(f.fit, f.measured) for f in self.validation], JUDGED)
        return f"the model predicts the held-out logs poorly (mean fit {', '.join(bad)})" if bad else None

    @property
    def band_holds(self) -> bool | None:
        """Whether the held-out logs' 95 % prediction bands hold for this model (None: no band): each judged signal
        of each held-out log at least :data:`BAND_HOLDS` inside (:attr:`LogFit.band_misses`)."""
        banded = [f for f in self.validation if f.coverage]
        return None if not banded else not any(f.band_misses for f in banded)

    @property
    def validation_fit(self) -> dict[str, float]:
        """Mean fit [%] over the held-out logs of each signal they are judged on (:data:`JUDGED`: ``q1``, ``q4``;
        NaN without held-out logs)."""
        return mean_fit([f.fit for f in self.validation], JUDGED)

    @property
    def predicted(self) -> tuple[str, ...]:
        """The signals computed for the logs: those fitted, and the wheel's angle where a held-out log holds it."""
        return tuple(dict.fromkeys(o for f in self.train + self.validation for o in ("q1", "q2", "q4")
                                   if o in f.fit))

    def validation_range(self) -> dict[str, tuple[float, float]]:
        """Per judged signal, the lowest and the highest fit [%] of the held-out logs (a mean hides a failed log)."""
        out = {}
        for o in JUDGED:
            vals = [f.fit[o] for f in self.validation if o in f.fit and math.isfinite(f.fit[o])]
            out[o] = (float(min(vals)), float(max(vals))) if vals else (float("nan"), float("nan"))
        return out

    @property
    def training_fit(self) -> dict[str, float]:
        """Mean fit [%] per signal over the training logs."""
        return mean_fit([f.fit for f in self.train], self.outputs)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able summary (NaN -> None)."""
        r = self.refinement
        return {
            "kind": "iwp-fit",
            "model": self.model,
            "outputs": list(self.outputs),
            "options": dict(self.options),
            "held_out_q1_offset": json_float(self.held_out_offset),
            "held_out_q1_offset_spread": json_float(self.held_out_zero.spread),
            "rig": None if self.rig is None else self.rig.to_dict(),
            "parameters": {k: v.to_dict() for k, v in r.parameters.items()},
            "free": list(r.free),
            "correlation": r.to_dict()["correlation"],
            "start": {"method": self.start_method, "values": self.start.to_dict()},
            "least_squares": self.least_squares,
            "train": [f.to_dict() for f in self.train],
            "validation": [f.to_dict() for f in self.validation],
            "training_fit": {k: json_float(v) for k, v in self.training_fit.items()},
            "validation_fit": {k: json_float(v) for k, v in self.validation_fit.items()},
            "refinement": {k: r.to_dict()[k] for k in ("cost_start", "cost", "success", "message", "nfev", "njev",
                                                        "n_samples", "residual_std")},
            "uncertainty": None if r.reliability is None else r.reliability.to_dict(),
            "structures": None if self.structures is None else self.structures.to_dict(),
            "warnings": list(self.warnings),
            "elapsed_s": json_float(self.elapsed),
            "lumped": self.params.to_dict(),
            "belt": None if self.belt is None else self.belt.to_dict(),
            "input_hold": {src: r.to_dict() for src, r in self.input_holds.items()},
            "band_holds": self.band_holds,
        }

    def summary(self, warnings: bool = True) -> str:
        """Readable lines: parameters, fits per log and signal, (with ``warnings``) the warnings."""
        lines = [self.structures.table()] if self.structures is not None else []
        lines.append(f"model {self.model} {model_info(self.model).equation}, free: "
                     f"{', '.join(self.refinement.free)}; outputs {', '.join(self.outputs)}, start: "
                     f"{self.start_method}")
        for n in self.refinement.free:
            pe = self.refinement.parameters[n]
            lines.append(f"  {n:<9} {pe.value:>12.6g} +- {pe.stderr:.2g}  [{pe.ci95_low:.6g}, {pe.ci95_high:.6g}]")
        if self.refinement.reliability is not None:
            lines.append(self.refinement.reliability.describe())
        if self.input_holds:
            lines.append(describe_readings(self.input_holds))
        for f in self.train + self.validation:
            fits = ", ".join(f"{k} {v:.2f} %" + (" (not judged)" if k not in JUDGED else "") for k, v in f.fit.items())
            band = (", in the 95 % prediction band: " + ", ".join(f"{k} {100 * v:.0f} %" for k, v in f.coverage.items())
                    + (f" (the band does not hold for {', '.join(f.band_misses)})" if f.band_misses else "")
                    if f.coverage else "")
            kind = "" if f.kind == "free" else f" ({f.kind})"
            lines.append(f"{f.role:>8} {f.source}{kind}: fit {fits}{band}")
        if len(self.validation) > 1:
            rng = self.validation_range()
            lines.append("held-out logs: " + ", ".join(
                f"{o} mean {m:.2f} % (from {rng[o][0]:.2f} to {rng[o][1]:.2f} % over {len(self.validation)} logs)"
                for o, m in self.validation_fit.items()))
        for w in self.warnings if warnings else ():
            lines.append(f"warning: {w}")
        lines.append(f"fitted in {self.elapsed:.3g} s")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()



def report_fit(plan: FitPlan, fitted: Fitted, *, elapsed: float = 0.0) -> LogFitResult:
    """The training fits per log and the held-out logs simulated from their measured state, with every warning."""
    options, r = fitted.options, fitted.result
    model = options.model
    msgs = list(plan.messages) + list(r.warnings)
    train_logs = [model_input(d, model, "train") for d in plan.train]
    val_logs = [model_input(d, model, "validate") for d in plan.held_out]
    offs = [r.offsets[i].get("q1", (0.0, 0.0))[0] for i in range(len(train_logs))]
    train_fits = [log_fit(d, "train", Replayed.of(r, i), offs[i]) for i, d in enumerate(train_logs)]
    for j, o in enumerate(plan.others, start=len(train_logs)):
        train_fits.append(log_fit(o.data, "train", Replayed.of(r, j), r.offsets[j].get("q1", (0.0, 0.0))[0],
                                   kind=o.kind))
    zero = EncoderZero.of(offs, plan.offset_given)
    val_off = zero.value
    if val_logs and not plan.offset_given:
        msgs.append(f"held-out logs: the pendulum zero offset is taken as the training logs' mean, "
                    f"{val_off:+.4g} rad (offsets of the training logs: "
                    + ", ".join(f"{o:+.4g}" for o in offs) + ")")
    priors = held_prior_spreads(fitted.held, r.params)
    uncertainty = (ParameterUncertainty.from_refinement(r).with_priors(priors)
                   if np.all(np.isfinite(r.covariance)) else None)
    if val_logs and uncertainty is None:
        msgs.append("held-out logs: no prediction band, for the fit did not determine every free parameter")
    plant = Fitting(plan).plant(options, r.params, r.belt)
    val_fits = [predict_held_out(d, plant, predicted_signals(d), zero, msgs, uncertainty) for d in val_logs]
    msgs.extend(band_misses(val_fits, r))
    params = r.params
    if r.belt is not None:  # p2 and p3 do not enter the belt model: its rigid limit stands for them
        params = params.replace(p2=r.belt.rigid_p2rho / params.rho, p3=r.belt.rigid_p3rho / params.rho)
    for n in fitted.held:
        where = ("held there, its partners carrying the damping" if getattr(r.params, n) == 0.0 else
                 f"held at {getattr(r.params, n):.3g}, Table 1's damping ratio on this rig's frequency (the fit "
                 "sees no pendulum damping)")
        msgs.append(f"{n} is not identified by these logs (the fit drove it to its bound 0, with an interval a "
                    f"hundred times wider than any value): {where}, with a spread of {priors[n]:.3g} in the bands "
                    f"(--fix {n}=VALUE for your rig's); {HOLDABLE_FRICTION[n]} identifies it")
    msgs.extend(poor_prediction_advice(val_fits, JUDGED, chose=fitted.structures is not None))
    if fitted.structures is not None:
        msgs.extend(fitted.structures.kept_simpler_advice())
    return LogFitResult(params=params, refinement=r, start=fitted.start, start_method=plan.start.method,
                        least_squares=plan.start.details, model=model, outputs=plan.outputs,
                        options=options.to_dict(plan.offset_given), train=train_fits, validation=val_fits,
                        warnings=unique_lines(msgs), rig=plan.rig, elapsed=elapsed, structures=fitted.structures,
                        held_out_zero=zero, held_priors=priors, input_holds=dict(plan.holds))


def predicted_signals(d: ExperimentData) -> tuple[str, ...]:
    """The signals computed for held-out log ``d``: :data:`~iwp.ident.metrics.JUDGED`, and the wheel's angle where
    the log holds it (shown, not judged)."""
    return JUDGED[:1] + (("q2",) if d.q2 is not None else ()) + JUDGED[1:]


def poor_prediction_advice(fits: Sequence[LogFit], outputs: Sequence[str], *, chose: bool) -> list[str]:
    """A warning, with what to try, when the held-out logs are predicted poorly (mean fit below
    :data:`~iwp.ident.metrics.POOR_FIT` % or below zero on a log, :func:`~iwp.ident.metrics.poor_fits`), or none."""
    bad = poor_fits([judged_fits(f.fit, f.measured) for f in fits], outputs)
    if not bad:
        return []
    tries = ["the rig description's units, signs and zero (docs/rig-description.md): a wrong encoder gain or sign "
             "fits the training logs and predicts nothing",
             "held-out logs of the same set-up as the training logs (the same pendulum and counterweights)",
             "training logs that excite what the held-out logs do (amplitudes, frequencies, the input's range)"]
    if not chose:
        tries.insert(0, "letting iwp fit choose the model structure (without --model or the term flags)")
    else:
        tries.insert(0, "the clamped-pendulum and locked-wheel logs of the rig joining the training (--clamped, "
                        "--wheel-locked)")
    return ["the model predicts the held-out logs poorly (mean fit " + ", ".join(bad) + "); check or try: "
            + "; ".join(tries)]

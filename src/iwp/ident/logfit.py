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
"""

from __future__ import annotations

import math
import os
import time
import warnings as _warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np

from ..data import ExperimentData, check_distinct, read_experiment
from ..data.rig_description import ControllerSpec, RigDescription, load_rig
from ..data.rig_log import read_rig_log
from ..errors import InputError
from ..files import json_float
from ..models.encoder import EncoderZero
from ..models.parameters import PARAMETER_INFO, BeltParameters, LumpedParameters, table1
from ..models.plant import Plant, model_info
from ..models.terms import (
    TERMS,
    DriveModel,
    closure,
    drive_of,
    free_parameters,
    model_of,
    starting_values,
    term,
)
from ..sim.inputs import HopfController, Input
from ..sim.uncertainty import ParameterUncertainty, StartUncertainty, prediction_band, undetermined
from ..threads import one_blas_thread, thread_map
from .fit_start import MIN_SAMPLES_PER_PERIOD, LeastSquaresStart, least_squares_start
from .identification import HOLDABLE, PRIOR_SPREAD
from .input_hold import INPUT_HOLDS, InputHoldReading, describe_readings, with_input_hold
from .metrics import JUDGED, fit_percent, judged_fits, poor_fits
from .output_error import (
    EXPERIMENT_KINDS,
    Experiment,
    OutputError,
    angle_quantum,
    band_as_measured,
    start_state,
)
from .problem import Loss, SolverOptions
from .refinement import RefineResult, as_experiments, refine
from .structure import (
    CROSS_VALIDATION,
    HELD_OUT_LOGS,
    SIGNED_RANK_MIN,
    LadderResult,
    Rung,
    RungOutcome,
    information_criteria,
    ladder,
    select,
)
from .validation import model_input

__all__ = ["fit_logs", "LogFitOptions", "LogFitResult", "LogFit", "LeastSquaresStart", "least_squares_start",
           "BAND_HOLDS", "load_logs", "MIN_SAMPLES_PER_PERIOD", "kind_mismatches", "inferred_kind"]

#: A held-out log's 95 % prediction band holds when at least this share of its samples of each judged signal lies
#: inside; below, the fit says that it does not hold on that log. A right band held 80-100 % of each set of three
#: held-out logs (mean 93-96 %) on tests/independent.py's logs with AR(1) noise (benchmarks/independent_study.py),
#: one log of a set 64 % where the estimates lay two standard errors off (a 95 % band fails so, now and then); the
#: twin's held-out chirp fitted with model (9), which lacks the twin's belt and dead zone, held 60 % of q1 (the
#: README's sequence).
BAND_HOLDS = 0.8


@dataclass
class LogFit:
    """How the model fits one log (training: at the optimum; held out: simulated from its measured state).

    Attributes
    ----------
    source : str
    role : {"train", "validate"}
    fit, rms, max_abs_error : dict of str to float
        Per signal: fit [%], RMS and largest error (unit of the signal).
    t : ndarray
        Sample times [s].
    measured, simulated : dict of str to ndarray
    used : dict of str to ndarray
        True where a sample enters the fit (False at replaced glitches).
    x0 : ndarray
        Initial state of the simulation.
    q1_offset : float
        The pendulum zero offset removed from ``q1`` [rad].
    glitches : list of str
    """

    source: str
    role: str
    fit: dict[str, float]
    rms: dict[str, float]
    max_abs_error: dict[str, float]
    t: np.ndarray
    measured: dict[str, np.ndarray]
    simulated: dict[str, np.ndarray]
    used: dict[str, np.ndarray]
    x0: np.ndarray
    q1_offset: float = 0.0
    glitches: list[str] = field(default_factory=list)
    #: held-out logs: per signal, the share of the samples inside the fit's 95 % prediction band
    coverage: dict[str, float] = field(default_factory=dict)
    #: the set-up (:data:`~iwp.ident.output_error.EXPERIMENT_KINDS`)
    kind: str = "free"

    @property
    def band_misses(self) -> tuple[str, ...]:
        """The judged signals of a held-out log of which less than :data:`BAND_HOLDS` lies inside its 95 % band."""
        return tuple(o for o in JUDGED if o in self.coverage and math.isfinite(self.coverage[o])
                     and self.coverage[o] < BAND_HOLDS)

    def to_dict(self) -> dict[str, Any]:
        return {"source": self.source, "role": self.role,
                "fit": {k: json_float(v) for k, v in self.fit.items()},
                "band_holds": None if not self.coverage else not self.band_misses,
                "rms": {k: json_float(v) for k, v in self.rms.items()},
                "max_abs_error": {k: json_float(v) for k, v in self.max_abs_error.items()},
                "samples": int(self.t.size), "t_start": float(self.t[0]), "t_end": float(self.t[-1]),
                "x0": [json_float(v) for v in self.x0], "q1_offset": json_float(self.q1_offset),
                "glitches": list(self.glitches), "band_coverage": {k: json_float(v) for k, v in self.coverage.items()},
                "kind": self.kind}


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
        return _mean_fit([f.fit for f in self.validation], JUDGED)

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
        return _mean_fit([f.fit for f in self.train], self.outputs)

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


def _mean_fit(fits: Sequence[dict[str, float]], outputs) -> dict[str, float]:
    """Per output, the mean of the finite fits [%] of the logs that compare it (NaN if none)."""
    out = {}
    for o in outputs:
        vals = [f[o] for f in fits if o in f and math.isfinite(f[o])]
        out[o] = float(np.mean(vals)) if vals else float("nan")
    return out


# --------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------
def load_logs(items, rig: RigDescription | None, *, argument: str = "logs") -> list[ExperimentData]:
    """Read logs as :class:`ExperimentData`, glitches found and recorded.

    Paths are read with the rig description (or as iwp logs without one).

    Parameters
    ----------
    items : str, path-like, ExperimentData or sequence of them
        Log files or logs already read.
    rig : RigDescription or None
        How to read the files (another rig's logs); None: iwp's own log format.
    argument : str, default "logs"
        Name of the argument in error messages.

    Returns
    -------
    list of ExperimentData
        The logs, in order, with their glitches found.

    Raises
    ------
    InputError
        A missing file, an item of another type, or a file that does not read.
    """
    if isinstance(items, (str, os.PathLike, ExperimentData)):
        items = [items]
    out = []
    for it in items:
        if isinstance(it, ExperimentData):
            d = it
        elif isinstance(it, (str, os.PathLike)):
            p = Path(it)
            if not p.is_file():
                raise InputError(f"{argument}: {p}: no such file", argument=argument)
            d = read_rig_log(p, rig) if rig is not None else read_experiment(p)
        else:
            raise InputError(f"{argument}: expected log files or ExperimentData, got {type(it).__name__}",
                             argument=argument)
        out.append(d.with_glitches_found())
    return out


# --------------------------------------------------------------------------
# the fit
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class LogFitOptions:
    """How :func:`fit_logs` fits (``iwp fit``'s options).

    Parameters
    ----------
    terms : iterable of str
        The optional terms of model (9) fitted (:data:`iwp.models.terms.TERMS`:
        ``"coulomb"``, ``"pendulum_coulomb"``, ``"widths"``, ``"input_offset"``,
        ``"dead_zone"``, ``"belt"``, ``"stribeck"``), with the terms they
        require; the model follows from them (model (6) with the dead zone,
        ``"belt-full"`` with the belt, else model (9)). Default: none.
    select : bool
        Fit the ladder of structures (:mod:`iwp.ident.structure`) and keep the
        simplest within noise of the best on held-out data (``iwp fit``'s
        default); ``terms`` is then ignored.
    try_terms : iterable of str
        Terms off the default ladder whose rungs the ladder tries too (``iwp fit --try``).
    fixed : mapping of str to float
        Lumped parameters held at these values in every structure fitted, e.g. ``{"rho": 247.2}`` (``iwp fit
        --fix rho=247.2``): known from a data sheet or another experiment, or not identified by these logs.
    loss : str
        ``"linear"`` or a robust loss (:class:`~iwp.ident.problem.Loss`).
    start : LumpedParameters, optional
        Start of the refinement instead of the least squares.
    window : (float or None, float or None)
        Window of every training log [s].
    input_hold : {"auto", "zoh", "continuous"}
        How each log's input acted between its samples (:mod:`iwp.ident.input_hold`), for the least squares and
        the replay of the input in every simulation: ``"auto"`` (default) as its metadata says, else read from
        the log itself; ``"zoh"`` or ``"continuous"`` for every log.

    Examples
    --------
    >>> LogFitOptions(terms={"stribeck"}).free()[-3:]
    ('sigma_c2', 'sigma_s2', 'v_s2')
    """

    terms: frozenset[str] = frozenset()
    select: bool = False
    try_terms: frozenset[str] = frozenset()
    fixed: Mapping[str, float] = field(default_factory=dict)
    loss: str = "linear"
    start: LumpedParameters | None = None
    window: tuple[float | None, float | None] = (None, None)
    input_hold: str = "auto"

    def __post_init__(self) -> None:
        Loss(self.loss)
        if self.input_hold not in INPUT_HOLDS:
            raise InputError(f"input_hold must be one of {', '.join(INPUT_HOLDS)}, got {self.input_hold!r}",
                             argument="input_hold")
        if isinstance(self.terms, str) or isinstance(self.try_terms, str):
            raise InputError("terms: give a set of term names, e.g. {'coulomb', 'widths'}", argument="terms")
        object.__setattr__(self, "terms", closure(self.terms))
        object.__setattr__(self, "try_terms", frozenset(term(n, argument="try").name for n in self.try_terms))
        object.__setattr__(self, "fixed", _checked_fixed(self.fixed))
        if self.start is not None and not isinstance(self.start, LumpedParameters):
            raise InputError(f"start must be LumpedParameters, got {type(self.start).__name__}", argument="start")

    @property
    def model(self) -> str:
        """The model the terms make: ``"raw"`` (6) with the dead zone, ``"belt-full"`` with the belt, or
        ``"compensated"`` (9) (:func:`iwp.models.terms.model_of`)."""
        return model_of(self.terms)

    @property
    def drive(self) -> DriveModel | None:
        """The model of its own a term puts in place of ``p2, p3`` (the belt's), or None."""
        return drive_of(self.terms)

    def free(self) -> tuple[str, ...]:
        """The parameters fitted: model (9)'s (a drive model's in place of those it replaces) and the terms', less
        the fixed ones."""
        return tuple(n for n in free_parameters(self.terms) if n not in self.fixed)

    def with_rung(self, rung: Rung) -> "LogFitOptions":
        """These options with the structure of ``rung`` (and no ladder)."""
        return replace(self, select=False, terms=rung.terms)

    def starting_values(self, start: LumpedParameters, umax: float, *, fraction: float = 1.0) -> LumpedParameters:
        """The terms' parameters that are 0 in ``start`` started at a fraction of what the logs' input and ``start``
        allow (terms a simpler structure fitted keep their values); ``fraction`` scales those starts (a start
        next to the simpler structure's optimum, :data:`NESTED_RESTART`); the fixed parameters at their values."""
        return starting_values(self.terms, start, umax, fraction=fraction).replace(**self.fixed)

    def to_dict(self, offset_given: bool) -> dict[str, Any]:
        return {**{n: n in self.terms for n in TERMS}, "loss": self.loss,
                "q1_offset": "given by the rig" if offset_given else "estimated per log",
                **({"fixed": dict(self.fixed)} if self.fixed else {})}


def _checked_fixed(fixed) -> dict[str, float]:
    """``fixed`` as ``{name: value}`` of lumped parameters, each a finite number of its physical sign."""
    if not isinstance(fixed, Mapping):
        raise InputError(f"fixed must map parameter names to values, e.g. {{'rho': 247.2}}, got {fixed!r}",
                         argument="fixed")
    out = {}
    for name, value in fixed.items():
        info = PARAMETER_INFO.get(name)
        if info is None or info.owner != "lumped":
            known = ", ".join(n for n, i in PARAMETER_INFO.items() if i.owner == "lumped")
            raise InputError(f"fixed: {name!r} is not a lumped parameter that a fit can hold; choose among {known}",
                             argument="fixed")
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise InputError(f"fixed: {name} = {value!r} is not a number", argument="fixed") from None
        lo, _hi = info.default_bounds()
        if not math.isfinite(v) or (info.sign == "positive" and v <= 0) or v < min(lo, 0.0):
            raise InputError(f"fixed: {name} = {value!r} is not a physical value ({info.description}: "
                             f"{info.sign} [{info.unit}])", argument="fixed")
        out[name] = v
    return out


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


# --------------------------------------------------------------------------
# plan: the logs read and sorted by set-up, checked, the start
# --------------------------------------------------------------------------
@dataclass
class FitPlan:
    """What :func:`fit_logs` fits, before any fit: the logs by role and set-up, what they measure, the start.

    Attributes
    ----------
    options : LogFitOptions
    rig : RigDescription or None
    train : list of ExperimentData
        The free training logs.
    held_out : list of ExperimentData
        The held-out logs.
    others : list of JoinedLog
        The training logs of the other set-ups (clamped, wheel-locked, closed loop).
    outputs : tuple of str
        The signals fitted and compared: :data:`~iwp.ident.metrics.JUDGED`, the pendulum's angle and the wheel's
        speed (differentiated from the wheel's angle where a log holds no speed).
    offset_given : bool
        The rig description gives the pendulum's zero offset (else it is estimated per log).
    drive_ratio : float or None
        The belt drive's ratio ``N`` where the rig's drive is a belt measured at the wheel, else None.
    umax : float
        The training logs' largest input magnitude [in].
    start : LeastSquaresStart
        Where the fits start.
    messages : list of str
        What was found on the way (warnings).
    holds : dict of str to InputHoldReading
        How each log's input acted between its samples, by source (:mod:`iwp.ident.input_hold`).
    """

    options: LogFitOptions
    rig: RigDescription | None
    train: list[ExperimentData]
    held_out: list[ExperimentData]
    others: list["JoinedLog"]
    outputs: tuple[str, ...]
    offset_given: bool
    drive_ratio: float | None
    umax: float
    start: LeastSquaresStart
    messages: list[str]
    holds: dict[str, InputHoldReading] = field(default_factory=dict)

    @property
    def Ts(self) -> float:
        """The training logs' sample period [s] (a drive model's start and bounds)."""
        return float(self.train[0].Ts)


def plan_fit(train, *, rig=None, validate=(), kinds=None, controller: Input | None = None,
             options: LogFitOptions) -> FitPlan:
    """The logs of :func:`fit_logs` read, sorted by set-up and checked, and the start found (no simulation fit).

    Parameters are those of :func:`fit_logs`.

    Returns
    -------
    FitPlan
    """
    rig_d = load_rig(rig) if rig is not None else None
    with _warnings.catch_warnings(record=True) as caught:
        _warnings.simplefilter("always")
        train_logs = load_logs(train, rig_d, argument="train")
        val_logs = load_logs(validate, rig_d, argument="validate") if validate else []
        others = _other_kinds(kinds, rig_d, controller)
    msgs = [str(w.message) for w in caught]
    _check_controller(controller, others)
    if not train_logs:
        raise InputError("train: no training logs given", argument="train")
    _check_held_out_distinct(train_logs, others, val_logs)
    train_logs, others = _sort_by_kind(train_logs, others, rig_d, msgs)
    train_logs, val_logs, others, holds = _read_holds(train_logs, val_logs, others, options.input_hold)
    msgs.extend(_held_out_kind_notes(val_logs, rig_d))
    msgs.extend(disagreeing_logs(train_logs, window=options.window))
    mismatched = kind_mismatches(train_logs, [(o.kind, o.data) for o in others])
    contradicted = [m for m in mismatched if m.startswith(("--clamped ", "--wheel-locked "))]
    if contradicted:  # a log given as clamped whose pendulum swings: the fit would compare only its wheel
        flag = contradicted[0].split()[0]
        raise InputError(contradicted[0], argument=flag[2:].replace("-", "_"))
    msgs.extend(mismatched)
    for d in train_logs + val_logs:
        if d.q2 is None and d.q4 is None:
            raise InputError(f"{d.source}: logs no wheel signal (q2 or q4)")
    if not any(d.input_name is not None and np.ptp(np.asarray(d.input, dtype=float)) > 0 for d in train_logs) \
            and not any(o.kind in ("clamped", "closed-loop") for o in others):
        raise InputError("train: no training log drives the wheel (every input is zero or absent): iwp fit identifies "
                         "the drive from its input; a free swing identifies the pendulum alone (iwp identify LOG "
                         "--setup free)", argument="train")
    # fitted on the pendulum's angle and the wheel's speed (differentiated where the log holds the wheel's angle):
    # the wheel's angle enters no equation, and its error, the integral of the speed's, grows over a log; fitted on
    # it, model (9) predicted the README's held-out chirp at 77 % (q1) and 74 % (q4), on the speed at 88 % and 93 %
    outputs = JUDGED
    offset_given = rig_d is not None and rig_d.pendulum.offset is not None
    ratio = _drive_ratio(rig_d, options)
    wtrain = [d.window(*options.window) for d in train_logs]
    start = _start(wtrain, options)
    msgs.extend(start.notes)
    return FitPlan(options, rig_d, train_logs, val_logs, others, outputs, offset_given, ratio,
                   max(float(np.max(np.abs(d.input))) for d in wtrain), start, msgs, holds)


def _read_holds(train_logs, val_logs, others, input_hold: str):
    """Every log with its input's hold in its metadata (:func:`~iwp.ident.input_hold.with_input_hold`; a
    closed-loop log's input is the law's, not replayed), and the readings by source."""
    train_logs, tr = with_input_hold(train_logs, input_hold)
    val_logs, vr = with_input_hold(val_logs, input_hold)
    holds = {d.source: r for d, r in zip(train_logs + val_logs, tr + vr)}
    joined = []
    for o in others:
        if o.kind == "closed-loop":
            joined.append(o)
            continue
        (d,), (r,) = with_input_hold([o.data], input_hold)
        holds[d.source] = r
        joined.append(replace(o, data=d))
    return train_logs, val_logs, joined, holds


def _check_controller(controller: Input | None, others: list["JoinedLog"]) -> None:
    """A feedback law is given exactly when closed-loop logs are, and is an :mod:`iwp.sim.inputs` controller."""
    closed = any(o.kind == "closed-loop" for o in others)
    if closed and controller is None:
        raise InputError("controller: the closed-loop logs need their feedback law (--controller hopf --k1 K1 "
                         "--k2 K2)", argument="controller")
    if controller is not None and not closed:
        raise InputError("controller: a feedback law is the law of closed-loop logs, and none is given "
                         "(--closed-loop LOG...)", argument="controller")
    if controller is not None and not isinstance(controller, Input):
        raise InputError(f"controller must be an iwp.sim.inputs controller (e.g. HopfController), got "
                         f"{type(controller).__name__}", argument="controller")


def _check_held_out_distinct(train_logs, others, val_logs) -> None:
    """No log twice among the training logs, nor among the held-out ones, nor in both."""
    check_distinct([*train_logs, *(o.data for o in others)], "training logs")
    check_distinct(val_logs, "held-out logs")
    for v in val_logs:
        try:
            check_distinct([*train_logs, *(o.data for o in others), v])
        except InputError:
            raise InputError(f"validate: {v.source} is also a training log; a held-out log must be one the fit has "
                             "not seen, or its fit says nothing about prediction", argument="validate") from None


def _sort_by_kind(train_logs, others, rig_d, msgs: list[str]):
    """The free training logs and the logs of other set-ups: the rig description's ``experiments`` declare a
    log's set-up (the command line's kinds come first); an undeclared log whose motion shows another set-up joins
    as that set-up when a free log remains among the undeclared ones; a declared free log stays free."""
    declared = [rig_d.experiment_of(d.source) if rig_d is not None else None for d in train_logs]
    msgs.extend(f"{o.kind_flag} {o.data.source}: the rig description gives it as {e.kind}; fitted as {o.kind} (the "
                "command line's kind)" for o in others
                if rig_d is not None and (e := rig_d.experiment_of(o.data.source)) is not None and e.kind != o.kind)
    others = others + [JoinedLog(e.kind, d, _law(e.controller), "train") for d, e in zip(train_logs, declared)
                       if e is not None and e.kind != "free"]
    free = [(d, inferred_kind(d) if e is None else None) for d, e in zip(train_logs, declared)
            if e is None or e.kind == "free"]
    shown = [k for _, k in free if k is not None]
    if "free" in shown and any(k != "free" for k in shown):
        others = others + [JoinedLog(k, d) for d, k in free if k not in (None, "free")]
        msgs.extend(f"train {d.source}: {KIND_SHOWN[k]}: fitted as a {k} log (--{k})" for d, k in free
                    if k not in (None, "free"))
        free = [(d, k) for d, k in free if k in (None, "free")]
    if shown and "free" not in shown and not any(o.kind not in ("clamped", "wheel-locked") for o in others) \
            and all(k is not None for _, k in free):
        listing = ", ".join(f"{Path(d.source).name}: {KIND_SHOWN[k]}" for d, k in free)
        raise InputError(f"train: no training log shows a free pendulum ({listing}); the joint fit needs one, with "
                         "these beside it (--clamped, --wheel-locked); a clamped log alone identifies the drive: "
                         "iwp identify LOG --setup motor-disk; a wheel-locked swing the pendulum: --setup free",
                         argument="train")
    train_logs = [d for d, _ in free]
    if not train_logs:
        raise InputError("train: no free training log: the rig description's experiments give every training log "
                         "another set-up (" + ", ".join(f"{Path(o.data.source).name}: {o.kind}" for o in others)
                         + "); the joint fit needs a log of the free pendulum", argument="train")
    return train_logs, others


def _held_out_kind_notes(val_logs, rig_d) -> list[str]:
    """Held-out logs of another set-up than the free pendulum they are simulated as."""
    msgs = []
    for d in val_logs:
        e = rig_d.experiment_of(d.source) if rig_d is not None else None
        if e is not None and e.kind != "free":
            msgs.append(f"validate {d.source}: the rig description gives it as {e.kind}; a held-out log is simulated "
                        "as a free pendulum, so its fit says little")
        elif e is None and (k := inferred_kind(d)) != "free":
            msgs.append(f"validate {d.source}: {KIND_SHOWN[k]}: a log of the {k} set-up? a held-out log is simulated "
                        "as a free pendulum, so its fit says little")
    return msgs


def _drive_ratio(rig_d: RigDescription | None, options: LogFitOptions) -> float | None:
    """The belt drive's ratio where the rig has one whose wheel is measured at the wheel, else None; a clear error
    when a term that needs a belt drive is asked for and the rig has none (or measures at the motor)."""
    belt_drive = rig_d is not None and rig_d.drive.kind == "belt"
    # the belt's model compares the wheel's own signal: a sensor at the motor shaft reads q2 less the belt's stretch
    at_motor = belt_drive and rig_d.wheel is not None and rig_d.wheel.at == "motor"
    ratio = rig_d.drive.ratio if belt_drive and not at_motor else None
    for t in (TERMS[n] for n in options.terms if TERMS[n].drive == "belt"):
        if at_motor:
            raise InputError(f"{t.name}: {t.called} compares the wheel's own signal, but the rig description "
                             "measures it at the motor shaft (wheel.at 'motor'), which the belt's stretch separates "
                             "from the wheel", argument=t.name)
        if ratio is None:
            drive = "no rig description" if rig_d is None else f"a {rig_d.drive.kind} drive"
            raise InputError(f"{t.name}: {t.called} needs a rig description with \"drive\": {{\"kind\": "
                             f"\"belt\", \"ratio\": N}} (N motor turns per wheel turn); the logs have {drive}",
                             argument=t.name)
    return ratio


def _start(wtrain: list[ExperimentData], options: LogFitOptions) -> LeastSquaresStart:
    """The least-squares start on the windowed training logs, or the options' start."""
    if options.start is not None:
        return LeastSquaresStart(options.start, "given", {}, [])
    try:
        return least_squares_start(wtrain)
    except InputError as exc:
        if options.window == (None, None):
            raise
        given = ", ".join(f"{n}={v:g} s" for n, v in zip(("t_start", "t_end"), options.window) if v is not None)
        raise InputError(f"{exc} (the window {given} keeps "
                         + ", ".join(f"{d.n_samples} of {Path(d.source).name}" for d in wtrain) + ")",
                         argument=("t_start", "t_end")) from None


# --------------------------------------------------------------------------
# fit: one structure, or the ladder of them
# --------------------------------------------------------------------------
@dataclass
class Fitted:
    """The fit :func:`fit_plan` made.

    Attributes
    ----------
    options : LogFitOptions
        The structure fitted (the ladder's choice when it climbed one).
    result : RefineResult
        Its joint simulation-error fit.
    start : LumpedParameters
        Its start, the structure's terms started (:meth:`LogFitOptions.starting_values`).
    structures : LadderResult or None
        The ladder fitted and ranked, or None.
    held : tuple of str
        The pendulum's friction coefficients its logs did not identify, held at their prior
        (:func:`hold_unidentified`; in ``options.fixed``).
    """

    options: LogFitOptions
    result: RefineResult
    start: LumpedParameters
    structures: LadderResult | None = None
    held: tuple[str, ...] = ()


def fit_plan(plan: FitPlan) -> Fitted:
    """The joint simulation-error fit of the plan's structure, or of each structure of the ladder (``select``);
    then the pendulum's friction the logs do not identify held at its prior (:func:`hold_unidentified`)."""
    fitting = _Fitting(plan)
    options, start = plan.options, plan.start.params
    if options.select:
        structures = fitting.ladder(start)
        chosen = options.with_rung(structures.chosen.rung)
        fitted = Fitted(chosen, structures.chosen.result, chosen.starting_values(start, plan.umax), structures)
        return hold_unidentified(fitting, fitted)
    started = options.starting_values(start, plan.umax)
    if options.drive is None:
        return hold_unidentified(fitting, Fitted(options, fitting.joint(options, started), started))
    # a drive model starts from the fits of the rigid structures, as the ladder's rung does
    rigid = [replace(options, terms=s) for s in rigid_structures(options.terms)][:options.drive.starts]
    fits = thread_map(lambda o: fitting.joint(o, o.starting_values(started, plan.umax)), rigid)
    return hold_unidentified(fitting, Fitted(options, fitting.drive_fit(options, [f.params for f in fits]), started))


#: the pendulum's friction coefficients a fit holds at their prior when its logs do not identify them, and the
#: experiment that identifies them (as the least squares hold them, :data:`~iwp.ident.identification.HOLDABLE`)
HOLDABLE_FRICTION: dict[str, str] = {n: HOLDABLE[n] for n in ("sigma_a1", "sigma_v1", "sigma_b1")}


def friction_prior(name: str, params: LumpedParameters) -> float:
    """The scale of a pendulum friction coefficient a fit holds [its unit]: Table 1's share of the pendulum's
    damping ``sigma_a1 + sigma_v1`` times this fit's damping, or where the fit sees none :func:`rig_prior`. The
    paper's rig sets the proportions, not the size: a rig whose damping is four times Table 1's has friction
    coefficients four times as large (``iwp fit --fix`` gives a rig's own value)."""
    t1 = table1()
    damping = _damping(params)
    share = float(getattr(t1, name)) / float(t1.sigma_a1 + t1.sigma_v1)
    return share * damping if damping > 0 else rig_prior(name, params)


def held_prior_spreads(held: Mapping[str, float], params: LumpedParameters) -> dict[str, float]:
    """The standard deviation about its held value of each friction coefficient a fit holds [its unit]:
    :data:`PRIOR_SPREAD` of :func:`friction_prior` (a held value is a guess; the held-out bands and the stored
    covariance carry it)."""
    return {n: PRIOR_SPREAD * friction_prior(n, params) for n in held}


#: an undetermined friction coefficient is held only when the fit drove it to its bound 0 (below this share of its
#: typical value): one left inside with a huge interval (the Stribeck fit's sigma_v1) is kept, for its refit from a
#: prior that is not the rig's sent sigma_c2 16 % low and v_s2 to 3e7
AT_BOUND = 1e-3

#: a hold is kept only if the refit's cost stays within this share of the free fit's: holding what the logs say
#: nothing of barely moves the cost; a refit that ends higher (seen: a Stribeck fit whose refit from sigma_v1 held
#: went to v_s2 = 3e7 and sigma_c2 16 % low) says the parameter mattered, and the free fit is kept
HOLD_SLACK = 0.01


def hold_unidentified(fitting: "_Fitting", fitted: Fitted) -> Fitted:
    """The fit with the pendulum's friction coefficients its logs do not identify held where the fit put them.

    The coefficient of :data:`HOLDABLE_FRICTION` the estimate says least of, driven to its bound 0
    (:func:`~iwp.sim.uncertainty.undetermined` and below :data:`AT_BOUND` of its typical value: ``1e-18 +- 230``
    where two of them cannot be told apart; the largest interval relative to its value first) is held at 0, the
    bound the fit drove it to, and the others' covariance taken again without it (a solve from the optimum: one
    or two evaluations), one at a time until what is left is determined: of a pair the logs cannot tell apart one
    is held and the other carries their sum. It used to be held at Table 1's value and the structure fitted again:
    on a rig whose damping is not Table 1's that moved the optimum (sigma_v1 held at 0.01 where the rig's is 0.05:
    rho and sigma_a1 then 8 and 877 standard errors off, the ladder study of issue 50) and cost a second fit. The
    held value's spread (:func:`held_prior_spreads`, scaled to this rig's damping) goes into the bands. A solve
    whose cost ends more than :data:`HOLD_SLACK` above the free fit's is not kept. The held ones are listed in
    ``fitted.held``. One whose interval merely reaches 0 keeps its estimate.
    """
    held: dict[str, float] = {}
    while True:
        r = fitted.result
        names = [n for n in HOLDABLE_FRICTION if n in r.free and n in r.parameters
                 and undetermined(n, r.parameters[n].value, r.parameters[n].stderr)
                 and r.parameters[n].value <= AT_BOUND * PARAMETER_INFO[n].typical]
        if not names:
            break

        def spread(n: str) -> float:  # the interval's width over the value (inf: NaN or at the bound)
            p = r.parameters[n]
            return p.stderr / p.value if p.value > 0 and math.isfinite(p.stderr) else math.inf

        if _damping(r.params) > 0.0:
            # the fit sees the pendulum's damping: the one it says least of held at 0, where it drove it, the others
            # carrying the damping (the same optimum: the others' covariance taken again without it)
            now = {max(names, key=spread): 0.0}
        else:
            # no damping seen at all (a short chirp's swing): the paper's damping ratio on this rig's frequency
            now = {n: rig_prior(n, r.params) for n in names}
        before = dict(held)
        held.update(now)
        options = replace(fitted.options, fixed={**fitted.options.fixed, **now})
        start = r.params.replace(**now)
        result = fitting.joint(options, start, x0=[x[:4] for x in r.x0], belt=r.belt if options.drive else None)
        if not result.cost <= r.cost * (1.0 + HOLD_SLACK):  # the data did say something, or the refit went astray
            held = before
            break
        fitted = replace(fitted, options=options, result=result, held=tuple(held))
    return fitted


def _damping(params: LumpedParameters) -> float:
    """The pendulum's damping of a fit, ``sigma_a1 + sigma_v1`` [1/s], 0 below :data:`AT_BOUND` of its typical."""
    d = float(params.sigma_a1 + params.sigma_v1)
    return d if d > AT_BOUND * PARAMETER_INFO["sigma_v1"].typical else 0.0


def rig_prior(name: str, params: LumpedParameters) -> float:
    """Table 1's value of a pendulum friction coefficient on a rig of frequency ``sqrt(p1)`` [its unit]: the paper's
    rig's damping ratio, ``sigma / sqrt(p1)`` (``sigma_b1 / sqrt(p1)`` per rad^2), kept (a rig five times stiffer
    than the paper's damps its faster swing with sqrt(5) times the coefficient, not with the paper's)."""
    t1 = table1()
    return float(getattr(t1, name)) * math.sqrt(max(float(params.p1), 0.0) / float(t1.p1))


def rigid_structures(on: frozenset[str]) -> list[frozenset[str]]:
    """The rigid structures a fit with a drive model (the belt) in ``on`` starts from, richest first: ``on`` less
    the drive's term, then less also the term of the rung the drive's rung extends, if on."""
    drive = [n for n in on if TERMS[n].replacement is not None]
    rigid = on - set(drive)
    out = [rigid]
    for n in drive:
        below = next((t.name for t in TERMS.values() if t.rung.name == TERMS[n].rung.extends), None)
        if below in rigid:
            out.append(rigid - {below})
    return out


# --------------------------------------------------------------------------
# report: the fits per log, the held-out logs predicted
# --------------------------------------------------------------------------
def report_fit(plan: FitPlan, fitted: Fitted, *, elapsed: float = 0.0) -> LogFitResult:
    """The training fits per log and the held-out logs simulated from their measured state, with every warning."""
    options, r = fitted.options, fitted.result
    model = options.model
    msgs = list(plan.messages) + list(r.warnings)
    train_logs = [model_input(d, model, "train") for d in plan.train]
    val_logs = [model_input(d, model, "validate") for d in plan.held_out]
    offs = [r.offsets[i].get("q1", (0.0, 0.0))[0] for i in range(len(train_logs))]
    train_fits = [_log_fit(d, "train", _Replayed.of(r, i), offs[i]) for i, d in enumerate(train_logs)]
    for j, o in enumerate(plan.others, start=len(train_logs)):
        train_fits.append(_log_fit(o.data, "train", _Replayed.of(r, j), r.offsets[j].get("q1", (0.0, 0.0))[0],
                                   kind=o.kind))
    zero = EncoderZero.of(offs, plan.offset_given)
    val_off = zero.value
    if val_logs and not plan.offset_given:
        msgs.append(f"held-out logs: the pendulum zero offset is taken as the training logs' mean, "
                    f"{val_off:+.4g} rad (offsets of the training logs: "
                    + ", ".join(f"{o:+.4g}" for o in offs) + ")")
    priors = held_prior_spreads(fitted.held, r.params)
    uncertainty = (ParameterUncertainty.from_refinement(r).with_priors(priors)
                   if r.belt is None and np.all(np.isfinite(r.covariance)) else None)
    if val_logs and r.belt is not None:
        msgs.append("held-out logs: no prediction band for the belt model (15): the bands draw lumped parameters "
                    "and simulate them in the batch engine, which has no belt")
    elif val_logs and uncertainty is None:
        msgs.append("held-out logs: no prediction band, for the fit did not determine every free parameter")
    plant = _Fitting(plan).plant(options, r.params, r.belt)
    val_fits = [_held_out(d, plant, predicted_signals(d), zero, msgs, uncertainty) for d in val_logs]
    msgs.extend(_band_misses(val_fits, r))
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
                        warnings=_unique(msgs), rig=plan.rig, elapsed=elapsed, structures=fitted.structures,
                        held_out_zero=zero, held_priors=priors, input_holds=dict(plan.holds))


#: the kinds of log that join ``iwp fit``'s training besides the free ones (``--clamped``, ``--wheel-locked``,
#: ``--closed-loop``)
OTHER_KINDS = ("clamped", "wheel-locked", "closed-loop")


@dataclass(frozen=True)
class JoinedLog:
    """A log of another set-up that joins the training: its kind, the log, the law of a closed-loop one, and where
    its kind came from (``"train"``: the rig description; else the command line's ``--kind``)."""

    kind: str
    data: ExperimentData
    controller: Input | None = None
    given: str = ""

    @property
    def kind_flag(self) -> str:
        """How the user gave the log: ``--clamped`` etc., or ``train``."""
        return self.given or f"--{self.kind}"


def _law(spec: ControllerSpec | None) -> Input | None:
    """The controller of a rig description's closed-loop entry (its ``controller``), or None."""
    if spec is None:
        return None
    if spec.law != "hopf":
        raise InputError(f"controller: the law {spec.law!r} has no simulation in iwp (hopf has)",
                         argument="controller")
    return HopfController(spec.k1, spec.k2, spec.ts)


def _other_kinds(kinds: Mapping[str, Any] | None, rig: RigDescription | None, controller: Input | None = None
                 ) -> list[JoinedLog]:
    """The logs of ``kinds``, read; the ``closed-loop`` ones with ``controller``."""
    if not kinds:
        return []
    if not isinstance(kinds, Mapping):
        raise InputError(f"kinds must map a kind to logs, e.g. {{'clamped': ['c.csv']}}, got {type(kinds).__name__}",
                         argument="kinds")
    out = []
    for kind, items in kinds.items():
        if kind not in OTHER_KINDS:
            what = "; ".join(f"{k}: {EXPERIMENT_KINDS[k]}" for k in OTHER_KINDS)
            raise InputError(f"kinds: {kind!r} is not a kind of log that joins the fit; choose among "
                             f"{', '.join(OTHER_KINDS)} ({what})", argument="kinds")
        out += [JoinedLog(kind, d, controller if kind == "closed-loop" else None)
                for d in load_logs(items, rig, argument=f"--{kind}")]
    return out


#: a free training log whose pendulum angle spans less than this [rad] while the wheel turns looks clamped ...
STILL_PENDULUM = 0.01
#: ... and a log given as clamped whose angle spans more than this [rad] is not
MOVING_PENDULUM = 0.1
#: the wheel turns: its angle spans more than this [rad], or its speed more than this [rad/s]
TURNING_WHEEL = 1.0


def _span(y) -> float:
    """The range of signal ``y`` (0 without it)."""
    return float(np.ptp(y)) if y is not None and np.size(y) else 0.0


#: the window of the running mean whose range measures whether the pendulum moves [s] (the virtual rig's
#: 0.002 rad of white noise spans about 0.012 rad over 400 samples, their 0.5 s means about 0.004)
STILL_WINDOW = 0.5


def _moved(d: ExperimentData) -> float:
    """The range of log ``d``'s pendulum angle's running mean over :data:`STILL_WINDOW` [rad]."""
    n = max(1, min(d.q1.size, int(round(STILL_WINDOW / float(d.Ts)))))
    return _span(np.convolve(d.q1, np.full(n, 1.0 / n), mode="valid"))


def inferred_kind(d: ExperimentData) -> str:
    """The set-up log ``d``'s motion shows (:data:`~iwp.ident.output_error.EXPERIMENT_KINDS`).

    ``"clamped"``: its pendulum angle spans less than :data:`STILL_PENDULUM`
    while its wheel turns (:data:`TURNING_WHEEL`): a free pendulum would move
    with the wheel's reaction. ``"wheel-locked"``: its wheel does not turn
    while its pendulum angle spans more than :data:`MOVING_PENDULUM`: a free
    wheel would turn against a swinging arm. ``"free"`` otherwise. The angle's span is that of its running mean
    over :data:`STILL_WINDOW` (the encoder's noise is not motion).

    Parameters
    ----------
    d : ExperimentData
        A log, in rad and rad/s.

    Returns
    -------
    str
    """
    turning = _span(d.q2) > TURNING_WHEEL or _span(d.q4) > TURNING_WHEEL
    moved = _moved(d)
    if turning and moved < STILL_PENDULUM:
        return "clamped"
    if not turning and moved > MOVING_PENDULUM:
        return "wheel-locked"
    return "free"


#: what a training log's motion shows, by the kind :func:`inferred_kind` gives it
KIND_SHOWN = {"clamped": "its pendulum angle does not move while its wheel turns",
              "wheel-locked": "its wheel does not turn while its pendulum swings"}


def kind_mismatches(train: Sequence[ExperimentData], others: Sequence[tuple[str, ExperimentData]]) -> list[str]:
    """Warnings for logs whose motion contradicts their kind, or none.

    A free training log whose motion shows another set-up
    (:func:`inferred_kind`) is left free only when no training log is free
    (:func:`fit_logs` otherwise fits it as that set-up); it is named: a
    clamped pendulum's angle tells the fit nothing about the gravity term,
    and a locked wheel's nothing about the disk. A log given as clamped whose
    angle spans more than :data:`MOVING_PENDULUM` is not clamped (the fit,
    which compares only its wheel, would take a moving pendulum for a fixed
    one); a log given as wheel-locked whose wheel turns
    (:data:`TURNING_WHEEL`) is not locked.

    Parameters
    ----------
    train : sequence of ExperimentData
        The free training logs.
    others : sequence of (str, ExperimentData)
        The logs of other kinds, with their kind (``"clamped"``, ``"wheel-locked"``).

    Returns
    -------
    list of str
    """
    msgs = []
    for d in train:
        kind = inferred_kind(d)
        if kind != "free":
            msgs.append(f"train {d.source}: {KIND_SHOWN[kind]} (its angle's {STILL_WINDOW:g} s means span "
                        f"{_moved(d):.3g} rad): a log "
                        f"of the {kind} set-up? give it with --{kind} (kinds={{'{kind}': [...]}}) beside a free "
                        "log, or the fit takes it as a free pendulum")
    for kind, d in others:
        if kind == "clamped" and _span(d.q1) > MOVING_PENDULUM:
            msgs.append(f"--clamped {d.source}: the pendulum angle spans {_span(d.q1):.3g} rad, so the pendulum was "
                        "not clamped; the fit compares only its wheel as if it were: give a free log as a training "
                        "log")
        if kind == "wheel-locked" and (_span(d.q2) > TURNING_WHEEL or _span(d.q4) > TURNING_WHEEL):
            msgs.append(f"--wheel-locked {d.source}: the wheel turns (angle span {_span(d.q2):.3g} rad, speed span "
                        f"{_span(d.q4):.3g} rad/s), so it was not locked to the arm; the fit compares only the "
                        "pendulum's angle as if it were: give a free log as a training log")
    return msgs


#: logs whose gravity terms differ by more than this factor (and beyond their spread) cannot share one model
P1_RATIO = 1.2


def disagreeing_logs(logs: Sequence[ExperimentData], *, window=(None, None)) -> list[str]:
    """A warning naming logs that no single parameter set explains, or none.

    Each log's gravity term ``p1`` (:func:`least_squares_start` on it alone)
    with a spread from its two halves, ``|p1(first) - p1(second)| / 2``. Two
    logs disagree when their ``p1`` differ by more than three combined spreads
    and by more than the factor :data:`P1_RATIO` (a moved counterweight, a
    different pendulum): a joint fit of them fits neither.
    """
    if len(logs) < 2:
        return []
    est = []
    for d in logs:
        w = d.window(*window)
        try:
            with _warnings.catch_warnings():
                _warnings.simplefilter("ignore")
                p1 = least_squares_start([w]).params.p1
                h = w.n_samples // 2
                halves = [least_squares_start([w.window(*span)]).params.p1
                          for span in ((None, float(w.t[h])), (float(w.t[h]), None))]
        except InputError:
            return []  # too short to judge
        est.append((d.source, p1, abs(halves[0] - halves[1]) / 2.0))
    lo = min(est, key=lambda e: e[1])
    hi = max(est, key=lambda e: e[1])
    if not (lo[1] > 0 and hi[1] / lo[1] > P1_RATIO and hi[1] - lo[1] > 3.0 * math.hypot(lo[2], hi[2])):
        return []
    listing = ", ".join(f"{Path(src).name} {p1:.4g} +- {sd:.2g}" for src, p1, sd in est)
    return [f"the training logs disagree on the gravity term p1 [1/s^2] (each log alone: {listing}): no single "
            "parameter set explains them (a moved counterweight, another pendulum?); fit them separately"]


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


#: The budget of each fit of the ladder (the optimiser's evaluations of the residuals). Its 54 fits on the virtual
#: rigs of ``benchmarks/ladder_study.py`` (three truths, three seeds) took 5 to 62; one that crept along a valley
#: (the widths freed where the Coulomb term they shape had dropped to 0) took 2,500 and 290 s. A fit stopped by
#: the budget has not converged and is not chosen.
LADDER_MAX_NFEV = 200
#: A structure holds the one it extends (its new terms at 0), so its fit ends at or below that one's cost; one that
#: ends above it by more than this share stopped short, and is fitted again from next to that optimum (its new
#: terms started at :data:`NESTED_RESTART` of their usual starts), then from each simpler structure's optimum,
#: until one ends at or below it; else it is marked not converged. Seen: a fit started where a swing's initial
#: state was far off stopped after 3 evaluations at 55 times the simpler structure's cost; the dead zone's fit,
#: started from widths driven to their floor (1e-3 rad/s) to mimic it, stopped at its start on a clamped log.
NESTED_SLACK = 1e-3
#: the share of their usual starts the new terms of a fit started again next to the simpler optimum take
NESTED_RESTART = 1e-3
class _Fitting:
    """The joint fits of one call of :func:`fit_logs`: one structure, or the ladder of them ranked on held-out data."""

    def __init__(self, plan: FitPlan):
        self.options, self.train, self.held_out = plan.options, plan.train, plan.held_out
        self.outputs, self.offset_given, self.umax = plan.outputs, plan.offset_given, plan.umax
        self.others = plan.others  # the logs of the other set-ups, with the closed-loop ones' laws
        self.drive_ratio = plan.drive_ratio  # the rig's drive ratio when its drive is a belt, else None
        self.Ts = plan.Ts  # the logs' sample period, for a drive model's start and bounds

    def plant(self, options: LogFitOptions, params: LumpedParameters, belt: BeltParameters | None = None) -> Plant:
        """The plant of ``options``' structure with ``params`` (and ``belt``; without it a structure with a drive
        model starts from the drive's start, :attr:`iwp.models.terms.DriveModel.start`)."""
        drive = options.drive
        if drive is None:
            return Plant(params, model=options.model)
        if belt is None:
            belt = drive.start(params, ratio=self.drive_ratio, Ts=self.Ts)
        return Plant(params, model=options.model, belt=belt)

    def joint(self, options: LogFitOptions, start: LumpedParameters, logs=None, x0=None,
              belt: BeltParameters | None = None, max_nfev: int | None = None) -> RefineResult:
        """The joint simulation-error fit of ``options``' structure on ``logs`` (default: the training logs) and
        the logs of the other set-ups; ``x0``: initial-state guesses per experiment (a simpler structure's);
        ``belt``: the drive model's start; ``max_nfev``: the optimiser's budget (default
        :class:`~iwp.ident.problem.SolverOptions`')."""
        model = options.model
        logs = [model_input(d, model, "train") for d in (self.train if logs is None else logs)]
        guesses = list(x0) if x0 is not None else [None] * (len(logs) + len(self.others))
        exps = as_experiments(logs, windows=tuple(options.window), offsets=() if self.offset_given else ("q1",),
                              x0=guesses[:len(logs)])
        for o, g in zip(self.others, guesses[len(logs):]):
            moves_q1 = o.kind != "clamped"
            exps.append(Experiment(model_input(o.data, model, o.kind_flag), kind=o.kind, window=tuple(options.window),
                                   x0=g, offsets=("q1",) if moves_q1 and not self.offset_given else (),
                                   controller=o.controller))
        plant = self.plant(options, start, belt)
        drive = options.drive
        bounds = (drive.bounds(ratio=plant.belt.N, Ts=self.Ts, speed_per_input=plant.belt.kTbeta_over_Rgamma)
                  if drive is not None else None)
        solver = (SolverOptions(rtol=drive.rtol, atol=drive.rtol, scaling="start") if drive is not None
                  else SolverOptions())
        return refine(exps, plant, free=options.free(), outputs=self.outputs, bounds=bounds, loss=options.loss,
                      options=replace(solver, max_nfev=max_nfev), warn=False)

    def drive_starts(self, options: LogFitOptions, rigid: Sequence[LumpedParameters]) -> list[LumpedParameters]:
        """The starts of ``options``' structure with a drive model: from each of the first
        :attr:`~iwp.models.terms.DriveModel.starts` rigid fits ``rigid`` (richest first)."""
        return [options.starting_values(p, self.umax) for p in rigid[:options.drive.starts]]

    def drive_fit(self, options: LogFitOptions, rigid: Sequence[LumpedParameters]) -> RefineResult:
        """The fit of ``options``' structure with a drive model from each of :meth:`drive_starts`, side by side;
        the one with the lowest cost."""
        return lowest_cost(thread_map(lambda s: self.joint(options, s), self.drive_starts(options, rigid)))

    def score(self, r: RefineResult, options: LogFitOptions, logs: list[ExperimentData]) -> list[LogFit]:
        """``logs`` simulated from their measured state with the fit ``r`` (the training logs' mean offset)."""
        model = options.model
        offs = [o.get("q1", (0.0, 0.0))[0] for o in r.offsets[:len(r.offsets) - len(self.others)]]
        zero = EncoderZero.of(offs, self.offset_given)
        plant = self.plant(options, r.params, r.belt)
        return thread_map(lambda d: _held_out(model_input(d, model, "validate"), plant, JUDGED, zero, [],
                                              None), logs)

    def ladder(self, start: LumpedParameters) -> LadderResult:
        """Each structure of the ladder fitted (from the fit of the one it extends) and scored.

        A structure starts once every structure it extends is fitted; structures that do not extend each
        other (the offset, the dead zone and the belt, all on the widths) are fitted side by side, as are a
        drive model's starts (:attr:`~iwp.models.terms.DriveModel.starts`) and the cross-validation folds
        (:func:`iwp.threads.thread_map`).
        """
        raw = all(d.input_name == "v" for d in self.train + self.held_out)
        # fewer held-out logs than the signed-rank test needs: the training logs each predicted by a fit on the
        # others join them (a consistent gain then shows over more logs)
        folds = len(self.train) >= 2 and len(self.held_out) < SIGNED_RANK_MIN
        rungs = ladder(raw, belt_drive=self.drive_ratio is not None, extra=self.options.try_terms)
        done: dict[str, RungOutcome] = {}
        held: dict[str, list[LogFit]] = {}  # each structure's held-out logs' fits
        # entered once for the whole ladder: the fits side by side (thread_map enters it too) and the work between
        # the waves on one BLAS thread, the limit not set and restored at every wave
        with one_blas_thread():
            while len(done) < len(rungs):
                wave = [rg for rg in rungs if rg.name not in done
                        and all(o.name in done for o in rungs if o.terms < rg.terms)]
                extended = {rg.name: [done[o.name] for o in rungs if o.terms < rg.terms] for rg in wave}
                # the tasks: a drive model's fit from each of its starts (first: they are the slowest fits), then
                # each other structure fitted and scored
                tasks = [(rg, s) for rg in wave if drive_of(rg.terms) is not None
                         for s in self.drive_starts(self.options.with_rung(rg),
                                                    [o.result.params for o in _parents(extended[rg.name])] or [start])]
                tasks += [(rg, None) for rg in wave if drive_of(rg.terms) is None]

                def run(task: tuple[Rung, LumpedParameters | None]) -> RefineResult | tuple[RungOutcome, list]:
                    rg, s = task
                    if s is None:
                        return self._rung(rg, extended[rg.name], start)
                    return self.joint(self.options.with_rung(rg), s, max_nfev=LADDER_MAX_NFEV)

                ran = thread_map(run, tasks)
                for rg in wave:
                    if drive_of(rg.terms) is not None:
                        fit = lowest_cost([r for (t, s), r in zip(tasks, ran) if t is rg and s is not None])
                        done[rg.name], held[rg.name] = self._rung(rg, extended[rg.name], start, fit=fit)
                    else:
                        done[rg.name], held[rg.name] = next(r for (t, s), r in zip(tasks, ran) if t is rg)
            outcomes = [done[rg.name] for rg in rungs]
            if folds:
                outcomes = self._with_folds(outcomes, [held[rg.name] for rg in rungs])
        scored_on = " and ".join(([HELD_OUT_LOGS] if self.held_out else []) + ([CROSS_VALIDATION] if folds else [])) \
            or "training fit"
        n = len(self.held_out) + (len(self.train) if folds else 0)
        return LadderResult(outcomes, select(outcomes), scored_on, n)

    def _with_folds(self, outcomes: list[RungOutcome], held: list[list[LogFit]]) -> list[RungOutcome]:
        """``outcomes`` scored also on each training log predicted by a refit on the others (from the joint fit;
        the folds of all structures side by side); ``held``: each one's held-out logs' fits. A structure
        :func:`~iwp.ident.structure.select` cannot take (:attr:`~iwp.ident.structure.RungOutcome.takeable`)
        gets no folds, and NaN for them, unless no structure can be taken."""
        takeable = [o.takeable for o in outcomes]
        if not any(takeable):
            takeable = [True] * len(outcomes)
        tasks = [(i, k) for i in range(len(outcomes)) if takeable[i] for k in range(len(self.train))]

        def fold(task: tuple[int, int]) -> LogFit:
            i, k = task
            opts, r = self.options.with_rung(outcomes[i].rung), outcomes[i].result
            rest = self.train[:k] + self.train[k + 1:]
            x0 = [x[:4] for j, x in enumerate(r.x0) if j != k]
            refit = self.joint(opts, r.params, rest, x0=x0, belt=r.belt, max_nfev=LADDER_MAX_NFEV)
            return self.score(refit, opts, [self.train[k].window(*opts.window)])[0]

        fits = thread_map(fold, tasks)
        out = []
        for i, o in enumerate(outcomes):
            if not takeable[i]:
                out.append(replace(o, scores=np.concatenate([o.scores, np.full(len(self.train), np.nan)])))
                continue
            scored = held[i] + [f for (j, _), f in zip(tasks, fits) if j == i]
            out.append(replace(o, scores=_scores(scored), fit=_mean_fit([f.fit for f in scored], JUDGED)))
        return out

    def _rung(self, rg: Rung, extended: list[RungOutcome], start: LumpedParameters,
              fit: RefineResult | None = None) -> tuple[RungOutcome, list[LogFit]]:
        """One structure fitted, from the fit of the richest converged structure it extends, and scored on the
        held-out logs (and their fits); ``fit``: its fit made beforehand (the belt's, from its starts side by side
        with the other structures)."""
        parents = _parents(extended)
        parent = parents[0].result if parents else None
        opts = self.options.with_rung(rg)
        # the parameters of the structure this one extends; the initial states from the data again (a
        # simpler structure's took more iterations to undo: 115 evaluations over the ladder against 87)
        base = parent.params if parent else start
        first = opts.starting_values(base, self.umax)
        r = fit if fit is not None else self.joint(opts, first, max_nfev=LADDER_MAX_NFEV)
        # the most this structure's fit may cost: that of the structure it extends (a drive model holds it only in a
        # limit)
        nested = parent is not None and drive_of(rg.terms) is None
        bound = parent.cost * (1.0 + NESTED_SLACK) if nested else math.inf
        if nested and not r.cost <= bound:
            # next to that optimum, then from each simpler structure's (a width the richest one drove to its
            # floor to mimic a missing dead zone made the dead zone's fit stall there, at its start)
            starts = [opts.starting_values(base, self.umax, fraction=NESTED_RESTART)]
            starts += [opts.starting_values(o.result.params, self.umax) for o in parents[1:]]
            for s in starts:
                if s == first:
                    continue
                again = self.joint(opts, s, max_nfev=LADDER_MAX_NFEV)
                if again.cost < r.cost:
                    r = again
                if r.cost <= bound:
                    break
            else:
                r = replace(r, success=False, message=f"{r.message}; not a minimum: its cost {r.cost:.6g} is above "
                                                      f"that of the structure it extends, {parent.cost:.6g}")
        if parent is not None and fit is None and _at_bound(r):
            # a pendulum friction the fit drove to its bound from the simpler structure's values: the pair
            # sigma_a1, sigma_v1 trades one for the other, and a start where one is 0 may end in the minimum where it
            # stays 0; the least-squares start too, the lower cost kept (the ladder study's wheel Coulomb rung: cost
            # 0.01968 from (9)'s fit with sigma_v1 0, rho 9.7 standard errors off; 0.01932 from the least squares)
            fresh = self.joint(opts, opts.starting_values(start, self.umax), max_nfev=LADDER_MAX_NFEV)
            if fresh.cost < r.cost and (not nested or fresh.cost <= bound):
                r = fresh
        scored = self.score(r, opts, self.held_out) if self.held_out else []
        fr = r.fit_result
        aic, bic = information_criteria(fr.cost, fr.dof + len(fr.free), len(fr.free))
        fit = _mean_fit([f.fit for f in scored], JUDGED)
        return RungOutcome(rg, len(r.free), _scores(scored), fit, _mean_fit(r.fit, self.outputs), aic, bic,
                           bool(r.success), r.message, r, unidentified=_unidentified_added(r, rg, extended),
                           held_out_fit=fit if scored else {}), scored


def _at_bound(r: RefineResult) -> bool:
    """A pendulum friction coefficient of the fit at its bound 0 (below :data:`AT_BOUND` of its typical value)."""
    return any(n in r.free and r.parameters[n].value <= AT_BOUND * PARAMETER_INFO[n].typical
               for n in HOLDABLE_FRICTION)


def _scores(scored: Sequence[LogFit]) -> np.ndarray:
    """Per scoring log, the mean over the judged signals of ``1 - fit/100`` (:attr:`RungOutcome.scores`)."""
    return np.array([float(np.mean([1.0 - f.fit[o] / 100.0 for o in JUDGED])) for f in scored])


def _unidentified_added(r: RefineResult, rg: Rung, extended: Sequence[RungOutcome]) -> tuple[str, ...]:
    """The parameters rung ``rg`` frees beyond the richest structure it extends that its fit ``r`` says nothing of
    (:func:`~iwp.sim.uncertainty.undetermined`: at their bound, or an interval a hundred times wider than the
    value); none for the ladder's first rung."""
    if not extended:
        return ()
    below = max(extended, key=lambda o: len(o.rung.terms)).rung.terms
    added = [n for n in free_parameters(rg.terms) if n not in free_parameters(below) and n in r.parameters]
    return tuple(n for n in added if undetermined(n, r.parameters[n].value, r.parameters[n].stderr))


def _parents(extended: Sequence[RungOutcome]) -> list[RungOutcome]:
    """The converged structures of ``extended``, richest first."""
    return sorted((o for o in extended if o.success), key=lambda o: len(o.rung.terms), reverse=True)


def lowest_cost(fits: Sequence[RefineResult]) -> RefineResult:
    """The fit of ``fits`` with the lowest cost (a non-finite cost counts as infinite; the first of equals)."""
    return min(fits, key=lambda f: f.cost if math.isfinite(f.cost) else math.inf)


def _held_out(d: ExperimentData, plant: Plant, outputs: tuple[str, ...], zero: EncoderZero, msgs: list[str],
              uncertainty: ParameterUncertainty | None) -> LogFit:
    """A held-out log simulated from its measured initial state (its angle less ``zero``'s value), not fitted;
    with the fit's uncertainty, the share of its samples inside the 95 % prediction band (the initial state's
    uncertainty and its own zero's in it)."""
    offset = zero.value
    dc = replace(d, q1=d.q1 - offset) if offset else d
    start = start_state(dc, plant)
    x0 = start.x0
    model = OutputError(plant, [Experiment(dc, x0=x0, estimate_x0=False)], outputs, fitting=False)
    ev = model.evaluate(model.parameters().values())
    p = model.prepared[0]
    simulated = model.predictions(ev)[0]
    fit = _log_fit(d, "validate", _Replayed(p.t, dict(p.y), simulated, dict(p.w), model.states(ev.values)[0]),
                   offset)
    if uncertainty is not None and not p.mean:
        zero_variance = 0.0 if plant.pendulum_locked else zero.variance(angle_quantum(dc.q1))  # as validate's
        band = band_as_measured(prediction_band(plant, uncertainty, input=p.input, x0=x0, t_eval=p.t,
                                                signals=outputs, start=StartUncertainty(
                                                    start.covariance, zero_variance)),
                                p.derived, simulated)
        fit.coverage = band.coverage(p.y, {o: p.w[o] > 0 for o in outputs})
    if ev.status[0] != 0 or not all(math.isfinite(x) for x in fit.fit.values()):
        msgs.append(f"{d.source}: the validation simulation failed or diverged")
    return fit


def _band_misses(val_fits: Sequence[LogFit], r: RefineResult) -> list[str]:
    """A warning for each held-out log outside its 95 % prediction band (:attr:`LogFit.band_misses`): the band
    carries the parameters', the start's and the residuals' uncertainty, and does not hold when the model misses
    what the log shows."""
    out = []
    for f in val_fits:
        if not f.band_misses:
            continue
        inside = " and ".join(f"{100 * f.coverage[o]:.0f} % of {o}'s" for o in f.band_misses)
        rel = r.reliability
        why = ("; the training experiments disagree beyond their noise (model-structure error)" if rel is not None
               and rel.structure_error else "; one training experiment cannot check the model's structure"
               if rel is not None and rel.experiments < 2 else "")
        out.append(f"{f.source}: only {inside} samples lie inside the 95 % prediction band (below "
                   f"{100 * BAND_HOLDS:.0f} %): the band does not hold on this log. It carries the uncertainty of the "
                   "parameters, the start and the residuals, not what the model misses: the model misses what this "
                   f"log shows, or its parameters lie beyond their 95 % intervals{why}; try richer structures (iwp "
                   "fit without --structure) and more training logs")
    return out


def _unique(msgs: list[str]) -> list[str]:
    seen, out = set(), []
    for m in msgs:
        if m not in seen:
            seen.add(m)
            out.append(m)
    return out


class _Replayed(NamedTuple):
    """One log replayed by the model: its times [s], measured and simulated outputs, their weights (0: held
    still) and the initial state."""

    t: np.ndarray
    measured: dict
    simulated: dict
    weights: dict
    x0: np.ndarray

    @classmethod
    def of(cls, r: RefineResult, i: int) -> "_Replayed":
        """Experiment ``i`` of a joint fit."""
        return cls(r.times[i], r.measured[i], r.simulated[i], r.weights[i], r.x0[i])


def _log_fit(d: ExperimentData, role: str, run: _Replayed, off: float, kind: str = "free") -> LogFit:
    fit, rms, mx, used = {}, {}, {}, {}
    for o, y in run.measured.items():
        m = run.weights[o] > 0
        if not m.any():  # a signal this set-up holds still (the clamped pendulum's angle)
            continue
        used[o] = m
        fit[o] = fit_percent(y[m], run.simulated[o][m])
        e = (y - run.simulated[o])[m]
        rms[o] = float(np.sqrt(np.mean(e ** 2)))
        mx[o] = float(np.max(np.abs(e)))
    return LogFit(d.source, role, fit, rms, mx, np.asarray(run.t), {o: run.measured[o] for o in used},
                  {o: run.simulated[o] for o in used}, used, np.asarray(run.x0, dtype=float), float(off),
                  [g.describe() for g in d.glitches], kind=kind)

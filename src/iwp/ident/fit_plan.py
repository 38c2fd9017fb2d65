"""The plan of ``iwp fit``: the logs read, sorted by set-up and checked, and the options of the fit.

:func:`plan_fit` is the first step of :func:`iwp.ident.logfit.fit_logs`:
it reads the training and held-out logs (:func:`load_logs`, with a rig
description or as iwp logs), joins the logs of other set-ups (clamped,
wheel-locked, closed-loop: :class:`JoinedLog`), the rig description's and
the command line's (:func:`inferred_kind` for a log no one declared),
reads how each log's input was held (:mod:`iwp.ident.input_hold`), refuses
what cannot be fitted (a log that contradicts its kind:
:func:`kind_mismatches`; no log that drives the wheel; no free pendulum)
and names logs that no single parameter set explains
(:func:`disagreeing_logs`), then takes the least-squares start
(:mod:`iwp.ident.fit_start`). :class:`LogFitOptions` are the fit's options.
The fit itself is :mod:`iwp.ident.fit_ladder`; its report
:mod:`iwp.ident.fit_report`.
"""

from __future__ import annotations

import math
import os
import warnings as _warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..data import ExperimentData, check_distinct, read_experiment
from ..data.rig_description import ControllerSpec, RigDescription, load_rig
from ..data.rig_log import read_rig_log
from ..errors import InputError
from ..models.parameters import PARAMETER_INFO, LumpedParameters
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
from .fit_start import LeastSquaresStart, check_period, least_squares_start
from .input_hold import INPUT_HOLDS, InputHoldReading, with_input_hold
from .metrics import JUDGED
from .output_error import (
    EXPERIMENT_KINDS,
)
from .problem import Loss
from .structure import (
    Rung,
)

__all__ = ["LogFitOptions", "FitPlan", "plan_fit", "load_logs", "JoinedLog", "inferred_kind", "kind_mismatches",
           "disagreeing_logs", "OTHER_KINDS", "KIND_SHOWN", "STILL_PENDULUM", "MOVING_PENDULUM", "TURNING_WHEEL",
           "STILL_WINDOW", "P1_RATIO"]


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
    check_period(train_logs + [o.data for o in others])  # a wrong time unit first: it misleads what follows
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
    if not any(_drives_wheel(d) for d in train_logs) and not any(o.kind in ("clamped", "closed-loop") for o in others):
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


def _drives_wheel(d: ExperimentData) -> bool:
    """Whether log ``d`` has an input that varies (one that drives the wheel, which ``iwp fit`` identifies)."""
    return d.input_name is not None and bool(np.ptp(np.asarray(d.input, dtype=float)) > 0)


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
            and all(k is not None for _, k in free) \
            and any(_drives_wheel(d) for d, _ in free):  # (without a drive: "no training log drives the wheel")
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

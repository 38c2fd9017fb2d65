"""Validation: simulate a model against a log and measure the fit (paper section 5, figures 3-10).

:func:`validate` simulates the model from the state of the log at the start
of a time window, replaying the logged input with a zero-order hold (or
running a controller in closed loop, as in figure 10), and compares the
simulated signals with the measured ones:

* the **fit** per signal, ``100 (1 - ||y - y^|| / ||y - mean(y)||)``
  (:func:`fit_percent`, the NRMSE fit of MATLAB's ``compare``): 100 % for a
  perfect match, 0 % for a prediction no better than the mean;
* the **error signal** ``e = y - y^`` of the paper's figures;
* the **restart** of figure 9(b): at chosen times the simulation restarts
  from the measured state, which removes the error accumulated over a long
  experiment.

The initial state is the measured one: positions from the log (smoothed
with the same Savitzky-Golay filter that gives the velocities), velocities
by differentiation, at ``t_start``; with ``ValidationOptions(estimate_x0=True)`` it is instead
estimated by a simulation-error fit of the initial state only
(:func:`iwp.ident.refinement.refine` with no free parameter), which is what a
grey-box tool's ``compare`` with estimated initial conditions does.

Simulations use the adaptive DOP853 simulator :func:`iwp.sim.simulate`
at ``rtol = atol = 1e-10``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from typing import Any, Sequence

import numpy as np

from ..data import ExperimentData
from ..errors import InputError
from ..files import json_float
from ..models.encoder import EncoderZero
from ..models.parameters import BeltParameters, LumpedParameters, PhysicalParameters
from ..models.plant import MODELS, Plant, model_info
from ..sim.inputs import Input
from ..sim.uncertainty import ParameterUncertainty, PredictionBand, StartUncertainty, prediction_band
from .input_hold import INPUT_HOLDS, InputHoldReading, with_input_hold
from .metrics import fit_percent
from .output_error import (
    Experiment,
    OutputError,
    angle_quantum,
    band_as_measured,
    measured_signals,
    solve_output_error,
    start_state,
)
from .problem import SolverOptions
from .refinement import REFINE_MODELS

__all__ = ["validate", "ValidationOptions", "fit_percent", "ValidationResult", "auto_model", "choose_model",
           "validation_plant", "VALIDATION_OPTIONS", "UninformativeValidation", "READS_V_AS_U", "model_input",
           "held_out_q1_offset"]


class UninformativeValidation(UserWarning):
    """A validation that says nothing about the model: no motion in the log, or a model that explains less of
    it than its mean. Callers that tabulate every fit themselves filter it
    (``warnings.simplefilter("ignore", UninformativeValidation)``)."""

_SIGNALS = ("q1", "q2", "q3", "q4")



@dataclass(eq=False)
class ValidationResult:
    """The outcome of :func:`validate`.

    Attributes
    ----------
    t : ndarray
        Sample times of the window [s].
    measured, simulated, error : dict of str to ndarray
        Per signal: the measured signal, the simulation and ``measured - simulated``.
    fit : dict of str to float
        Fit per signal [%] (:func:`fit_percent`) over the samples compared; NaN for a constant measured signal.
    x0 : ndarray, shape (4,)
        Initial state of the simulation at ``t[0]``.
    restart_times : tuple of float
        Times at which the simulation restarted from the measured state [s] (snapped to samples).
    model : str
    source : str
    estimate_x0 : bool
    closed_loop : bool
    """

    t: np.ndarray
    measured: dict[str, np.ndarray]
    simulated: dict[str, np.ndarray]
    error: dict[str, np.ndarray]
    fit: dict[str, float]
    x0: np.ndarray
    restart_times: tuple[float, ...]
    model: str
    params: LumpedParameters
    source: str = "<memory>"
    estimate_x0: bool = False
    closed_loop: bool = False
    locked: bool = False
    restart_states: list[np.ndarray] = field(default_factory=list)
    #: the fit's 95 % parameter and prediction bands, when the parameters came with their uncertainty
    band: PredictionBand | None = None
    #: per signal, the share of the measured samples inside the prediction band
    coverage: dict[str, float] | None = None
    #: per signal, the samples compared (as a fit weighs them: not a replaced glitch, nor a mean speed's first
    #: sample, which has no preceding period; all of a signal the set-up holds still); None: all
    used: dict[str, np.ndarray] | None = None
    #: why the simulation did not reach the end of the window (it diverged, or took too many steps), or None; its
    #: samples after that are NaN and the fits are not defined
    failed: str | None = None
    #: how the replayed input acted between the samples, and why (None in closed loop)
    input_hold: InputHoldReading | None = None

    def _compared(self, k: str) -> np.ndarray:
        e = self.error[k]
        return e if self.used is None or k not in self.used else e[self.used[k]]

    @property
    def rms(self) -> dict[str, float]:
        """Root-mean-square error per signal over the samples compared."""
        return {k: float(np.sqrt(np.mean(self._compared(k) ** 2))) for k in self.error}

    @property
    def max_abs_error(self) -> dict[str, float]:
        """Largest absolute error per signal over the samples compared."""
        return {k: float(np.max(np.abs(self._compared(k)))) for k in self.error}

    def to_dict(self) -> dict[str, Any]:
        """JSON-able summary: ``{"fit": {signal: percent}, "x0": [...], "samples": n, ...}`` (NaN -> None)."""
        return {
            "fit": {k: json_float(v) for k, v in self.fit.items()},
            "rms": {k: json_float(v) for k, v in self.rms.items()},
            "max_abs_error": {k: json_float(v) for k, v in self.max_abs_error.items()},
            "x0": [json_float(v) for v in self.x0],
            "samples": int(self.t.size),
            "t_start": float(self.t[0]),
            "t_end": float(self.t[-1]),
            "model": self.model,
            "locked": self.locked,
            "estimate_x0": self.estimate_x0,
            "closed_loop": self.closed_loop,
            "failed": self.failed,
            "restart_times": [float(r) for r in self.restart_times],
            "band": None if self.band is None else {
                "method": self.band.method, "level": self.band.level,
                "coverage": {k: json_float(v) for k, v in (self.coverage or {}).items()}},
            "source": self.source,
            "params": self.params.to_dict(),
            "input_hold": None if self.input_hold is None else self.input_hold.to_dict(),
        }

    def summary(self) -> str:
        """One readable line per signal."""
        head = (f"validation of model {self.model!r} on {self.source}, t = [{self.t[0]:g}, {self.t[-1]:g}] s, "
                f"{self.t.size} samples" + (f", restarts at {', '.join(f'{r:g}' for r in self.restart_times)} s"
                                             if self.restart_times else ""))
        lines = [head]
        if self.input_hold is not None and self.input_hold.residual:
            lines.append("  " + self.input_hold.describe())
        for k in self.fit:
            cov = ""
            if self.coverage is not None and k in self.coverage and math.isfinite(self.coverage[k]):
                cov = f", {100 * self.coverage[k]:.1f} % of the samples in the 95 % prediction band"
            lines.append(f"  {k}: fit {self.fit[k]:.2f} %, rms error {self.rms[k]:.4g}, "
                         f"max |error| {self.max_abs_error[k]:.4g}{cov}")
        if self.failed:
            lines.append(f"  {self.failed}")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()

    def plot(self, signals: Sequence[str] | None = None, axes=None, **kw):
        """Measured against simulated signals with the error below each (the paper's figures);
        see :func:`iwp.plotting.validation.plot_validation`."""
        sig = tuple(signals) if signals is not None else tuple(self.measured)
        from ..plotting.validation import plot_validation  # plotting only when asked

        return plot_validation(self.t, self.measured, self.simulated, signals=sig, fit=self.fit,
                               restart_times=self.restart_times, axes=axes, band=self.band, coverage=self.coverage,
                               **kw)


def auto_model(data: ExperimentData) -> str:
    """The model that suits a log: free pendulum without input, motor-disk when locked, else model (9).

    ``"free-nowheel"`` for angle logs (``source_format: angle-log``) or
    ``wheel: none``; ``"free"`` for other logs without input; ``"raw"``
    for logs of ``v``; ``"compensated"`` otherwise (the pendulum locked or
    not, see ``locked``).

    Parameters
    ----------
    data : ExperimentData
        The log (its input and metadata).

    Returns
    -------
    str
        ``"free-nowheel"``, ``"free"``, ``"raw"`` or ``"compensated"``.

    Examples
    --------
    >>> from iwp.ident import auto_model
    >>> from iwp.rig import run_experiment
    >>> auto_model(run_experiment("free-pendulum", duration=1.0))  # no input
    'free'
    >>> auto_model(run_experiment("sine-60", duration=1.0))  # the compensated input u
    'compensated'
    >>> auto_model(run_experiment("sine-60", duration=1.0, v_dz=None))  # no compensation: the raw command v
    'raw'
    """
    m = data.metadata
    if data.input_name is None:
        if m.get("source_format") == "angle-log" or m.get("wheel", "").lower() in ("none", "no"):
            return "free-nowheel"
        return "free"
    return "raw" if data.input_name == "v" else "compensated"


#: Tolerances of the validation's simulations (far below any encoder step).
VALIDATION_OPTIONS = SolverOptions(rtol=1e-10, atol=1e-10)


def choose_model(data: ExperimentData, model: str = "auto", *, stored: str | None = None, closed_loop: bool = False,
                 source: str = "the parameter file", log: str = "the log", reads_v_as_u: bool = False) -> str:
    """The model that validates a parameter file on a log (``iwp validate --model``).

    ``"auto"``: the model the parameters were fitted with (``stored``) when it
    takes the log's input (a raw command ``v`` too, for a model of
    :data:`READS_V_AS_U` that read it as ``u`` in its fit), else :func:`auto_model` with a warning naming
    ``source``. A model given explicitly must take the log's input (none,
    ``u`` or ``v``), unless the loop is closed by a simulated controller.

    Parameters
    ----------
    data : ExperimentData
        The log.
    model : str, default "auto"
        A model of :data:`~iwp.models.MODELS`, or ``"auto"``.
    stored : str, optional
        The model the parameter file names (:func:`~iwp.models.stored_model`).
    closed_loop : bool, default False
        A simulated controller closes the loop (the log's input is not replayed).
    source : str, default "the parameter file"
        How the warning and errors name the parameter file.
    log : str, default "the log"
        How the error names the log.
    reads_v_as_u : bool, default False
        The parameters were fitted reading a raw command ``v`` as ``u``
        (``iwp fit``: :func:`~iwp.models.parameters.stored_reads_v_as_u`); the
        log then goes through :func:`model_input`.

    Returns
    -------
    str
        The model name.

    Raises
    ------
    InputError
        ``stored`` not one of iwp's models, or an explicit ``model`` that does not take the log's input.

    Warns
    -----
    UserWarning
        With ``"auto"``, when the stored model does not take the log's input.
    """
    if stored is not None and stored not in MODELS:
        raise InputError(f"params {source}: its model {stored!r} is not one of iwp's models ({', '.join(MODELS)})",
                         argument="params")
    if model == "auto":
        chosen = auto_model(data)
        if stored is not None and MODELS.get(stored) is not None and MODELS[stored].input == data.input_name:
            return stored
        if reads_v_as_u and stored in READS_V_AS_U and data.input_name == "v":
            return stored
        if stored is not None:
            has = f"input {data.input_name}" if data.input_name else "no input"
            warnings.warn(f"{source} was fitted with model {stored!r}, which does not take a log with {has}; "
                          f"simulating model {chosen!r} (give --model to choose)", UserWarning, stacklevel=2)
        return chosen
    if (model in MODELS and data.input_name is not None and MODELS[model].input != data.input_name
            and not closed_loop and not (reads_v_as_u and model in READS_V_AS_U and data.input_name == "v")):
        raise InputError(f"--model {model} does not take the input {data.input_name} of {log}; "
                         f"use --model {auto_model(data)}")
    return model


#: The models that read a logged raw command ``v`` as their input ``u`` in ``iwp fit`` (no dead zone).
READS_V_AS_U = tuple(name for name, info in MODELS.items() if info.reads_v_as_u)


def model_input(d: ExperimentData, model: str, argument: str) -> ExperimentData:
    """The log with the input ``model`` takes, as ``iwp fit`` reads it.

    Model (9) and the belt model read a raw command ``v`` as their ``u``
    (:data:`READS_V_AS_U`: no dead zone between them); the dead-zone model
    (6) needs the raw command.

    Parameters
    ----------
    d : ExperimentData
        The log.
    model : str
        The model that will simulate it.
    argument : str
        How an error names the log's argument (``"train"``, ``"validate"``, ``"FILE"``).

    Returns
    -------
    ExperimentData
        The log, its ``v`` moved to ``u`` for a model of :data:`READS_V_AS_U`.

    Raises
    ------
    InputError
        A log of the compensated input ``u`` for the raw model (6).

    Examples
    --------
    A log of the raw command ``v`` (the rig's compensation off) as model (9) reads it:

    >>> from iwp.ident import model_input
    >>> from iwp.rig import run_experiment
    >>> raw = run_experiment("sine-60", duration=1.0, v_dz=None)
    >>> raw.input_name, model_input(raw, "compensated", "train").input_name
    ('v', 'u')
    >>> model_input(run_experiment("sine-60", duration=1.0), "raw", "train")
    Traceback (most recent call last):
    ...
    iwp.errors.InputError: train: virtual rig: sine-60 logs the compensated input u (...); the dead-zone model (6) ...
    """
    if model in READS_V_AS_U and d.input_name == "v":
        return replace(d, u=d.v, v=None)
    if model_info(model).input == "v" and d.input_name == "u":
        raise InputError(f"{argument}: {d.source} logs the compensated input u (the rig compensates its dead "
                         f"zone); the dead-zone model {model_info(model).equation} needs the raw command v",
                         argument="dead_zone")
    return d


def held_out_q1_offset(data: ExperimentData, stored: float) -> float:
    """The pendulum zero offset [rad] to take off a log validated with a fit's parameters.

    ``iwp fit`` estimates the offset of each training log when the rig
    description does not give it, and takes the training logs' mean off its
    held-out logs (stored as ``q1_offset`` in its ``parameters.json``:
    :func:`~iwp.models.parameters.stored_q1_offset`). A log converted from
    such a rig says so (metadata ``q1_offset: estimate``) and gets the same
    offset; any other log (corrected when read, or not a rig's) none.

    Parameters
    ----------
    data : ExperimentData
        The log.
    stored : float
        The fit's offset for held-out logs [rad].

    Returns
    -------
    float
        ``stored`` for a log whose offset is to be estimated, else 0.

    Examples
    --------
    >>> from dataclasses import replace
    >>> from iwp.ident import held_out_q1_offset
    >>> from iwp.rig import run_experiment
    >>> log = run_experiment("free-pendulum", duration=1.0)
    >>> held_out_q1_offset(log, 0.012)  # the virtual rig's encoders have no offset
    0.0
    >>> converted = replace(log, metadata={**log.metadata, "q1_offset": "estimate"})
    >>> held_out_q1_offset(converted, 0.012)  # [rad]
    0.012
    """
    return float(stored) if data.metadata.get("q1_offset") == "estimate" else 0.0


def validation_plant(params, data: ExperimentData, model: str = "compensated", *, belt: BeltParameters | None = None,
                     source: str = "params") -> Plant:
    """The plant that validates ``params`` on the log ``data``.

    ``model`` is one of :data:`~iwp.ident.refinement.REFINE_MODELS`, a belt
    model (``"belt-full"``, (15), with the ``belt`` of the fit, as
    :func:`~iwp.models.parameters.stored_belt` reads it from the parameter
    file of ``iwp fit --belt``), or ``"auto"`` (:func:`auto_model`); the
    pendulum of ``"compensated"`` and ``"raw"`` is clamped when the log says
    so (metadata ``pendulum: locked``). A :class:`~iwp.models.plant.Plant` is
    taken as it is.

    Parameters
    ----------
    params : LumpedParameters, PhysicalParameters or Plant
        The parameters (physical ones are mapped to lumped ones).
    data : ExperimentData
        The log (its input, and metadata ``pendulum``).
    model : str, default "compensated"
        One of :data:`~iwp.ident.refinement.REFINE_MODELS`, a belt model, or ``"auto"``; ignored for a plant.
    belt : BeltParameters, optional
        The belt (15) of a belt model; required for one, ignored for the others.
    source : str, default "params"
        How the error of a belt model without a belt names the parameters (``iwp validate``: the file).

    Returns
    -------
    Plant
        The plant.

    Raises
    ------
    InputError
        ``params`` of another type, an unknown model, or a belt model without ``belt``.

    Examples
    --------
    Table 1 on a log of figure 3(a), whose metadata say the pendulum was locked, and on a free swing:

    >>> from iwp import table1
    >>> from iwp.ident import validation_plant
    >>> from iwp.rig import run_experiment
    >>> plant = validation_plant(table1(), run_experiment("sine-60", duration=1.0))
    >>> plant.model, plant.locked
    ('compensated', True)
    >>> validation_plant(table1(), run_experiment("free-pendulum", duration=1.0), "auto").model
    'free'
    """
    if isinstance(params, Plant):
        return params
    if isinstance(params, PhysicalParameters):
        params = params.to_lumped()
    if not isinstance(params, LumpedParameters):
        raise InputError(f"params must be LumpedParameters, got {type(params).__name__}")
    if model in MODELS and MODELS[model].drive is not None:
        if belt is None:
            raise InputError(f"{source}: model {model!r} needs the belt's parameters (15), which it does not hold; "
                             "give the parameters.json of a fit with the belt")
        return Plant(params, model=model, belt=belt)
    if model == "auto":
        model = auto_model(data)
    if model not in REFINE_MODELS:
        raise InputError(f"model must be one of auto, {', '.join(REFINE_MODELS)}, got {model!r}")
    locked = data.metadata.get("pendulum") == "locked" and model_info(model).clampable
    return Plant(params, model=model, locked=locked)


def _segments(t: np.ndarray, restart_times: Sequence[float]) -> list[int]:
    """Sample indices where the simulation starts: 0 and each restart time snapped to the nearest inner sample."""
    starts = [0]
    for rt in restart_times:
        try:
            rt = float(rt)
        except (TypeError, ValueError):
            raise InputError(f"restart time {rt!r} is not a number") from None
        if not (t[0] < rt < t[-1]) or not math.isfinite(rt):
            raise InputError(f"restart time {rt:g} s is outside the window ({t[0]:g}, {t[-1]:g}) s")
        k = int(np.argmin(np.abs(t - rt)))
        if 0 < k < t.size - 1 and k not in starts:
            starts.append(k)
    return sorted(starts)


def _estimated_x0(experiment: Experiment, plant: Plant, signals: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """The initial state fitted to the signals that move (the parameters fixed), and its 4 x 4 covariance."""
    fit_out = tuple(s for s in signals if s in plant.outputs)
    measured = measured_signals(experiment.data.window(*experiment.window), fit_out)
    fit_out = tuple(s for s in fit_out if np.ptp(measured[s]) > 0)
    if not fit_out:
        raise InputError(f"estimate_x0: none of the signals {', '.join(signals)} varies in the window")
    model = OutputError(plant, [experiment], fit_out)
    res = solve_output_error(model, model.parameters())
    return model.states(res.parameters.values())[0], model.start_covariance(res)


@dataclass(frozen=True)
class ValidationOptions:
    """Where :func:`validate` simulates and from which states.

    Parameters
    ----------
    window : (float or None, float or None)
        Time window [s] (None: the log's start / end).
    restart_times : sequence of float
        Restart the simulation from the measured state at these times [s]
        (figure 9(b)); each is snapped to the nearest sample inside the window.
    estimate_x0 : bool
        Estimate the initial state by a simulation-error fit (parameters
        fixed) instead of taking the measured one.
    q1_offset : float
        A pendulum zero offset [rad] taken off the log's ``q1`` first (the
        one ``iwp fit`` took off its held-out logs: :func:`held_out_q1_offset`).
    q1_zero_variance : float, optional
        How far the log's own zero may lie from ``q1_offset`` [rad^2], which
        the prediction band carries when the start is measured
        (:meth:`iwp.models.EncoderZero.variance`); default one encoder count's
        ``step^2 / 12``.
    input_hold : {"auto", "zoh", "continuous"}
        How the log's input acted between its samples, for its replay
        (:mod:`iwp.ident.input_hold`): ``"auto"`` (default) as its metadata
        says, else read from the log itself.

    Raises
    ------
    InputError
        ``q1_offset`` not a finite number, ``q1_zero_variance`` not finite and >= 0, an unknown ``input_hold``.
    """

    window: tuple[float | None, float | None] = (None, None)
    restart_times: Sequence[float] = ()
    estimate_x0: bool = False
    q1_offset: float = 0.0
    q1_zero_variance: float | None = None
    input_hold: str = "auto"

    def __post_init__(self) -> None:
        if self.input_hold not in INPUT_HOLDS:
            raise InputError(f"input_hold must be one of {', '.join(INPUT_HOLDS)}, got {self.input_hold!r}",
                             argument="input_hold")
        q = self.q1_offset
        if isinstance(q, bool) or not isinstance(q, (int, float)) or not math.isfinite(q):
            raise InputError(f"q1_offset must be a finite number of radians, got {q!r}")
        v = self.q1_zero_variance
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
                              or v < 0):
            raise InputError(f"q1_zero_variance must be a finite number >= 0 [rad^2], got {v!r}")


def validate(
    experiment: ExperimentData,
    params,
    *,
    model: str = "compensated",
    signals: Sequence[str] | None = None,
    controller: Input | None = None,
    options: ValidationOptions | None = None,
) -> ValidationResult:
    """Simulate a model against a log and measure how well it predicts it.

    Parameters
    ----------
    experiment : ExperimentData
        The log.
    params : LumpedParameters, PhysicalParameters, Plant or ParameterUncertainty
        The parameters (with ``model``), or a plant. With a
        :class:`~iwp.sim.uncertainty.ParameterUncertainty` (a fit's
        parameters and covariance) the result also holds the fit's 95 %
        parameter and prediction bands (linearised) and how much of the
        measured data falls inside the prediction band.
    model : str
        ``"compensated"`` (9, input ``u``), ``"raw"`` (6, input ``v``),
        ``"motor-disk"``, ``"motor-disk-raw"`` (14), ``"free"`` (free
        pendulum, wheel held) or ``"free-nowheel"``; ``"auto"``:
        :func:`auto_model` (see :func:`validation_plant`).
    signals : sequence of str, optional
        Signals compared, among ``q1, q2, q3, q4``; velocities missing from
        the log are differentiated from the positions. Default: ``q1`` and
        the wheel's own signal, ``q2``, or ``q4`` when the log holds only
        the wheel's speed.
    controller : iwp.sim.inputs controller, optional
        Simulate in closed loop with it (e.g. ``HopfController(-10, 0.1)``,
        figure 10) instead of replaying the logged input.
    options : ValidationOptions, optional
        Time window [s], restart times [s], whether to estimate the initial
        state, and a pendulum zero offset [rad] (default: the whole log from
        the measured state, no restarts, no offset).

    Returns
    -------
    ValidationResult

    Warns
    -----
    UninformativeValidation
        When the validation says nothing: every compared signal is constant, or the model explains less of each
        than its mean (fit < 0 %). Callers that report the fits themselves filter it.

    Examples
    --------
    >>> from iwp import Plant, simulate, table1, validate
    >>> log = simulate(Plant(table1(), model="free"), x0=[1.0, 0, 0, 0], t_end=20.0).to_experiment()
    >>> v = validate(log, table1(), model="free", signals=["q1"])
    >>> round(v.fit["q1"])  # fit percentage of the pendulum angle
    100
    """
    opts = ValidationOptions() if options is None else options
    if not isinstance(experiment, ExperimentData):
        raise InputError(f"experiment must be an ExperimentData, got {type(experiment).__name__}")
    if not isinstance(opts, ValidationOptions):
        raise InputError(f"options must be a ValidationOptions, got {type(opts).__name__}")
    if opts.q1_offset:
        experiment = replace(experiment, q1=experiment.q1 - opts.q1_offset)
    hold = None
    if controller is None:  # the logged input is replayed: as it acted between the samples
        (experiment,), (hold,) = with_input_hold([experiment], opts.input_hold)
    uncertainty = params if isinstance(params, ParameterUncertainty) else None
    plant = (validation_plant(params, experiment, model) if uncertainty is None
             else validation_plant(uncertainty.params, experiment, model, belt=uncertainty.belt))
    signals = _compared_signals(experiment, signals)
    if controller is not None and plant.input_name != "u":
        raise InputError(f"a controller drives the input u; model {plant.model!r} takes "
                         f"{plant.input_name or 'no input'}")
    plan = _plan_validation(experiment, plant, signals, controller, opts)
    run = _simulate_segments(plan, uncertainty)
    return replace(_report_validation(plan, run, experiment.source), input_hold=hold)


@dataclass(frozen=True, eq=False)
class _ValidationPlan:
    """The simulated segments of a validation: the plant, the window's times, the segments and their start states."""

    plant: Plant
    signals: tuple[str, ...]
    t: np.ndarray
    starts: list[int]
    experiments: list[Experiment]
    x0_cov: list[np.ndarray]
    estimate_x0: bool
    closed_loop: bool
    zero_variance: float  # of the logged angle's zero [rad^2], 0 with an estimated start


@dataclass(frozen=True, eq=False)
class _ValidationRun:
    """The measured and simulated signals, the states the segments started from, and the samples compared."""

    measured: dict[str, np.ndarray]
    simulated: dict[str, np.ndarray]
    x0s: list[np.ndarray]
    weighed: dict[str, np.ndarray]
    used: dict[str, np.ndarray]
    status: list[int]
    band: PredictionBand | None
    coverage: dict[str, float] | None


def _compared_signals(experiment: ExperimentData, signals: Sequence[str] | str | None) -> tuple[str, ...]:
    """The signals compared (default ``q1`` and the wheel's own signal), checked."""
    if signals is None:
        signals = ("q1", "q2" if experiment.q2 is not None or experiment.q4 is None else "q4")
    signals = (signals,) if isinstance(signals, str) else tuple(signals)
    if not signals:
        raise InputError("signals is empty")
    for s in signals:
        if s not in _SIGNALS:
            raise InputError(f"unknown signal {s!r}; choose among {', '.join(_SIGNALS)}")
    return signals


def _plan_validation(experiment: ExperimentData, plant: Plant, signals: tuple[str, ...], controller: Input | None,
                     opts: ValidationOptions) -> _ValidationPlan:
    """Split the window at the restarts and give each segment its start state (measured, or estimated)."""
    wdata = experiment.window(*opts.window)
    if wdata.n_samples < 10:
        raise InputError(f"the window keeps {wdata.n_samples} samples of {experiment.source}; at least 10 are needed")
    t = np.asarray(wdata.t, dtype=float)
    starts = _segments(t, opts.restart_times)
    kind = "free" if controller is None else "closed-loop"
    ends = [k - 1 for k in starts[1:]] + [t.size - 1]
    # each segment from the state the model puts through its first samples, as iwp fit starts its held-out logs (a
    # smoothing filter is biased at a log's first sample, 0.34 rad/s for a pendulum at rest on a 50 ms log, and
    # where the angle curves fast: 12 mrad at 0.5 s of the real swing of docs/refinement.md, fit 90.7 % against
    # 98.8 % from the model's start; a quadratic where the input drives the rig)
    exps = [Experiment(experiment, kind=kind, window=(float(t[a]), float(t[b])), estimate_x0=False,
                       controller=controller) for a, b in zip(starts, ends)]
    segs = [start_state(experiment.window(*e.window), plant, controller) for e in exps]
    exps = [replace(e, x0=g.x0) for e, g in zip(exps, segs)]
    x0_cov = [g.covariance for g in segs]
    if opts.estimate_x0:
        x0, x0_cov[0] = _estimated_x0(replace(exps[0], estimate_x0=True), plant, signals)
        exps[0] = replace(exps[0], x0=x0[:4])
    # a measured start: the log's zero (known to within an encoder count, or as the fit's logs spread) moves it
    # and every sample alike
    zero = (EncoderZero().variance(angle_quantum(experiment.q1)) if opts.q1_zero_variance is None
            else float(opts.q1_zero_variance))
    if opts.estimate_x0 or plant.pendulum_locked:
        zero = 0.0
    return _ValidationPlan(plant=plant, signals=signals, t=t, starts=starts, experiments=exps, x0_cov=x0_cov,
                           estimate_x0=bool(opts.estimate_x0), closed_loop=controller is not None,
                           zero_variance=zero)


def _simulate_segments(plan: _ValidationPlan, uncertainty: ParameterUncertainty | None) -> _ValidationRun:
    """Simulate every segment; the measured and simulated signals joined, and the bands with an uncertainty."""
    signals = plan.signals
    model_ = OutputError(plan.plant, plan.experiments, signals, rtol=VALIDATION_OPTIONS.rtol,
                         atol=VALIDATION_OPTIONS.atol, fitting=False)
    ev = model_.evaluate(model_.parameters().values())
    pred = model_.predictions(ev)
    measured = {s: np.concatenate([p.y[s] for p in model_.prepared]) for s in signals}
    simulated = {s: np.concatenate([q[s] for q in pred]) for s in signals}
    x0s = model_.states(ev.values)
    weighed = {s: np.concatenate([p.w[s] > 0 for p in model_.prepared]) for s in signals}
    # a signal the set-up holds still (a held wheel's angle) is compared as it is
    used = {s: w if w.any() else np.ones_like(w) for s, w in weighed.items()}
    band = coverage = None
    if uncertainty is not None:
        band = _band(model_, x0s, plan.x0_cov, uncertainty, signals, pred, plan.zero_variance)
        coverage = band.coverage(measured, weighed)
    return _ValidationRun(measured=measured, simulated=simulated, x0s=x0s, weighed=weighed, used=used,
                          status=list(ev.status), band=band, coverage=coverage)


def _report_validation(plan: _ValidationPlan, run: _ValidationRun, source: str) -> ValidationResult:
    """The fits per signal (undefined when a simulation stopped), with the warnings, as one result."""
    signals, t, measured, simulated, used = plan.signals, plan.t, run.measured, run.simulated, run.used
    fits = {s: fit_percent(measured[s][used[s]], simulated[s][used[s]]) for s in signals}
    failed = None
    if any(st != 0 for st in run.status):
        lost = ~np.all([np.isfinite(simulated[s]) for s in signals], axis=0)
        when = f" at t = {t[int(np.argmax(lost))]:.4g} s" if lost.any() else ""
        failed = f"the simulation stopped{when} (it diverged, or took too many steps): the fit is not defined"
        fits = {s: math.nan for s in signals}
        warnings.warn(f"{source}: {failed}", UserWarning, stacklevel=3)
    else:
        _warn_uninformative(source, measured, fits, stacklevel=4)
    plant, x0s = plan.plant, run.x0s
    return ValidationResult(
        t=t, measured=measured, simulated=simulated, error={s: measured[s] - simulated[s] for s in signals},
        fit=fits, x0=np.asarray(x0s[0], dtype=float),
        restart_times=tuple(float(t[k]) for k in plan.starts[1:]), model=plant.model, params=plant.lumped,
        source=source, estimate_x0=plan.estimate_x0, closed_loop=plan.closed_loop,
        locked=bool(plant.locked), restart_states=[np.asarray(x, dtype=float) for x in x0s[1:]], band=run.band,
        coverage=run.coverage, used=used, failed=failed,
    )


def _warn_uninformative(source: str, measured: dict[str, np.ndarray], fits: dict[str, float], *,
                        stacklevel: int = 3) -> None:
    """Warn when a validation says nothing: a log without motion, or a model that explains less than the mean."""
    flat = [s for s, y in measured.items() if y.size and float(np.ptp(y)) == 0.0]
    if flat and len(flat) == len(measured):  # one constant signal is a locked pendulum or a held wheel
        warnings.warn(f"{source}: {', '.join(flat)} {'is' if len(flat) == 1 else 'are'} constant (no motion in the "
                      "log): the validation says nothing about the model", UninformativeValidation,
                      stacklevel=stacklevel)
    defined = {s: f for s, f in fits.items() if math.isfinite(f)}
    if defined and all(f < 0.0 for f in defined.values()):
        listing = ", ".join(f"{s} {f:.1f} %" for s, f in defined.items())
        warnings.warn(f"{source}: the model explains less of the log than the log's mean does (fit {listing}): "
                      "is it a log of this rig, with these parameters and this model?", UninformativeValidation,
                      stacklevel=stacklevel)


def _moving(plant: Plant, C: np.ndarray) -> np.ndarray:
    """The covariance of a measured state restricted to the states the plant moves (a held wheel, a clamp)."""
    keep = np.zeros(4, dtype=bool)
    keep[[i for i in plant.info.moving if i < 4]] = True
    if plant.pendulum_locked:
        keep[[0, 2]] = False
    return np.where(np.outer(keep, keep), C, 0.0)


def _band(model: OutputError, x0s: list[np.ndarray], x0_cov: list[np.ndarray], uncertainty: ParameterUncertainty,
          signals: tuple[str, ...], simulated: list[dict[str, np.ndarray]], zero: float) -> PredictionBand:
    """The linearised bands of every segment of a validation (the initial state's uncertainty and the variance
    ``zero`` of the angle's zero in), about the model's outputs as each segment measures them (``simulated``),
    joined."""
    parts = [band_as_measured(prediction_band(p.plant, uncertainty, input=p.input, x0=x0, t_eval=p.t,
                                              signals=signals, start=StartUncertainty(_moving(p.plant, c), zero)),
                              p.not_instant, q)
             for p, x0, c, q in zip(model.prepared, x0s, x0_cov, simulated)]

    def join(attr):
        return {s: np.concatenate([getattr(b, attr)[s] for b in parts]) for s in signals}

    return PredictionBand(np.concatenate([b.t for b in parts]), join("nominal"), join("lower"), join("upper"),
                          join("pred_lower"), join("pred_upper"), "linear", 0.95, 0)


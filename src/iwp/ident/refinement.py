"""Simulation-error identification: refine parameters so that the simulated outputs match the logs.

Least squares on differentiated data (:func:`iwp.ident.identify`, the
paper's (13)) is fast and needs no starting point, but the regressors carry
the noise and the quantisation of the encoders and the filter of the
differentiator, which biases the estimates; friction terms that differ little
over the data (the paper's free-decay numbers, section 5.2) are not
separated. :func:`refine` starts from such an estimate and minimises the
*simulation error* of the measured outputs (the output-error criterion of
MATLAB's ``nlgreyest``):

    minimise  sum_e sum_o sum_k  rho( (y_o,e(t_k) - y^_o,e(t_k; theta, x0_e)) / s_o )^2

over the free parameters ``theta`` of a :class:`~iwp.models.plant.Plant` (each
fixed or free, with bounds) and the initial state ``x0_e`` of every
experiment ``e`` (positions and velocities at the start of its time window),
jointly over several experiments, with an optional robust loss ``rho``. It is
one :class:`~iwp.ident.problem.FitProblem` over the residual model
:class:`~iwp.ident.output_error.OutputError`: prepare (the experiments, the
parameters of the plant), solve, report (:class:`RefineResult`).

Models
------
Any model whose parameters are lumped ones (:data:`REFINE_MODELS`):
``"free"`` (free pendulum, motor off, the wheel held to the arm by the
friction of its drive: ``q3' = -xi rho/(1 + rho)``, the paper's free-pendulum
experiment on a belt-driven rig), ``"free-nowheel"`` (a pendulum without a
wheel, ``q3' = -xi``, for plain pendulums such as the angle logs of
:func:`iwp.data.read_angle_log`), ``"compensated"`` (9) and ``"raw"`` (6)
(the pendulum clamped with ``Plant(locked=True)``), the motor-disk models
(14). The belt (15) is fitted by :func:`iwp.ident.belt_fit.refine_belt`.
The input of every experiment is its logged ``u`` (models with input ``u``)
or ``v`` (raw models), replayed with a zero-order hold; a log without input
replays zero.

Uncertainty
-----------
At the optimum, the covariance of the free parameters and initial states is
``(J^T W J)^-1`` with ``W`` the inverse residual variance of each output
(:mod:`iwp.ident.covariance`). Simulation residuals are correlated in time
(model error, quantisation), so these standard errors are a lower bound of
the true spread. Pairs of free parameters whose correlation exceeds 0.95 in
magnitude, and directions that the data do not determine (a rank-deficient
Jacobian), are reported in :attr:`RefineResult.warnings` (and with
:func:`warnings.warn`).
"""

from __future__ import annotations

import dataclasses
import math
import warnings as _warnings
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..data import ExperimentData, StaticCurve
from ..errors import InputError
from ..files import json_float
from ..models.parameters import PARAMETER_INFO, BeltParameters, LumpedParameters
from ..models.plant import CLAMPABLE, MODELS, Plant, model_info
from ..sim.sensitivity import difference_step
from .covariance import Reliability
from .drives import BELT_RTOL
from .fit_parameters import Parameter
from .metrics import fit_percent
from .output_error import Experiment, OutputError, offset_name, solve_output_error, x0_name
from .problem import FitResult, Loss, SolverOptions
from .setups import get_setup

__all__ = [
    "refine",
    "refine_identification",
    "RefineResult",
    "REFINE_MODELS",
    "FREE_PENDULUM",
    "as_experiments",
    "fit_percent",
    "fit_plant",
    "refine_report",
    "BELT_OPTIONS",
    "simulation_equivalent",
]

#: The models :func:`refine` fits, and the parameters that enter each (from the models' own description).
REFINE_MODELS: dict[str, tuple[str, ...]] = {
    name: info.parameters for name, info in MODELS.items()
    if info.parameters and all(PARAMETER_INFO[n].owner == "lumped" for n in info.parameters)
}
#: The free pendulum's parameters (section 3.1): what :func:`refine` frees by default.
FREE_PENDULUM = ("p1", "sigma_a1", "sigma_v1", "sigma_b1")


#: The options of a fit with the belt (15): simulations at 1e-10, and the trust region in the parameters' own (log)
#: coordinates. The tolerance is that of the forward differences' Jacobian, not of the outputs' accuracy: on the
#: belt rig of ``benchmarks/ladder_study.py`` (10 seeds, belt truth) the true parameters were inside the chosen
#: fit's 95 % intervals 42 times of 140 at 1e-6, 113 at 1e-9 and 132 at 1e-10 (the fits stopped at 1e-6 where the
#: differences, 1000 times less accurate, found no descent), a ``fit_logs`` 13.4, 20.8 and 32.2 s; since the play
#: is integrated as a hybrid system (:mod:`iwp.sim.engine`) a run at 1e-10 costs what one at 1e-8 did. Scaled by
#: the columns of its forward-difference Jacobian, the belt's fit stopped (xtol) at 16 times the cost it reached
#: in the log coordinates (2.12 against 0.131, ladder study, belt truth, seed 2, at 1e-6) and the ladder chose a
#: rigid structure in 3 of 10 seeds.
BELT_OPTIONS = SolverOptions(rtol=BELT_RTOL, atol=BELT_RTOL, scaling="start")


def belt_note(rtol: float) -> str:
    """What a fit with the belt says beside its intervals: how its Jacobian is taken (simulations at ``rtol``) and
    how often such intervals held (measured: ``benchmarks/ladder_study.py --belt-rig``, belt truth, 10 seeds)."""
    return (f"the belt's play makes the fit non-smooth: its Jacobian is taken by forward differences of simulations "
            f"at rtol {rtol:g} (on the virtual belt rig of benchmarks/ladder_study.py, at rtol 1e-10, the true values "
            f"were inside these intervals for 132 of 140 parameters; at 1e-6, for 42)")


def fit_plant(start, model: str = "compensated", *, locked: bool = False) -> Plant:
    """The plant a simulation-error fit of ``model`` starts from (a clear error for a model it does not fit).

    Parameters
    ----------
    start : LumpedParameters
        The start values (the fixed parameters keep them).
    model : str
        One of :data:`REFINE_MODELS`.
    locked : bool
        The pendulum clamped (models ``"compensated"`` and ``"raw"``).

    See Also
    --------
    refine : The fit that starts from this plant.

    Examples
    --------
    >>> from iwp import table1
    >>> from iwp.ident import fit_plant
    >>> plant = fit_plant(table1(), "free")  # the free pendulum of section 5.2
    >>> plant.model, plant.locked
    ('free', False)
    >>> fit_plant(table1(), "compensated", locked=True).locked  # model (9), pendulum clamped (section 5.1)
    True
    >>> fit_plant(table1(), "belt")
    Traceback (most recent call last):
    ...
    iwp.errors.InputError: model must be one of raw, compensated, ..., got 'belt' (...; refine does not fit it)
    """
    if not isinstance(model, str) or model not in REFINE_MODELS:
        extra = ""
        if isinstance(model, str) and model in MODELS:
            extra = f" ({model!r} needs other parameters than LumpedParameters; refine does not fit it)"
        raise InputError(f"model must be one of {', '.join(REFINE_MODELS)}, got {model!r}{extra}")
    if not isinstance(start, LumpedParameters):
        raise InputError(f"start must be LumpedParameters, got {type(start).__name__}")
    if locked and not model_info(model).clampable:
        raise InputError(f"locked=True applies to the models {', '.join(CLAMPABLE)}, not {model!r}")
    return Plant(start, model=model, locked=locked)


def simulation_equivalent(model: str, params: LumpedParameters) -> tuple[str, LumpedParameters]:
    """The model and parameters that :func:`iwp.sim.simulate` runs for ``model``: the same ones.

    Every model that :func:`refine` fits (the free pendulum included) is a
    model of :mod:`iwp.models`; kept so that callers need not know it.

    Parameters
    ----------
    model : str
        Model name, one of :data:`REFINE_MODELS`.
    params : LumpedParameters
        The fitted parameters.

    Returns
    -------
    model : str
        ``model`` itself.
    params : LumpedParameters
        ``params`` itself.

    Raises
    ------
    InputError
        A model :func:`refine` does not fit, or ``params`` not :class:`LumpedParameters`.
    """
    fit_plant(params, model)
    return model, params


def as_experiments(logs, *, windows=None, x0=None, estimate_x0: bool = True, offsets: Sequence[str] = (),
                   kind: str = "free") -> list[Experiment]:
    """:class:`~iwp.ident.output_error.Experiment` objects for logs that share their settings.

    Parameters
    ----------
    logs : ExperimentData, Experiment or sequence of them
        Experiments are kept as they are.
    windows : (t_start, t_end) or list of them, optional
        Time window [s] per log (``None`` for an open end); one pair applies to all.
    x0 : list of array_like, optional
        Initial-state guesses per log (default: from the data).
    estimate_x0 : bool
        Estimate each log's initial state with the parameters.
    offsets : sequence of str
        Outputs with an estimated sensor offset per log.
    kind : str
        The logs' kind (:data:`~iwp.ident.output_error.EXPERIMENT_KINDS`).

    Examples
    --------
    Two releases of the free pendulum, each fitted from 0.5 s on with its own encoder zero:

    >>> from iwp.ident import as_experiments
    >>> from iwp.rig import run_experiment
    >>> logs = [run_experiment("free-pendulum", duration=5.0),
    ...         run_experiment("free-pendulum", duration=5.0, x0=-1.0, seed=1)]
    >>> exps = as_experiments(logs, windows=(0.5, None), offsets=["q1"])
    >>> [(e.window, e.offsets, e.estimate_x0) for e in exps]
    [((0.5, None), ('q1',), True), ((0.5, None), ('q1',), True)]
    """
    if isinstance(logs, (ExperimentData, Experiment)):
        logs = [logs]
    try:
        items = list(logs)
    except TypeError:
        raise InputError(f"experiments must be an ExperimentData or a list of them, got "
                         f"{type(logs).__name__}") from None
    if not items:
        raise InputError("no experiments given")
    wins = _windows(windows, len(items))
    guesses = [None] * len(items)
    if x0 is not None:
        guesses = list(x0)
        if len(guesses) != len(items):
            raise InputError(f"x0 must give one initial state per experiment ({len(items)}), got {len(guesses)}")
    offsets = (offsets,) if isinstance(offsets, str) else tuple(offsets)
    out = []
    for i, (e, w, g) in enumerate(zip(items, wins, guesses)):
        if isinstance(e, Experiment):
            out.append(e)
        elif isinstance(e, ExperimentData):
            out.append(Experiment(e, kind=kind, window=w, x0=g, estimate_x0=estimate_x0, offsets=offsets))
        else:
            raise InputError(f"experiments[{i}] must be an ExperimentData (time series log), got {type(e).__name__}")
    return out


def _windows(windows, n: int) -> list[tuple[float | None, float | None]]:
    if windows is None:
        return [(None, None)] * n
    if isinstance(windows, tuple) and len(windows) == 2 and all(w is None or isinstance(w, (int, float))
                                                                 for w in windows):
        return [windows] * n
    ws = list(windows)
    if len(ws) != n:
        raise InputError(f"windows must be one (t_start, t_end) pair or one per experiment ({n}), got {len(ws)}")
    out = []
    for i, w in enumerate(ws):
        if w is None:
            out.append((None, None))
            continue
        try:
            a, b = w
        except (TypeError, ValueError):
            raise InputError(f"windows[{i}] must be a pair (t_start, t_end) [s], got {w!r}") from None
        out.append((a, b))
    return out


# --------------------------------------------------------------------------
# result
# --------------------------------------------------------------------------
@dataclass(eq=False)
class RefineResult:
    """The outcome of :func:`refine` (and of :func:`~iwp.ident.belt_fit.refine_belt`).

    Attributes
    ----------
    params : LumpedParameters
        Refined values of the free parameters, the others from ``start``.
    parameters : dict of str to Parameter
        Every parameter of the plant: value, standard error, 95 % interval
        (Student t) and ``fixed`` flag (fixed ones have stderr 0).
    free : tuple of str
        The free parameters, in the order of :attr:`covariance`.
    covariance, correlation : ndarray, shape (n_free, n_free)
        Of the free parameters (the initial states marginalised).
    fit : list of dict
        Per experiment, ``{output: fit percent}`` at the optimum (:func:`fit_percent`).
    fit_start : list of dict
        The same at the start (start parameters, initial states from the data).
    rms, rms_start : list of dict
        Per experiment and output, the root-mean-square simulation error at the optimum and at the start.
    x0 : list of ndarray
        Initial state of each experiment at the start of its window (estimated or from the data).
    x0_stderr : list of ndarray
        Standard errors of ``x0`` (0 where not estimated).
    windows : list of (float, float)
        Time window of each experiment [s].
    success, message : bool, str
        From :func:`scipy.optimize.least_squares`.
    warnings : list of str
        Not separable parameters, rank deficiency, parameters at a bound, ...
    cost_start, cost : float
        ``0.5 sum r^2`` of the weighted residuals ``r = (y - y^)/s_o`` at the start and at the optimum.
    nfev, njev : int
        Simulations without and with sensitivities.
    residual_std : dict
        Standard deviation of the simulation error per output at the optimum (in the output's unit).
    fit_result : FitResult
        The fit problem's own result (every unknown, the Jacobian, the evaluations).
    reliability : Reliability or None
        How far the intervals can be trusted (:class:`~iwp.ident.covariance.Reliability`).
    """

    params: LumpedParameters
    parameters: dict[str, Parameter]
    free: tuple[str, ...]
    covariance: np.ndarray
    correlation: np.ndarray
    fit: list[dict[str, float]]
    fit_start: list[dict[str, float]]
    rms: list[dict[str, float]]
    rms_start: list[dict[str, float]]
    x0: list[np.ndarray]
    x0_stderr: list[np.ndarray]
    windows: list[tuple[float, float]]
    success: bool
    message: str
    warnings: list[str]
    cost_start: float
    cost: float
    nfev: int
    njev: int
    model: str
    outputs: tuple[str, ...]
    loss: str
    start: LumpedParameters
    residual_std: dict[str, float] = field(default_factory=dict)
    n_samples: int = 0
    elapsed: float = 0.0
    sources: list[str] = field(default_factory=list)
    #: per experiment and output, at the optimum: the model's output (offsets included), the measured
    #: signal, the sample times and the weights (0: left out, e.g. a replaced glitch)
    simulated: list[dict[str, np.ndarray]] = field(default_factory=list)
    measured: list[dict[str, np.ndarray]] = field(default_factory=list)
    times: list[np.ndarray] = field(default_factory=list)
    weights: list[dict[str, np.ndarray]] = field(default_factory=list)
    #: per experiment, ``{output: (offset, stderr)}`` of the estimated output offsets
    offsets: list[dict[str, tuple[float, float]]] = field(default_factory=list)
    #: the belt models (:func:`iwp.ident.belt_fit.refine_belt`): the fitted belt and its start
    belt: BeltParameters | None = None
    belt_start: BeltParameters | None = None
    fit_result: FitResult | None = field(default=None, repr=False)
    reliability: Reliability | None = None

    def value(self, name: str) -> float:
        """Value of one parameter."""
        return self.parameters[name].value

    def stderr(self, name: str) -> float:
        """Standard error of one parameter (0 when fixed)."""
        return self.parameters[name].stderr

    def combination_stderr(self, weights: Mapping[str, float]) -> float:
        """Standard error of a linear combination ``sum_i w_i theta_i`` of free parameters,
        e.g. ``{"sigma_a1": 1, "sigma_v1": 1}`` for the small-angle damping."""
        c = np.zeros(len(self.free))
        for n, wt in weights.items():
            if n not in self.free:
                if n in self.parameters:
                    continue  # fixed: no variance
                raise InputError(f"unknown parameter {n!r}")
            c[self.free.index(n)] = wt
        return float(math.sqrt(max(c @ self.covariance @ c, 0.0)))

    def to_dict(self) -> dict[str, Any]:
        """JSON-able summary (NaN -> None)."""
        n = len(self.free)
        return {
            "method": "simulation-error refinement (output error, iwp.refine)",
            "model": self.model,
            "outputs": list(self.outputs),
            "loss": self.loss,
            "free": list(self.free),
            "parameters": {k: v.to_dict() for k, v in self.parameters.items()},
            "correlation": {self.free[i]: {self.free[j]: json_float(self.correlation[i, j]) for j in range(n)}
                            for i in range(n)},
            "experiments": [
                {
                    "source": self.sources[i] if i < len(self.sources) else None,
                    "window": list(self.windows[i]),
                    "x0": [json_float(v) for v in self.x0[i]],
                    "x0_stderr": [json_float(v) for v in self.x0_stderr[i]],
                    "fit": {k: json_float(v) for k, v in self.fit[i].items()},
                    "fit_start": {k: json_float(v) for k, v in self.fit_start[i].items()},
                    "rms": {k: json_float(v) for k, v in self.rms[i].items()},
                    "rms_start": {k: json_float(v) for k, v in self.rms_start[i].items()},
                    "offsets": ({k: {"value": json_float(v), "stderr": json_float(s)}
                                 for k, (v, s) in self.offsets[i].items()} if i < len(self.offsets) else {}),
                }
                for i in range(len(self.x0))
            ],
            "fit": [{k: json_float(v) for k, v in f.items()} for f in self.fit],
            "residual_std": {k: json_float(v) for k, v in self.residual_std.items()},
            "cost_start": json_float(self.cost_start),
            "cost": json_float(self.cost),
            "success": bool(self.success),
            "message": self.message,
            "nfev": int(self.nfev),
            "njev": int(self.njev),
            "n_samples": int(self.n_samples),
            "elapsed_s": json_float(self.elapsed),
            "warnings": list(self.warnings),
            "uncertainty": None if self.reliability is None else self.reliability.to_dict(),
            "lumped": self.params.to_dict(),
            **({"belt": self.belt.to_dict()} if self.belt is not None else {}),
        }

    def summary(self, warnings: bool = True) -> str:
        """A readable table of the refined parameters and the fit (and the warnings, unless ``warnings=False``:
        for a caller that issued them already, as ``iwp identify --refine`` does on stderr)."""
        lines = [f"simulation-error refinement, model {self.model!r}, outputs {', '.join(self.outputs)}, "
                 f"loss {self.loss}"]
        lines.append(f"{'parameter':<10} {'start':>12} {'refined':>12} {'stderr':>10}")
        for name in self.free:
            pe = self.parameters[name]
            first = getattr(self.belt_start if hasattr(self.belt_start, name) else self.start, name)
            lines.append(f"{name:<10} {first:>12.6g} {pe.value:>12.6g} {pe.stderr:>10.3g}")
        for i, f in enumerate(self.fit):
            fs = ", ".join(f"{k} {v:.2f} % (start {self.fit_start[i][k]:.2f} %)" for k, v in f.items())
            lines.append(f"experiment {i} [{self.windows[i][0]:g}, {self.windows[i][1]:g}] s: fit {fs}")
        if self.reliability is not None:
            lines.append(self.reliability.describe())
        lines.append(f"cost {self.cost_start:.6g} -> {self.cost:.6g}, {self.nfev} simulations, "
                     f"{self.njev} with sensitivities, {self.elapsed:.3g} s; {self.message}")
        for w in self.warnings if warnings else ():
            lines.append(f"warning: {w}")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()


def refine_report(residuals: OutputError, result: FitResult, start: Plant) -> RefineResult:
    """The :class:`RefineResult` of a solved simulation-error problem (per experiment and output).

    Parameters
    ----------
    residuals : OutputError
        The simulation-error problem (experiments, outputs, weights).
    result : FitResult
        Its solution: optimum, start, estimates with standard errors, covariance.
    start : Plant
        The plant the fit started from (its model and parameters).

    Returns
    -------
    RefineResult
        Estimated parameters, fits [%] and RMS errors [rad or rad/s] per experiment and output, at the start and
        at the optimum, initial states, offsets and the simulated signals.
    """
    est = result.parameters
    plant = start.with_values({n: est[n].value for n in residuals.model_parameter_names()})
    model_free = tuple(n for n in result.free if est[n].kind == "model")
    idx = [result.free.index(n) for n in model_free]
    sim, sim0 = residuals.predictions(result.optimum), residuals.predictions(result.start)
    fit, fit0, rms, rms0, x0s, x0_sd, offsets = [], [], [], [], [], [], []
    ssr = {o: 0.0 for o in residuals.outputs}
    cnt = {o: 0 for o in residuals.outputs}
    for p, yh, yh0, st0, x in zip(residuals.prepared, sim, sim0, result.start.status,
                                  residuals.states(result.optimum.values)):
        # the outputs this experiment compares (a clamped pendulum's angle is none of them)
        used = {o: p.w[o] > 0 for o in residuals.outputs if np.any(p.w[o] > 0)}
        fit.append({o: fit_percent(p.y[o][m], yh[o][m]) for o, m in used.items()})
        fit0.append({o: fit_percent(p.y[o][m], yh0[o][m]) if st0 == 0 else float("nan") for o, m in used.items()})
        rms.append({o: float(np.sqrt(np.mean((p.y[o] - yh[o])[m] ** 2))) for o, m in used.items()})
        rms0.append({o: float(np.sqrt(np.mean((p.y[o] - yh0[o])[m] ** 2))) if st0 == 0 else float("inf")
                     for o, m in used.items()})
        for o in residuals.outputs:
            ssr[o] += float(np.sum(((p.y[o] - yh[o]) * p.w[o]) ** 2))
            cnt[o] += int(np.count_nonzero(p.w[o]))
        x0s.append(x)
        sd = np.zeros(x.size)
        for s in p.est:
            sd[s] = est[x0_name(s, p.index)].stderr
        x0_sd.append(sd)
        offsets.append({o: (est[offset_name(o, p.index)].value, est[offset_name(o, p.index)].stderr)
                        for o in p.spec.offsets})
    return RefineResult(
        params=plant.lumped, parameters={n: est[n] for n in residuals.model_parameter_names()}, free=model_free,
        covariance=result.covariance[np.ix_(idx, idx)], correlation=result.correlation[np.ix_(idx, idx)],
        fit=fit, fit_start=fit0, rms=rms, rms_start=rms0, x0=x0s, x0_stderr=x0_sd,
        windows=[p.window for p in residuals.prepared], success=result.success, message=result.message,
        warnings=list(result.warnings), cost_start=result.cost_start, cost=result.cost, nfev=result.nfev,
        njev=result.njev, model=start.model, outputs=residuals.outputs, loss=result.loss, start=start.lumped,
        residual_std={o: math.sqrt(ssr[o] / max(cnt[o], 1)) for o in residuals.outputs},
        n_samples=residuals.n_rows // len(residuals.outputs), elapsed=result.elapsed,
        sources=[p.spec.data.source for p in residuals.prepared], simulated=sim,
        measured=[dict(p.y) for p in residuals.prepared], times=[p.t for p in residuals.prepared],
        weights=[dict(p.w) for p in residuals.prepared], offsets=offsets, belt=plant.belt, belt_start=start.belt,
        fit_result=result, reliability=result.reliability)


# --------------------------------------------------------------------------
# refine
# --------------------------------------------------------------------------
def refine(
    experiments,
    start,
    *,
    free: Sequence[str] = FREE_PENDULUM,
    outputs: Sequence[str] = ("q1",),
    bounds: Mapping[str, tuple[float | None, float | None]] | None = None,
    loss: str | Loss = "linear",
    options: SolverOptions | None = None,
    warn: bool = True,
) -> RefineResult:
    """Refine model parameters by minimising the simulation error of the measured outputs.

    Parameters
    ----------
    experiments : ExperimentData, Experiment or a sequence of them
        Logs fitted jointly, each with its kind, window, initial state and
        offsets (:func:`as_experiments` builds them from logs); each one's
        input (``u`` or ``v``, or none) is replayed with a zero-order hold.
    start : Plant or LumpedParameters
        The model and the starting point (e.g. a least-squares result,
        ``IdentificationResult.to_params()``; :func:`fit_plant` checks a model
        name); the fixed parameters keep these values. Parameters alone stand
        for model (9).
    free : sequence of str
        Parameters to estimate; every other parameter stays at its ``start`` value.
        Empty: estimate the initial states only.
    outputs : sequence of str
        Measured signals compared: ``q1``, ``q2`` and the velocities ``q3``,
        ``q4`` (from the log, else differentiated). Each output is weighted
        by the inverse of its spread over the data.
    bounds : dict, optional
        ``{name: (low, high)}`` for free parameters (``None`` for no bound).
        Default: the physical signs (:data:`iwp.models.parameters.PARAMETER_INFO`):
        ``p1, p3, rho > 0``, ``u_offset`` free, the other parameters ``>= 0``.
    loss : str or Loss
        ``"linear"`` or a robust loss (:class:`~iwp.ident.problem.Loss`, with its residual scale).
    options : SolverOptions, optional
        Tolerances of the optimiser and of the simulations, most evaluations.
    warn : bool
        Also issue the warnings with :func:`warnings.warn` (they are always in ``.warnings``).

    Returns
    -------
    RefineResult

    Raises
    ------
    InputError
        A model refine does not fit, an unknown parameter or output, a
        parameter that does not enter the model, bad bounds or windows, an
        output constant in every experiment.

    Notes
    -----
    Other rigs' sensors are read from each log: a wheel speed ``q4`` logged
    as the mean over the preceding sample period (metadata ``q4_sampling:
    mean``) is compared with ``(q2(t_k) - q2(t_k-1)) / Ts`` of the model,
    and samples replaced as glitches (:attr:`ExperimentData.glitches`) are
    left out of the residuals.

    Examples
    --------
    The least squares of section 5.2 on 5 s of the virtual rig's free pendulum, refined by simulation error
    (the twin's truth: ``p1 = 26.47``):

    >>> from iwp import identify, refine
    >>> from iwp.ident import fit_plant
    >>> from iwp.rig import run_experiment
    >>> log = run_experiment("free-pendulum", duration=5.0)
    >>> ls = identify(log, "free")
    >>> res = refine(log, fit_plant(ls.to_params(), "free"), free=["p1", "sigma_b1"], warn=False)
    >>> round(ls.value("p1"), 2), round(res.value("p1"), 2)
    (26.36, 26.47)
    >>> round(res.fit_start[0]["q1"], 1), round(res.fit[0]["q1"], 1)  # fit of q1 [%]
    (98.3, 99.9)
    """
    plant = start if isinstance(start, Plant) else fit_plant(start)
    if plant.model not in REFINE_MODELS and plant.belt is None:
        fit_plant(plant.lumped, plant.model)  # the error that names the models
    loss = loss if isinstance(loss, Loss) else Loss(loss)
    if plant.belt is None:
        options = options or SolverOptions()
        model = OutputError(plant, as_experiments(experiments), tuple(outputs), rtol=options.rtol, atol=options.atol)
        params = model.parameters(free, bounds)
    else:  # the belt's play is not smooth: forward differences of whole simulations, its parameters on a log scale
        options = options or BELT_OPTIONS
        model = OutputError(plant, as_experiments(experiments), tuple(outputs), rtol=options.rtol, atol=options.atol,
                            differences=difference_step(options.rtol))
        params = model.parameters(free, bounds, log=tuple(n for n in free if PARAMETER_INFO[n].owner == "belt"))
    res = refine_report(model, solve_output_error(model, params, loss, options), plant)
    if plant.belt is not None and res.reliability is not None:
        res = dataclasses.replace(res, reliability=dataclasses.replace(
            res.reliability, notes=[*res.reliability.notes, belt_note(options.rtol)]))
    if warn:
        for m in res.warnings:
            _warnings.warn(m, stacklevel=2)
    return res


# --------------------------------------------------------------------------
# refine after an identification set-up
# --------------------------------------------------------------------------
def _has_no_wheel(exps: list[ExperimentData]) -> bool:
    """Logs of a pendulum without a wheel: angle logs (``source_format: angle-log``) or ``wheel: none``."""
    def nowheel(e):
        m = e.metadata
        return m.get("source_format") == "angle-log" or m.get("wheel", "").lower() in ("none", "no")
    return all(nowheel(e) for e in exps)


def refine_identification(setup: str, experiments, start: LumpedParameters, *,
                          window: tuple[float | None, float | None] = (None, None),
                          options: SolverOptions | None = None, warn: bool = True) -> RefineResult:
    """Refine the result of an identification set-up by simulation error.

    Picks the model, the free parameters and the outputs from the set-up's
    :attr:`~iwp.ident.setups.Setup.refine` (:data:`iwp.ident.setups.SETUPS`):

    ======================  ===============  ========================================  =========
    set-up                  model            free                                      outputs
    ======================  ===============  ========================================  =========
    ``free``                free (1)         p1, sigma_a1, sigma_v1, sigma_b1          q1
    ``motor-disk``          motor-disk       p2, p3 (rho fixed)                        q4
    ``motor-disk-coulomb``  motor-disk       p2, p3, sigma_c2                          q4
    ``full``                compensated      p1, p2, p3, rho, sigma_a1/v1/b1           q1, q4
    ``two-step``            compensated      p2, p3, rho                               q1, q4
    ``dead-zone``           motor-disk-raw   p2, p3, v_dz_pos, v_dz_neg                q4
    ======================  ===============  ========================================  =========

    (1) ``"free-nowheel"`` when every log is of a pendulum without a wheel
    (angle logs, or metadata ``wheel: none``). ``q4`` is the differentiated
    disk angle when the log has no velocity. Initial states are estimated
    per experiment; ``window`` (t_start, t_end) [s] windows every experiment.

    Parameters
    ----------
    setup : str
        A set-up of section 5 (the table above).
    experiments : ExperimentData or Experiment or sequence of them
        The logs the model is fitted to.
    start : LumpedParameters
        Start values, e.g. the set-up's least squares (``identify(...).to_params()``).
    window : (float or None, float or None)
        Time window [s] of every experiment.
    options : SolverOptions, optional
        Settings of the least-squares solver.
    warn : bool
        Also issue the result's warnings with :func:`warnings.warn`.

    Returns
    -------
    RefineResult
        The refined parameters with their covariance, fit [%] per output and
        experiment, and warnings.

    See Also
    --------
    refine : The same with the model, free parameters and outputs chosen by hand.

    Examples
    --------
    Set-up ``"free"`` (figure 8) on 5 s of the virtual rig, from the least squares (the twin's truth:
    ``p1 = 26.47``):

    >>> from iwp import identify, refine_identification
    >>> from iwp.rig import run_experiment
    >>> log = run_experiment("free-pendulum", duration=5.0)
    >>> res = refine_identification("free", log, identify(log, "free").to_params(), warn=False)
    >>> res.model, res.free
    ('free', ('p1', 'sigma_a1', 'sigma_v1', 'sigma_b1'))
    >>> round(res.value("p1"), 2), round(res.fit[0]["q1"], 1)  # fit of q1 [%]
    (26.47, 99.9)
    """
    spec = get_setup(setup).refine
    items = [experiments] if not isinstance(experiments, (list, tuple)) else list(experiments)
    if any(isinstance(e, StaticCurve) for e in items):
        raise InputError(f"set-up {setup!r} was identified from static curves; there is no time series to "
                         "simulate, so there is nothing to refine by simulation error")
    exps = as_experiments(items, windows=tuple(window))
    model = spec.model
    if setup == "free" and _has_no_wheel([e.data for e in exps]):
        model = "free-nowheel"
    if setup in ("full", "two-step") and all(e.data.metadata.get("pendulum") == "locked" for e in exps):
        raise InputError(f"set-up {setup!r} needs the pendulum free; these logs have it locked")
    return refine(exps, fit_plant(start, model), free=spec.free, outputs=spec.outputs, options=options, warn=warn)


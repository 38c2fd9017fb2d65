"""Simulation-error identification: refine parameters so that the simulated outputs match the logs.

Least squares on differentiated data (:mod:`iwp.identify`, the paper's (13))
is fast and needs no starting point, but the regressors carry the noise and
the quantisation of the encoders and the filter of the differentiator, which
biases the estimates; friction terms that differ little over the data (the
paper's free-decay numbers, section 5.2) are not separated. :func:`refine`
starts from such an estimate and minimises the *simulation error* of the
measured outputs (the output-error criterion of MATLAB's ``nlgreyest``):

    minimise  sum_e sum_o sum_k  rho( (y_o,e(t_k) - y^_o,e(t_k; theta, x0_e)) / s_o )^2

over the free parameters ``theta`` of any model variant of
:mod:`iwp.models` (each parameter fixed or free, with bounds) and the
initial state ``x0_e`` of every experiment ``e`` (positions and velocities
at the start of its time window), jointly over several experiments, with an
optional robust loss ``rho`` (:func:`scipy.optimize.least_squares`'s
``loss=``). ``s_o`` is the spread (standard deviation) of output ``o`` over
the data, so that outputs in different units weigh alike.

The simulator and its Jacobian
------------------------------
Every simulation, and every Jacobian, is a run of the one compiled engine
(:func:`iwp.sim.sensitivity.simulate_sensitivities`, adaptive DOP853): the
forward sensitivities ``dx/dtheta`` and ``dx/dx0`` ride along with the
states (the variational equations ``S' = (df/dx) S + df/dtheta``, with the
Jacobians of the model's one compiled right-hand side taken by forward
differences), at the tolerances ``rtol``/``atol`` (1e-8 by default: the
simulated outputs are then far more accurate than the encoder step,
3.1e-3 rad). The input is replayed with a zero-order hold on the log's
sample grid (:class:`~iwp.sim.inputs.Sampled`), exactly as a digital rig
applies it; the integration restarts at every sample, so no step straddles
an input jump.

Model variants (``model=``)
---------------------------
``"free"``
    Free pendulum, motor off, the wheel held to the arm by the friction of
    its drive (``q4 = 0``): the arm then carries the wheel's inertia, and
    model (9) gives ``q3' = -xi rho/(1 + rho)`` (computed from ``_rhs``
    as ``q3' + q4'/(1 + rho)`` at ``q4 = 0``). This is the paper's
    free-pendulum experiment on a rig whose belt-driven disk does not turn
    (the virtual rig's). The parameters are those of model (9).
``"free-nowheel"``
    A pendulum without a wheel (or with a wheel that turns freely without
    torque): ``q3' = -xi``, the paper's free-pendulum equation (section
    5.2) taken literally; ``rho`` plays no role. Use it for logs of plain
    pendulums such as the angle logs read by :func:`iwp.io.read_angle_log`.
``"compensated"``
    Model (9), input ``u`` (``locked=True``: the pendulum clamped, section 5.1).
``"raw"``
    Model (6), input ``v`` through the dead zone (5).
``"motor-disk"``, ``"motor-disk-raw"``
    Model (14), input ``u`` or ``v``.

The input of every experiment is its logged ``u`` (models with input ``u``)
or ``v`` (raw models), replayed with a zero-order hold; a log without input
replays zero.

Uncertainty
-----------
At the optimum, the covariance of the free parameters and initial states is
``(J^T W J)^-1`` with ``W`` the inverse residual variance of each output
(estimated from the residuals), computed from the singular value
decomposition of the weighted Jacobian (never by inverting ``J^T J``).
Simulation residuals are correlated in time (model error, quantisation), so
these standard errors are a lower bound of the true spread. Pairs of free
parameters whose correlation exceeds 0.95 in magnitude, and directions that
the data do not determine (a rank-deficient Jacobian), are reported in
:attr:`RefineResult.warnings` (and with :func:`warnings.warn`).
"""

from __future__ import annotations

import math
import time
import warnings as _warnings
from dataclasses import dataclass, field, fields
from typing import Any, Mapping, Sequence

import numpy as np
from scipy import optimize, stats

from ..data import ExperimentData, StaticCurve
from ..errors import InputError
from ..files import json_float
from ..models.layout import LUMPED_INDEX
from ..models.parameters import TYPICAL, BeltParameters, LumpedParameters
from ..models.plant import MODELS, ModelInfo, Plant
from ..sim.inputs import Sampled
from ..sim.sensitivity import simulate_sensitivities
from .differentiate import Differentiator
from .fit import fit_percent
from .lsq import ParameterEstimate, null_space_message
from .setups import get_setup

__all__ = [
    "refine",
    "refine_identification",
    "RefineResult",
    "REFINE_MODELS",
    "fit_percent",
    "simulation_equivalent",
    "measured_signals",
    "measured_state",
    "initial_state",
]

# --------------------------------------------------------------------------
# models and parameters
# --------------------------------------------------------------------------
_FREE_PARAMS = ("p1", "sigma_a1", "sigma_v1", "sigma_b1", "sigma_c1")
_LUMPED_ALL = ("p1", "p2", "p3", "rho", "sigma_a1", "sigma_v1", "sigma_b1", "sigma_c2", "sigma_c1", "u_offset")
_MD = ("p2", "p3", "rho", "sigma_c2", "u_offset")
#: The models :func:`refine` fits, and the parameters that enter each (see the module docstring).
REFINE_MODELS: dict[str, tuple[str, ...]] = {
    "free": _FREE_PARAMS,
    "free-nowheel": _FREE_PARAMS,
    "compensated": _LUMPED_ALL,
    "raw": _LUMPED_ALL + ("v_dz_pos", "v_dz_neg"),
    "motor-disk": _MD,
    "motor-disk-raw": _MD + ("v_dz_pos", "v_dz_neg"),
}
_POSITIVE = ("p1", "p3", "rho")
_SIGNED = ("u_offset",)
_STATE_NAMES = ("q1", "q2", "q3", "q4")
_OUTPUTS = {"q1": 0, "q2": 1, "q3": 2, "q4": 3}
_LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")
#: |correlation| above which two free parameters are reported as not told apart.
CORR_WARN = 0.95
#: Relative singular value below which a direction counts as not determined.
RCOND = 1e-8
_BAD_RESIDUAL = 1e6


def _check_model(model: str) -> ModelInfo:
    if not isinstance(model, str) or model not in REFINE_MODELS:
        extra = ""
        if isinstance(model, str) and model in MODELS:
            extra = f" ({model!r} needs other parameters than LumpedParameters; refine does not fit it)"
        raise InputError(f"model must be one of {', '.join(REFINE_MODELS)}, got {model!r}{extra}")
    return MODELS[model]


def _is_locked(model: str, locked: bool) -> bool:
    return model.startswith("motor-disk") or locked


def replay(data: ExperimentData, input_name: str | None):
    """A log's input ``u`` or ``v`` replayed with a zero-order hold on its sample grid, or ``None``."""
    if input_name is None or data.input_name is None:
        return None
    return Sampled(np.asarray(getattr(data, input_name), dtype=float), data.Ts, float(data.t[0]))


def simulation_equivalent(model: str, params: LumpedParameters) -> tuple[str, LumpedParameters]:
    """The model and parameters that :func:`iwp.sim.simulate` runs for ``model``: the same ones.

    Every model that :func:`refine` fits (the free pendulum included) is a
    model of :mod:`iwp.models`; kept so that callers need not know it.
    """
    _check_model(model)
    return model, params


def model_input(model: str) -> str | None:
    """The logged input a model replays: ``"u"``, ``"v"`` or None (no input)."""
    return _check_model(model).input


# --------------------------------------------------------------------------
# fit measure
# --------------------------------------------------------------------------
# --------------------------------------------------------------------------
# experiments
# --------------------------------------------------------------------------
_DIFF = Differentiator("savgol", window=21, polyorder=3)


def measured_signals(data: ExperimentData, names: Sequence[str], differentiator: Differentiator | None = None
                     ) -> dict[str, np.ndarray]:
    """Measured ``q1, q2`` and velocities ``q3, q4`` of a log.

    Velocities come from the log's ``q3``/``q4`` columns when present, else
    from differentiating the positions (Savitzky-Golay, 21 samples, cubic, by
    default).
    """
    out: dict[str, np.ndarray] = {}
    d = differentiator or _DIFF
    for n in names:
        if n not in _OUTPUTS:
            raise InputError(f"unknown signal {n!r}; choose among q1, q2, q3, q4")
        if n in ("q1", "q2"):
            if getattr(data, n) is None:
                raise InputError(f"{data.source} has no wheel angle q2 (only the wheel speed q4); use the output q4")
            out[n] = np.asarray(getattr(data, n), dtype=float)
        else:
            col = getattr(data, n)
            if col is not None:
                out[n] = np.asarray(col, dtype=float)
            else:
                pos = getattr(data, "q1" if n == "q3" else "q2")
                if pos is None:
                    raise InputError(f"{data.source} logs neither q2 nor q4; the output q4 cannot be formed")
                out[n] = d.derivatives(data.Ts, pos).velocity
    return out


def measured_state(data: ExperimentData, index: int, differentiator: Differentiator | None = None) -> np.ndarray:
    """The state ``[q1, q2, q3, q4]`` of a log at sample ``index``: smoothed positions, differentiated velocities."""
    d = differentiator or _DIFF
    q = np.column_stack([data.q1, data.q2 if data.q2 is not None else np.zeros_like(data.q1)])
    if data.n_samples >= d.min_samples(data.Ts):
        pos, vel, _ = d.derivatives(data.Ts, q)
    else:  # too short to filter: plain central differences
        pos = q
        vel = np.gradient(q, data.t, axis=0)
    x = np.array([pos[index, 0], pos[index, 1], vel[index, 0], vel[index, 1]])
    if data.q3 is not None:
        x[2] = data.q3[index]
    if data.q4 is not None:
        x[3] = data.q4[index]
        if data.q4_sampling == "mean" and index + 2 < data.n_samples:
            # samples are means over the preceding periods (at t_k - Ts/2): the speed at t_k lies between two
            # of them; the first sample has no preceding period, extrapolate the next two
            y = data.q4
            x[3] = 0.5 * (y[index] + y[index + 1]) if index > 0 else 1.5 * y[1] - 0.5 * y[2]
    return x


def initial_state(data: ExperimentData, index: int, model: str, *, locked: bool = False,
                  differentiator: Differentiator | None = None) -> np.ndarray:
    """The measured state of a log at sample ``index`` as the state of ``model``.

    Positions smoothed and velocities differentiated (:func:`measured_state`);
    the held wheel of the free-pendulum variants has ``q4 = 0``; a locked
    pendulum (motor-disk models, ``locked=True``) has ``q1 = q3 = 0``.
    """
    info = _check_model(model)
    x = measured_state(data, index, differentiator)
    if info.input is None:
        x[3] = 0.0
    if model.startswith("motor-disk") or locked:
        x[0] = 0.0
        x[2] = 0.0
    return x


@dataclass
class _FitLog:
    data: ExperimentData  # the windowed log
    t: np.ndarray
    input: Sampled | None  # the logged input, held over each sample
    y: dict[str, np.ndarray]
    x0_guess: np.ndarray
    est: tuple[int, ...]
    window: tuple[float, float]
    #: per output: weight of each sample (0 at replaced glitches and where a mean has no preceding period)
    w: dict[str, np.ndarray] = field(default_factory=dict)
    #: outputs logged as the mean over the preceding sample period (``q4_sampling: mean``)
    mean: tuple[str, ...] = ()
    #: per estimated output offset, its start value
    off0: dict[str, float] = field(default_factory=dict)
    Ts: float = 0.0

    def predict(self, o: str, X: np.ndarray) -> np.ndarray:
        """The model's output ``o`` from states ``X`` (N, n) or sensitivities (N, n, k): the state, or for a
        mean-sampled speed the difference of its angle over the preceding period over ``Ts``."""
        si = _OUTPUTS[o]
        if o in self.mean:
            pos = X[:, si - 2]
            out = np.empty_like(X[:, si])
            out[1:] = (pos[1:] - pos[:-1]) / self.Ts
            out[0] = X[0, si]  # weight 0
            return out
        return X[:, si]


def _as_list(experiments) -> list[ExperimentData]:
    if isinstance(experiments, ExperimentData):
        exps = [experiments]
    else:
        try:
            exps = list(experiments)
        except TypeError:
            raise InputError(f"experiments must be an ExperimentData or a list of them, got "
                             f"{type(experiments).__name__}") from None
    if not exps:
        raise InputError("no experiments given")
    for i, e in enumerate(exps):
        if not isinstance(e, ExperimentData):
            raise InputError(f"experiments[{i}] must be an ExperimentData (time series log), got {type(e).__name__}")
    return exps


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


def _prepare_experiment(data: ExperimentData, info: ModelInfo, model: str, window, outputs, estimate_x0: bool,
                        locked: bool, i: int, offsets: tuple[str, ...] = ()) -> _FitLog:
    t_start, t_end = window
    wdata = data.window(t_start, t_end)
    i0 = int(np.searchsorted(data.t, wdata.t[0]))
    n_min = 10
    if wdata.n_samples < n_min:
        raise InputError(f"experiment {i} ({data.source}): the window keeps {wdata.n_samples} samples, "
                         f"at least {n_min} are needed")
    # input replay
    name = data.input_name
    if info.input is not None and name is not None and name != info.input:
        hint = ("a compensated model ('compensated', 'motor-disk')" if name == "u"
                else "a raw model ('raw', 'motor-disk-raw')")
        raise InputError(f"experiment {i} ({data.source}) logs the input {name!r} but model {model!r} "
                         f"takes {info.input!r}; use {hint}")
    w = replay(wdata, info.input)
    # measured outputs (velocities differentiated on the whole log, then windowed)
    full = measured_signals(data, outputs)
    y = {o: np.ascontiguousarray(full[o][i0:i0 + wdata.n_samples]) for o in outputs}
    x0 = initial_state(data, i0, model, locked=locked)
    moving = (1, 3) if _is_locked(model, locked) else info.moving
    est: tuple[int, ...] = ()
    mean = tuple(o for o in outputs if o == "q4" and data.q4 is not None and data.q4_sampling == "mean")
    if estimate_x0:
        # q2 enters no right-hand side: estimate it only when it is an output (or a mean speed needs it)
        est = tuple(s for s in moving if s != 1 or "q2" in outputs)
    weights = {}
    for o in outputs:
        wt = np.ones(wdata.n_samples)
        col = "q2" if o == "q4" and data.q4 is None else ("q1" if o == "q3" and data.q3 is None else o)
        wt[data.glitch_mask(col)[i0:i0 + wdata.n_samples]] = 0.0
        if o in mean:
            wt[0] = 0.0
        weights[o] = wt
    off0 = {o: 0.0 for o in offsets}
    return _FitLog(wdata, np.ascontiguousarray(wdata.t, dtype=float), w, y, x0, est,
                   (float(wdata.t[0]), float(wdata.t[-1])), weights, mean, off0, float(wdata.Ts))


# --------------------------------------------------------------------------
# result
# --------------------------------------------------------------------------

@dataclass(eq=False)
class RefineResult:
    """The outcome of :func:`refine`.

    Attributes
    ----------
    params : LumpedParameters
        Refined values of the free parameters, the others from ``start``.
    parameters : dict of str to ParameterEstimate
        Every parameter of ``params``: value, standard error, 95 % interval
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
    x0 : list of ndarray, shape (4,)
        Initial state of each experiment at the start of its window (estimated or from the data).
    x0_stderr : list of ndarray, shape (4,)
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
    """

    params: LumpedParameters
    parameters: dict[str, ParameterEstimate]
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
    #: the belt models (``model="belt"``, :func:`iwp.ident.belt_fit.refine_belt`): the fitted belt and its start
    belt: BeltParameters | None = None
    belt_start: BeltParameters | None = None

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
            "lumped": self.params.to_dict(),
            **({"belt": self.belt.to_dict()} if self.belt is not None else {}),
        }

    def summary(self) -> str:
        """A readable table of the refined parameters and the fit."""
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
        lines.append(f"cost {self.cost_start:.6g} -> {self.cost:.6g}, {self.nfev} simulations, "
                     f"{self.njev} with sensitivities, {self.elapsed:.3g} s; {self.message}")
        for w in self.warnings:
            lines.append(f"warning: {w}")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()


# --------------------------------------------------------------------------
# refine
# --------------------------------------------------------------------------
def _check_bounds(free, bounds, start: LumpedParameters) -> tuple[np.ndarray, np.ndarray]:
    lo = np.empty(len(free))
    hi = np.empty(len(free))
    bounds = {} if bounds is None else dict(bounds)
    unknown = sorted(set(bounds) - set(free))
    if unknown:
        raise InputError(f"bounds given for {', '.join(unknown)}, which is not free (free: {', '.join(free)})")
    for i, n in enumerate(free):
        if n in bounds:
            try:
                a, b = bounds[n]
            except (TypeError, ValueError):
                raise InputError(f"bounds[{n!r}] must be a pair (low, high), got {bounds[n]!r}") from None
            a = -np.inf if a is None else float(a)
            b = np.inf if b is None else float(b)
            if not a < b or math.isnan(a) or math.isnan(b):
                raise InputError(f"bounds[{n!r}] = ({a}, {b}): low must be < high")
        else:
            # physical signs (LumpedParameters.check_physical); an input offset has either sign
            a = 1e-12 * TYPICAL[n] if n in _POSITIVE else (-np.inf if n in _SIGNED else 0.0)
            b = np.inf
        lo[i], hi[i] = a, b
    return lo, hi


def refine(
    experiments,
    start: LumpedParameters,
    *,
    model: str = "compensated",
    free: Sequence[str] = ("p1", "sigma_a1", "sigma_v1", "sigma_b1"),
    bounds: Mapping[str, tuple[float | None, float | None]] | None = None,
    outputs: Sequence[str] = ("q1",),
    estimate_x0: bool = True,
    windows=None,
    loss: str = "linear",
    locked: bool = False,
    f_scale: float | None = None,
    max_nfev: int | None = None,
    x0=None,
    tol: float = 1e-6,
    rtol: float = 1e-8,
    atol: float = 1e-8,
    tr_solver: str = "exact",
    warn: bool = True,
    output_offsets: Sequence[str] = (),
    belt: BeltParameters | None = None,
) -> RefineResult:
    """Refine model parameters by minimising the simulation error of the measured outputs.

    Parameters
    ----------
    experiments : ExperimentData or sequence of ExperimentData
        Logs fitted jointly; each one's input (``u`` or ``v``, or none) is
        replayed with a zero-order hold.
    start : LumpedParameters
        Starting point (e.g. a least-squares result, ``IdentificationResult.to_params()``);
        the fixed parameters keep these values.
    model : str
        One of :data:`REFINE_MODELS` (see the module docstring).
    free : sequence of str
        Parameters to estimate; every other parameter stays at its ``start`` value.
        Empty: estimate the initial states only.
    bounds : dict, optional
        ``{name: (low, high)}`` for free parameters (``None`` for no bound).
        Default: ``p1, p3, rho > 0``, ``u_offset`` free, the other parameters ``>= 0``.
    outputs : sequence of str
        Measured signals compared: ``q1``, ``q2`` and the velocities ``q3``,
        ``q4`` (from the log, else differentiated). Each output is weighted
        by the inverse of its spread over the data.
    estimate_x0 : bool
        Estimate the initial state of each experiment (positions and
        velocities at the window start) together with the parameters.
        Otherwise use the measured state (smoothed positions, differentiated
        velocities).
    windows : (t_start, t_end) or list of them, optional
        Time window [s] per experiment (``None`` for an open end); one pair applies to all.
    loss : {"linear", "soft_l1", "huber", "cauchy", "arctan"}
        Robust loss of :func:`scipy.optimize.least_squares`.
    locked : bool
        Pendulum clamped (models ``"compensated"``/``"raw"``).
    f_scale : float, optional
        Residual scale of a robust loss, in units of each output's spread
        (residuals beyond it count as outliers). Default: a first fit with the
        linear loss, then 2.5 robust standard deviations (1.4826 x the median
        absolute deviation) of its residuals, and the robust fit from there.
    max_nfev : int, optional
        Most simulations (default 100 x (number of unknowns + 1)).
    x0 : list of array_like, optional
        Initial-state guesses per experiment (default: from the data).
    tol : float
        ``ftol``, ``xtol`` and ``gtol`` of ``least_squares`` (1e-6: the parameters then stop moving by
        far less than their standard errors).
    rtol, atol : float
        Tolerances of the simulations (:func:`~iwp.sim.sensitivity.simulate_sensitivities`).
    tr_solver : {"exact", "lsmr"}
        Trust-region subproblem solver of ``least_squares``: ``"exact"`` (an
        SVD of the Jacobian per iteration; robust, the default) or
        ``"lsmr"`` (products with the Jacobian only; cheaper per iteration
        on long logs, but needs many more iterations on ill-conditioned
        problems such as Coulomb friction).
    warn : bool
        Also issue the warnings with :func:`warnings.warn` (they are always in ``.warnings``).
    output_offsets : sequence of str
        Outputs whose sensor has an unknown constant offset (``("q1",)``: a
        pendulum angle whose zero is a few hundredths off), estimated per
        experiment: the model's output is ``y^ + offset``.
    belt : BeltParameters, optional
        ``model="belt"`` (the rubber belt (15), pendulum locked): the belt's
        starting values. The fit is then :func:`iwp.ident.belt_fit.refine_belt`
        (``free`` among its parameters, output ``q4``, Jacobian by finite
        differences of whole simulations, for the play of figure 5 is not smooth);
        the defaults of ``free`` and ``outputs``, which concern the pendulum
        that this model locks, become the belt's (:data:`~iwp.ident.belt_fit.BELT_FREE`, ``q4``).

    Other rigs' sensors are read from each log: a wheel speed ``q4`` logged
    as the mean over the preceding sample period (metadata ``q4_sampling:
    mean``) is compared with ``(q2(t_k) - q2(t_k-1)) / Ts`` of the model,
    and samples replaced as glitches (:attr:`ExperimentData.glitches`) are
    left out of the residuals.

    Returns
    -------
    RefineResult

    Raises
    ------
    InputError
        Unknown model, parameter or output; a parameter that does not enter
        the model; bad bounds or windows; an output constant in every experiment.
    """
    if model == "belt" or belt is not None:
        from .belt_fit import BELT_FREE, refine_belt

        if model != "belt" or belt is None:
            raise InputError("the belt model (15) is fitted with model='belt' and belt=BeltParameters(...)")
        free = BELT_FREE if tuple(free) == _FREE_PARAMS[:4] else free
        outputs = ("q4",) if tuple(outputs) == ("q1",) else outputs
        if tuple(outputs) != ("q4",):
            raise InputError(f"the belt model is fitted to the disk velocity: outputs must be ('q4',), got {outputs!r}")
        return refine_belt(experiments, start, belt, free=free, bounds=bounds, windows=windows, max_nfev=max_nfev,
                           tol=tol, rtol=rtol, atol=atol, warn=warn)
    t_begin = time.perf_counter()
    info = _check_model(model)
    if not isinstance(start, LumpedParameters):
        raise InputError(f"start must be LumpedParameters, got {type(start).__name__}")
    if tr_solver not in ("exact", "lsmr"):
        raise InputError(f"tr_solver must be 'exact' or 'lsmr', got {tr_solver!r}")
    if loss not in _LOSSES:
        raise InputError(f"loss must be one of {', '.join(_LOSSES)}, got {loss!r}")
    if isinstance(free, str):
        free = (free,)
    free = tuple(free)
    for n in free:
        if n not in LUMPED_INDEX:
            raise InputError(f"unknown parameter {n!r}; free parameters are among {', '.join(LUMPED_INDEX)}")
        if n not in REFINE_MODELS[model]:
            raise InputError(f"parameter {n!r} does not enter model {model!r} (its parameters: "
                             f"{', '.join(REFINE_MODELS[model])}); fix it or choose another model")
    if len(set(free)) != len(free):
        raise InputError(f"free lists a parameter twice: {free}")
    if locked and model not in ("compensated", "raw"):
        raise InputError(f"locked=True applies to models 'compensated' and 'raw', not {model!r}")
    if isinstance(outputs, str):
        outputs = (outputs,)
    outputs = tuple(outputs)
    if not outputs:
        raise InputError("outputs is empty")
    for o in outputs:
        if o not in _OUTPUTS:
            raise InputError(f"unknown output {o!r}; choose among q1, q2, q3, q4")
    if info.input is None and any(o in ("q2", "q4") for o in outputs):
        raise InputError(f"model {model!r} has no wheel motion; its outputs are q1 and q3")
    if _is_locked(model, locked) and any(o in ("q1", "q3") for o in outputs):
        raise InputError("the pendulum is locked in this model; its outputs are q2 and q4")
    exps_in = _as_list(experiments)
    wins = _windows(windows, len(exps_in))
    if isinstance(output_offsets, str):
        output_offsets = (output_offsets,)
    output_offsets = tuple(output_offsets)
    for o in output_offsets:
        if o not in outputs:
            raise InputError(f"output_offsets names {o!r}, which is not an output ({', '.join(outputs)})")
    exps = [_prepare_experiment(e, info, model, w, outputs, estimate_x0, locked, i, output_offsets)
            for i, (e, w) in enumerate(zip(exps_in, wins))]
    if x0 is not None:
        x0l = list(x0)
        if len(x0l) != len(exps):
            raise InputError(f"x0 must give one initial state per experiment ({len(exps)}), got {len(x0l)}")
        for e, g in zip(exps, x0l):
            g = np.asarray(g, dtype=float).ravel()
            if g.size != 4 or not np.all(np.isfinite(g)):
                raise InputError(f"each x0 guess must be 4 finite numbers, got {g.tolist()}")
            e.x0_guess = g.copy()

    # output weights: the spread of each output over the data
    scale_o = {}
    for o in outputs:
        v = np.mean([np.var(e.y[o][e.w[o] > 0]) for e in exps])
        if not v > 0:
            raise InputError(f"output {o} is constant in every experiment (nothing to fit); choose other outputs")
        scale_o[o] = math.sqrt(v)

    plant0 = Plant(start, model=model, locked=locked)
    theta0 = np.array([getattr(start, n) for n in free], dtype=float)
    lo, hi = _check_bounds(free, bounds, start)
    msgs: list[str] = []
    clipped = np.clip(theta0, lo, hi)
    for i, n in enumerate(free):
        if clipped[i] != theta0[i]:
            msgs.append(f"start value {n} = {theta0[i]:.6g} is outside its bounds [{lo[i]:.6g}, {hi[i]:.6g}]; "
                        f"started from {clipped[i]:.6g}")
    theta0 = clipped
    pscale = np.array([max(abs(v), TYPICAL[n] * 1e-3) if v != 0 else TYPICAL[n] for v, n in zip(theta0, free)])
    npar = len(free)

    # unknowns z = [theta / pscale, x0 of each experiment (estimated components)]
    xoff = []
    k = npar
    for e in exps:
        xoff.append(k)
        k += len(e.est) + len(output_offsets)
    nz = k
    x_scale_state = np.array([1.0, 1.0, 1.0, 1.0])
    z0 = np.empty(nz)
    z0[:npar] = theta0 / pscale
    zlo = np.full(nz, -np.inf)
    zhi = np.full(nz, np.inf)
    zlo[:npar] = lo / pscale
    zhi[:npar] = hi / pscale
    for e, off in zip(exps, xoff):
        for j, s in enumerate(e.est):
            z0[off + j] = e.x0_guess[s] / x_scale_state[s]
        for j, o in enumerate(output_offsets):
            z0[off + len(e.est) + j] = e.off0[o]
    n_rows = sum(e.t.size * len(outputs) for e in exps)
    if n_rows <= nz:
        raise InputError(f"{n_rows} residuals for {nz} unknowns: give longer windows or fewer free parameters")

    counters = {"nfev": 0, "njev": 0}

    def unpack(z):
        theta = z[:npar] * pscale
        x0s = []
        for e, off in zip(exps, xoff):
            x = e.x0_guess.copy()
            for j, s in enumerate(e.est):
                x[s] = z[off + j] * x_scale_state[s]
            x0s.append(x)
        return theta, x0s

    def offsets_of(z):
        return [{o: float(z[off + len(e.est) + j]) for j, o in enumerate(output_offsets)}
                for e, off in zip(exps, xoff)]

    def simulate_all(z, sens: bool):
        """Per experiment ``(status, X (N, 4), S (N, 4, npar + len(est)))``, one engine run each."""
        theta, x0s = unpack(z)
        plant = plant0.with_params(start.replace(**dict(zip(free, (float(v) for v in theta)))))
        out = []
        for e, x0e in zip(exps, x0s):
            r = simulate_sensitivities(plant, t_eval=e.t, t0=float(e.t[0]), x0=x0e, input=e.input,
                                       wrt=free if sens else (), wrt_x0=e.est if sens else (), rtol=rtol, atol=atol,
                                       check=False)
            out.append((r.status, r.x, r.S))
        return out

    def residuals_of(sims, z):
        parts = []
        for e, (status, X, _S), offs in zip(exps, sims, offsets_of(z)):
            for o in outputs:
                r = e.w[o] * (e.predict(o, X) + offs.get(o, 0.0) - e.y[o]) / scale_o[o]
                if status != 0:
                    r = np.where(np.isfinite(r), r, _BAD_RESIDUAL)
                parts.append(r)
        return np.concatenate(parts)

    cache: dict[str, Any] = {}

    def fun(z):
        key = z.tobytes()
        if cache.get("fun_key") == key:
            return cache["fun_r"].copy()
        counters["nfev"] += 1
        sims = simulate_all(z, False)
        r = residuals_of(sims, z)
        cache["fun_key"], cache["fun_r"] = key, r
        cache["fun_X"] = [X.copy() for (_st, X, _S) in sims]
        cache["fun_status"] = [st for (st, _X, _S) in sims]
        return r.copy()

    def jac(z):
        counters["njev"] += 1
        sims = simulate_all(z, True)
        cache["jac_key"] = z.tobytes()
        cache["jac_r"] = residuals_of(sims, z)
        cache["jac_X"] = [X.copy() for (_st, X, _S) in sims]
        J = jac_of(sims)
        cache["jac_J"] = J
        return J

    def jac_of(sims):
        J = np.zeros((n_rows, nz))
        row = 0
        for e, off, (status, _X, S) in zip(exps, xoff, sims):
            n = e.t.size
            for o in outputs:
                blk = J[row:row + n]
                Sp = e.predict(o, S) * e.w[o][:, None]
                blk[:, :npar] = Sp[:, :npar] * (pscale / scale_o[o])
                for j, s in enumerate(e.est):
                    blk[:, off + j] = Sp[:, npar + j] * (x_scale_state[s] / scale_o[o])
                if o in output_offsets:
                    blk[:, off + len(e.est) + output_offsets.index(o)] = e.w[o] / scale_o[o]
                row += n
        if not np.all(np.isfinite(J)):
            J = np.nan_to_num(J, nan=0.0, posinf=0.0, neginf=0.0)
        return J

    r0 = fun(z0)
    X_start = cache["fun_X"]
    status_start = cache["fun_status"]
    if not np.all(np.abs(r0) < _BAD_RESIDUAL):
        msgs.append("the simulation from the start point diverged or failed; the fit may be poor")
    cost_start = 0.5 * float(r0 @ r0)
    auto_scale = loss != "linear" and f_scale is None
    if f_scale is not None and not (isinstance(f_scale, (int, float)) and f_scale > 0 and math.isfinite(f_scale)):
        raise InputError(f"f_scale must be a positive number, got {f_scale!r}")
    # stages: a robust loss with an automatic scale first fits with the linear
    # loss, then takes 2.5 robust standard deviations (1.4826 MAD) of those
    # residuals as the scale beyond which residuals count as outliers
    stages = [("linear", 1.0), (loss, None)] if auto_scale else [(loss, float(f_scale or 1.0))]
    z_init = z0.copy()
    # inside the bounds (the trust-region reflective method keeps it strictly feasible)
    z_init[:npar] = np.clip(z_init[:npar], zlo[:npar], zhi[:npar])
    used_scale = 1.0
    if nz > 0:
        budget = max_nfev or 100 * (nz + 1)
        for stage_loss, scale in stages:
            if scale is None:
                rr = cache["jac_r"] if cache.get("jac_key") == z_init.tobytes() else fun(z_init)
                mad = 1.4826 * float(np.median(np.abs(rr - np.median(rr))))
                scale = 2.5 * mad if mad > 0 else 1.0
            used_scale = scale
            sol = optimize.least_squares(
                fun, z_init, jac=jac, bounds=(zlo, zhi), method="trf", loss=stage_loss, f_scale=scale,
                x_scale=1.0, ftol=tol, xtol=tol, gtol=tol, max_nfev=budget, tr_solver=tr_solver,
            )
            z_init = sol.x
            success, message = bool(sol.success) and sol.status != 0, str(sol.message)
            budget = max(budget - sol.nfev, 1)
        z_opt = z_init
    else:
        z_opt = z0
        success, message = True, "nothing to estimate"
    f_scale = used_scale
    # final simulation with sensitivities at the optimum
    if cache.get("jac_key") != z_opt.tobytes():
        jac(z_opt)
    r = cache["jac_r"]
    J = cache["jac_J"]
    X_opt = cache["jac_X"]
    cost = 0.5 * float(r @ r)
    theta, x0s = unpack(z_opt)
    # ------------------------------------------------------------------ statistics
    row = 0
    ssr = {o: 0.0 for o in outputs}
    cnt = {o: 0 for o in outputs}
    row_out = []
    for e in exps:
        for o in outputs:
            n = e.t.size
            seg = r[row:row + n] * scale_o[o]
            ssr[o] += float(seg @ seg)
            cnt[o] += int(np.count_nonzero(e.w[o]))
            row_out.append((row, n, o))
            row += n
    n_used = sum(cnt.values())
    dof = max(n_used - nz, 1)
    sig2 = {o: ssr[o] / max(cnt[o], 1) * n_used / dof for o in outputs}
    Jw = J.copy()
    for (r0_, n, o) in row_out:
        s = math.sqrt(sig2[o]) / scale_o[o]  # residual std in weighted units
        Jw[r0_:r0_ + n] /= s if s > 0 else 1.0
    cov_z, rank_msgs = _covariance(Jw, [*free] + [name for i, e in enumerate(exps) for name in (
        [f"{_STATE_NAMES[s]}(0) of experiment {i}" for s in e.est]
        + [f"offset of {o} in experiment {i}" for o in output_offsets])])
    msgs.extend(rank_msgs)
    D = np.concatenate([pscale] + [np.concatenate([x_scale_state[list(e.est)], np.ones(len(output_offsets))])
                                   for e in exps])
    cov_full = cov_z * np.outer(D, D)
    cov = cov_full[:npar, :npar]
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None)) if npar else np.zeros(0)
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd) if npar else np.zeros((0, 0))
    tq = float(stats.t.ppf(0.975, dof))
    parameters: dict[str, ParameterEstimate] = {}
    refined = dict(zip(free, (float(v) for v in theta)))
    params = start.replace(**refined)
    for f_ in fields(LumpedParameters):
        n = f_.name
        v = float(getattr(params, n))
        if n in refined:
            s = float(sd[free.index(n)])
            parameters[n] = ParameterEstimate(n, v, s, v - tq * s, v + tq * s, False)
        else:
            parameters[n] = ParameterEstimate(n, v, 0.0, v, v, True)
    # correlations: name the pairs that the data cannot tell apart
    msgs.extend(_correlation_messages(free, theta, cov, corr, J[:, :npar]))
    for i, n in enumerate(free):
        if theta[i] <= lo[i] * (1 + 1e-9) + 1e-15 * pscale[i] and math.isfinite(lo[i]):
            msgs.append(f"{n} = {theta[i]:.6g} is at its lower bound {lo[i]:.6g}")
        if math.isfinite(hi[i]) and theta[i] >= hi[i] * (1 - 1e-9):
            msgs.append(f"{n} = {theta[i]:.6g} is at its upper bound {hi[i]:.6g}")
    if not success:
        msgs.append(f"the optimiser did not converge: {message}")
    # fit per experiment, at the start and at the optimum
    fit, fit0, rms, rms0, x0_sd, sim_out, off_out = [], [], [], [], [], [], []
    off_sd = npar
    offs_opt = offsets_of(z_opt)
    offs_start = offsets_of(z0)
    for e, X, st0, X0, oo, o0 in zip(exps, X_opt, status_start, X_start, offs_opt, offs_start):
        used = {o: e.w[o] > 0 for o in outputs}
        yh = {o: e.predict(o, X) + oo.get(o, 0.0) for o in outputs}
        yh0 = {o: e.predict(o, X0) + o0.get(o, 0.0) for o in outputs}
        sim_out.append(yh)
        fit.append({o: fit_percent(e.y[o][used[o]], yh[o][used[o]]) for o in outputs})
        fit0.append({o: fit_percent(e.y[o][used[o]], yh0[o][used[o]]) if st0 == 0 else float("nan") for o in outputs})
        rms.append({o: float(np.sqrt(np.mean((e.y[o] - yh[o])[used[o]] ** 2))) for o in outputs})
        rms0.append({o: float(np.sqrt(np.mean((e.y[o] - yh0[o])[used[o]] ** 2))) if st0 == 0 else float("inf")
                     for o in outputs})
        s4 = np.zeros(4)
        for j, s in enumerate(e.est):
            s4[s] = math.sqrt(max(cov_full[off_sd + j, off_sd + j], 0.0))
        off_sd += len(e.est)
        x0_sd.append(s4)
        off_out.append({o: (v, math.sqrt(max(cov_full[off_sd + j, off_sd + j], 0.0)))
                        for j, (o, v) in enumerate(oo.items())})
        off_sd += len(output_offsets)
    # x0 of the held/no-wheel models: the wheel does not move
    res = RefineResult(
        params=params, parameters=parameters, free=free, covariance=cov, correlation=corr, fit=fit,
        fit_start=fit0, rms=rms, rms_start=rms0, x0=[x.copy() for x in x0s], x0_stderr=x0_sd,
        windows=[e.window for e in exps], success=success, message=message, warnings=msgs,
        cost_start=cost_start, cost=cost, nfev=counters["nfev"], njev=counters["njev"], model=model,
        outputs=outputs, loss=loss, start=start, residual_std={o: math.sqrt(ssr[o] / cnt[o]) for o in outputs},
        n_samples=n_rows // len(outputs), elapsed=time.perf_counter() - t_begin,
        sources=[e.data.source for e in exps],
        simulated=sim_out, measured=[dict(e.y) for e in exps], times=[e.t for e in exps],
        weights=[dict(e.w) for e in exps], offsets=off_out,
    )
    if warn:
        for m in msgs:
            _warnings.warn(m, stacklevel=2)
    return res


_UNITS = {"p1": "s^-2", "p2": "s^-1", "p3": "s^-2/in", "rho": "-", "sigma_a1": "s^-1", "sigma_v1": "s^-1",
          "sigma_b1": "s rad^-2", "v_dz_pos": "in", "v_dz_neg": "in", "sigma_c2": "s^-2", "sigma_c1": "s^-2",
          "u_offset": "in"}


def _correlation_messages(free, theta, cov, corr, Jp) -> list[str]:
    """Warnings for pairs of free parameters with ``|correlation| > CORR_WARN``.

    A poorly determined direction of the Jacobian correlates every parameter
    that has a component along it, even one that is determined to 1 %. The
    pairs of which neither member is determined to within 5 % are named as
    "cannot be told apart" (most collinear Jacobian columns first); when
    there is none, the most collinear pair is named as strongly correlated;
    the other correlated pairs are listed in one line.
    """
    npar = len(free)
    cand = [(i, j) for i in range(npar) for j in range(i + 1, npar)
            if math.isfinite(corr[i, j]) and abs(corr[i, j]) > CORR_WARN]
    if not cand:
        return []
    cn = np.linalg.norm(Jp, axis=0)
    cn[cn == 0] = 1.0
    Q = (Jp / cn).T @ (Jp / cn)
    msgs, others = [], []
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    rel = sd / np.maximum(np.abs(theta), 1e-300)
    ranked = sorted(cand, key=lambda p: -abs(Q[p[0], p[1]]))
    main = [p for p in ranked if rel[p[0]] > 0.05 and rel[p[1]] > 0.05]
    if not main:  # all determined to 5 %: name the most collinear pair, without alarm
        i, j = ranked[0]
        c = corr[i, j]
        msgs.append(f"{free[i]} and {free[j]} are strongly correlated (correlation {c:+.3f}; stderr {free[i]} "
                    f"{sd[i]:.2g}, {free[j]} {sd[j]:.2g}): their errors move together")
        main_done = {ranked[0]}
    else:
        main_done = set()
    for (i, j) in ranked:
        c = corr[i, j]
        a, b = free[i], free[j]
        if (i, j) in main_done:
            continue
        if (i, j) in main:
            text = (f"{a} and {b} cannot be told apart by these data (correlation {c:+.3f}; "
                    f"stderr {a} {math.sqrt(max(cov[i, i], 0)):.2g}, {b} {math.sqrt(max(cov[j, j], 0)):.2g})")
            if _UNITS[a] == _UNITS[b]:
                sign = 1.0 if c < 0 else -1.0
                val = theta[i] + sign * theta[j]
                s_comb = math.sqrt(max(cov[i, i] + cov[j, j] + 2 * sign * cov[i, j], 0.0))
                text += f"; {a} {'+' if sign > 0 else '-'} {b} = {val:.4g} +- {s_comb:.2g} is determined"
            text += "; excite larger amplitudes or fix one of them"
            msgs.append(text)
        else:
            others.append(f"{a}/{b} {c:+.3f}")
    if others:
        msgs.append("also strongly correlated (|correlation| > 0.95): " + ", ".join(others))
    return msgs


def _covariance(Jw: np.ndarray, names: list[str]) -> tuple[np.ndarray, list[str]]:
    """``(Jw^T Jw)^+`` from the SVD of the column-scaled Jacobian; messages on rank deficiency."""
    nz = Jw.shape[1]
    if nz == 0:
        return np.zeros((0, 0)), []
    cn = np.linalg.norm(Jw, axis=0)
    msgs = []
    zero = cn == 0
    cn_safe = np.where(zero, 1.0, cn)
    _U, s, Vt = np.linalg.svd(Jw / cn_safe, full_matrices=False)
    tol = RCOND * (s[0] if s.size else 0.0)
    keep = s > tol
    if not np.all(keep) or np.any(zero):
        null = Vt[~keep]
        msgs.append("the Jacobian is rank deficient, the data do not determine every unknown: "
                    + null_space_message(null, names))
    else:
        cond = s[0] / s[-1]
        if cond > 1e6:
            msgs.append(f"the Jacobian is ill conditioned (condition number {cond:.2g} with unit-norm columns): "
                        "some combination of unknowns is poorly determined")
    inv = np.where(keep, 1.0 / np.where(keep, s, 1.0) ** 2, np.inf)
    Vk = Vt.T
    cov = (Vk * np.where(keep, inv, 0.0)) @ Vk.T
    # directions not determined: infinite variance on the unknowns they involve
    if not np.all(keep):
        bad = np.any(np.abs(Vt[~keep]) > 1e-3, axis=0)
        cov[bad, :] = np.nan
        cov[:, bad] = np.nan
    cov = cov / np.outer(cn_safe, cn_safe)
    return cov, msgs


# --------------------------------------------------------------------------
# refine after an identification set-up
# --------------------------------------------------------------------------
def _has_no_wheel(exps: list[ExperimentData]) -> bool:
    """Logs of a pendulum without a wheel: angle logs (``source_format: angle-log``) or ``wheel: none``."""
    def nowheel(e):
        m = e.metadata
        return m.get("source_format") == "angle-log" or m.get("wheel", "").lower() in ("none", "no")
    return all(nowheel(e) for e in exps)


def refine_identification(setup: str, experiments, start: LumpedParameters, t_start: float | None = None,
                          t_end: float | None = None, **kw) -> RefineResult:
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
    per experiment; ``t_start``/``t_end`` window every experiment. Other
    keyword arguments go to :func:`refine`.
    """
    spec = get_setup(setup).refine
    model, free, outputs = spec.model, spec.free, spec.outputs
    items = [experiments] if not isinstance(experiments, (list, tuple)) else list(experiments)
    if any(isinstance(e, StaticCurve) for e in items):
        raise InputError(f"set-up {setup!r} was identified from static curves; there is no time series to "
                         "simulate, so there is nothing to refine by simulation error")
    exps = _as_list(experiments)
    if setup == "free" and _has_no_wheel(exps):
        model = "free-nowheel"
    locked = False
    if setup in ("full", "two-step"):
        if all(e.metadata.get("pendulum") == "locked" for e in exps):
            raise InputError(f"set-up {setup!r} needs the pendulum free; these logs have it locked")
    kw.setdefault("model", model)
    kw.setdefault("free", free)
    kw.setdefault("outputs", outputs)
    kw.setdefault("locked", locked)
    return refine(exps, start, windows=(t_start, t_end), **kw)

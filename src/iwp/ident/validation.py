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
by differentiation, at ``t_start``; with ``estimate_x0=True`` it is instead
estimated by a simulation-error fit of the initial state only
(:func:`iwp.ident.refinement.refine` with no free parameter), which is what a
grey-box tool's ``compare`` with estimated initial conditions does.

Simulations use the adaptive DOP853 simulator :func:`iwp.sim.simulate`
at ``rtol = atol = 1e-10``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..data import ExperimentData
from ..errors import InputError
from ..files import json_float
from ..models.parameters import LumpedParameters, PhysicalParameters
from ..models.plant import MODELS, Plant
from ..sim.inputs import Input
from ..sim.simulate import simulate
from .fit import fit_percent
from .refinement import REFINE_MODELS, initial_state, measured_signals, model_input, refine, replay

__all__ = ["validate", "fit_percent", "ValidationResult", "auto_model"]

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
        Fit per signal [%] (:func:`fit_percent`); NaN for a constant measured signal.
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

    @property
    def rms(self) -> dict[str, float]:
        """Root-mean-square error per signal."""
        return {k: float(np.sqrt(np.mean(e ** 2))) for k, e in self.error.items()}

    @property
    def max_abs_error(self) -> dict[str, float]:
        """Largest absolute error per signal."""
        return {k: float(np.max(np.abs(e))) for k, e in self.error.items()}

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
            "restart_times": [float(r) for r in self.restart_times],
            "source": self.source,
            "params": self.params.to_dict(),
        }

    def summary(self) -> str:
        """One readable line per signal."""
        head = (f"validation of model {self.model!r} on {self.source}, t = [{self.t[0]:g}, {self.t[-1]:g}] s, "
                f"{self.t.size} samples" + (f", restarts at {', '.join(f'{r:g}' for r in self.restart_times)} s"
                                             if self.restart_times else ""))
        lines = [head]
        for k in self.fit:
            lines.append(f"  {k}: fit {self.fit[k]:.2f} %, rms error {self.rms[k]:.4g}, "
                         f"max |error| {self.max_abs_error[k]:.4g}")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()

    def plot(self, signals: Sequence[str] | None = None, axes=None, **kw):
        """Measured against simulated signals with the error below each (the paper's figures);
        see :func:`iwp.plotting.validation.plot_validation`."""
        from ..plotting.validation import plot_validation

        sig = tuple(signals) if signals is not None else tuple(self.measured)
        return plot_validation(self.t, self.measured, self.simulated, signals=sig, fit=self.fit,
                               restart_times=self.restart_times, axes=axes, **kw)


def auto_model(data: ExperimentData) -> str:
    """The model that suits a log: free pendulum without input, motor-disk when locked, else model (9).

    ``"free-nowheel"`` for angle logs (``source_format: angle-log``) or
    ``wheel: none``; ``"free"`` for other logs without input; ``"raw"``
    for logs of ``v``; ``"compensated"`` otherwise (the pendulum locked or
    not, see ``locked``).
    """
    m = data.metadata
    if data.input_name is None:
        if m.get("source_format") == "angle-log" or m.get("wheel", "").lower() in ("none", "no"):
            return "free-nowheel"
        return "free"
    return "raw" if data.input_name == "v" else "compensated"


def validate(
    experiment: ExperimentData,
    params,
    *,
    model: str = "compensated",
    estimate_x0: bool = False,
    t_start: float | None = None,
    t_end: float | None = None,
    restart_times: Sequence[float] = (),
    controller: Input | None = None,
    signals: Sequence[str] = ("q1", "q2"),
    locked: bool | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-10,
) -> ValidationResult:
    """Simulate ``model`` against a log and measure how well it predicts it.

    Parameters
    ----------
    experiment : ExperimentData
        The log.
    params : LumpedParameters (or PhysicalParameters)
    model : str
        ``"compensated"`` (9, input ``u``), ``"raw"`` (6, input ``v``),
        ``"motor-disk"``, ``"motor-disk-raw"`` (14), ``"free"`` (free
        pendulum, wheel held) or ``"free-nowheel"``, see :mod:`iwp.ident.refinement`;
        ``"auto"``: :func:`auto_model`.
    estimate_x0 : bool
        Estimate the initial state by a simulation-error fit (parameters
        fixed) instead of taking the measured one.
    t_start, t_end : float, optional
        Time window [s].
    restart_times : sequence of float
        Restart the simulation from the measured state at these times [s]
        (figure 9(b)); each is snapped to the nearest sample inside the window.
    controller : iwp.sim.inputs controller, optional
        Simulate in closed loop with it (e.g. ``HopfController(-10, 0.1)``,
        figure 10) instead of replaying the logged input.
    signals : sequence of str
        Signals compared, among ``q1, q2, q3, q4``; velocities missing from
        the log are differentiated from the positions.
    locked : bool, optional
        Pendulum clamped (models ``"compensated"``/``"raw"``); default from
        the log's metadata (``pendulum: locked``).
    rtol, atol : float
        Tolerances of the simulator.

    Returns
    -------
    ValidationResult
    """
    if not isinstance(experiment, ExperimentData):
        raise InputError(f"experiment must be an ExperimentData, got {type(experiment).__name__}")
    if isinstance(params, PhysicalParameters):
        params = params.to_lumped()
    if not isinstance(params, LumpedParameters):
        raise InputError(f"params must be LumpedParameters, got {type(params).__name__}")
    if model == "auto":
        model = auto_model(experiment)
    if model not in REFINE_MODELS:
        raise InputError(f"model must be one of auto, {', '.join(REFINE_MODELS)}, got {model!r}")
    info = MODELS[model]
    wheel_held = info.input is None  # free pendulum: the wheel is held (or absent)
    if isinstance(signals, str):
        signals = (signals,)
    signals = tuple(signals)
    if not signals:
        raise InputError("signals is empty")
    for s in signals:
        if s not in _SIGNALS:
            raise InputError(f"unknown signal {s!r}; choose among {', '.join(_SIGNALS)}")
    if locked is None:
        locked = experiment.metadata.get("pendulum") == "locked" and model in ("compensated", "raw")
    if locked and model not in ("compensated", "raw"):
        raise InputError(f"locked=True applies to models 'compensated' and 'raw', not {model!r}")
    if controller is not None and not isinstance(controller, Input):
        raise InputError(f"controller must be an iwp.inputs controller (e.g. HopfController), got "
                         f"{type(controller).__name__}")
    if controller is not None and info.input != "u":
        raise InputError(f"a controller drives the input u; model {model!r} takes "
                         f"{info.input or 'no input'}")
    data = experiment
    wdata = data.window(t_start, t_end)
    if wdata.n_samples < 10:
        raise InputError(f"the window keeps {wdata.n_samples} samples of {data.source}; at least 10 are needed")
    i0 = int(np.searchsorted(data.t, wdata.t[0]))
    n = wdata.n_samples
    t = np.asarray(wdata.t, dtype=float)
    meas_full = measured_signals(data, signals)
    measured = {s: np.asarray(meas_full[s][i0:i0 + n], dtype=float) for s in signals}
    # the replayed input
    inp = None
    need = model_input(model)
    if controller is not None:
        inp = controller
    elif need is not None and data.input_name is not None:
        if data.input_name != need:
            raise InputError(f"{data.source} logs the input {data.input_name!r} but model {model!r} takes {need!r}")
        inp = replay(wdata, need)
    plant = Plant(params, model=model, locked=locked)
    # restart indices
    starts = [0]
    snapped = []
    for rt in restart_times:
        try:
            rt = float(rt)
        except (TypeError, ValueError):
            raise InputError(f"restart time {rt!r} is not a number") from None
        if not (t[0] < rt < t[-1]) or not math.isfinite(rt):
            raise InputError(f"restart time {rt:g} s is outside the window ({t[0]:g}, {t[-1]:g}) s")
        k = int(np.argmin(np.abs(t - rt)))
        if k > 0 and k < n - 1 and k not in starts:
            starts.append(k)
    starts.sort()
    snapped = tuple(float(t[k]) for k in starts[1:])
    # initial state
    x0 = initial_state(data, i0, model, locked=locked)
    if estimate_x0:
        fit_out = []
        for s in signals:
            usable = s in ("q1", "q3") if wheel_held else (
                s in ("q2", "q4") if (model.startswith("motor-disk") or locked) else True)
            if usable and np.ptp(measured[s]) > 0:
                fit_out.append(s)
        if not fit_out:
            raise InputError(f"estimate_x0: none of the signals {', '.join(signals)} varies in the window")
        r = refine(wdata, params, model=model, free=(), outputs=tuple(fit_out), estimate_x0=True, locked=locked,
                   warn=False)
        x0 = np.asarray(r.x0[0], dtype=float)
    simulated = {s: np.empty(n) for s in signals}
    restart_states = []
    bounds = starts + [n - 1]

    for si, k0 in enumerate(starts):
        k1 = bounds[si + 1]
        last = si == len(starts) - 1
        idx = np.arange(k0, k1 + 1 if last else k1)
        if si == 0:
            xs = x0.copy()
        else:
            xs = initial_state(data, i0 + k0, model, locked=locked)
            restart_states.append(xs.copy())
        t_seg_end = float(t[k1])
        res = simulate(plant, x0=xs, t0=float(t[k0]), t_end=t_seg_end, input=inp, t_eval=t[idx], rtol=rtol,
                       atol=atol, Ts=wdata.Ts)
        X = np.array(res.x, dtype=float)
        for s in signals:
            simulated[s][idx] = X[:, _SIGNALS.index(s)]
    error = {s: measured[s] - simulated[s] for s in signals}
    fit = {s: fit_percent(measured[s], simulated[s]) for s in signals}
    return ValidationResult(
        t=t, measured=measured, simulated=simulated, error=error, fit=fit, x0=np.asarray(x0, dtype=float),
        restart_times=snapped, model=model, params=params, source=data.source, estimate_x0=bool(estimate_x0),
        closed_loop=controller is not None, locked=bool(locked), restart_states=restart_states,
    )

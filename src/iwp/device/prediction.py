"""The model's prediction of a run on a rig: the same input or controller simulated on a parameter set.

A live view (:mod:`iwp.device.live`) draws it beside the measurement.
:func:`predict_rig_run` simulates what :func:`~iwp.device.runs.run_on_rig`
will run (the input as the device applies it, held over each period, on
model (9) for a compensated input ``u`` or model (6) with its dead zone for
a raw command ``v``; the pendulum clamped or free; a release with the motor
off; the Hopf law of the closed loop), :func:`predict_control_run` what
:func:`~iwp.device.control.run_control` will run (the Hopf law; the upright
LQR; the swing-up on the rig's conditions of :func:`iwp.control.swing_up`).
With a :class:`~iwp.sim.uncertainty.ParameterUncertainty` (a fit's
``parameters.json``) the 95 % prediction band comes with it
(:func:`~iwp.sim.uncertainty.prediction_band`, linearised), but for the
swing-up (a Python controller the sensitivities cannot follow).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..control import RigConditions, lqr_balance, swing_up
from ..models.parameters import LumpedParameters
from ..models.plant import Plant, plant_for_kind
from ..rig.experiments import RunKind
from ..rig.run_settings import initial_state, law_input
from ..sim.inputs import HopfController, Input, Sampled
from ..sim.options import SimOptions
from ..sim.simulate import simulate
from ..sim.uncertainty import ParameterUncertainty, prediction_band
from .runs import run_kind, run_settings

__all__ = ["RunPrediction", "predict_rig_run", "predict_control_run", "PREDICTED"]

#: The signals predicted.
PREDICTED = ("q1", "q2")


@dataclass(frozen=True, eq=False)
class RunPrediction:
    """The model's prediction of a run.

    Attributes
    ----------
    t : ndarray
        Times from the run's start [s].
    nominal : dict of str to ndarray
        ``q1``, ``q2`` simulated with the parameters [rad].
    lower, upper : dict of str to ndarray or None
        The 95 % prediction band of each (None without a covariance) [rad].
    text : str
        What was simulated, one line.
    """

    t: np.ndarray
    nominal: dict
    lower: dict | None = None
    upper: dict | None = None
    text: str = ""

    def to_dict(self, max_points: int = 600) -> dict:
        """As JSON-ready lists, every ``k``-th sample and the last so that at most about ``max_points`` are kept."""
        k = max(1, int(math.ceil(self.t.size / max_points)))
        keep = np.unique(np.r_[np.arange(0, self.t.size, k), self.t.size - 1])

        def cut(a):
            return [round(float(v), 6) for v in np.asarray(a)[keep]]

        out = {"t": cut(self.t), "nominal": {s: cut(v) for s, v in self.nominal.items()}, "text": self.text,
               "band": self.lower is not None}
        if self.lower is not None:
            out["lower"] = {s: cut(v) for s, v in self.lower.items()}
            out["upper"] = {s: cut(v) for s, v in self.upper.items()}
        return out


def _params_of(params) -> tuple[LumpedParameters, ParameterUncertainty | None]:
    if isinstance(params, ParameterUncertainty):
        return params.params, params
    return params, None


def _simulated(plant: Plant, uncertainty, *, input: Input | None, x0, duration: float, Ts: float, text: str,
               saturation: float | None = None) -> RunPrediction:
    """``plant`` driven by ``input`` from ``x0`` over ``duration``, at the loop period ``Ts``; with the band."""
    n = int(math.floor(duration / Ts + 1e-9)) + 1
    t = np.arange(n) * Ts
    if uncertainty is not None:
        b = prediction_band(plant, uncertainty, input=input, x0=x0, t_eval=t, signals=PREDICTED)
        return RunPrediction(b.t, dict(b.nominal), dict(b.pred_lower), dict(b.pred_upper),
                             text + f"; 95 % prediction band ({b.method})")
    r = simulate(plant, x0=x0, t_end=float(t[-1]), Ts=Ts, input=input, t_eval=t,
                 options=SimOptions(saturation=saturation, check=False))
    return RunPrediction(r.t, {"q1": r.q1, "q2": r.q2}, text=text)


def predict_rig_run(name: str, params, *, Ts: float = 0.005, **options) -> RunPrediction | None:
    """The model's prediction of experiment or input ``name`` of :func:`~iwp.device.runs.run_on_rig`.

    Parameters
    ----------
    name : str
        As for :func:`~iwp.device.runs.run_on_rig`.
    params : LumpedParameters or ParameterUncertainty
        The model's parameters (with their covariance: the prediction band too).
    Ts : float
        The rig's loop period [s].
    **options
        The run's options, as for :func:`~iwp.device.runs.run_on_rig`.

    Returns
    -------
    RunPrediction or None
        None for the static curves (a series of holds, not one run).
    """
    kind = run_kind(name)
    s = run_settings(name, options)
    if kind.run is RunKind.STATIC_CURVE:
        return None
    lumped, unc = _params_of(params)
    duration = float(s["duration"])
    x0 = initial_state(s["x0"]) if "x0" in s else None
    if kind.run is RunKind.RELEASE:
        plant = plant_for_kind(Plant(lumped), "wheel-locked")
        return _simulated(plant, unc, input=None, x0=x0, duration=duration, Ts=Ts,
                          text="the release, motor off, the wheel held (section 5.2)")
    compensated = s.get("v_dz") is not None
    plant = Plant(lumped, model="compensated" if compensated else "raw")
    if kind.run is RunKind.CLOSED_LOOP:
        law = HopfController(float(s["k1"]), float(s["k2"]), Ts)
        return _simulated(plant, unc, input=law, x0=x0, duration=duration, Ts=Ts,
                          text=f"the Hopf law k1 = {s['k1']:g}, k2 = {s['k2']:g} on model (9)")
    if s.get("locked", kind.locked):
        plant = plant_for_kind(plant, "clamped")
    inp = law_input(kind.law, s, Ts)
    n = int(math.floor(duration / Ts + 1e-9)) + 1
    held = Sampled(np.array([inp.evaluate(k * Ts) for k in range(n)]), Ts)  # as the device holds it
    return _simulated(plant, unc, input=held, x0=x0, duration=duration, Ts=Ts,
                      text=f"the {kind.law.value} input held each period on model {'(9)' if compensated else '(6)'}"
                           + (", the pendulum clamped" if plant.locked else ""))


def predict_control_run(run, params, *, Ts: float = 0.005, u_max: float = 69.0, q1_start: float = 0.0,
                        counts_per_rev: int = 2000) -> RunPrediction:
    """The model's prediction of a :class:`~iwp.device.control.ControlRun` of
    :func:`~iwp.device.control.run_control`.

    Parameters
    ----------
    run : ControlRun
        The controller, where, how long, from where.
    params : LumpedParameters or ParameterUncertainty
        The model's parameters (with their covariance: the prediction band too, but for the swing-up).
    Ts : float
        The rig's loop period [s].
    u_max : float
        The input's limit of the balance [input units].
    q1_start : float
        Where the pendulum is released [rad].
    counts_per_rev : int
        The pendulum encoder's counts per revolution (the swing-up's rig conditions).

    Returns
    -------
    RunPrediction
    """
    lumped, unc = _params_of(params)
    x0 = np.array([q1_start, 0.0, 0.0, 0.0])
    if run.what == "hopf":
        return _simulated(Plant(lumped), unc, input=HopfController(run.k1, run.k2, Ts), x0=x0,
                          duration=run.duration, Ts=Ts,
                          text=f"the Hopf law k1 = {run.k1:g}, k2 = {run.k2:g} on model (9)")
    if run.what == "balance":
        lqr = lqr_balance(lumped, u_max=u_max, Ts=Ts)
        return _simulated(Plant(lumped), unc, input=lqr.controller(), x0=x0, duration=run.duration, Ts=Ts,
                          text=f"the upright LQR, |u| <= {u_max:g}, on model (9)", saturation=u_max)
    cond = RigConditions(Ts=Ts, u_max=u_max, counts_per_rev=int(counts_per_rev))
    r = swing_up(lumped, x0=x0, t_end=run.duration, rig=cond, Ts_out=Ts).result
    return RunPrediction(np.asarray(r.t), {"q1": np.asarray(r.q1), "q2": np.asarray(r.q2)},
                         text="the swing-up and balance on the rig's conditions (no band: a Python controller)")

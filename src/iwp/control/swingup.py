"""Swing-up by energy pumping with the wheel, then LQR balance at the upright (beyond the paper).

:class:`SwingUpController` pumps energy from rest at the bottom, switches to
the LQR of :mod:`.balance` near the top, and can run on the rig's
conditions (:class:`~iwp.control.conditions.RigConditions`: dead zone
compensated with a mismatched threshold, encoder quantisation, 5 ms
sampling, ``|u| <= 100``) through the observer of :mod:`.observer`.
:func:`swing_up` simulates it and judges the run (:class:`SwingUpResult`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..checks import check_finite, check_nonnegative, check_positive
from ..files import prepare_output_file
from ..models.analysis import pendulum_energy
from ..models.encoder import quantize
from ..models.parameters import LumpedParameters
from ..models.plant import Plant
from ..sim.inputs import CallableController
from ..sim.options import Feedforward, SimOptions
from ..sim.simulate import simulate
from .balance import LQRBalance, lqr_balance, wrap_angle
from .closed_loop import lumped_parameters
from .conditions import RigConditions
from .observer import EncoderObserver

__all__ = ["SwingUpController", "SwingUpResult", "swing_up"]


class SwingUpController:
    """Swing-up by energy pumping with the wheel, then LQR balance at the upright.

    Swing-up (pendulum energy ``E``, target ``E* = 2 p1 (1 + energy_margin)``):
    ``u = sat(k_energy (E - E*) sgn(q3) - k_disk q4)``. The wheel acts on
    the pendulum through its reaction torque (``q3' = ... - p3 u`` in (9)),
    so ``dE/dt = -p3 k_energy (E - E*) |q3| + ...``: energy is pumped in while
    ``E < E*`` and taken out above. The disk velocity stays bounded by the
    back-emf and the ``-k_disk q4`` term (``q4' = ... + p3 (1 + rho) u``).

    Balance: the switch to the LQR (:func:`~iwp.control.balance.lqr_balance`)
    happens when the pendulum is within ``theta_in`` of the upright *and* its
    unstable mode is inside the capture region,
    ``|w . x| < catch * capture_bound`` (with ``|u| <= u_max`` the fall
    cannot be stopped beyond it; the disk velocity counts through ``w``).
    The swing-up law takes over again if the error exceeds ``theta_out``.

    Model errors shift the energy the top needs (the controller's ``E``
    uses its own ``p1``), so the target adapts: up by ``adapt_step`` (of
    ``2 p1``) after a swing that turns back within ``theta_in`` of the top
    without being caught, down after an uncaught pass over the top, within
    ``+-adapt_limit``.

    With :class:`~iwp.control.conditions.RigConditions` the controller
    measures quantised encoder angles and estimates the state with an
    :class:`~iwp.control.observer.EncoderObserver`; without, it reads the
    true state.

    Parameters
    ----------
    params : LumpedParameters
        The controller's model (e.g. Table 1).
    rig : RigConditions, optional
        Measurement conditions (quantisation, sample period, ``u_max``).
    Ts : float
        Sample period [s] when ``rig`` is None.
    u_max : float
        Saturation [input units] when ``rig`` is None.
    k_energy : float
        Energy gain [input units s^2].
    k_disk : float
        Disk-velocity gain [input units s/rad].
    energy_margin : float
        Relative excess of the energy target.
    catch : float
        Fraction of the capture bound at which the LQR takes over.
    theta_in, theta_out : float
        Angle windows around the upright to switch in and out [rad].
    lqr : LQRBalance, optional
        Default: :func:`~iwp.control.balance.lqr_balance` with the sample period and ``u_max``.
    adapt_step, adapt_limit : float
        Step and bound of the energy-target adaptation (relative to
        ``2 p1``); ``adapt_step=0`` disables it.

    Attributes
    ----------
    mode : str
        ``"swing-up"`` or ``"balance"``.
    switches : list of (float, str)
        Mode switches so far.
    E_target : float
        Current energy target [s^-2].
    """

    def __init__(self, params: LumpedParameters, *, rig: RigConditions | None = None, Ts: float = 0.005,
                 u_max: float = 100.0, k_energy: float = 100.0, k_disk: float = 0.05, energy_margin: float = 0.0,
                 catch: float = 0.6, theta_in: float = 0.5, theta_out: float = 0.8, lqr: LQRBalance | None = None,
                 adapt_step: float = 0.005, adapt_limit: float = 0.1):
        self.params = lumped_parameters(params)
        self.rig = rig
        self.Ts = rig.Ts if rig is not None else check_positive("Ts", Ts)
        self.u_max = rig.u_max if rig is not None else check_positive("u_max", u_max)
        self.k_energy = check_finite("k_energy", k_energy)
        self.k_disk = check_finite("k_disk", k_disk)
        self.energy_margin = check_finite("energy_margin", energy_margin)
        self.catch = check_positive("catch", catch)
        self.theta_in = check_positive("theta_in", theta_in)
        self.theta_out = check_positive("theta_out", theta_out)
        self.adapt_step = check_nonnegative("adapt_step", adapt_step)
        self.adapt_limit = check_nonnegative("adapt_limit", adapt_limit)
        self.lqr = lqr if lqr is not None else lqr_balance(self.params, u_max=self.u_max, Ts=self.Ts)
        self.observer = None
        if rig is not None:
            self.observer = EncoderObserver(self.params, self.Ts, rig.quantum, rig.sigma_q3, rig.sigma_q4)
        self.reset()

    def reset(self) -> None:
        """Forget the mode, the switch log and the observer state."""
        self.mode = "swing-up"
        self.switches: list[tuple[float, str]] = []
        self._u = 0.0
        self._sign = None
        self._err = None
        self.E_target = 2.0 * self.params.p1 * (1.0 + self.energy_margin)
        if self.observer is not None:
            self.observer.reset()

    def measure(self, x) -> np.ndarray:
        """The state the controller works with: observer estimate from quantised angles, or the true state."""
        x = np.asarray(x, dtype=float)
        if self.observer is None:
            return x[:4].copy()
        return self.observer.update(quantize(x[:2], self.rig.quantum), self._u)

    def swing_law(self, x) -> float:
        """Energy pumping ``k_energy (E - E*) sgn(q3) - k_disk q4`` (unsaturated)."""
        E = float(pendulum_energy(self.params, x))
        sg = 1.0 if x[2] >= 0.0 else -1.0
        return self.k_energy * (E - self.E_target) * sg - self.k_disk * x[3]

    def __call__(self, t: float, x) -> float:
        xh = self.measure(x)
        err = LQRBalance.error_state(xh)[0]
        th = abs(err)
        if self.mode == "swing-up" and th < self.theta_in and self.lqr.capture_ratio(xh) < self.catch:
            self.mode = "balance"
            self.switches.append((float(t), "balance"))
        elif self.mode == "balance" and th > self.theta_out:
            self.mode = "swing-up"
            self.switches.append((float(t), "swing-up"))
        if self.mode == "balance":
            u = -float(self.lqr.K @ LQRBalance.error_state(xh))
        else:
            self._adapt(xh, err)
            u = self.swing_law(xh)
        self._u = min(max(u, -self.u_max), self.u_max)
        return self._u

    def _adapt(self, xh, err) -> None:
        """Adjust the energy target (model errors shift the energy the top needs): up by
        ``adapt_step`` after a swing that turns back within ``theta_in`` of the upright without
        being caught, down after a pass over the top that was not caught."""
        if self.adapt_step <= 0:
            return
        sg = 1.0 if xh[2] >= 0.0 else -1.0
        E2 = 2.0 * self.params.p1
        if self._sign is not None and sg != self._sign and abs(err) < self.theta_in:
            self.E_target = min(self.E_target + self.adapt_step * E2, E2 * (1.0 + self.adapt_limit))
        if self._err is not None and abs(err) < 0.5 and abs(self._err) < 0.5 and err * self._err < 0:
            self.E_target = max(self.E_target - self.adapt_step * E2, E2 * (1.0 - self.adapt_limit))
        self._sign = sg
        self._err = err

    def as_input(self) -> CallableController:
        """This controller as a sampled :class:`~iwp.sim.inputs.CallableController`."""
        return CallableController(self, self.Ts)


@dataclass(frozen=True, eq=False)
class SwingUpResult:
    """A swing-up and balance run.

    Attributes
    ----------
    result : SimulationResult
        The simulation (true states; ``u`` the ideal input, ``command`` the
        driver command after the feedforward).
    success : bool
        Within ``tolerance`` of the upright over the final ``hold`` seconds.
    t_catch : float
        First switch to the balance law [s] (NaN if none).
    t_balanced : float
        From this time on the pendulum stays within ``tolerance`` of the upright [s] (NaN if never).
    switches : list of (float, str)
        Mode switches (time, new mode).
    u_max, q4_max : float
        Largest ``|u|`` [input units] and ``|q4|`` [rad/s].
    tolerance, hold : float
        Success criterion [rad], [s].
    conditions : str
        ``"rig"`` or ``"ideal"``.
    """

    result: object
    success: bool
    t_catch: float
    t_balanced: float
    switches: list
    u_max: float
    q4_max: float
    tolerance: float
    hold: float
    conditions: str

    @property
    def theta(self) -> np.ndarray:
        """Angle from the upright, wrapped to ``[-pi, pi)`` [rad]."""
        return wrap_angle(self.result.q1 - math.pi)

    def summary(self) -> dict:
        return {"success": self.success, "t_catch": self.t_catch, "t_balanced": self.t_balanced,
                "switches": [[t, m] for t, m in self.switches], "u_max": self.u_max, "q4_max": self.q4_max,
                "tolerance": self.tolerance, "hold": self.hold, "conditions": self.conditions}

    def plot(self, **kw):
        """Angle, velocities and input; see :func:`iwp.plotting.plot_swingup`."""
        from ..plotting import plot_swingup  # plotting only when asked

        return plot_swingup(self, **kw)

    def animate(self, path, *, frames: int = 100, force: bool = False, **kw):
        """Write a GIF of the pendulum; see :func:`iwp.plotting.animate_pendulum`."""
        p = prepare_output_file(path, force=force)
        from ..plotting import animate_pendulum  # plotting only when asked

        return animate_pendulum(self.result.t, self.result.q1, self.result.q2, p, frames=frames,
                                u=self.result.u, **kw)


def swing_up(
    params: LumpedParameters,
    *,
    x0=(0.0, 0.0, 0.0, 0.0),
    t_end: float = 20.0,
    rig: RigConditions | None = RigConditions(),
    controller: SwingUpController | None = None,
    Ts_out: float = 0.005,
    tolerance: float = 0.05,
    hold: float = 3.0,
    plant_params: LumpedParameters | None = None,
    **controller_kw,
) -> SwingUpResult:
    """Swing the pendulum up from ``x0`` and balance it; simulate and judge.

    Parameters
    ----------
    params : LumpedParameters
        The model the controller is designed on (Table 1).
    x0 : array_like
        Initial state ``[q1, q2, q3, q4]`` (default: rest at the bottom).
    t_end : float
        Simulated time [s].
    rig : RigConditions or None
        The rig's conditions (default): raw model (6) with the asymmetric
        dead zone compensated with one threshold, quantised encoders, an
        observer, 5 ms sampling, ``|u| <= 100``. ``None``: the compensated
        model (9) with the true state, sampled every ``Ts``.
    controller : SwingUpController, optional
        Built from ``params``, ``rig`` and ``controller_kw`` when omitted.
    Ts_out : float
        Output sample time [s].
    tolerance, hold : float
        Success: ``|q1 - pi| < tolerance`` [rad] over the final ``hold`` [s].
    plant_params : LumpedParameters, optional
        The plant's parameters if they differ from the controller's (e.g.
        randomised for a robustness check); the rig's dead zone is applied
        on top.

    Returns
    -------
    SwingUpResult

    Examples
    --------
    From rest at the bottom, under the rig's conditions (dead zone, encoders, observer, ``|u| <= 100``):

    >>> from iwp import swing_up, table1
    >>> res = swing_up(table1(), t_end=13.0)
    >>> res.success, res.t_catch, res.switches  # caught and balanced after 9.2 s
    (True, 9.185, [(9.185, 'balance')])
    >>> float(abs(res.theta[res.result.t >= 10.0]).max().round(4))  # then within 3 mrad of the upright [rad]
    0.0026
    """
    params = lumped_parameters(params)
    t_end = check_positive("t_end", t_end)
    ctrl = controller if controller is not None else SwingUpController(params, rig=rig, **controller_kw)
    ctrl.reset()
    truth = lumped_parameters(plant_params) if plant_params is not None else params
    if rig is not None:
        plant = rig.plant(truth)
        feedforward = rig.feedforward
    else:
        plant = Plant(truth)
        feedforward = None
    res = simulate(plant, x0=list(x0), t_end=t_end, Ts=Ts_out, input=ctrl.as_input(),
                   options=SimOptions(feedforward=None if feedforward is None else Feedforward(*feedforward),
                                      check=False))
    th = np.abs(wrap_angle(res.q1 - math.pi))
    inside = th < tolerance
    success = bool(res.success and res.t[-1] >= t_end - 1e-9 and np.all(inside[res.t >= t_end - hold]))
    if inside[-1]:
        out = np.flatnonzero(~inside)
        t_bal = float(res.t[out[-1] + 1]) if out.size else float(res.t[0])
    else:
        t_bal = float("nan")
    catches = [t for t, m in ctrl.switches if m == "balance"]
    return SwingUpResult(result=res, success=success, t_catch=catches[0] if catches else float("nan"),
                         t_balanced=t_bal, switches=list(ctrl.switches), u_max=float(np.nanmax(np.abs(res.u))),
                         q4_max=float(np.nanmax(np.abs(res.q4))), tolerance=tolerance, hold=hold,
                         conditions="rig" if rig is not None else "ideal")

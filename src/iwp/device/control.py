"""iwp's controllers on a rig in the loop: the Hopf law, the upright LQR, swing-up and balance.

:func:`run_control` runs one of them on a :class:`~iwp.device.connection.Rig`,
on the device (its Hopf law or its state feedback, with the gains uploaded)
or from the host (the Python controllers of :mod:`iwp.control` and
:mod:`iwp.rig.controller`, one period of delay), and returns the run as
:func:`iwp.device.runs.run_on_rig` does.

* ``hopf``: the closed loop of section 5.3, ``u = k1 q3 + k2 q3^3``, from
  the pendulum released at ``x0`` (the experiment ``closed-loop``).
* ``balance``: the LQR at the upright (:func:`iwp.control.lqr_balance`,
  discrete at the loop period), from the pendulum released near the top.
  On the device it is state feedback on the device's velocity estimates;
  on the host the LQR acts on the observer of
  :class:`~iwp.control.SwingUpController`.
* ``swingup``: energy pumping from rest, then the LQR
  (:class:`~iwp.control.SwingUpController` on the rig's conditions); host
  only. Success: within ``tolerance`` of the upright over the last ``hold``
  seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..checks import check_finite, check_positive
from ..control import RigConditions, SwingUpController, lqr_balance
from ..control.balance import wrap_angle
from ..errors import InputError
from ..models.parameters import LumpedParameters
from .connection import Rig
from .loop import DeviceLaw, HostLaw, HostLimits, LoopCommand, run_loop
from .record import loop_log
from .runs import Clearing, RigRun, arrange, default_operator, hold_at, prepare, releaser, run_on_rig

__all__ = ["run_control", "ControlRun", "CONTROLLERS", "DEFAULT_DURATIONS", "balanced", "BALANCE_START", "V_DZ",
           "control_conditions", "HOPF_START"]

#: The balance starts this far from the upright [rad] (the capture region of the LQR with |u| <= 69 is 0.05 rad).
BALANCE_START = 0.02
#: The Hopf law's run starts from the pendulum released here [rad] (the experiment ``closed-loop``).
HOPF_START = 0.3
#: The paper's feedforward threshold (section 5.1) [input units].
V_DZ = 31.0

#: The controllers and where each can run.
CONTROLLERS = {"hopf": ("device", "host"), "balance": ("device", "host"), "swingup": ("host",)}
#: How long a run of each controller lasts by default [s]: the Hopf orbit settles within tens of seconds; a
#: balance is judged over 10 s; a swing-up needs about 10 s to reach the top, then balances.
DEFAULT_DURATIONS = {"hopf": 60.0, "balance": 10.0, "swingup": 20.0}


def balanced(q1, t, *, tolerance: float = 0.05, hold: float = 3.0) -> bool:
    """Within ``tolerance`` [rad] of the upright over the last ``hold`` [s] of the log.

    Parameters
    ----------
    q1 : array_like, shape (n,)
        Pendulum angle, 0 hanging down [rad].
    t : array_like, shape (n,)
        Sample times [s], increasing.
    tolerance : float, default 0.05
        Largest distance to the upright ``q1 = pi`` (mod ``2 pi``) [rad].
    hold : float, default 3.0
        Length of the end of the log checked [s].

    Returns
    -------
    bool
        True when every sample of the last ``hold`` seconds is within ``tolerance``; False for a log shorter
        than ``hold``.
    """
    q1, t = np.asarray(q1, dtype=float), np.asarray(t, dtype=float)
    if t.size == 0 or t[-1] - t[0] < hold:
        return False
    return bool(np.all(np.abs(wrap_angle(q1[t >= t[-1] - hold] - math.pi)) < tolerance))


@dataclass(frozen=True)
class ControlRun:
    """Which controller runs on a rig, where, for how long and from where (:func:`run_control`).

    Attributes
    ----------
    what : str
        A controller of :data:`CONTROLLERS`: ``"hopf"``, ``"balance"`` or ``"swingup"``.
    duration : float, optional
        Length of the run [s]; None: the controller's :data:`DEFAULT_DURATIONS`.
    where : str
        ``"device"`` (the firmware's law) or ``"host"`` (the law on the host, over the link).
    k1, k2 : float
        The Hopf gains (``u = k1 q3 + k2 q3^3``, section 5.3).
    x0 : float, optional
        Where the pendulum is released [rad] (hopf: 0.3; balance: pi - 0.05; swingup: rest at the bottom).
    """

    what: str
    duration: float | None = None
    where: str = "device"
    k1: float = -10.0
    k2: float = 0.1
    x0: float | None = None

    def __post_init__(self) -> None:
        if self.what not in CONTROLLERS:
            raise InputError(f"the controller must be one of {', '.join(CONTROLLERS)}, got {self.what!r}",
                             argument="what")
        duration = DEFAULT_DURATIONS[self.what] if self.duration is None else self.duration
        object.__setattr__(self, "duration", check_positive("duration", duration))


def control_conditions(rig: Rig, run: ControlRun) -> dict:
    """The conditions ``run`` runs with on ``rig`` (:func:`run_control`).

    Parameters
    ----------
    rig : Rig
        Connected.
    run : ControlRun
        The controller and its release.

    Returns
    -------
    dict
        ``Ts``, the loop period [s]; ``u_max``, what the driver can give on top of the feedforward [input
        units]; ``q1_start``, where the pendulum is released [rad]; ``counts_per_rev``, the pendulum encoder's.
    """
    p = rig.info.params
    default = {"hopf": HOPF_START, "balance": math.pi - BALANCE_START}.get(run.what, 0.0)
    return {"Ts": p["period_us"] * 1e-6, "u_max": min(p["u_max"], p["v_max"] - V_DZ),
            "q1_start": default if run.x0 is None else float(np.ravel([run.x0])[0]),
            "counts_per_rev": int(p["counts1"])}


def run_control(rig: Rig, run: ControlRun, *, params: LumpedParameters, fast: bool = False, operator=None,
                progress=None, limits: HostLimits | None = None, clearing: Clearing | None = None) -> RigRun:
    """Run the controller of ``run`` (:class:`ControlRun`) on ``rig``; see the module's docstring.

    Parameters
    ----------
    rig : Rig
        Connected.
    run : ControlRun
        The controller, where it runs, the run's length and the release.
    params : LumpedParameters
        The model the LQR and the swing-up are designed on (e.g. Table 1).
    fast : bool
        On the host's clock, faster than real time (the emulator and the twin only).
    operator, progress : callable, optional
        Who clamps and releases the pendulum; called with the run's progress.
    limits : HostLimits, optional
        The host's limits (default: the device's).
    clearing : Clearing, optional
        Clear a fault left on the device, restore its changed limits (see :func:`~iwp.device.runs.prepare`).

    Examples
    --------
    The upright LQR on the device's state feedback, the twin's pendulum released 0.02 rad from the top:

    >>> import numpy as np
    >>> from iwp import ControlRun, open_rig, run_control, table1
    >>> with open_rig("twin", fast=True) as rig:
    ...     run = run_control(rig, ControlRun("balance", duration=3.5), params=table1(), fast=True)
    >>> run.reason, run.log.metadata["balanced"]  # within 0.05 rad of the upright over the last 3 s
    ('complete', 'yes')
    >>> round(float(np.abs(run.log.q1 - np.pi).max()), 4)  # the largest distance to the upright [rad]
    0.0188
    """
    if not isinstance(run, ControlRun):
        raise InputError(f"run must be a ControlRun, got {type(run).__name__}", argument="run")
    what, where, duration, k1, k2, x0 = run.what, run.where, run.duration, run.k1, run.k2, run.x0
    if what not in CONTROLLERS:
        raise InputError(f"unknown controller {what!r}; valid: {', '.join(CONTROLLERS)}")
    if where not in CONTROLLERS[what]:
        raise InputError(f"{what} runs on the {' or the '.join(CONTROLLERS[what])}, not on the {where}",
                         argument="where")
    if x0 is not None:
        q1_x0 = check_finite("x0", float(np.ravel([x0])[0]))
        if not abs(q1_x0) < rig.info.params["q1_max"]:
            raise InputError(f"x0 = {q1_x0:g} rad is beyond the rig's angle limit q1_max = "
                             f"{rig.info.params['q1_max']:g} rad: the device would not arm", argument="x0")
    if what == "hopf":
        return run_on_rig(rig, "closed-loop", fast=fast, operator=operator, progress=progress,
                          limits=limits, k1=k1, k2=k2, duration=duration, x0=HOPF_START if x0 is None else x0,
                          clearing=clearing, where=where)
    if fast and not rig.has("HOST_CLOCK"):
        raise InputError(f"{rig.port}: this device runs in real time only (no HOST_CLOCK); drop --fast")
    # what the driver can give on top of the feedforward: |u| <= v_max - v_dz
    at = control_conditions(rig, run)
    Ts, u_max, q1_start = at["Ts"], at["u_max"], at["q1_start"]
    operator = operator or default_operator
    prepare(rig, fast, clearing)
    rig.set_params(v_dz_pos=V_DZ, v_dz_neg=V_DZ)
    meta = {"experiment": f"control {what}", "controller": where, "pendulum": "free", "x0": repr(q1_start),
            "params": params.to_dict() if hasattr(params, "to_dict") else str(params)}
    arrange(rig, False, operator)
    on_start = None
    if q1_start != 0.0:
        hold_at(rig, q1_start, operator)
        on_start = releaser(rig)
    command: LoopCommand
    if what == "balance" and where == "device":
        lqr = lqr_balance(params, u_max=u_max, Ts=Ts)
        rig.set_params(K_q1=float(lqr.K[0]), K_q3=float(lqr.K[1]), K_q4=float(lqr.K[2]), q1_ref=math.pi, u_max=u_max)
        rig.mode("STATE_FEEDBACK")
        meta["K"] = repr([float(k) for k in lqr.K])
        command = DeviceLaw()
    else:
        rig.mode("HOST")
        cond = RigConditions(Ts=Ts, u_max=u_max, counts_per_rev=int(rig.info.params["counts1"]))
        ctrl = SwingUpController(params, rig=cond)
        for _ in range(3):  # load its compiled observer now, not while the watchdog counts
            ctrl(0.0, np.array([q1_start, 0.0, 0.0, 0.0]))
        ctrl.reset()
        command = HostLaw(ctrl)
    if limits is None:
        limits = HostLimits(rig.info.params["q1_max"], rig.info.params["q4_max"])
    res = run_loop(rig, duration=duration, command=command, limits=limits, progress=progress, on_start=on_start)
    seq = np.array([s.seq for s in res.samples], dtype=float)
    ok = balanced([s.q1 for s in res.samples], (seq - seq[0]) * Ts if seq.size else seq)
    meta["balanced"] = "yes" if ok else "no"
    log = loop_log(res, rig.info, rig.link.stats, input_name="u", metadata=meta, source=f"{what} on {rig.port}")
    return RigRun(log, res.interrupted, res.reason, res.error, [res])

"""Sensors of other rigs: what a rig described by a :class:`~iwp.data.RigDescription` logs of the true motion.

Each function maps the true states sampled at the log's instants to the
values the rig writes, in the rig's units and conventions; the reader
:func:`iwp.data.rig_log.read_rig_log` maps them back. Together they let the
virtual rig (:mod:`iwp.rig.described`) be any such rig, with known truth.

* :func:`pendulum_reading`: ``x = (q1 + offset - zero) / (sign * unit)``,
  rounded to whole counts for an encoder; an absolute sensor in rad or deg
  (an IMU) reports within one turn, (-half turn, half turn].
* :func:`wheel_reading`: the wheel angle or speed relative to the arm, at
  the wheel or at the motor shaft (times the drive ratio); a speed
  ``sampled`` as the mean over the preceding period is the board's backward
  difference of its encoder (quantised to ``counts_per_rev``), and its
  first sample, having no preceding period, reads 0 unless a glitch is
  asked for.
* :func:`motor_current`: the current of a motor whose electrical time
  constant is neglected (section 2 of the paper), proportional to the motor
  torque: ``i = k_i (p3 w - p2_emf q4)`` with ``k_i`` [A per rad s^-2].
"""

from __future__ import annotations

import math

import numpy as np

from ..data.rig_description import CURRENT_UNITS, TIME_UNITS, PendulumSpec, RigDescription, WheelSpec
from ..errors import InputError
from ..models.encoder import quantize

__all__ = ["pendulum_reading", "wheel_reading", "motor_current", "time_reading"]


def time_reading(t, rig: RigDescription) -> np.ndarray:
    """Times [s] in the unit of the rig's time column.

    Parameters
    ----------
    t : array_like
        Times [s].
    rig : RigDescription
        The rig, whose ``time.unit`` is ``"s"``, ``"ms"`` or ``"us"``.

    Returns
    -------
    ndarray
        The times in that unit.
    """
    return np.asarray(t, dtype=float) / TIME_UNITS[rig.time.unit]


def pendulum_reading(q1, spec: PendulumSpec, *, offset: float = 0.0, noise=None) -> np.ndarray:
    """What the pendulum sensor logs for the true angle ``q1`` [rad].

    Parameters
    ----------
    q1 : array_like
        True pendulum angle [rad], 0 hanging down.
    spec : PendulumSpec
    offset : float
        The sensor's true zero error [rad] (the reading minus the truth, after ``zero``).
    noise : array_like, optional
        Sensor noise [rad] added before quantisation.
    """
    q = np.asarray(q1, dtype=float) + offset
    if noise is not None:
        q = q + np.asarray(noise, dtype=float)
    x = (q - spec.zero) / spec.sign
    if spec.unit == "counts":
        return np.round(x / spec.factor)
    half = math.pi
    x = (x + half) % (2.0 * half) - half  # an absolute sensor reports within one turn
    return x / spec.factor


def wheel_reading(q2, q4, spec: WheelSpec, *, ratio: float, Ts: float,
                  first_sample: float | None = None) -> np.ndarray:
    """What the wheel sensor logs for the true wheel angle ``q2`` [rad] and speed ``q4`` [rad/s].

    Parameters
    ----------
    q2, q4 : array_like
        True wheel angle and speed relative to the arm at the sample instants.
    spec : WheelSpec
    ratio : float
        Drive ratio (motor turns per wheel turn); used when the sensor is at the motor.
    Ts : float
        Sample period [s] (the mean speed's period).
    first_sample : float, optional
        The value a mean-speed sensor logs at the first sample (default 0: no preceding period),
        e.g. 2345 for the glitch of a board whose encoder was not reset.
    """
    k = ratio if spec.at == "motor" else 1.0
    ang = spec.sign * k * np.asarray(q2, dtype=float)
    spd = spec.sign * k * np.asarray(q4, dtype=float)
    if spec.quantity == "angle":
        if spec.unit == "counts":
            return np.round(ang / (2.0 * math.pi / spec.counts_per_rev))
        return ang / spec.factor(1.0)
    unit = spec.factor(1.0)
    if spec.sampling == "mean":
        step = 2.0 * math.pi / spec.counts_per_rev if spec.counts_per_rev else 0.0
        enc = quantize(ang, step)
        y = np.empty_like(enc)
        y[1:] = np.diff(enc) / Ts
        y[0] = 0.0 if first_sample is None else first_sample * unit
        return y / unit
    y = spd / unit
    if first_sample is not None:
        y = y.copy()
        y[0] = first_sample
    return y


def motor_current(w, q4, *, p3: float, p2_emf: float, amps_per_accel: float, unit: str = "A") -> np.ndarray:
    """Motor current for the model input ``w`` and wheel speed ``q4``, electrical time constant neglected.

    ``i = amps_per_accel * (p3 w - p2_emf q4)``: the current is the motor
    torque over ``kT`` (section 2), here in the lumped units of model (9)
    (``p3 w - p2_emf q4`` is the motor torque over ``I1_hat``) [A, or mA with ``unit``].

    Parameters
    ----------
    w : array_like
        Model input ``w`` that reaches the motor [input units].
    q4 : array_like
        Wheel velocity [rad/s], of ``w``'s shape.
    p3 : float
        Input gain [rad s^-2 per input unit].
    p2_emf : float
        Back-emf part of ``p2`` [1/s].
    amps_per_accel : float
        Current per motor torque over ``I1_hat`` [A per rad s^-2].
    unit : {"A", "mA"}, default "A"
        Unit of the result.

    Returns
    -------
    ndarray
        The current [``unit``].

    Raises
    ------
    InputError
        Unknown ``unit``.
    """
    if unit not in CURRENT_UNITS:
        raise InputError(f"unit must be one of {', '.join(CURRENT_UNITS)}, got {unit!r}")
    i = amps_per_accel * (p3 * np.asarray(w, dtype=float) - p2_emf * np.asarray(q4, dtype=float))
    return i / CURRENT_UNITS[unit]

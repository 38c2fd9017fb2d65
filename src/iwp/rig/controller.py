"""The rig's digital Hopf controller: the law of section 5.3 on the encoder readings.

On the rig the controller sees only the quantised angles, every ``Ts``. It
estimates the pendulum velocity ``q3`` from the measured ``q1`` and applies
the Hopf anticontrol law ``u = k1 q3^ + k2 q3^3``
(:func:`iwp.models.laws.hopf_law`), held until the next sample.
"""

from __future__ import annotations

import math

import numpy as np

from ..models.laws import hopf_law

__all__ = ["EncoderHopfController"]


class EncoderHopfController:
    """The rig's digital Hopf controller: ``u = k1 q3^ + k2 q3^3`` (section 5.3).

    ``q3^`` is the backward difference of the measured (quantised) ``q1``,
    low-pass filtered with a first-order filter of time constant ``tau``
    (discretised exactly: ``q3^_k = a q3^_{k-1} + (1 - a) (y_k - y_{k-1})/Ts``
    with ``a = exp(-Ts/tau)``; ``tau = 0``: no filter).

    Parameters
    ----------
    k1 : float
        Linear gain [input units s/rad].
    k2 : float
        Cubic gain [input units s^3/rad^3].
    Ts : float
        Sample time [s].
    tau : float
        Time constant of the velocity filter [s]; 0 for none.

    Notes
    -----
    Called as ``controller(t, y)`` with the measured positions
    ``y = [q1, q2]`` [rad] once per sample, in order
    (:meth:`iwp.rig.VirtualRig.record`); it keeps the filter's state.
    """

    def __init__(self, k1: float, k2: float, Ts: float, tau: float):
        self.k1, self.k2, self.Ts = float(k1), float(k2), float(Ts)
        self.a = math.exp(-Ts / tau) if tau > 0 else 0.0
        self.y_prev: float | None = None
        self.q3 = 0.0
        # the law is compiled code: its first call loads it (half a second), here, not inside a rig's real-time
        # loop, where the device's watchdog would stop the motor meanwhile
        hopf_law(self.k1, self.k2, 0.0)

    def __call__(self, t: float, y: np.ndarray) -> float:
        y1 = float(y[0])
        if self.y_prev is not None:
            d = (y1 - self.y_prev) / self.Ts
            self.q3 = self.a * self.q3 + (1.0 - self.a) * d
        self.y_prev = y1
        return float(hopf_law(self.k1, self.k2, self.q3))

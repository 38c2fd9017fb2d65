"""Feedback laws written once, for the simulator, the analysis and the rig.

:func:`hopf_law` is the amplitude controller of section 5.3, based on the
anticontrol of Hopf bifurcations (reference [15] of the paper);
:func:`balance_law` the linear state feedback at the upright (the balance
LQR of :mod:`iwp.control.balance`, beyond the paper).
"""

from __future__ import annotations

import math

from ..jit import jit


@jit
def hopf_law(k1, k2, q3):
    """The Hopf anticontrol law ``u = k1 q3 + k2 q3^3`` (section 5.3) [input units].

    ``k1`` [input units s/rad], ``k2`` [input units s^3/rad^3], ``q3`` the
    pendulum velocity [rad/s]. Works element-wise on arrays too.
    """
    return k1 * q3 + k2 * q3 * q3 * q3


@jit
def balance_law(k_angle, k_q3, k_q4, q1, q3, q4):
    """State feedback at the upright ``u = -(k_angle wrap(q1 - pi) + k_q3 q3 + k_q4 q4)`` [input units].

    ``wrap(q1 - pi)`` is the angle from the upright in ``[-pi, pi)`` [rad];
    the gains are those of :class:`iwp.control.balance.LQRBalance` on
    ``(q1 - pi, q3, q4)`` [input units per rad, per rad/s, per rad/s]. The
    saturation is applied by the caller (the controller, or the simulator's
    ``saturation``).
    """
    two_pi = 2.0 * math.pi
    err = (q1 % two_pi) - math.pi  # (q1 - pi) wrapped to [-pi, pi)
    return -(k_angle * err + k_q3 * q3 + k_q4 * q4)

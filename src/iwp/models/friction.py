"""Friction laws of section 3.

Pendulum joint (section 3.1): viscous friction ``sigma_v1 q3`` and rolling
friction ``sigma_a1 |cos q1| q3 + sigma_b1 q3^3``. Disk joint (section 3.2):
the optional Coulomb term ``sigma_c2 sgn q4`` and its Stribeck rise at low
speed (the dead zone, the main effect at this joint, is in
:mod:`iwp.models.actuator`).

The functions take the coefficients, so that the same law serves the lumped
models (coefficients over ``I1_hat``) and the Euler-Lagrange model (SI).
"""

from __future__ import annotations

import math

from ..jit import jit

#: Default regularisation of ``sgn(q4)`` in Coulomb terms [rad/s]:
#: ``sgn(q4) ~ tanh(q4 / eps)``. An exact ``sgn`` makes a disk that should
#: stick chatter and stalls any integrator; 0 selects the exact sign.
COULOMB_EPS = 0.01


@jit
def pendulum_friction(abs_cos_q1, q3, sigma_a1, sigma_v1, sigma_b1):
    """Friction torque of the pendulum joint, ``tau_f1 = tau_v1 + tau_r1`` (section 3.1).

    ``sigma_v1 q3 + sigma_a1 |cos q1| q3 + sigma_b1 q3^3``: viscous friction
    and rolling friction with the normal force of gravity and of the
    centrifugal force. Units: those of the coefficients (N m, or s^-2 for
    the lumped ``sigma~`` over ``I1_hat``). ``abs_cos_q1`` is ``|cos q1|``.
    """
    return sigma_v1 * q3 + sigma_a1 * abs_cos_q1 * q3 + sigma_b1 * q3 * q3 * q3


@jit
def coulomb_sign(x, eps):
    """``sgn(x)`` of a Coulomb friction term, regularised as ``tanh(x/eps)`` when ``eps > 0``."""
    if eps > 0.0:
        return math.tanh(x / eps)
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@jit
def stribeck_rise(x, v_s):
    """The Stribeck curve's share of the static friction's excess at speed ``x``: ``exp(-(x / v_s)^2)``.

    The disk's friction with the Stribeck effect is ``(sigma_c + sigma_s exp(-(q4/v_s)^2)) sgn q4``
    (Armstrong-Helouvry's model): at rest the static level ``sigma_c + sigma_s``, falling to the Coulomb level
    ``sigma_c`` above the Stribeck speed ``v_s`` [rad/s]. 1 at ``x = 0``; 0 for ``v_s <= 0`` (no rise).
    """
    if v_s > 0.0:
        r = x / v_s
        return math.exp(-r * r)
    return 0.0

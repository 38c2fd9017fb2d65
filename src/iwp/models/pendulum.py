"""The pendulum terms of models (6) and (9), and the free pendulum of section 5.2.

``xi = p1 sin q1 + sigma~_a1 |cos q1| q3 + sigma~_v1 q3 + sigma~_b1 q3^3``
gathers gravity and the friction of section 3.1 over ``I1_hat``; (9) reads
``q3' = -xi + p2 q4 - p3 u`` and ``q4' = xi - (1 + rho)(p2 q4 - p3 u)``.
Section 5.2 prints the rolling term of ``xi`` without its factor ``q3``
(ERRATA item 1); by (9) it has it.

The free pendulum (``u = 0``, section 5.2) comes in two forms:

* wheel held to the arm (``q4 = 0``, the motor's drive friction holds it, as
  on a belt-driven rig): the arm carries the wheel's inertia and (4a) with
  ``q2'' = 0`` gives ``q3' = -xi rho/(1 + rho)``;
* no wheel (a plain pendulum, or a wheel that turns without torque):
  ``q3' = -xi``, the paper's free-pendulum equation taken literally.

Other rigs may need a Coulomb term at the pendulum joint,
``sigma~_c1 sgn q3`` (:func:`pendulum_coulomb`, parameter ``sigma_c1``),
which the paper neglects for large oscillations (section 3.1); it adds to
``xi`` wherever ``xi`` enters, and is 0 by default.

The rolling friction ``sigma~_a1 |cos q1| q3`` has kinks where ``cos q1 = 0``
(``q1 = pi/2 + m pi``): their switching function and its prediction over a
step are :mod:`iwp.models.guards`', the one home of the models' switching
surfaces.
"""

from __future__ import annotations

from ..jit import jit
from .friction import coulomb_sign, pendulum_friction
from .layout import EPSC1, P1, RHO, SA, SB, SC1, SV
from .mathfn import sincos


@jit
def pendulum_accel_terms(q1, q3, P):
    """``xi`` of (6)/(9) and section 5.2: gravity and pendulum friction over ``I1_hat`` [s^-2]."""
    s, c = sincos(q1)
    return P[P1] * s + pendulum_friction(abs(c), q3, P[SA], P[SV], P[SB])


@jit
def pendulum_coulomb(q3, P):
    """Coulomb friction of the pendulum joint over ``I1_hat``, ``sigma~_c1 sgn q3`` [s^-2] (0 when off).

    ``sgn`` regularised as ``tanh(q3/eps)`` with the width ``eps_c1`` (the
    plant's ``coulomb_eps`` unless set, :func:`iwp.models.friction.coulomb_sign`);
    it adds to ``xi``.
    """
    if P[SC1] == 0.0:
        return 0.0
    return P[SC1] * coulomb_sign(q3, P[EPSC1])


@jit(inline=True)
def rhs_free_pendulum(x, P, dx, held):
    """The free pendulum of section 5.2: ``q3' = -xi rho/(1 + rho)`` (wheel ``held``) or ``-xi``.

    The wheel does not move relative to the arm: ``q2' = q4' = 0``.
    """
    a = -pendulum_accel_terms(x[0], x[2], P) - pendulum_coulomb(x[2], P)
    if held:
        a = a * (P[RHO] / (1.0 + P[RHO]))
    dx[0] = x[2]
    dx[1] = 0.0
    dx[2] = a
    dx[3] = 0.0

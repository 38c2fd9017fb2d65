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
(``q1 = pi/2 + m pi``): :func:`switch_of` is the switching function whose sign
changes there, :func:`kink_ahead` (with its branch-free pieces
:func:`kink_start` and :func:`kink_newton`, which the lanes run side by side)
predicts the next one on a Taylor model of the angle, and :func:`may_cross`
tells a step that surely crosses none. The engine calls them through
:mod:`iwp.models.guards`.
"""

from __future__ import annotations

import math

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


# --------------------------------------------------------------------------
# the kinks of |cos q1| (rolling friction, section 3.1)
# --------------------------------------------------------------------------
@jit(inline=True)
def switch_of(kinked, q1):
    """Switching function of the right-hand side's kinks (its sign changes there): ``cos q1``, or 1 without kink.

    The rolling friction ``sigma_a1 |cos q1| q3`` of section 3.1 has a kink
    where ``cos q1 = 0``; a Runge-Kutta step across it loses its order and its
    error estimate.
    """
    return math.cos(q1) if kinked else 1.0


@jit(inline=True)
def may_cross(q_a, q_b):
    """False only if ``cos q`` surely has one sign at ``q_a`` and ``q_b`` (branch-free, vectorises).

    The same half-period ``floor((q - pi/2)/pi)`` at both ends, neither within
    1e-9 rad of a kink: then :func:`switch_of` has one sign at both, so the
    lanes need no cosine for a step that crosses nothing.
    """
    m_a = (q_a - 0.5 * math.pi) / math.pi
    m_b = (q_b - 0.5 * math.pi) / math.pi
    f_a = math.floor(m_a)
    f_b = math.floor(m_b)
    near = (m_a - f_a < 1e-9) | (f_a + 1.0 - m_a < 1e-9) | (m_b - f_b < 1e-9) | (f_b + 1.0 - m_b < 1e-9)
    return (f_a != f_b) | near | (not (abs(q_a) < 1e9)) | (not (abs(q_b) < 1e9))


@jit(inline=True)
def half_turns_ahead(q1, v, a, jk, H):
    """The Taylor model of :func:`kink_ahead` at ``H``, ``qe``, and the half-turns ``floor((q - pi/2)/pi)`` of
    ``q1`` and ``qe`` (the kinks lie where it changes)."""
    qe = q1 + H * (v + H * (0.5 * a + H * jk / 6.0))
    m0 = math.floor((q1 - 0.5 * math.pi) / math.pi)
    me = math.floor((qe - 0.5 * math.pi) / math.pi)
    return qe, m0, me


@jit(inline=True)
def kink_possible(q1, v, a, jk, H):
    """True if ``cos q`` may change sign within ``H`` on the Taylor model of :func:`kink_ahead` (branch-free)."""
    qe, m0, me = half_turns_ahead(q1, v, a, jk, H)
    return (m0 != me) & (abs(q1) < 1e9) & (abs(qe) < 1e9)


@jit(inline=True)
def kink_start(q1, v, a, jk, H):
    """The start of :func:`kink_ahead`'s search (branch-free, so that the lanes run it side by side).

    Returns ``(qs, s, lo, hi, plo, possible)``: the kink ``qs = pi/2 + m pi``
    the Taylor model may reach within ``H``, the secant's first guess ``s``,
    the bracket ``[lo, hi] = [0, H]``, the model's offset ``plo`` from
    ``qs`` at ``lo``, and :func:`kink_possible` (the rest is meaningless
    without it).
    """
    qe, m0, me = half_turns_ahead(q1, v, a, jk, H)
    possible = kink_possible(q1, v, a, jk, H)
    qs = 0.5 * math.pi + math.pi * max(m0, me)
    plo = q1 - qs
    phi = qe - qs
    span = plo - phi if possible else 1.0
    return qs, H * plo / span, 0.0, H, plo, possible


@jit(inline=True)
def kink_newton(q1, qs, v, a, jk, H, s, lo, hi, plo):
    """One iteration of :func:`kink_ahead`'s search: Newton on the Taylor model, kept inside its bracket.

    Returns ``(s, lo, hi, plo, done)``: the next guess and bracket, and
    whether Newton's correction fell below ``1e-15 H`` (then ``s`` is the
    root, clamped into the bracket). Branch-free (selects only), so that a
    loop over lanes vectorises and a lane computes what a single run does.
    """
    p = q1 - qs + s * (v + s * (0.5 * a + s * jk / 6.0))
    left = p * plo > 0.0
    lo = s if left else lo
    plo = p if left else plo
    hi = hi if left else s
    dp = v + s * (a + 0.5 * s * jk)
    mid = 0.5 * (lo + hi)
    # (the division is computed in either case when the lanes run this side by side: not by 0)
    s_new = s - p / (dp if dp != 0.0 else 1.0) if dp != 0.0 else mid
    # converged: Newton's last correction is below the tolerance (tested before the bracket, which a root on its
    # edge would otherwise leave for a bisection, and the iteration for its cap)
    done = abs(s_new - s) <= 1e-15 * H
    inside = (lo < s_new) & (s_new < hi)
    s = min(max(s_new, lo), hi) if done else (s_new if inside else mid)
    return s, lo, hi, plo, done


#: iterations of :func:`kink_newton` at most (3-5 are usual)
KINK_ITERATIONS = 30
#: the smallest positive float: :func:`kink_ahead`'s root when Newton lands on 0
KINK_TINY = 5e-324


@jit
def kink_ahead(q1, v, a, jk, H):
    """First ``s`` in (0, H] where ``cos q(s)`` changes sign, or -1.

    ``q(s) = q1 + v s + a s^2/2 + jk s^3/6`` is the Taylor model of the
    pendulum angle over the coming step (``v = q3``, ``a = q3'`` and ``jk``
    an estimate of ``q3''``); the kinks are at ``q = pi/2 + m pi``. From
    the secant's guess, :func:`kink_newton` until it converges (the lanes run
    the same iterations side by side).
    """
    qs, s, lo, hi, plo, possible = kink_start(q1, v, a, jk, H)
    if not possible:
        return -1.0
    for _it in range(KINK_ITERATIONS):
        s, lo, hi, plo, done = kink_newton(q1, qs, v, a, jk, H, s, lo, hi, plo)
        if done:
            break
    # the start and the end lie on either side of the kink, so the root is after the start even when q1 is within
    # rounding of the kink and Newton lands on 0 (hypothesis found q1 = -pi/2 + 1.4e-16 moving towards it)
    return s if s > 0.0 else KINK_TINY

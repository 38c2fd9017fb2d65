"""The switching surfaces of the models: where a right-hand side has a kink or switches a discrete mode.

The engine (:mod:`iwp.sim.engine`, and the lanes of :mod:`iwp.sim.lanes`) ends its steps at these surfaces so
that no step integrates across them; it calls the functions below with the model code, as it calls
:func:`iwp.models.equations.rhs`, and knows neither the state's slots nor the switching functions:

=================================  ==========================================================================
function                           what
=================================  ==========================================================================
:func:`has_kink`                   the model has the rolling-friction kinks of ``|cos q1|`` (section 3.1)
:func:`kink_coordinate`            the coordinate the kinks lie on (``q1``), its rate and acceleration
:func:`kink_at`, :func:`kink_value`  the switching function of the kinks (``cos q1``), its sign changes there
:func:`has_branches`               the model holds a discrete mode (the belt's play of (15), figure 5)
:func:`branch_of`                  the parameters with the mode held on the branch of a state
:func:`switch_ahead`               which switching function of the held mode changes sign over a step
:func:`guard`, :func:`guard_needs_rate`  a switching function ``which`` (:data:`KINKS`, or the held mode's) at a state
=================================  ==========================================================================

Each model declares its switching surfaces by family name (:attr:`iwp.models.plant.ModelInfo.surfaces`):
:data:`SURFACES` says what each family is and the code ``which`` of each of its surfaces, by name. The two kinds
the engine handles are a *predicted* surface (the kinks: located ahead on a Taylor model of their coordinate and
crossed by an RK4 bridge) and the *held modes* (the play: a discrete mode held through each step, which ends where
one of its surfaces is crossed, located on the dense output). A new surface of either kind is written here
(its switching function, its detection in :func:`switch_ahead`, its hold in :func:`branch_of`) and declared on its
model; the engine and the lanes call the functions above and need no edit. A test checks the compiled functions
against the declarations.

The kinks' switching function and their prediction over a step are written here on the kink coordinate
(:func:`switch_of`, :func:`kink_ahead` on a Taylor model of the angle, with its branch-free pieces
:func:`kink_start` and :func:`kink_newton` that the lanes run side by side, and :func:`may_cross`, which tells a
step that surely crosses none); the play's guards in :mod:`iwp.models.belt`. The engine and the lanes import
the models' switching surfaces from here only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..jit import jit
from .belt import (
    PLAY_ENGAGES_LOWER,
    PLAY_ENGAGES_UPPER,
    PLAY_LEAVES_LOWER,
    PLAY_LEAVES_UPPER,
    has_play,
    play_guard_of,
    play_held,
    play_switch,
)
from .layout import E_SR, M_BELT, M_EL, M_MD, M_MD_RAW, SA

#: ``which`` of the kinks' switching function (:func:`kink_value`)
KINKS = 0.0


@dataclass(frozen=True)
class Surface:
    """One switching surface of a model: its code ``which`` for :func:`guard` and what it is.

    Attributes
    ----------
    which : float
        The code the engine hands back to :func:`guard` for it (the compiled code's).
    description : str
        Where it lies and what switches there.
    reads_rate : bool
        Its switching function reads the rate at the state (:func:`guard_needs_rate`).
    """

    which: float
    description: str
    reads_rate: bool = False


@dataclass(frozen=True)
class SurfaceFamily:
    """The switching surfaces of one family a model declares (:attr:`~iwp.models.plant.ModelInfo.surfaces`).

    Attributes
    ----------
    kind : {"predicted", "held mode"}
        How the engine meets them: located ahead and bridged (the kinks), or a mode held through each step that
        ends where one of them is crossed (the play).
    surfaces : dict of str to Surface
        Its surfaces, by name.
    """

    kind: str
    surfaces: dict[str, Surface]


#: The families of switching surfaces a model declares (:attr:`~iwp.models.plant.ModelInfo.surfaces`), by name.
SURFACES: dict[str, SurfaceFamily] = {
    "kinks": SurfaceFamily("predicted", {
        "cos q1 = 0": Surface(KINKS, "the rolling friction sigma_a1 |cos q1| q3 has kinks at q1 = pi/2 + m pi "
                                     "(section 3.1)"),
    }),
    "play": SurfaceFamily("held mode", {
        "engages upper": Surface(PLAY_ENGAGES_UPPER, "the free play's stretch reaching its upper edge, "
                                                     "delta - w = d (figure 5)"),
        "engages lower": Surface(PLAY_ENGAGES_LOWER, "the free play's stretch reaching its lower edge, "
                                                     "delta - w = -d"),
        "leaves upper": Surface(PLAY_LEAVES_UPPER, "engaged on the upper edge, the stretch's rate delta' turning "
                                                   "back through 0", reads_rate=True),
        "leaves lower": Surface(PLAY_LEAVES_LOWER, "engaged on the lower edge, delta' turning back through 0",
                                reads_rate=True),
    }),
}


@jit
def has_kink(model, P):
    """True if the model has the rolling-friction kink at ``cos q1 = 0`` (section 3.1; see :func:`kink_value`)."""
    if model == M_EL:
        return P[E_SR] != 0.0
    if model == M_MD or model == M_MD_RAW or model == M_BELT:
        return False
    return P[SA] != 0.0


@jit(inline=True)
def kink_coordinate(model, y, f):
    """The coordinate the kinks lie on at the state ``y`` with rate ``f``: ``(q1, q1', q3')`` [rad, rad/s, rad/s^2].

    Every model with the kink (:func:`has_kink`) has the pendulum angle ``q1`` first and its rate ``q3`` third;
    the kinks lie at ``q1 = pi/2 + m pi`` (:func:`kink_ahead`).
    """
    return y[0], f[0], f[2]


@jit(inline=True)
def kink_at(kinked, y):
    """The kinks' switching function at the state ``y``: ``cos q1``, or 1 when not ``kinked`` (:func:`has_kink`)."""
    return switch_of(kinked, y[0])


@jit
def kink_value(model, P, y):
    """:func:`kink_at` of a state ``y`` of ``model`` with parameters ``P``."""
    return kink_at(has_kink(model, P), y)


@jit
def has_branches(model, P):
    """True if the model holds a discrete mode through a step: a belt model (15) whose play has a width."""
    return has_play(model, P)


@jit
def branch_of(model, P, y, f):
    """The packed parameters with the discrete mode held on the branch of the state ``y`` (rate ``f``), and whether
    they changed: ``(P, changed)`` (the belt's play, :func:`~iwp.models.belt.play_held`)."""
    return play_held(P, y, f)


@jit
def switch_ahead(model, P, y, y_new, f, f_new):
    """Which switching function of the mode held in ``P`` changes sign over a step from ``y`` to ``y_new`` (rates
    ``f``, ``f_new``), or 0 (:func:`~iwp.models.belt.play_switch`): its ``which`` for :func:`guard`."""
    return play_switch(P, y, y_new, f, f_new)


@jit
def guard_needs_rate(model, which):
    """True if :func:`guard` ``which`` reads the rate at the state (the play engaged on an edge)."""
    return which == PLAY_LEAVES_UPPER or which == PLAY_LEAVES_LOWER


@jit
def guard(model, P, y, f, which):
    """The switching function ``which`` at the state ``y``: :data:`KINKS` the kinks (:func:`kink_value`), else the
    held mode's (:func:`~iwp.models.belt.play_guard_of`; ``f`` the rate at ``y`` when :func:`guard_needs_rate`)."""
    if which == KINKS:
        return kink_value(model, P, y)
    return play_guard_of(P, y, f, which)


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


__all__ = [
    "KINKS",
    "SURFACES",
    "Surface",
    "SurfaceFamily",
    "KINK_ITERATIONS",
    "KINK_TINY",
    "branch_of",
    "guard",
    "guard_needs_rate",
    "has_branches",
    "has_kink",
    "kink_at",
    "kink_coordinate",
    "kink_value",
    "kink_ahead",
    "kink_newton",
    "kink_possible",
    "kink_start",
    "may_cross",
    "switch_of",
    "switch_ahead",
]

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
:func:`guard`, :func:`guard_needs_rate`  a switching function ``which`` (0: the kinks) at a state
=================================  ==========================================================================

The kinks' prediction over a step (:func:`~iwp.models.pendulum.kink_ahead` and its branch-free pieces) is written
on the kink coordinate in :mod:`iwp.models.pendulum`; the play's guards in :mod:`iwp.models.belt`.
"""

from __future__ import annotations

from ..jit import jit
from .belt import has_play, play_guard_of, play_held, play_switch
from .layout import E_SR, M_BELT, M_EL, M_MD, M_MD_RAW, SA
from .pendulum import switch_of


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
    the kinks lie at ``q1 = pi/2 + m pi`` (:func:`~iwp.models.pendulum.kink_ahead`).
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
    return which == 2.0 or which == -2.0


@jit
def guard(model, P, y, f, which):
    """The switching function ``which`` at the state ``y``: 0 the kinks (:func:`kink_value`), else the held mode's
    (:func:`~iwp.models.belt.play_guard_of`; ``f`` the rate at ``y`` when :func:`guard_needs_rate`)."""
    if which == 0.0:
        return kink_value(model, P, y)
    return play_guard_of(P, y, f, which)


__all__ = [
    "branch_of",
    "guard",
    "guard_needs_rate",
    "has_branches",
    "has_kink",
    "kink_at",
    "kink_coordinate",
    "kink_value",
    "switch_ahead",
]

"""The flexible rubber belt of eq. (15), with the hysteresis of figure 5.

The belt couples the motor shaft (angle ``q_m``) to the disk. With the motor
inertia neglected (the paper's reduced form) the motor follows
``gamma q_m' - Psi/N = (kT beta / R) u``; the belt force ``Psi`` is a
linear spring ``k`` acting on the output ``w`` of a play (backlash) operator
of half-width ``d`` applied to the belt stretch ``delta = q2 - q_m / N``
(our reading of figure 5: a parallelogram loop of slope ``k`` and width
``2 d``). The states ``delta`` and ``w`` follow ``q1..q4``.

The play switches branch (inside the band ``w' = 0``; on an edge ``w'``
follows ``delta'``); :func:`play_rate` takes the branch from the state, or
the branch the engine holds through a step (:func:`play_branch`,
:func:`play_guard`), which ends its steps where the branch switches.
"""

from __future__ import annotations

from numba.cpython.unsafe.tuple import tuple_setitem

from ..jit import jit
from .actuator import effective_input
from .friction import coulomb_sign
from .layout import B2I2, BELT_CODES, DPLAY, EPSC, KBRG, KG, KI2, KNEG, LOCK, NB, PMODE, RHO, SC2
from .pendulum import pendulum_accel_terms, pendulum_coulomb

#: the play's branch inside its band (``w' = 0``); engaged on an edge, the branch is that edge, +1 or -1
PLAY_FREE = 2.0
#: :func:`play_guard`'s ``which`` for each of the play's switching surfaces (:data:`iwp.models.guards.SURFACES`):
#: free, reaching the upper or lower edge; engaged on it, leaving it
PLAY_ENGAGES_UPPER = 1.0
PLAY_ENGAGES_LOWER = -1.0
PLAY_LEAVES_UPPER = 2.0
PLAY_LEAVES_LOWER = -2.0


@jit
def play_branch(gap, ddelta, d):
    """The play's branch at a state (figure 5): +1 or -1 engaged on that edge (``w`` follows ``delta``), else
    :data:`PLAY_FREE`; ``gap = delta - w``, ``ddelta = delta'``, half-width ``d > 0``."""
    if gap >= d and ddelta > 0.0:
        return 1.0
    if gap <= -d and ddelta < 0.0:
        return -1.0
    return PLAY_FREE


@jit
def play_rate(gap, ddelta, d, mode):
    """Rate of the output of a play operator of half-width ``d`` (figure 5); ``gap = delta - w``.

    ``mode`` 0: the branch of the state (:func:`play_branch`); otherwise the branch held (the engine holds it
    through a step and ends steps where it switches, so that no step integrates across the switch).
    """
    if d <= 0.0:
        return ddelta
    if mode == 0.0:
        mode = play_branch(gap, ddelta, d)
    return 0.0 if mode == PLAY_FREE else ddelta


@jit
def has_play(model, P):
    """True for a belt model whose play has a width (``d > 0``)."""
    return model in BELT_CODES and P[DPLAY] > 0.0


@jit
def play_guard(P, y, ddelta, which):
    """The switching function of the play's branch held through a step; its sign changes where the branch does.

    ``which`` +1 or -1, branch free: ``d - which (delta - w)`` [rad], the room to that edge (the play engages there
    at 0); ``which`` +2 or -2, engaged on the edge ``which / 2``: ``(which / 2) ddelta`` [rad/s] (it leaves that edge
    at 0). ``y`` is the state of (15) (``delta = y[4]``, ``w = y[5]``), ``ddelta = delta'`` there.
    """
    if which == PLAY_ENGAGES_UPPER or which == PLAY_ENGAGES_LOWER:
        return P[DPLAY] - which * (y[4] - y[5])
    return 0.5 * which * ddelta


@jit
def play_held(P, y, f):
    """The packed parameters ``P`` with the play held on the branch of the state ``y`` of (15) (figure 5), and whether
    that changed them: ``(P, changed)``. ``f`` is the rate at ``y`` (``delta' = f[4]``); the branch is stored in
    ``P[PMODE]``, which :func:`play_rate` follows until the engine holds another."""
    mode = play_branch(y[4] - y[5], f[4], P[DPLAY])
    if mode == P[PMODE]:
        return P, False
    return tuple_setitem(P, PMODE, mode), True


@jit
def play_guard_of(P, y, f, which):
    """:func:`play_guard` ``which`` at the state ``y`` of (15) with its rate ``f`` (read only for ``which`` +2 or -2,
    the engaged branches, whose guard is the stretch's rate ``delta' = f[4]`` [rad/s]; else [rad])."""
    ddelta = 0.0
    if which == PLAY_LEAVES_UPPER or which == PLAY_LEAVES_LOWER:
        ddelta = f[4]
    return play_guard(P, y, ddelta, which)


@jit
def play_switch(P, y, y_new, f, f_new):
    """Which switching function of the belt's play held on its branch changes sign over a step from ``y`` to
    ``y_new`` (rates ``f`` and ``f_new``; :func:`play_guard`'s ``which``), or 0: free, the stretch reaching an edge;
    engaged, its rate turning back from the edge (figure 5)."""
    mode = P[PMODE]
    if mode == PLAY_FREE:
        for edge in (PLAY_ENGAGES_UPPER, PLAY_ENGAGES_LOWER):
            if play_guard(P, y, 0.0, edge) > 0.0 and play_guard(P, y_new, 0.0, edge) <= 0.0:
                return edge
        return 0.0
    which = 2.0 * mode
    if play_guard(P, y, f[4], which) > 0.0 and play_guard(P, y_new, f_new[4], which) <= 0.0:
        return which
    return 0.0


@jit(inline=True)
def rhs_belt(x, w, P, dx, free):
    """Right-hand side of the belt model (15); pendulum locked, or free (``free``, (4a) with (15)).

    Disk torque over ``I2`` (without inertial coupling):
    ``T = b2/I2 q4 + s_c2 rho sgn q4 + k/I2 w_b``. Motor (``J_m = 0``):
    ``q_m' = kT beta/(R gamma) w_eff + (k/gamma) w_b / N``, the gain times
    ``gain_neg`` when ``w_eff < 0`` (section 3.2). Belt stretch
    ``delta' = q4 - q_m'/N``; ``w_b`` is the play operator of ``delta``.
    Locked: ``q4' = -T`` (15). Free: ``q3' = -xi + T/rho``,
    ``q4' = -q3' - T``.
    """
    q1 = x[0]
    q3 = x[2]
    q4 = x[3]
    delta = x[4]
    wb = x[5]
    weff = effective_input(w, q4, P)
    T = P[B2I2] * q4 + P[SC2] * P[RHO] * coulomb_sign(q4, P[EPSC]) + P[KI2] * wb
    gain = P[KBRG] * P[KNEG] if weff < 0.0 else P[KBRG]  # the motor's gain may differ by sign (section 3.2)
    qm_dot = gain * weff + P[KG] * wb / P[NB]
    ddelta = q4 - qm_dot / P[NB]
    dx[1] = q4
    dx[4] = ddelta
    dx[5] = play_rate(delta - wb, ddelta, P[DPLAY], P[PMODE])
    if free and P[LOCK] == 0.0:
        acc1 = -pendulum_accel_terms(q1, q3, P) - pendulum_coulomb(q3, P) + T / P[RHO]
        dx[0] = q3
        dx[2] = acc1
        dx[3] = -acc1 - T
    else:
        dx[0] = 0.0
        dx[2] = 0.0
        dx[3] = -T

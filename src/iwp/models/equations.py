"""The right-hand sides of the paper's models, each written once and compiled.

============================  ===========================  ==================================
function                      equation                     model names
============================  ===========================  ==================================
:func:`rhs_state_space`       (6) and (9)                  ``"raw"``, ``"compensated"``
:func:`rhs_motor_disk`        (14)                         ``"motor-disk"``, ``"motor-disk-raw"``
:func:`rhs_euler_lagrange`    (4) with (3), (5)            ``"el"``
:func:`~iwp.models.belt.rhs_belt`  (15)                    ``"belt"``, ``"belt-full"``
:func:`~iwp.models.pendulum.rhs_free_pendulum`  section 5.2  ``"free"``, ``"free-nowheel"``
============================  ===========================  ==================================

All take ``(x, w, P, dx)``: the state, the plant's input (``v`` for the raw
models, ``u`` otherwise), the packed parameters of :mod:`iwp.models.layout`
and the output array; they write ``dx = x'``. :func:`rhs` dispatches on a
model code at run time; :func:`rhs_of` does it at compile time when the code
is a constant, so that only that model is compiled and inlined.

A note on the locked pendulum (section 5.1): with ``q1`` held by a clamp,
(4b) gives ``q4' = rho (-p2 q4 + p3 u)``; the paper's (14) sets
``q1 = q3 = 0`` in the second row of (6) and writes ``1 + rho``. The
difference is ``1/(1 + rho)`` (0.4 % with Table 1). ``"motor-disk"`` is the
paper's (14); the clamp (``Plant(locked=True)``) is physical.
"""

from __future__ import annotations

import math

from numba import types
from numba.extending import overload

from ..jit import jit
from .actuator import dead_zone_saturation, effective_input
from .belt import rhs_belt
from .friction import coulomb_sign, pendulum_friction, stribeck_rise
from .layout import (
    DZ,
    E_BETA,
    E_C,
    E_EPSC,
    E_G,
    E_I1,
    E_I2,
    E_KF,
    E_KT,
    E_L,
    E_M1,
    E_M2,
    E_N,
    E_R,
    E_RR,
    E_SC2,
    E_SR,
    E_SV1,
    E_SV2,
    E_VNEG,
    E_VPOS,
    EPSC,
    LOCK,
    M_BELT,
    M_BELT_FULL,
    M_COMP,
    M_EL,
    M_FREE_HELD,
    M_FREE_NOWHEEL,
    M_MD,
    M_MD_RAW,
    M_PLAIN,
    M_RAW,
    P2,
    P3,
    RHO,
    SC2,
    SWITCH_SLOTS,
    TERM_INDEX,
)
from .mathfn import sincos
from .pendulum import pendulum_accel_terms, pendulum_coulomb, rhs_free_pendulum

#: the disk's Stribeck level and speed (:mod:`iwp.models.terms`, ``stribeck``)
SS2, VS2 = TERM_INDEX["sigma_s2"], TERM_INDEX["v_s2"]


@jit(inline=True)
def rhs_state_space(x, w, P, dx, optional):
    """Models (6) and (9), and the pendulum clamped at ``q1 = q3 = 0``.

    With ``xi`` the pendulum terms and ``m = p3 w_eff - p2 q4 - s_c2 sgn q4``
    the net disk torque over ``I1_hat`` (with the Stribeck rise
    ``s_s2 exp(-(q4/v_s2)^2) sgn q4`` of the disk's friction when ``s_s2 > 0``,
    :func:`~iwp.models.friction.stribeck_rise`): ``q3' = -xi - m`` and
    ``q4' = xi + (1 + rho) m`` -- eq. (6) when ``w_eff = v - f(v)`` (dead
    zone (5) active), eq. (9) when ``w_eff = u``.

    ``optional=False`` (a compile-time constant, see :data:`M_PLAIN`) leaves
    out the dead zone, the input offset, the Coulomb terms and the clamp; the
    compiled code then has no branch and no library call.
    """
    q1 = x[0]
    q3 = x[2]
    q4 = x[3]
    weff = w
    if optional:
        weff = effective_input(w, q4, P)
    m = P[P3] * weff - P[P2] * q4
    if optional and P[SC2] != 0.0:
        m -= P[SC2] * coulomb_sign(q4, P[EPSC])
    if optional and P[SS2] != 0.0:  # the Stribeck rise of the disk's friction
        m -= P[SS2] * stribeck_rise(q4, P[VS2]) * coulomb_sign(q4, P[EPSC])
    dx[0] = q3
    dx[1] = q4
    if optional and P[LOCK] != 0.0:
        # pendulum clamped at q1 = q3 = 0: (4b) with q1'' = 0
        dx[0] = 0.0
        dx[2] = 0.0
        dx[3] = P[RHO] * m
        return
    xi = pendulum_accel_terms(q1, q3, P)
    if optional:
        xi += pendulum_coulomb(q3, P)
    dx[2] = -xi - m
    dx[3] = xi + (1.0 + P[RHO]) * m


@jit(inline=True)
def rhs_motor_disk(x, w, P, dx):
    """Model (14): ``q4' = (1 + rho)(-p2 q4 + p3 w_eff - s_c2 sgn q4)``, ``q1 = q3 = 0``."""
    q4 = x[3]
    weff = effective_input(w, q4, P)
    dx[0] = 0.0
    dx[1] = q4
    dx[2] = 0.0
    dx[3] = (1.0 + P[RHO]) * (-P[P2] * q4 + P[P3] * weff - P[SC2] * coulomb_sign(q4, P[EPSC]))


@jit(inline=True)
def rhs_euler_lagrange(x, v, P, dx):
    """Euler-Lagrange equations (4) with the motor torque (3), physical units.

    ``M(q) q'' = [-G sin q1 - tau_f1, tau_d - tau_f2]`` with
    ``M = [[I1_hat + I2, I2], [I2, I2]]``, ``G = (m1 c + m2 l) g``,
    ``tau_f1`` the pendulum friction (section 3.1),
    ``tau_d = N kT/R V - N^2 kT kF/R q4`` (3),
    ``tau_f2 = N kT/R f(V) + sigma_v2 q4 + sigma_c2 sgn q4`` (section 3.2, (5)),
    and ``V = beta v``.
    """
    q1 = x[0]
    q3 = x[2]
    q4 = x[3]
    m1 = P[E_M1]
    m2 = P[E_M2]
    I2 = P[E_I2]
    I1h = P[E_I1] + m1 * P[E_C] ** 2 + m2 * P[E_L] ** 2
    G = (m1 * P[E_C] + m2 * P[E_L]) * P[E_G]
    sigma_a1 = P[E_SR] * (m1 + m2) * P[E_G] * P[E_RR]
    sigma_b1 = P[E_SR] * (m1 * P[E_C] + m2 * P[E_L]) * P[E_RR]
    s1, c1 = sincos(q1)
    tau_f1 = pendulum_friction(abs(c1), q3, sigma_a1, P[E_SV1], sigma_b1)
    V = P[E_BETA] * v
    gain = P[E_N] * P[E_KT] / P[E_R]
    tau_d = gain * V - P[E_N] ** 2 * P[E_KT] * P[E_KF] / P[E_R] * q4
    tau_dz = gain * dead_zone_saturation(V, P[E_VPOS], P[E_VNEG])
    tau_f2 = tau_dz + P[E_SV2] * q4 + P[E_SC2] * coulomb_sign(q4, P[E_EPSC])
    r1 = -G * s1 - tau_f1
    r2 = tau_d - tau_f2
    # solve [[I1h + I2, I2], [I2, I2]] a = [r1, r2]
    a11 = I1h + I2
    det = a11 * I2 - I2 * I2
    dx[0] = q3
    dx[1] = q4
    dx[2] = (I2 * r1 - I2 * r2) / det
    dx[3] = (-I2 * r1 + a11 * r2) / det


@jit(inline=True)
def rhs(model, x, w, P, dx):
    """The right-hand side of the model with code ``model`` (run-time dispatch)."""
    if model == M_EL:
        rhs_euler_lagrange(x, w, P, dx)
    elif model == M_MD or model == M_MD_RAW:
        rhs_motor_disk(x, w, P, dx)
    elif model == M_BELT:
        rhs_belt(x, w, P, dx, False)
    elif model == M_BELT_FULL:
        rhs_belt(x, w, P, dx, True)
    elif model == M_FREE_HELD:
        rhs_free_pendulum(x, P, dx, True)
    elif model == M_FREE_NOWHEEL:
        rhs_free_pendulum(x, P, dx, False)
    elif model == M_RAW or model == M_COMP or model == M_PLAIN:
        rhs_state_space(x, w, P, dx, True)
    else:  # a code no branch knows: NaN, which every caller reports (a model of MODELS missing here; tests)
        dx[0] = math.nan
        dx[1] = math.nan
        dx[2] = math.nan
        dx[3] = math.nan


@jit(inline=True)
def optional_terms_off(model, P):
    """True if ``model`` with parameters ``P`` is model (9) without dead zone, input offset, Coulomb terms, clamp.

    Then ``rhs_of(M_PLAIN, ...)`` gives the same derivatives with code that
    has no branch and no library call (it vectorises across lanes).
    """
    if model != M_RAW and model != M_COMP:
        return False
    if P[DZ] != 0.0 or P[LOCK] != 0.0:
        return False
    for i in SWITCH_SLOTS:  # each optional term's switch (iwp.models.terms.SWITCHES)
        if P[i] != 0.0:
            return False
    return True


def rhs_of(model, x, w, P, dx):
    """:func:`rhs` for compiled callers; with a constant ``model`` only that model is compiled."""
    rhs(model, x, w, P, dx)


# inlined at numba's IR level: a call here is opaque to LLVM, which then leaves the lanes' stage loop
# (iwp.sim.lanes.plain_stages) scalar; M_PLAIN has no branch, the other codes stay calls
@overload(rhs_of, prefer_literal=True, inline="always")
def _rhs_of_overload(model, x, w, P, dx):
    if not isinstance(model, types.IntegerLiteral):
        return lambda model, x, w, P, dx: rhs(model, x, w, P, dx)
    code = model.literal_value
    if code == M_PLAIN:
        return lambda model, x, w, P, dx: rhs_state_space(x, w, P, dx, False)
    if code in (M_RAW, M_COMP):
        return lambda model, x, w, P, dx: _rhs_state_space_optional(x, w, P, dx)
    return lambda model, x, w, P, dx: rhs(model, x, w, P, dx)


@jit
def _rhs_state_space_optional(x, w, P, dx):
    """:func:`rhs_state_space` with its optional terms, called (its branches are not inlined into the caller)."""
    rhs_state_space(x, w, P, dx, True)

"""The models of the paper, each right-hand side written once.

Every right-hand side is a numba-compiled function so that the compiled
simulator (:mod:`iwp.simulate`), the identification and the tests all use
the same code. The public, Python-level entry points are :func:`rhs`,
:func:`dead_zone`, :func:`feedforward`, :func:`energy` and
:func:`linearize`; they take the parameter dataclasses of
:mod:`iwp.params`.

Models (``model=`` names)
-------------------------
``"el"``
    Euler-Lagrange equations (4) with the dc motor (3) and the friction laws of
    section 3, in :class:`~iwp.params.PhysicalParameters`; input ``v``
    (``V_i = beta v``); dead zone (5) and Coulomb friction included.
``"raw"``
    State-space model (6) in :class:`~iwp.params.LumpedParameters`, driven by
    the raw input ``v`` through the dead zone (5).
``"compensated"``
    The feedforward-compensated model (9), driven by the ideal input ``u``.
``"motor-disk"``
    Model (14) with the pendulum locked (``q1 = q3 = 0``) after exact
    compensation, ``q4' = (1 + rho)(-p2 q4 + p3 u - sigma_c2 sgn q4)``; the
    Coulomb term of section 5.1 is active when ``sigma_c2 > 0``.
``"motor-disk-raw"``
    Model (14) driven by the raw input ``v`` through the dead zone.
``"belt"``
    The flexible-belt model (15) with the pendulum locked and the motor
    inertia neglected (the paper's reduced form), with the hysteresis of
    figure 5, driven by ``u``; :class:`~iwp.params.BeltParameters`.
``"belt-full"``
    The belt model with the pendulum free: (4a) together with (15), with
    the pendulum friction of section 3.1, the dead zone (optional) and the
    Coulomb friction of the disk. This is the virtual rig's truth plant.

States are ``x = [q1, q2, q3, q4]`` (positions [rad], velocities [rad/s]);
the belt models add ``delta`` (belt stretch ``q2 - q_m/N`` [rad]) and ``w``
(output of the play operator [rad]).

A note on the locked pendulum (section 5.1): with ``q1`` held by a clamp,
(4b) gives ``q4' = rho (-p2 q4 + p3 u)``; the paper's (14) sets
``q1 = q3 = 0`` in the second row of (6) and writes ``1 + rho``. The
difference is ``1/(1 + rho)`` (0.4 % with Table 1). ``"motor-disk"`` is the
paper's (14); the virtual rig's clamp (``locked=True``) is physical.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, types
from numba.extending import overload

#: LLVM fast-math flags: contraction and reassociation, but NaN and inf keep
#: their IEEE meaning so that divergence is still detected.
_FM = {"contract", "reassoc", "nsz", "arcp"}

from .errors import InputError
from .params import BeltParameters, LumpedParameters, PhysicalParameters

__all__ = [
    "MODELS",
    "StartupFriction",
    "rhs",
    "dead_zone",
    "dead_zone_output",
    "feedforward",
    "energy",
    "linearize",
    "to_statespace",
    "state_size",
]

# --------------------------------------------------------------------------
# Model codes and the packed parameter layout (internal to iwp)
# --------------------------------------------------------------------------
M_EL = 0
M_RAW = 1
M_COMP = 2
M_MD = 3
M_MD_RAW = 4
M_BELT = 5
M_BELT_FULL = 6
#: Internal code, never a user's model: model (9) compiled without its
#: optional terms (dead zone, Coulomb, clamp), for callers that have checked
#: :func:`plain_rhs`. Its right-hand side is that of "compensated".
M_PLAIN = 7

MODELS = {
    "el": M_EL,
    "raw": M_RAW,
    "compensated": M_COMP,
    "motor-disk": M_MD,
    "motor-disk-raw": M_MD_RAW,
    "belt": M_BELT,
    "belt-full": M_BELT_FULL,
}

# lumped layout
P1, P2, P3, RHO, SA, SV, SB, VPOS, VNEG, SC2, EPSC, BRK, WS, LOCK, DZ = range(15)
KI2, DPLAY, NB, B2I2, KG, KBRG = range(15, 21)
N_LUMPED = 21
# physical layout (model "el")
(E_M1, E_M2, E_I1, E_I2, E_L, E_C, E_G, E_KT, E_KF, E_R, E_N, E_BETA, E_SV1, E_SR, E_RR, E_SV2, E_SC2,
 E_VPOS, E_VNEG, E_EPSC) = range(20)
N_PHYS = 20
#: length of every packed parameter vector (one layout size for all models)
N_PACK = max(N_LUMPED, N_PHYS)

#: Default regularisation of ``sgn(q4)`` in Coulomb terms [rad/s]:
#: ``sgn(q4) ~ tanh(q4 / eps)``. An exact ``sgn`` makes a disk that should
#: stick chatter and stalls any integrator; 0 selects the exact sign.
COULOMB_EPS = 0.01


@dataclass(frozen=True)
class StartupFriction:
    """Break-away of the disk: the start-up discontinuity of figure 2(a).

    At rest the dead-zone thresholds are ``(1 + break_ratio) v+`` and
    ``(1 + break_ratio) v-``; they fall to ``v+`` and ``v-`` as the disk
    speeds up, ``v(q4) = v (1 + break_ratio exp(-(q4/omega_s)^2))``. The
    static curve then jumps when the disk starts (figure 2a).

    Parameters
    ----------
    break_ratio : float
        Extra threshold at rest, relative to ``v+``/``v-`` [-].
    omega_s : float
        Stribeck velocity [rad/s].
    """

    break_ratio: float = 0.0  # [-]
    omega_s: float = 1.0  # [rad/s]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.break_ratio) and self.break_ratio >= 0):
            raise InputError(f"StartupFriction.break_ratio must be finite and >= 0, got {self.break_ratio!r}")
        if not (math.isfinite(self.omega_s) and self.omega_s > 0):
            raise InputError(f"StartupFriction.omega_s must be finite and > 0, got {self.omega_s!r}")


def state_size(model: str) -> int:
    """Number of states of ``model`` (4, or 6 for the belt models)."""
    return 6 if MODELS[_model_code_name(model)] in (M_BELT, M_BELT_FULL) else 4


def _model_code_name(model: str) -> str:
    if model not in MODELS:
        raise InputError(f"unknown model {model!r}; choose one of: {', '.join(MODELS)}")
    return model


def pack(
    model: str,
    params,
    *,
    belt: BeltParameters | None = None,
    startup: StartupFriction | None = None,
    coulomb_eps: float = COULOMB_EPS,
    locked: bool = False,
    dead_zone_active: bool | None = None,
) -> tuple[int, np.ndarray]:
    """Internal: the model code and packed parameter vector for the kernels."""
    code = MODELS[_model_code_name(model)]
    if not (math.isfinite(coulomb_eps) and coulomb_eps >= 0):
        raise InputError(f"coulomb_eps must be finite and >= 0, got {coulomb_eps!r}")
    if code == M_EL:
        if not isinstance(params, PhysicalParameters):
            raise InputError("model 'el' (eq. (4)) needs PhysicalParameters; got " + type(params).__name__)
        P = np.zeros(N_PACK)
        d = params.to_dict()
        for i, name in enumerate(
            ["m1", "m2", "I1", "I2", "l", "c", "g", "kT", "kF", "R", "N", "beta", "sigma_v1", "sigma_r", "r",
             "sigma_v2", "sigma_c2", "V_dz_pos", "V_dz_neg"]
        ):
            P[i] = d[name]
        P[E_EPSC] = coulomb_eps
        return code, P
    if isinstance(params, PhysicalParameters):
        params = params.to_lumped()
    if not isinstance(params, LumpedParameters):
        raise InputError(f"model {model!r} needs LumpedParameters; got {type(params).__name__}")
    P = np.zeros(N_PACK)
    P[P1], P[P2], P[P3], P[RHO] = params.p1, params.p2, params.p3, params.rho
    P[SA], P[SV], P[SB] = params.sigma_a1, params.sigma_v1, params.sigma_b1
    P[VPOS], P[VNEG], P[SC2] = params.v_dz_pos, params.v_dz_neg, params.sigma_c2
    P[EPSC] = coulomb_eps
    if startup is not None:
        P[BRK], P[WS] = startup.break_ratio, startup.omega_s
    else:
        P[WS] = 1.0
    P[LOCK] = 1.0 if locked else 0.0
    if dead_zone_active is None:
        dead_zone_active = code in (M_RAW, M_MD_RAW)
    P[DZ] = 1.0 if dead_zone_active else 0.0
    if code in (M_BELT, M_BELT_FULL):
        if belt is None:
            raise InputError(f"model {model!r} needs belt=BeltParameters(...)")
        P[KI2], P[DPLAY], P[NB] = belt.k_over_I2, belt.d, belt.N
        P[B2I2], P[KG], P[KBRG] = belt.b2_over_I2, belt.k_over_gamma, belt.kTbeta_over_Rgamma
    return code, P


# --------------------------------------------------------------------------
# Compiled building blocks
# --------------------------------------------------------------------------
@njit(cache=True, fastmath=_FM)
def _sat(v, vpos, vneg):
    """Saturation ``f`` of the dead zone (5), in input units."""
    if v > vpos:
        return vpos
    if v < -vneg:
        return -vneg
    return v


@njit(cache=True, fastmath=_FM)
def _dz_out(v, vpos, vneg):
    """Net effective input ``v - f(v)`` of the dead zone: ``p3 v - tau~_dz = p3 (v - f(v))``."""
    return v - _sat(v, vpos, vneg)


@njit(cache=True, fastmath=_FM)
def _ff(u, vpos, vneg):
    """Dead-zone feedforward (7)-(8): ``v = u + v+`` (u > 0), ``u - v-`` (u < 0), 0 (u = 0)."""
    if u > 0.0:
        return u + vpos
    if u < 0.0:
        return u - vneg
    return 0.0


@njit(cache=True, fastmath=_FM)
def _sgn(x, eps):
    """``sgn(x)``, regularised as ``tanh(x/eps)`` when ``eps > 0``."""
    if eps > 0.0:
        return math.tanh(x / eps)
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


#: Flags for :func:`_sincos`: no reassociation, which would undo the
#: Cody-Waite reduction and the compensated sum of the cosine.
_FM_EXACT = {"contract", "nsz", "arcp"}
# pi/2 in three parts (the first two with trailing zero bits) and 2/pi (fdlibm)
_INVPIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_3 = 2.02226624871116645580e-21
# fdlibm's minimax coefficients of sin and cos on [-pi/4, pi/4]
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11


#: Largest |angle| [rad] that :func:`_sincos` reduces accurately; beyond it
#: (and for inf or NaN) it returns NaN, which the simulator reports as a
#: diverged run.
SINCOS_MAX = 1.0e9


@njit(cache=True, fastmath=_FM_EXACT)
def _sincos(x):
    """``(sin x, cos x)``, within 2 ulp of libm for ``|x| <= SINCOS_MAX`` (NaN beyond).

    fdlibm's algorithm written out: Cody-Waite reduction by pi/2 in three
    parts, the minimax polynomials of ``__kernel_sin`` and ``__kernel_cos``
    and a branch-free choice of quadrant. Being straight-line code without a
    library call, it is inlined into the integrator, overlaps with the stage
    arithmetic and vectorises across simulations run side by side
    (:mod:`iwp._lanes`); libm's ``sin`` and ``cos`` are two calls that do
    neither.
    """
    x = x if abs(x) <= SINCOS_MAX else math.nan
    fn = math.floor(x * _INVPIO2 + 0.5)
    r = ((x - fn * _PIO2_1) - fn * _PIO2_2) - fn * _PIO2_3
    z = r * r
    w = z * z
    s = r + z * r * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    cr = z * (_C1 + z * (_C2 + z * _C3)) + w * w * (_C4 + z * (_C5 + z * _C6))
    hz = 0.5 * z
    wc = 1.0 - hz
    c = wc + (((1.0 - wc) - hz) + z * cr)
    # quadrant fn mod 4 (NaN, whose conversion to an integer is undefined, as 0)
    n = int(fn if fn == fn else 0.0)
    odd = (n & 1) != 0
    sq = c if odd else s
    cq = s if odd else c
    if n & 2:
        sq = -sq
    if (n + 1) & 2:
        cq = -cq
    return sq, cq


@njit(cache=True, fastmath=_FM)
def _xi(q1, q3, P):
    """Pendulum terms ``p1 sin q1 + s_a1 |cos q1| q3 + s_v1 q3 + s_b1 q3^3`` of (6)/(9) [s^-2]."""
    s, c = _sincos(q1)
    return P[P1] * s + P[SA] * abs(c) * q3 + P[SV] * q3 + P[SB] * q3 * q3 * q3


@njit(cache=True, fastmath=_FM)
def _effective_input(w, q4, P):
    """The input after the dead zone when it is active (model (6)/(14) raw), else ``w``."""
    if P[DZ] == 0.0:
        return w
    scale = 1.0
    if P[BRK] > 0.0:
        r = q4 / P[WS]
        scale = 1.0 + P[BRK] * math.exp(-r * r)
    return _dz_out(w, P[VPOS] * scale, P[VNEG] * scale)


@njit(cache=True, fastmath=_FM)
def _play_rate(gap, ddelta, d):
    """Rate of the play (backlash) operator of half-width ``d``; ``gap = delta - w``."""
    if d <= 0.0:
        return ddelta
    if gap >= d and ddelta > 0.0:
        return ddelta
    if gap <= -d and ddelta < 0.0:
        return ddelta
    return 0.0


@njit(cache=True, fastmath=_FM, inline="always")
def _rhs_lumped(x, w, P, dx, optional):
    """Models (6)/(9) (and the clamped pendulum): one right-hand side.

    With ``xi`` the pendulum terms and ``m = p3 w_eff - p2 q4 - s_c2 sgn q4``
    the net disk torque over ``I1_hat``:
    ``q3' = -xi - m`` and ``q4' = xi + (1 + rho) m`` -- eq. (6) when
    ``w_eff = v - f(v)``, eq. (9) when ``w_eff = u``.

    ``optional=False`` (a constant of the caller, see :data:`M_PLAIN`) leaves
    out the dead zone, the Coulomb term and the clamp; the compiled code then
    has no branch and no library call.
    """
    q1 = x[0]
    q3 = x[2]
    q4 = x[3]
    weff = w
    if optional:
        weff = _effective_input(w, q4, P)
    m = P[P3] * weff - P[P2] * q4
    if optional and P[SC2] != 0.0:
        m -= P[SC2] * _sgn(q4, P[EPSC])
    dx[0] = q3
    dx[1] = q4
    if optional and P[LOCK] != 0.0:
        # pendulum clamped at q1 = q3 = 0: (4b) with q1'' = 0
        dx[0] = 0.0
        dx[2] = 0.0
        dx[3] = P[RHO] * m
        return
    xi = _xi(q1, q3, P)
    dx[2] = -xi - m
    dx[3] = xi + (1.0 + P[RHO]) * m


@njit(cache=True, fastmath=_FM, inline="always")
def _rhs_motor_disk(x, w, P, dx):
    """Model (14): ``q4' = (1 + rho)(-p2 q4 + p3 w_eff - s_c2 sgn q4)``, ``q1 = q3 = 0``."""
    q4 = x[3]
    weff = _effective_input(w, q4, P)
    dx[0] = 0.0
    dx[1] = q4
    dx[2] = 0.0
    dx[3] = (1.0 + P[RHO]) * (-P[P2] * q4 + P[P3] * weff - P[SC2] * _sgn(q4, P[EPSC]))


@njit(cache=True, fastmath=_FM, inline="always")
def _rhs_belt(x, w, P, dx, free):
    """Flexible belt (15) with the play hysteresis; pendulum locked or free.

    Disk torque over ``I2`` (without inertial coupling):
    ``T = b2/I2 q4 + s_c2 rho sgn q4 + k/I2 w_b``. Motor (``J_m = 0``):
    ``q_m' = kT beta/(R gamma) w_eff + (k/gamma) w_b / N``. Belt stretch
    ``delta' = q4 - q_m'/N``; ``w_b`` is the play operator of ``delta``.
    Locked: ``q4' = -T`` (15). Free: ``q3' = -xi + T/rho``,
    ``q4' = -q3' - T`` ((4a) with (15)).
    """
    q1 = x[0]
    q3 = x[2]
    q4 = x[3]
    delta = x[4]
    wb = x[5]
    weff = _effective_input(w, q4, P)
    T = P[B2I2] * q4 + P[SC2] * P[RHO] * _sgn(q4, P[EPSC]) + P[KI2] * wb
    qm_dot = P[KBRG] * weff + P[KG] * wb / P[NB]
    ddelta = q4 - qm_dot / P[NB]
    dx[1] = q4
    dx[4] = ddelta
    dx[5] = _play_rate(delta - wb, ddelta, P[DPLAY])
    if free and P[LOCK] == 0.0:
        acc1 = -_xi(q1, q3, P) + T / P[RHO]
        dx[0] = q3
        dx[2] = acc1
        dx[3] = -acc1 - T
    else:
        dx[0] = 0.0
        dx[2] = 0.0
        dx[3] = -T


@njit(cache=True, fastmath=_FM, inline="always")
def _rhs_el(x, v, P, dx):
    """Euler-Lagrange equations (4) with the motor torque (3), physical units.

    ``M(q) q'' = [-G sin q1 - tau_f1, tau_d - tau_f2]`` with
    ``M = [[I1_hat + I2, I2], [I2, I2]]``, ``G = (m1 c + m2 l) g``,
    ``tau_f1 = sigma_v1 q3 + sigma_a1 |cos q1| q3 + sigma_b1 q3^3`` (3.1),
    ``tau_d = N kT/R V - N^2 kT kF/R q4`` (3),
    ``tau_f2 = N kT/R f(V) + sigma_v2 q4 + sigma_c2 sgn q4`` (3.2, (5)),
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
    s1, c1 = _sincos(q1)
    tau_f1 = P[E_SV1] * q3 + sigma_a1 * abs(c1) * q3 + sigma_b1 * q3 * q3 * q3
    V = P[E_BETA] * v
    gain = P[E_N] * P[E_KT] / P[E_R]
    tau_d = gain * V - P[E_N] ** 2 * P[E_KT] * P[E_KF] / P[E_R] * q4
    tau_dz = gain * _sat(V, P[E_VPOS], P[E_VNEG])
    tau_f2 = tau_dz + P[E_SV2] * q4 + P[E_SC2] * _sgn(q4, P[E_EPSC])
    r1 = -G * s1 - tau_f1
    r2 = tau_d - tau_f2
    # solve [[I1h + I2, I2], [I2, I2]] a = [r1, r2]
    a11 = I1h + I2
    det = a11 * I2 - I2 * I2
    dx[0] = q3
    dx[1] = q4
    dx[2] = (I2 * r1 - I2 * r2) / det
    dx[3] = (-I2 * r1 + a11 * r2) / det


@njit(cache=True, fastmath=_FM, inline="always")
def _rhs(model, x, w, P, dx):
    """Dispatch on the model code; ``w`` is the model's input (``v`` or ``u``)."""
    if model == M_EL:
        _rhs_el(x, w, P, dx)
    elif model == M_MD or model == M_MD_RAW:
        _rhs_motor_disk(x, w, P, dx)
    elif model == M_BELT:
        _rhs_belt(x, w, P, dx, False)
    elif model == M_BELT_FULL:
        _rhs_belt(x, w, P, dx, True)
    else:
        _rhs_lumped(x, w, P, dx, True)


@njit(cache=True, fastmath=_FM, inline="always")
def plain_rhs(model, P):
    """True if ``model`` with parameters ``P`` is model (9) without its optional terms.

    That is model (6)/(9) with the dead zone, the Coulomb term and the clamp
    off, so that ``rhs_of(M_PLAIN, ...)`` gives the same derivatives with
    code that has no branch and no library call (it vectorises).
    """
    if model != M_RAW and model != M_COMP:
        return False
    return P[DZ] == 0.0 and P[SC2] == 0.0 and P[LOCK] == 0.0


def rhs_of(model, x, w, P, dx):
    """``_rhs`` for compiled callers whose ``model`` is a compile-time constant.

    Only the chosen model's right-hand side is typed, compiled and inlined
    (see the overload below); with a run-time ``model`` it is :func:`_rhs`.
    """
    _rhs(model, x, w, P, dx)


@overload(rhs_of, prefer_literal=True)
def _rhs_of_overload(model, x, w, P, dx):
    if not isinstance(model, types.IntegerLiteral):
        return lambda model, x, w, P, dx: _rhs(model, x, w, P, dx)
    code = model.literal_value
    if code == M_EL:
        return lambda model, x, w, P, dx: _rhs_el(x, w, P, dx)
    if code == M_MD or code == M_MD_RAW:
        return lambda model, x, w, P, dx: _rhs_motor_disk(x, w, P, dx)
    if code == M_BELT:
        return lambda model, x, w, P, dx: _rhs_belt(x, w, P, dx, False)
    if code == M_BELT_FULL:
        return lambda model, x, w, P, dx: _rhs_belt(x, w, P, dx, True)
    if code == M_PLAIN:
        return lambda model, x, w, P, dx: _rhs_lumped(x, w, P, dx, False)
    return lambda model, x, w, P, dx: _rhs_lumped(x, w, P, dx, True)


# --------------------------------------------------------------------------
# Python-level API
# --------------------------------------------------------------------------
def rhs(
    model: str,
    params,
    x,
    w: float,
    *,
    belt: BeltParameters | None = None,
    startup: StartupFriction | None = None,
    coulomb_eps: float = COULOMB_EPS,
    locked: bool = False,
    dead_zone_active: bool | None = None,
) -> np.ndarray:
    """Evaluate the right-hand side ``x' = f(x, w)`` of ``model``.

    Parameters
    ----------
    model : str
        One of :data:`MODELS` (see the module docstring).
    params : LumpedParameters or PhysicalParameters
        Parameter set (``PhysicalParameters`` for ``"el"``).
    x : array_like, shape (4,) or (6,)
        State ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s] (+ ``delta, w`` for the belt models).
    w : float
        Input: ``v`` for ``"el"``, ``"raw"``, ``"motor-disk-raw"``; ``u``
        otherwise [input units].
    belt, startup, coulomb_eps, locked, dead_zone_active
        Model options, see :func:`iwp.simulate.simulate`.

    Returns
    -------
    ndarray
        ``x'`` with the shape of ``x``.
    """
    code, P = pack(model, params, belt=belt, startup=startup, coulomb_eps=coulomb_eps, locked=locked,
                   dead_zone_active=dead_zone_active)
    x = np.asarray(x, dtype=float)
    n = 6 if code in (M_BELT, M_BELT_FULL) else 4
    if x.shape != (n,):
        raise InputError(f"x must have shape ({n},) for model {model!r}, got {x.shape}")
    dx = np.zeros(n)
    _rhs(code, x, float(w), P, dx)
    return dx


def dead_zone(v, v_dz_pos: float, v_dz_neg: float):
    """The dead-zone saturation ``f(v)`` of (5) in input units (vectorised)."""
    v = np.asarray(v, dtype=float)
    return np.clip(v, -v_dz_neg, v_dz_pos)


def dead_zone_output(v, v_dz_pos: float, v_dz_neg: float):
    """The effective input ``v - f(v)`` that reaches the disk through the dead zone (5)."""
    v = np.asarray(v, dtype=float)
    return v - dead_zone(v, v_dz_pos, v_dz_neg)


def feedforward(u, v_dz_pos: float, v_dz_neg: float | None = None):
    """Dead-zone feedforward (7)-(8): ``v = u + tau~_c(u)/p3``.

    ``v = u + v+`` for ``u > 0``, ``u - v-`` for ``u < 0`` and ``0`` for
    ``u = 0``, with asymmetric thresholds (``v_dz_neg`` defaults to
    ``v_dz_pos``; the paper uses ``v+ = v- = 31``).
    """
    if v_dz_neg is None:
        v_dz_neg = v_dz_pos
    u = np.asarray(u, dtype=float)
    return np.where(u > 0, u + v_dz_pos, np.where(u < 0, u - v_dz_neg, 0.0))


def energy(params, x) -> dict[str, np.ndarray]:
    """Kinetic and potential energy.

    For :class:`PhysicalParameters`, in joules:
    ``T = 1/2 I1_hat q3^2 + 1/2 I2 (q3 + q4)^2`` and
    ``V = (m1 c + m2 l) g (1 - cos q1)`` (eq. (2)).
    For :class:`LumpedParameters`, per unit ``I1_hat`` [s^-2]:
    ``T = 1/2 q3^2 + 1/2 (q3 + q4)^2 / rho`` and ``V = p1 (1 - cos q1)``.

    Parameters
    ----------
    x : array_like, shape (4,) or (n, 4)
        States.

    Returns
    -------
    dict
        ``{"kinetic": T, "potential": V, "total": T + V}``.
    """
    x = np.asarray(x, dtype=float)
    q1, q3, q4 = x[..., 0], x[..., 2], x[..., 3]
    if isinstance(params, PhysicalParameters):
        T = 0.5 * params.I1_hat * q3**2 + 0.5 * params.I2 * (q3 + q4) ** 2
        V = (params.m1 * params.c + params.m2 * params.l) * params.g * (1.0 - np.cos(q1))
    else:
        T = 0.5 * q3**2 + 0.5 * (q3 + q4) ** 2 / params.rho
        V = params.p1 * (1.0 - np.cos(q1))
    return {"kinetic": T, "potential": V, "total": T + V}


_EQUILIBRIA = {"down": 0.0, "hanging": 0.0, "up": math.pi, "upright": math.pi}


def linearize(params: LumpedParameters, equilibrium: str = "down") -> tuple[np.ndarray, np.ndarray]:
    """Linearisation ``(A, B)`` of the compensated model (9) at an equilibrium.

    At ``q1* = 0`` (``"down"``) or ``pi`` (``"up"``), ``q2`` arbitrary,
    ``q3 = q4 = 0``, ``u = 0``:

    ``A = [[0, 0, 1, 0], [0, 0, 0, 1], [-c, 0, -s, p2], [c, 0, s, -p2 (1 + rho)]]``,
    ``B = [0, 0, -p3, p3 (1 + rho)]^T`` with ``c = p1 cos q1*`` and
    ``s = sigma~_a1 + sigma~_v1`` (the ``q3^3`` term has zero slope). The
    Coulomb term is not part of (9) and is ignored.

    Returns
    -------
    A : ndarray, shape (4, 4)
    B : ndarray, shape (4, 1)
    """
    if equilibrium not in _EQUILIBRIA:
        raise InputError(f"equilibrium must be one of {', '.join(_EQUILIBRIA)}, got {equilibrium!r}")
    q1s = _EQUILIBRIA[equilibrium]
    c = params.p1 * math.cos(q1s)
    s = params.sigma_a1 * abs(math.cos(q1s)) + params.sigma_v1
    r1 = 1.0 + params.rho
    A = np.array(
        [
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [-c, 0.0, -s, params.p2],
            [c, 0.0, s, -params.p2 * r1],
        ]
    )
    B = np.array([[0.0], [0.0], [-params.p3], [params.p3 * r1]])
    return A, B


def to_statespace(params: LumpedParameters, equilibrium: str = "down"):
    """The linearisation as a python-control ``StateSpace`` (outputs: the full state).

    Needs the optional extra: ``pip install iwp[control]``.
    """
    try:
        import control
    except ImportError:  # pragma: no cover - exercised only without the extra
        raise InputError("to_statespace needs python-control: pip install 'iwp[control]'") from None
    A, B = linearize(params, equilibrium)
    return control.ss(A, B, np.eye(4), np.zeros((4, 1)), inputs=["u"], outputs=["q1", "q2", "q3", "q4"],
                      states=["q1", "q2", "q3", "q4"])

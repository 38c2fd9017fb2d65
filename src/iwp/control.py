"""Control of the inertia wheel pendulum.

Two parts:

**Hopf amplitude design** (section 5.3). The closed loop of the
compensated model (9) with the anticontrol law ``u = k1 q3 + k2 q3^3``
oscillates with an amplitude set by ``k1`` and ``k2``; the paper chose them
"based on a bifurcation analysis and numerical continuation". Here:

* :func:`hopf_point` -- the Hopf point ``k1*`` where a complex pair of the
  linearisation crosses the imaginary axis, the first Lyapunov coefficient
  ``l1`` (its sign, set by ``k2``, decides super- or subcritical) and the
  small-amplitude prediction ``A ~ c sqrt(k1* - k1)``.
* :func:`continue_hopf` -- numerical continuation of the periodic orbit in
  ``k1`` from the Hopf point: shooting with the variational equations and
  pseudo-arclength; amplitude, period, Floquet multipliers along the branch.
* :func:`design_hopf` -- the inverse problem: the gain that gives a wanted
  amplitude ``max q1``.
* :func:`simulated_amplitude` -- the amplitude reached by a long simulation
  (the check).

**Swing-up and balance** (beyond the paper). :func:`lqr_balance` designs
an LQR at the upright on the linearisation of (9) at ``q1 = pi``;
:class:`SwingUpController` pumps energy with the wheel from rest at the
bottom, then switches to the LQR near the top; it can run on the rig's
conditions (dead zone compensated with a mismatched threshold, encoder
quantisation, 5 ms sampling, ``|u| <= 100``) through :class:`RigConditions`
and an observer on quantised encoder positions. :func:`swing_up` runs it.

The closed loop is written through the compiled right-hand side of
:mod:`iwp.models`; no model equation is repeated here. ``q2`` is cyclic
(it enters nothing), so the Hopf analysis works on ``(q1, q3, q4)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from ._util import check_finite, check_positive
from .errors import InputError, SimulationError
from .models import MODELS, _rhs, linearize, pack
from .params import LumpedParameters

__all__ = [
    "closed_loop_matrix",
    "HopfPoint",
    "hopf_point",
    "PeriodicOrbit",
    "HopfBranch",
    "continue_hopf",
    "find_orbit",
    "HopfDesign",
    "design_hopf",
    "simulated_amplitude",
    "SimulatedOscillation",
    "LQRBalance",
    "lqr_balance",
    "RigConditions",
    "EncoderObserver",
    "pendulum_energy",
    "SwingUpController",
    "SwingUpResult",
    "swing_up",
]

_RED = (0, 2, 3)  # reduced state (q1, q3, q4) inside x = [q1, q2, q3, q4]
_M_COMP = MODELS["compensated"]


def _lumped(params) -> LumpedParameters:
    from .params import PhysicalParameters

    if isinstance(params, PhysicalParameters):
        params = params.to_lumped()
    if not isinstance(params, LumpedParameters):
        raise InputError(f"params must be LumpedParameters, got {type(params).__name__}")
    return params


# ==========================================================================
# Linearisation and the Hopf point
# ==========================================================================
def closed_loop_matrix(params: LumpedParameters, k1: float) -> np.ndarray:
    """Reduced linearisation of the closed loop at the hanging equilibrium.

    Model (9) linearised at ``q1 = 0`` (:func:`iwp.models.linearize`) with
    ``u = k1 q3`` (the cubic term has zero slope), on the reduced state
    ``(q1, q3, q4)``.

    Parameters
    ----------
    params : LumpedParameters
    k1 : float
        Linear gain [input units s/rad].

    Returns
    -------
    ndarray, shape (3, 3)
    """
    params = _lumped(params)
    k1 = check_finite("k1", k1)
    A, B = linearize(params, "down")
    K = np.zeros((1, 4))
    K[0, 2] = k1
    Acl = A + B @ K
    return Acl[np.ix_(_RED, _RED)]


def _critical_pair(A: np.ndarray):
    """The complex pair with the largest real part: (mu, omega) or None."""
    ev = np.linalg.eigvals(A)
    cplx = ev[np.abs(ev.imag) > 1e-9]
    if cplx.size == 0:
        return None
    lam = cplx[np.argmax(cplx.real + 1e-12 * cplx.imag)]
    return float(lam.real), float(abs(lam.imag))


def _hopf_k1(params: LumpedParameters) -> list[float]:
    """All k1 where a complex pair of the reduced closed loop is on the imaginary axis.

    The characteristic polynomial ``s^3 + a2 s^2 + a1 s + a0`` has coefficients
    affine in ``k1`` (``k1`` enters one column), so the Routh-Hurwitz
    condition ``a2 a1 - a0 = 0`` is a polynomial of degree <= 2 in ``k1``;
    its roots are refined on the real part of the critical pair.
    """

    def H(k1):
        c = np.poly(closed_loop_matrix(params, k1))
        return c[1] * c[2] - c[3]

    ks = np.array([-1.0, 0.0, 1.0])
    hs = np.array([H(k) for k in ks])
    co = np.polyfit(ks, hs, 2)
    scale = np.max(np.abs(co)) or 1.0
    if abs(co[0]) < 1e-10 * scale:
        co = co[1:]
    roots = [r.real for r in np.roots(co) if abs(r.imag) < 1e-9 * max(1.0, abs(r))]
    out = []
    for r in roots:
        if not math.isfinite(r):
            continue
        # refine by secant on mu(k1)
        k_a, k_b = r, r + 1e-3 * max(1.0, abs(r))
        pa, pb = _critical_pair(closed_loop_matrix(params, k_a)), _critical_pair(closed_loop_matrix(params, k_b))
        if pa is None or pb is None:
            continue
        fa, fb = pa[0], pb[0]
        for _ in range(50):
            if fb == fa:
                break
            k_c = k_b - fb * (k_b - k_a) / (fb - fa)
            pc = _critical_pair(closed_loop_matrix(params, k_c))
            if pc is None:
                break
            k_a, fa, k_b, fb = k_b, fb, k_c, pc[0]
            if abs(fb) < 1e-13:
                break
        pc = _critical_pair(closed_loop_matrix(params, k_b))
        if pc is not None and abs(pc[0]) < 1e-9 and pc[1] > 0:
            out.append(float(k_b))
    return sorted(set(out))


@njit(cache=True)
def _cl_rhs(code, P, x, k1, k2, dx):
    """Closed loop ``x' = f(x, u)`` with ``u = k1 q3 + k2 q3^3`` (model code ``code``)."""
    q3 = x[2]
    _rhs(code, x, k1 * q3 + k2 * q3 * q3 * q3, P, dx)


def _cl_eval(P, x, k1, k2):
    dx = np.zeros(4)
    _cl_rhs(_M_COMP, P, np.asarray(x, dtype=float), float(k1), float(k2), dx)
    return dx[list(_RED)]


def _lift(z) -> np.ndarray:
    """(q1, q3, q4) -> [q1, 0, q3, q4] (complex allowed)."""
    z = np.asarray(z)
    return np.array([z[0], 0.0, z[1], z[2]], dtype=z.dtype)


def _first_lyapunov(params: LumpedParameters, k1: float, k2: float, omega: float):
    """First Lyapunov coefficient at the origin by the invariant formula (Kuznetsov, eq. (3.20)).

    ``l1 = 1/(2 omega) Re[<p, C(q,q,qb)> - 2 <p, B(q, A^-1 B(q,qb))> + <p, B(qb, (2 i omega - A)^-1 B(q,q))>]``
    with ``A q = i omega q``, ``A^T p = -i omega p``, ``<p, q> = 1`` and
    ``<q, q> = 1``. The multilinear forms ``B`` and ``C`` are taken from the
    compiled right-hand side by finite differences with Richardson
    extrapolation (the closed loop is smooth at the origin: ``|cos q1|`` is
    ``cos q1`` there).

    Returns ``(l1, q, p)``.
    """
    P = pack("compensated", params)[1]
    A = closed_loop_matrix(params, k1)
    ev, V = np.linalg.eig(A)
    i = int(np.argmin(np.abs(ev - 1j * omega)))
    q = V[:, i] / np.linalg.norm(V[:, i])
    evT, W = np.linalg.eig(A.T)
    j = int(np.argmin(np.abs(evT + 1j * omega)))
    p = W[:, j]
    p = p / np.conj(np.vdot(p, q))  # <p, q> = conj(p) . q = 1

    def f(z):
        return _cl_eval(P, _lift(z), k1, k2)

    def quad(u, h):  # B(u, u) + O(h^2)
        return (f(h * u) + f(-h * u) - 2.0 * f(0.0 * u)) / h**2

    def cube(u, h):  # C(u, u, u) + O(h^2)
        return (f(2 * h * u) - 2 * f(h * u) + 2 * f(-h * u) - f(-2 * h * u)) / (2 * h**3)

    def rich(fun, u, h):
        return (4.0 * fun(u, h / 2) - fun(u, h)) / 3.0

    def Bsym(u, v, h=1e-3):
        """Symmetric bilinear B(u, v) for real u, v by polarisation."""
        return 0.25 * (rich(quad, u + v, h) - rich(quad, u - v, h))

    def Cuuu(u, h=2e-2):
        return rich(cube, u, h)

    def Csym_uuv(u, v):
        return (Cuuu(u + v) - Cuuu(u - v) - 2.0 * Cuuu(v)) / 6.0

    def Bc(x, y):  # complex bilinear
        a, b = x.real, x.imag
        c, d = y.real, y.imag
        return Bsym(a, c) - Bsym(b, d) + 1j * (Bsym(a, d) + Bsym(b, c))

    a, b = q.real, q.imag
    # C(q, q, qb) = C(aaa) + C(abb) + i (C(aab) + C(bbb))
    Cqqq = Cuuu(a) + Csym_uuv(b, a) + 1j * (Csym_uuv(a, b) + Cuuu(b))
    Bqq = Bc(q, q)
    Bqqb = Bc(q, np.conj(q))
    term = (np.vdot(p, Cqqq) - 2.0 * np.vdot(p, Bc(q, np.linalg.solve(A, Bqqb)))
            + np.vdot(p, Bc(np.conj(q), np.linalg.solve(2j * omega * np.eye(3) - A, Bqq))))
    return float(term.real / (2.0 * omega)), q, p


@dataclass(frozen=True, eq=False)
class HopfPoint:
    """The Hopf bifurcation of the closed loop ``u = k1 q3 + k2 q3^3`` (section 5.3).

    Attributes
    ----------
    k1 : float
        Critical gain ``k1*`` [input units s/rad]: for ``k1 < k1*`` the
        hanging equilibrium is unstable (the pair has crossed).
    k2 : float
        Cubic gain the coefficients below refer to [input units s^3/rad^3].
    omega : float
        Frequency of the critical pair ``+-i omega`` [rad/s].
    period : float
        ``2 pi / omega`` [s].
    eigenvalues : ndarray, shape (3,)
        Eigenvalues of the reduced linearisation at ``k1*``.
    dmu_dk1 : float
        Transversality ``d Re(lambda)/d k1`` at ``k1*`` [rad/s per gain unit]
        (negative: decreasing ``k1`` destabilises).
    l1 : float
        First Lyapunov coefficient (Kuznetsov's normalisation ``<q, q> = 1``,
        ``<p, q> = 1``) [1/(rad^2 s)]; negative: supercritical (stable
        small orbits for ``k1 < k1*``), positive: subcritical.
    l1_slope : float
        ``d l1 / d k2``: ``l1`` is affine in ``k2``.
    k2_critical : float
        The ``k2`` at which ``l1 = 0`` (degenerate Hopf): supercritical for
        ``k2`` on the side of ``sign(-l1_slope)``.
    criticality : str
        ``"supercritical"``, ``"subcritical"`` or ``"degenerate"``.
    amplitude_coefficient : float
        ``c`` in the small-amplitude prediction of ``max q1``:
        ``A ~ c sqrt(|k1 - k1*|)`` on the side where the orbit exists
        [rad / sqrt(gain unit)].
    """

    k1: float
    k2: float
    omega: float
    period: float
    eigenvalues: np.ndarray
    dmu_dk1: float
    l1: float
    l1_slope: float
    k2_critical: float
    criticality: str
    amplitude_coefficient: float
    eigenvector: np.ndarray = field(repr=False, default=None)

    @property
    def orbit_side(self) -> int:
        """-1 if the orbits exist for ``k1 < k1*``, +1 if for ``k1 > k1*``."""
        # mu(k1) ~ dmu (k1 - k1*); |z|^2 = -mu / (omega l1) > 0
        return int(-np.sign(self.dmu_dk1 * self.l1)) if self.l1 != 0 else -1

    def predicted_amplitude(self, k1) -> np.ndarray:
        """Small-amplitude prediction of ``max q1`` [rad] at gain ``k1`` (NaN on the wrong side).

        ``A = 2 |q_1| sqrt(-mu(k1) / (omega l1))`` with
        ``mu(k1) = dmu_dk1 (k1 - k1*)`` (normal form of the Hopf bifurcation).
        """
        k1 = np.asarray(k1, dtype=float)
        mu = self.dmu_dk1 * (k1 - self.k1)
        r2 = -mu / (self.omega * self.l1) if self.l1 != 0 else np.full_like(k1, np.nan)
        with np.errstate(invalid="ignore"):
            return np.where(r2 >= 0, 2.0 * abs(self.eigenvector[0]) * np.sqrt(np.abs(r2)), np.nan)

    def predicted_k1(self, amplitude: float) -> float:
        """Inverse of :meth:`predicted_amplitude`: the ``k1`` for a small amplitude [rad]."""
        a = float(amplitude)
        r2 = (a / (2.0 * abs(self.eigenvector[0]))) ** 2
        return self.k1 - r2 * self.omega * self.l1 / self.dmu_dk1

    def to_dict(self) -> dict:
        return {
            "k1_star": self.k1, "k2": self.k2, "omega": self.omega, "period": self.period,
            "eigenvalues": [[float(e.real), float(e.imag)] for e in self.eigenvalues],
            "dmu_dk1": self.dmu_dk1, "l1": self.l1, "l1_slope": self.l1_slope,
            "k2_critical": self.k2_critical, "criticality": self.criticality,
            "amplitude_coefficient": self.amplitude_coefficient,
        }


def hopf_point(params: LumpedParameters, k2: float = 0.1) -> HopfPoint:
    """The Hopf point of the closed loop ``u = k1 q3 + k2 q3^3`` on model (9).

    Parameters
    ----------
    params : LumpedParameters
        E.g. :func:`iwp.params.table1`.
    k2 : float
        Cubic gain [input units s^3/rad^3] (the paper: 0.1); it does not move
        ``k1*`` but sets the sign of the first Lyapunov coefficient.

    Returns
    -------
    HopfPoint

    Raises
    ------
    InputError
        If no complex pair crosses the imaginary axis for any ``k1``.
    """
    params = _lumped(params)
    k2 = check_finite("k2", k2)
    ks = _hopf_k1(params)
    if not ks:
        raise InputError("no Hopf point: no complex pair of the closed loop crosses the imaginary axis for any k1")
    # the crossing nearest to k1 = 0 (where the open loop is stable) destabilises first
    k1s = min(ks, key=abs)
    A = closed_loop_matrix(params, k1s)
    mu, omega = _critical_pair(A)
    dk = 1e-6 * max(1.0, abs(k1s))
    dmu = (_critical_pair(closed_loop_matrix(params, k1s + dk))[0]
           - _critical_pair(closed_loop_matrix(params, k1s - dk))[0]) / (2 * dk)
    l1, q, _p = _first_lyapunov(params, k1s, k2, omega)
    l1b, _, _ = _first_lyapunov(params, k1s, k2 + 1.0, omega)
    slope = l1b - l1
    k2c = k2 - l1 / slope if slope != 0 else float("nan")
    tol = 1e-9 * max(1.0, abs(slope))
    crit = "degenerate" if abs(l1) < tol else ("supercritical" if l1 < 0 else "subcritical")
    coeff = 2.0 * abs(q[0]) * math.sqrt(abs(dmu / (omega * l1))) if l1 != 0 else float("nan")
    return HopfPoint(k1=float(k1s), k2=k2, omega=omega, period=2 * math.pi / omega,
                     eigenvalues=np.linalg.eigvals(A), dmu_dk1=float(dmu), l1=l1, l1_slope=float(slope),
                     k2_critical=float(k2c), criticality=crit, amplitude_coefficient=coeff, eigenvector=q)


# ==========================================================================
# Shooting: compiled RK4 with the variational equations
# ==========================================================================
@njit(cache=True)
def _aug_rhs(code, P, x, S, k1, k2, free, dx, dS, xp, fp, fm, J, g):
    """``x' = f(x)`` and ``S' = J S + [0 0 0 df/dk]`` on the reduced state.

    ``J`` (3x3) and ``df/dk`` are central differences of the compiled
    closed loop (the model is written once, in :mod:`iwp.models`).
    """
    _cl_rhs(code, P, x, k1, k2, dx)
    for j in range(3):
        idx = 0 if j == 0 else j + 1
        e = 1e-6 * (1.0 + abs(x[idx]))
        for i in range(4):
            xp[i] = x[i]
        xp[idx] = x[idx] + e
        _cl_rhs(code, P, xp, k1, k2, fp)
        xp[idx] = x[idx] - e
        _cl_rhs(code, P, xp, k1, k2, fm)
        for i in range(3):
            ii = 0 if i == 0 else i + 1
            J[i, j] = (fp[ii] - fm[ii]) / (2.0 * e)
    kk = k1 if free == 0 else k2
    e = 1e-6 * (1.0 + abs(kk))
    if free == 0:
        _cl_rhs(code, P, x, k1 + e, k2, fp)
        _cl_rhs(code, P, x, k1 - e, k2, fm)
    else:
        _cl_rhs(code, P, x, k1, k2 + e, fp)
        _cl_rhs(code, P, x, k1, k2 - e, fm)
    for i in range(3):
        ii = 0 if i == 0 else i + 1
        g[i] = (fp[ii] - fm[ii]) / (2.0 * e)
    for i in range(3):
        for j in range(4):
            acc = 0.0
            for m in range(3):
                acc += J[i, m] * S[m, j]
            if j == 3:
                acc += g[i]
            dS[i, j] = acc


@njit(cache=True)
def _rk4_aug(code, P, x, S, h, k1, k2, free, k_x, k_S, xs, Ss, xp, fp, fm, J, g, dx, dS):
    """One RK4 step of the state and the sensitivities, in place."""
    for s in range(4):
        c = 0.0 if s == 0 else (0.5 if s < 3 else 1.0)
        for i in range(4):
            xs[i] = x[i] + (c * h * k_x[s - 1, i] if s > 0 else 0.0)
        for i in range(3):
            for j in range(4):
                Ss[i, j] = S[i, j] + (c * h * k_S[s - 1, i, j] if s > 0 else 0.0)
        _aug_rhs(code, P, xs, Ss, k1, k2, free, dx, dS, xp, fp, fm, J, g)
        for i in range(4):
            k_x[s, i] = dx[i]
        for i in range(3):
            for j in range(4):
                k_S[s, i, j] = dS[i, j]
    for i in range(4):
        x[i] += h * (k_x[0, i] + 2.0 * k_x[1, i] + 2.0 * k_x[2, i] + k_x[3, i]) / 6.0
    for i in range(3):
        for j in range(4):
            S[i, j] += h * (k_S[0, i, j] + 2.0 * k_S[1, i, j] + 2.0 * k_S[2, i, j] + k_S[3, i, j]) / 6.0


#: Sub-steps of an RK4 step that crosses the |cos q1| kink at q1 = +-pi/2:
#: the Jacobian jumps there, which would cost the sensitivities O(h).
_KINK_SUBSTEPS = 32


@njit(cache=True)
def _shoot(code, P, z0, T, k1, k2, free, n, zT, S, fT, traj):
    """Integrate the closed loop over ``[0, T]`` in ``n`` RK4 steps from ``z0 = (q1, q3, q4)``.

    Fills ``zT`` (3), the sensitivity ``S = [dzT/dz0 | dzT/dk]`` (3x4),
    ``fT = f(zT)`` (3) and ``traj`` (n+1, 4: q1, q3, q4, q2).
    """
    x = np.zeros(4)
    x[0] = z0[0]
    x[2] = z0[1]
    x[3] = z0[2]
    for i in range(3):
        for j in range(4):
            S[i, j] = 1.0 if i == j else 0.0
    h = T / n
    k_x = np.zeros((4, 4))
    k_S = np.zeros((4, 3, 4))
    xs = np.zeros(4)
    Ss = np.zeros((3, 4))
    xp = np.zeros(4)
    fp = np.zeros(4)
    fm = np.zeros(4)
    J = np.zeros((3, 3))
    g = np.zeros(3)
    dx = np.zeros(4)
    dS = np.zeros((3, 4))
    traj[0, 0] = x[0]
    traj[0, 1] = x[2]
    traj[0, 2] = x[3]
    traj[0, 3] = x[1]
    x_save = np.zeros(4)
    S_save = np.zeros((3, 4))
    for step in range(n):
        for i in range(4):
            x_save[i] = x[i]
        for i in range(3):
            for j in range(4):
                S_save[i, j] = S[i, j]
        _rk4_aug(code, P, x, S, h, k1, k2, free, k_x, k_S, xs, Ss, xp, fp, fm, J, g, dx, dS)
        if math.cos(x_save[0]) * math.cos(x[0]) <= 0.0:
            for i in range(4):
                x[i] = x_save[i]
            for i in range(3):
                for j in range(4):
                    S[i, j] = S_save[i, j]
            hs = h / _KINK_SUBSTEPS
            for _ in range(_KINK_SUBSTEPS):
                _rk4_aug(code, P, x, S, hs, k1, k2, free, k_x, k_S, xs, Ss, xp, fp, fm, J, g, dx, dS)
        traj[step + 1, 0] = x[0]
        traj[step + 1, 1] = x[2]
        traj[step + 1, 2] = x[3]
        traj[step + 1, 3] = x[1]
        if not (abs(x[0]) < 1e6 and abs(x[2]) < 1e6 and abs(x[3]) < 1e6):
            break
    zT[0] = x[0]
    zT[1] = x[2]
    zT[2] = x[3]
    _cl_rhs(code, P, x, k1, k2, dx)
    fT[0] = dx[0]
    fT[1] = dx[2]
    fT[2] = dx[3]


#: Amplitude at which the continuation for a design gives up [rad] (the upright is pi).
_A_MAX_DESIGN = 3.135

_H_TARGET = 2e-3  # RK4 step of the shooting [s]: amplitude errors ~1e-8 rad


class _Shooter:
    """Periodic-orbit equations of the closed loop in the unknowns ``y = (a, q4_0, T, k)``.

    The orbit starts at its maximum: ``q1(0) = a`` (the amplitude),
    ``q3(0) = 0`` (the phase condition), ``q4(0) = q4_0``; ``k`` is the free
    gain (``k1`` if ``free == 0`` else ``k2``), the other one is fixed.
    """

    def __init__(self, params: LumpedParameters, free: int, k_fixed: float):
        self.P = pack("compensated", params)[1]
        self.free = free
        self.k_fixed = float(k_fixed)
        self.n = None

    def gains(self, k: float) -> tuple[float, float]:
        return (k, self.k_fixed) if self.free == 0 else (self.k_fixed, k)

    def steps(self, T: float) -> int:
        return int(max(200, math.ceil(abs(T) / _H_TARGET)))

    def evaluate(self, y, n=None):
        a, q40, T, k = (float(v) for v in y)
        n = self.steps(T) if n is None else n
        k1, k2 = self.gains(k)
        z0 = np.array([a, 0.0, q40])
        zT = np.zeros(3)
        S = np.zeros((3, 4))
        fT = np.zeros(3)
        traj = np.zeros((n + 1, 4))
        _shoot(_M_COMP, self.P, z0, T, k1, k2, self.free, n, zT, S, fT, traj)
        R = zT - z0
        Jac = np.zeros((3, 4))
        Jac[:, 0] = S[:, 0] - np.array([1.0, 0.0, 0.0])
        Jac[:, 1] = S[:, 2] - np.array([0.0, 0.0, 1.0])
        Jac[:, 2] = fT
        Jac[:, 3] = S[:, 3]
        return R, Jac, S[:, :3], traj

    def newton(self, y0, row, y_ref, *, tol=1e-10, max_iter=12):
        """Solve ``R(y) = 0`` and ``row . (y - y_ref) = 0``; return ``(y, iterations, Jac, M, traj)`` or None."""
        y = np.array(y0, dtype=float)
        n = self.steps(y[2])
        for it in range(1, max_iter + 1):
            R, Jac, M, traj = self.evaluate(y, n)
            if not np.all(np.isfinite(R)) or not np.all(np.isfinite(Jac)):
                return None
            G = np.concatenate([R, [row @ (y - y_ref)]])
            JJ = np.vstack([Jac, row])
            try:
                dy = np.linalg.solve(JJ, -G)
            except np.linalg.LinAlgError:
                return None
            # damp very large updates of T (keep T > 0)
            if y[2] + dy[2] <= 0.2 * y[2]:
                dy *= 0.5 * y[2] / abs(dy[2])
            y = y + dy
            if np.max(np.abs(R)) < tol * 10 and np.max(np.abs(dy[[0, 2]])) < 1e-9 * max(1.0, abs(y[2])):
                break
            if it == max_iter:
                return None
            if y[2] <= 0 or not np.all(np.isfinite(y)):
                return None
        R, Jac, M, traj = self.evaluate(y, self.steps(y[2]))
        if not np.max(np.abs(R)) < 1e-7 * max(1.0, abs(y[0])):
            return None
        return y, it, Jac, M, traj

    def orbit(self, y, M, traj) -> "PeriodicOrbit":
        k1, k2 = self.gains(y[3])
        mult = np.linalg.eigvals(M)
        # the trivial multiplier is the one closest to 1
        nontriv = _nontrivial(mult)
        q3 = traj[:, 1]
        u = k1 * q3 + k2 * q3**3
        return PeriodicOrbit(k1=float(k1), k2=float(k2), amplitude=float(y[0]), period=float(y[2]),
                             x0=np.array([y[0], 0.0, 0.0, y[1]]), floquet=mult,
                             stable=bool(np.max(np.abs(nontriv)) < 1.0), u_max=float(np.max(np.abs(u))),
                             q3_max=float(np.max(np.abs(q3))), q4_max=float(np.max(np.abs(traj[:, 2]))),
                             q1_min=float(np.min(traj[:, 0])))


@dataclass(frozen=True, eq=False)
class PeriodicOrbit:
    """One periodic orbit of the closed loop ``u = k1 q3 + k2 q3^3`` on model (9).

    Attributes
    ----------
    k1, k2 : float
        Gains [input units s/rad, input units s^3/rad^3].
    amplitude : float
        ``max q1`` over the orbit [rad].
    period : float
        [s].
    x0 : ndarray, shape (4,)
        A state on the orbit, at its maximum: ``[amplitude, 0, 0, q4]``.
    floquet : ndarray, shape (3,)
        Floquet multipliers of the reduced state (one is 1).
    stable : bool
        All non-trivial multipliers inside the unit circle.
    u_max, q3_max, q4_max : float
        Largest ``|u|`` [input units], ``|q3|``, ``|q4|`` [rad/s] on the orbit.
    q1_min : float
        ``min q1`` [rad] (``-amplitude`` for the symmetric orbits).
    """

    k1: float
    k2: float
    amplitude: float
    period: float
    x0: np.ndarray
    floquet: np.ndarray
    stable: bool
    u_max: float
    q3_max: float
    q4_max: float
    q1_min: float

    @property
    def frequency(self) -> float:
        """``2 pi / period`` [rad/s]."""
        return 2 * math.pi / self.period

    def to_dict(self) -> dict:
        return {"k1": self.k1, "k2": self.k2, "amplitude": self.amplitude, "period": self.period,
                "x0": self.x0.tolist(), "floquet_abs": sorted(np.abs(self.floquet).tolist()),
                "stable": self.stable, "u_max": self.u_max, "q3_max": self.q3_max, "q4_max": self.q4_max}


@dataclass(frozen=True, eq=False)
class HopfBranch:
    """The branch of periodic orbits born at the Hopf point, continued in ``k1`` (fixed ``k2``).

    Attributes
    ----------
    hopf : HopfPoint
    k2 : float
    k1, amplitude, period : ndarray, shape (n,)
        Gain [input units s/rad], ``max q1`` [rad], period [s] along the branch
        (the Hopf point itself is the first entry, amplitude 0).
    floquet : ndarray, shape (n, 3), complex
        Floquet multipliers (NaN at the Hopf point).
    stable : ndarray of bool, shape (n,)
    u_max, q4_max : ndarray, shape (n,)
        Largest ``|u|`` and ``|q4|`` on each orbit.
    x0 : ndarray, shape (n, 4)
        States on the orbits (at ``max q1``).
    stop_reason : str
        Why the continuation stopped.
    n_shots : int
        Corrector runs (cost).
    bifurcations : tuple of dict
        Changes of stability along the branch, located by interpolating the
        crossing Floquet multiplier: ``{"kind", "k1", "amplitude",
        "multiplier"}``, ``kind`` one of ``"multiplier +1"`` (fold or, for
        these symmetric orbits, symmetry breaking), ``"period doubling"``,
        ``"torus"``.
    """

    hopf: HopfPoint
    k2: float
    k1: np.ndarray
    amplitude: np.ndarray
    period: np.ndarray
    floquet: np.ndarray
    stable: np.ndarray
    u_max: np.ndarray
    q4_max: np.ndarray
    x0: np.ndarray
    stop_reason: str
    n_shots: int = 0
    bifurcations: tuple = ()

    @property
    def stable_amplitude_range(self) -> tuple[float, float]:
        """Amplitudes [rad] of the stable part of the branch that starts at the Hopf point (empty: NaN)."""
        if not self.stable[1:2].all():
            return float("nan"), float("nan")
        i = 1
        while i + 1 < self.stable.size and self.stable[i + 1]:
            i += 1
        return 0.0, float(self.amplitude[i])

    @property
    def amplitude_range(self) -> tuple[float, float]:
        """``(0, max amplitude reached)`` [rad]."""
        return 0.0, float(np.nanmax(self.amplitude))

    def orbit(self, i: int) -> PeriodicOrbit:
        """The ``i``-th orbit of the branch as a :class:`PeriodicOrbit`."""
        return PeriodicOrbit(k1=float(self.k1[i]), k2=self.k2, amplitude=float(self.amplitude[i]),
                             period=float(self.period[i]), x0=self.x0[i].copy(), floquet=self.floquet[i],
                             stable=bool(self.stable[i]), u_max=float(self.u_max[i]),
                             q3_max=float("nan"), q4_max=float(self.q4_max[i]), q1_min=-float(self.amplitude[i]))

    def to_dict(self) -> dict:
        return {"hopf": self.hopf.to_dict(), "k2": self.k2, "k1": self.k1.tolist(),
                "amplitude": self.amplitude.tolist(), "period": self.period.tolist(),
                "stable": self.stable.tolist(), "u_max": self.u_max.tolist(), "stop_reason": self.stop_reason,
                "bifurcations": list(self.bifurcations)}

    def prediction(self, n: int = 60) -> tuple[np.ndarray, np.ndarray]:
        """The normal-form amplitude over the branch's ``k1`` range: ``(k1, amplitude)`` arrays."""
        k = np.linspace(self.hopf.k1, self.k1[-1], n)
        return k, self.hopf.predicted_amplitude(k)

    def plot(self, *, ax=None, simulations=None, design=None, prediction: bool = True, **kw):
        """Bifurcation diagram; see :func:`iwp.plotting_control.plot_bifurcation`.

        ``prediction=True`` adds the normal-form prediction over the branch.
        """
        from .plotting_control import plot_bifurcation

        return plot_bifurcation(self, ax=ax, simulations=simulations, design=design,
                                prediction=self.prediction() if prediction else None, **kw)


def _continue(shooter: _Shooter, y_first, Jac_first, M_first, traj_first, *, direction, ds, ds_min, ds_max,
              a_max, T_max, k_min, k_max, max_points, stop=None):
    """Pseudo-arclength continuation from a converged orbit; returns (orbits, ys, reason, n_shots).

    The arclength is measured in the plane (amplitude [rad], gain / k_scale).
    """
    k_scale = max(1.0, abs(y_first[3]))
    W = np.array([1.0, 0.0, 0.0, 1.0 / k_scale**2])  # metric of the (a, k) plane

    def tangent(Jac, prev=None):
        _, _, Vt = np.linalg.svd(Jac)
        t = Vt[-1]
        t = t / math.sqrt(t @ (W * t))
        if prev is not None:
            if t @ (W * prev) < 0:
                t = -t
        elif np.sign(t[0]) != direction:
            t = -t
        return t

    orbits = [shooter.orbit(y_first, M_first, traj_first)]
    ys = [y_first]
    y = y_first
    t = tangent(Jac_first)
    reason = "max_points"
    shots = 0
    while len(ys) < max_points:
        y_pred = y + ds * t
        row = W * t
        res = shooter.newton(y_pred, row, y_pred)
        shots += 1
        if res is None:
            ds *= 0.5
            if ds < ds_min:
                reason = "corrector failed (step below ds_min)"
                break
            continue
        y_new, its, Jac, M, traj = res
        if y_new[0] <= 0:
            reason = "amplitude returned to zero"
            break
        t_new = tangent(Jac, t)
        orbits.append(shooter.orbit(y_new, M, traj))
        ys.append(y_new)
        y, t = y_new, t_new
        if its <= 3:
            ds = min(ds * 1.5, ds_max)
        elif its >= 6:
            ds = max(ds * 0.5, ds_min)
        if y[0] >= a_max:
            reason = f"amplitude reached a_max = {a_max:g} rad"
            break
        if y[2] >= T_max:
            reason = f"period reached T_max = {T_max:.3g} s (approaching the upright: homoclinic orbit)"
            break
        if not (k_min <= y[3] <= k_max):
            reason = f"gain left [{k_min:g}, {k_max:g}]"
            break
        if stop is not None and stop(y):
            reason = "target reached"
            break
    return orbits, ys, reason, shots


def _hopf_start(params, hp: HopfPoint, k2: float, a_start: float):
    """A converged small orbit near the Hopf point, from the normal-form prediction."""
    shooter = _Shooter(params, 0, k2)
    q = hp.eigenvector
    z = a_start * (q / q[0]).real
    y0 = np.array([a_start, z[2], hp.period, hp.predicted_k1(a_start) if hp.l1 != 0 else hp.k1])
    row = np.array([1.0, 0.0, 0.0, 0.0])
    res = shooter.newton(y0, row, y0)
    if res is None:
        raise SimulationError(f"could not converge the first orbit of amplitude {a_start:g} rad near the Hopf point "
                              f"k1* = {hp.k1:.6g}")
    return shooter, res


def continue_hopf(
    params: LumpedParameters,
    k2: float = 0.1,
    *,
    a_start: float = 0.05,
    a_max: float = 3.13,
    ds: float = 0.05,
    ds_max: float = 0.2,
    ds_min: float = 1e-4,
    T_max_factor: float = 6.0,
    k1_limits: tuple[float, float] = (-1000.0, 1000.0),
    max_points: int = 400,
    _stop=None,
) -> HopfBranch:
    """Continue the periodic orbit born at the Hopf point in ``k1`` (section 5.3).

    Shooting on the reduced state ``(q1, q3, q4)`` with the variational
    equations (compiled RK4, step 2 ms), phase condition ``q3(0) = 0`` (the
    orbit starts at its maximum, so the amplitude ``max q1`` is an unknown),
    pseudo-arclength in the (amplitude, ``k1``) plane. The ``|cos q1|`` kink
    at ``q1 = pi/2`` costs the RK4 nothing noticeable (errors ~1e-8 rad).

    Parameters
    ----------
    params : LumpedParameters
    k2 : float
        Cubic gain, fixed along the branch.
    a_start : float
        Amplitude of the first orbit [rad], started from the normal-form
        prediction.
    a_max : float
        Stop when the amplitude exceeds it [rad] (orbits approach the upright
        ``pi``: the branch ends in a homoclinic orbit, the period grows
        without bound).
    ds, ds_max, ds_min : float
        Initial, largest and smallest arclength steps.
    T_max_factor : float
        Stop when the period exceeds ``T_max_factor`` times the Hopf period.
    k1_limits : (float, float)
        Stop when ``k1`` leaves this interval.
    max_points : int

    Returns
    -------
    HopfBranch
    """
    params = _lumped(params)
    a_start = check_positive("a_start", a_start)
    a_max = check_positive("a_max", a_max)
    hp = hopf_point(params, k2)
    shooter, (y, _its, Jac, M, traj) = _hopf_start(params, hp, k2, a_start)
    orbits, ys, reason, shots = _continue(
        shooter, y, Jac, M, traj, direction=+1, ds=ds, ds_min=ds_min, ds_max=ds_max, a_max=a_max,
        T_max=T_max_factor * hp.period, k_min=k1_limits[0], k_max=k1_limits[1], max_points=max_points, stop=_stop)
    nan3 = np.full(3, np.nan + 0j)
    return HopfBranch(
        hopf=hp, k2=float(k2),
        k1=np.array([hp.k1] + [o.k1 for o in orbits]),
        amplitude=np.array([0.0] + [o.amplitude for o in orbits]),
        period=np.array([hp.period] + [o.period for o in orbits]),
        floquet=np.array([nan3] + [o.floquet for o in orbits]),
        stable=np.array([hp.criticality == "supercritical"] + [o.stable for o in orbits]),
        u_max=np.array([0.0] + [o.u_max for o in orbits]),
        q4_max=np.array([0.0] + [o.q4_max for o in orbits]),
        x0=np.array([np.zeros(4)] + [o.x0 for o in orbits]),
        stop_reason=reason, n_shots=shots, bifurcations=_locate_bifurcations(orbits))


def _nontrivial(mult: np.ndarray) -> np.ndarray:
    i_triv = int(np.argmin(np.abs(mult - 1.0)))
    return np.delete(mult, i_triv)


def _locate_bifurcations(orbits) -> tuple:
    out = []
    for o_a, o_b in zip(orbits[:-1], orbits[1:]):
        ma, mb = _nontrivial(o_a.floquet), _nontrivial(o_b.floquet)
        na, nb = int(np.sum(np.abs(ma) > 1.0)), int(np.sum(np.abs(mb) > 1.0))
        if na == nb:
            continue
        # the multiplier that crossed: the largest |mu| on the unstable side
        m_a = ma[np.argmax(np.abs(ma))]
        m_b = mb[np.argmax(np.abs(mb))]
        fa, fb = abs(m_a) - 1.0, abs(m_b) - 1.0
        w = fa / (fa - fb) if fa != fb else 0.5
        mu = m_a + w * (m_b - m_a)
        if abs(mu.imag) > 1e-3:
            kind = "torus"
        elif mu.real > 0:
            kind = "multiplier +1"
        else:
            kind = "period doubling"
        out.append({"kind": kind, "k1": float(o_a.k1 + w * (o_b.k1 - o_a.k1)), "k2": float(o_a.k2 + w * (o_b.k2 - o_a.k2)),
                    "amplitude": float(o_a.amplitude + w * (o_b.amplitude - o_a.amplitude)),
                    "multiplier": [float(mu.real), float(mu.imag)]})
    return tuple(out)


# ==========================================================================
# Inverse design and the simulation check
# ==========================================================================
@dataclass(frozen=True, eq=False)
class HopfDesign:
    """Gains ``k1, k2`` of ``u = k1 q3 + k2 q3^3`` for an oscillation of a given amplitude.

    Attributes
    ----------
    amplitude : float
        The asked ``max q1`` [rad].
    k1, k2 : float
        The gains [input units s/rad, input units s^3/rad^3]; the one named by
        ``solved_for`` was computed, the other given.
    solved_for : str
        ``"k1"`` or ``"k2"``.
    period : float
        Period of the oscillation [s].
    orbit : PeriodicOrbit
        The designed orbit (Floquet multipliers, ``max |u|``...).
    hopf : HopfPoint
        The Hopf point at the design's ``k2``.
    k1_normal_form : float
        The small-amplitude (normal form) prediction of ``k1`` for this
        amplitude, for comparison (NaN when solving for ``k2``).
    stable_amplitude_max : float
        Largest amplitude of the stable orbits met on the way (from the Hopf
        point up to the design) [rad]; NaN if not known.
    """

    amplitude: float
    k1: float
    k2: float
    solved_for: str
    period: float
    orbit: PeriodicOrbit
    hopf: HopfPoint
    k1_normal_form: float = float("nan")
    stable_amplitude_max: float = float("nan")

    @property
    def stable(self) -> bool:
        return self.orbit.stable

    def controller(self, Ts: float | None = None):
        """The :class:`~iwp.inputs.HopfController` with these gains."""
        from .inputs import HopfController

        return HopfController(self.k1, self.k2, Ts)

    def to_dict(self) -> dict:
        return {"amplitude": self.amplitude, "k1": self.k1, "k2": self.k2, "solved_for": self.solved_for,
                "period": self.period, "frequency": 2 * math.pi / self.period, "stable": self.orbit.stable,
                "floquet_abs": sorted(np.abs(self.orbit.floquet).tolist()), "u_max": self.orbit.u_max,
                "q4_max": self.orbit.q4_max, "x0": self.orbit.x0.tolist(), "k1_star": self.hopf.k1,
                "l1": self.hopf.l1, "criticality": self.hopf.criticality, "k1_normal_form": self.k1_normal_form}


def _bracket_and_correct(shooter: _Shooter, ys, index: int, target: float):
    """Correct the orbit with ``y[index] = target`` from the two branch points around it."""
    vals = np.array([y[index] for y in ys])
    guess = None
    for i in range(len(ys) - 1):
        lo, hi = vals[i], vals[i + 1]
        if (lo - target) * (hi - target) <= 0 and lo != hi:
            w = (target - lo) / (hi - lo)
            guess = ys[i] + w * (ys[i + 1] - ys[i])
            break
    if guess is None:
        return None
    guess = guess.copy()
    guess[index] = target
    row = np.zeros(4)
    row[index] = 1.0
    return shooter.newton(guess, row, guess)


def find_orbit(params: LumpedParameters, k1: float, k2: float = 0.1, **continuation) -> PeriodicOrbit:
    """The periodic orbit of the closed loop at gains ``(k1, k2)`` on the Hopf branch.

    Continues the branch from the Hopf point (fixed ``k2``) until it passes
    ``k1``, then corrects the orbit at ``k1``.

    Raises
    ------
    InputError
        If ``k1`` is not on the branch (the reachable interval is given).
    """
    params = _lumped(params)
    k1 = check_finite("k1", k1)
    k2 = check_finite("k2", k2)
    hp = hopf_point(params, k2)
    side = hp.orbit_side
    if (k1 - hp.k1) * side <= 0:
        raise InputError(f"k1 = {k1:g}: the Hopf branch for k2 = {k2:g} lies on the side k1 {'<' if side < 0 else '>'} "
                         f"k1* = {hp.k1:.6g}")
    shooter, (y, _its, Jac, M, traj) = _hopf_start(params, hp, k2, 0.02)
    if (y[3] - k1) * side > 0:  # already beyond k1 with the first orbit: restart smaller
        a = max(1e-4, hp.predicted_amplitude(k1).item() if np.isfinite(hp.predicted_amplitude(k1)) else 1e-3)
        shooter, (y, _its, Jac, M, traj) = _hopf_start(params, hp, k2, a)
    kw = dict(ds=0.05, ds_min=1e-4, ds_max=0.2, a_max=3.1, T_max=6.0 * hp.period, k_min=-1e3, k_max=1e3,
              max_points=400)
    kw.update(continuation)
    orbits, ys, reason, _ = _continue(shooter, y, Jac, M, traj, direction=+1,
                                      stop=lambda yy: (yy[3] - k1) * side >= 0, **kw)
    res = _bracket_and_correct(shooter, ys, 3, k1)
    if res is None:
        ks = [yy[3] for yy in ys]
        raise InputError(f"k1 = {k1:g} is beyond the reach of the Hopf branch for k2 = {k2:g}: it covers k1 from "
                         f"{hp.k1:.6g} to {ks[-1]:.6g} ({reason})")
    y, _its, _Jac, M, traj = res
    return shooter.orbit(y, M, traj)


def design_hopf(
    params: LumpedParameters,
    amplitude: float,
    *,
    k2: float | None = None,
    k1: float | None = None,
    require_stable: bool = True,
    a_start: float = 0.05,
) -> HopfDesign:
    """The gain(s) of ``u = k1 q3 + k2 q3^3`` that give an oscillation of amplitude ``max q1 = amplitude``.

    The inverse of the continuation of section 5.3: with ``k2`` given (the
    paper's 0.1 by default) it solves for ``k1``; with ``k1`` given it
    solves for ``k2``. The orbit is found on the branch by continuation and
    corrected by Newton's method with the amplitude fixed.

    Parameters
    ----------
    params : LumpedParameters
    amplitude : float
        Wanted ``max q1`` [rad], ``0 < amplitude < pi``.
    k2 : float, optional
        Cubic gain [input units s^3/rad^3] (default 0.1 when ``k1`` is not given).
    k1 : float, optional
        Linear gain [input units s/rad]; give it (and not ``k2``) to solve for ``k2``.
    require_stable : bool
        Raise if the orbit found is unstable (default). With ``False`` the
        design is returned with ``stable == False``.
    a_start : float
        Amplitude of the first orbit of the continuation [rad].

    Returns
    -------
    HopfDesign

    Raises
    ------
    InputError
        ``amplitude`` outside ``(0, pi)`` or beyond the reach of the branch
        (the message gives the reachable range), both gains given, or an
        unstable orbit with ``require_stable``.
    """
    params = _lumped(params)
    amplitude = check_positive("amplitude", amplitude)
    if amplitude >= math.pi:
        raise InputError(f"amplitude must be below pi (the upright), got {amplitude:g} rad")
    if k1 is not None and k2 is not None:
        raise InputError("give k2 (to solve for k1) or k1 (to solve for k2), not both")
    if k1 is None:
        k2 = 0.1 if k2 is None else check_finite("k2", k2)
        design = _design_k1(params, amplitude, k2, a_start)
    else:
        design = _design_k2(params, amplitude, check_finite("k1", k1), a_start)
    if require_stable and not design.orbit.stable:
        mult = np.abs(_nontrivial(design.orbit.floquet)).max()
        raise InputError(
            f"amplitude = {amplitude:g} rad: the orbit found (k1 = {design.k1:.6g}, k2 = {design.k2:.6g}) is unstable "
            f"(largest Floquet multiplier |mu| = {mult:.4g}); "
            + ("the Hopf bifurcation is subcritical for this k2 (raise k2 above "
               f"{design.hopf.k2_critical:.4g})" if design.hopf.criticality == "subcritical" else
               (f"stable orbits of this branch reach amplitudes up to {design.stable_amplitude_max:.4g} rad; "
                if math.isfinite(design.stable_amplitude_max) else "")
               + "lower the amplitude or change k2"))
    return design


def _design_k1(params, amplitude, k2, a_start) -> HopfDesign:
    hp = hopf_point(params, k2)
    if hp.criticality == "degenerate":
        raise InputError(f"k2 = {k2:g} makes the Hopf bifurcation degenerate (l1 = 0); choose another k2")
    k1_nf = hp.predicted_k1(amplitude)
    stable_max = float("nan")
    if amplitude <= a_start:
        shooter, (y, _its, _Jac, M, traj) = _hopf_start(params, hp, k2, amplitude)
        orbit = shooter.orbit(y, M, traj)
    else:
        shooter, (y, _its, Jac, M, traj) = _hopf_start(params, hp, k2, a_start)
        orbits, ys, reason, _ = _continue(
            shooter, y, Jac, M, traj, direction=+1, ds=0.05, ds_min=1e-4, ds_max=0.2, a_max=_A_MAX_DESIGN,
            T_max=6.0 * hp.period, k_min=-1e3, k_max=1e3, max_points=400, stop=lambda yy: yy[0] >= amplitude)
        res = _bracket_and_correct(shooter, ys, 0, amplitude)
        if res is None:
            a_reach = max(yy[0] for yy in ys)
            raise InputError(f"amplitude = {amplitude:g} rad is beyond the reach of the Hopf branch for k2 = {k2:g}: "
                             f"reachable 0 < amplitude <= {a_reach:.4g} rad ({reason})")
        y, _its, _Jac, M, traj = res
        orbit = shooter.orbit(y, M, traj)
        for o in orbits:
            if not o.stable:
                break
            stable_max = o.amplitude
    return HopfDesign(amplitude=amplitude, k1=orbit.k1, k2=orbit.k2, solved_for="k1", period=orbit.period,
                      orbit=orbit, hopf=hp, k1_normal_form=float(k1_nf), stable_amplitude_max=stable_max)


def _design_k2(params, amplitude, k1, a_start) -> HopfDesign:
    hp0 = hopf_point(params, 0.1)
    if k1 >= hp0.k1:
        raise InputError(f"k1 = {k1:g} must be below the Hopf point k1* = {hp0.k1:.6g}: above it the hanging "
                         "equilibrium is stable and the oscillation does not start")
    # an orbit at this k1 for some reference k2 (larger k2: smaller orbits, further reach in k1)
    start = None
    for k2_ref in (0.1, 1.0, 10.0, 100.0):
        try:
            start = find_orbit(params, k1, k2_ref)
            break
        except InputError:
            continue
    if start is None:
        raise InputError(f"k1 = {k1:g}: no periodic orbit found on the Hopf branches for k2 in 0.1..100")
    shooter = _Shooter(params, 1, k1)
    y = np.array([start.amplitude, start.x0[3], start.period, start.k2])
    row = np.array([0.0, 0.0, 0.0, 1.0])
    res = shooter.newton(y, row, y)
    if res is None:  # pragma: no cover - the orbit was just converged
        raise SimulationError("could not re-converge the starting orbit")
    y, _its, Jac, M, traj = res
    if abs(y[0] - amplitude) < 1e-12:
        ys = [y]
    else:
        direction = 1 if amplitude > y[0] else -1
        _orbits, ys, reason, _ = _continue(
            shooter, y, Jac, M, traj, direction=direction, ds=0.05, ds_min=1e-4, ds_max=0.2, a_max=3.1,
            T_max=6.0 * hp0.period, k_min=-1e4, k_max=1e4, max_points=400,
            stop=lambda yy: (yy[0] - amplitude) * direction >= 0)
    res = _bracket_and_correct(shooter, ys, 0, amplitude) if len(ys) > 1 else res
    if res is None:
        a_vals = [yy[0] for yy in ys]
        raise InputError(f"amplitude = {amplitude:g} rad is beyond the reach of k2 for k1 = {k1:g}: continuation in k2 "
                         f"reached amplitudes {min(a_vals):.4g}..{max(a_vals):.4g} rad ({reason})")
    y, _its, _Jac, M, traj = res
    orbit = shooter.orbit(y, M, traj)
    return HopfDesign(amplitude=amplitude, k1=orbit.k1, k2=orbit.k2, solved_for="k2", period=orbit.period,
                      orbit=orbit, hopf=hopf_point(params, orbit.k2))


@dataclass(frozen=True, eq=False)
class SimulatedOscillation:
    """The oscillation reached by a long simulation of the closed loop.

    Attributes
    ----------
    k1, k2 : float
    amplitude : float
        ``max q1`` over the final window [rad] (NaN if the pendulum rotates).
    amplitude_min : float
        ``-min q1`` over the final window [rad].
    period : float
        Mean period over the final window [s] (from upward zero crossings).
    rotating : bool
        The pendulum went over the top (``|q1| > pi``) in the final window.
    result : SimulationResult
    """

    k1: float
    k2: float
    amplitude: float
    amplitude_min: float
    period: float
    rotating: bool
    result: object = field(repr=False)


def simulated_amplitude(
    params: LumpedParameters,
    k1: float,
    k2: float,
    *,
    x0=None,
    t_end: float = 300.0,
    window: float = 20.0,
    Ts: float = 0.002,
    controller_Ts: float | None = None,
    model: str = "compensated",
    **simulate_kw,
) -> SimulatedOscillation:
    """Simulate ``u = k1 q3 + k2 q3^3`` for a long time and measure the oscillation.

    Parameters
    ----------
    params : LumpedParameters
    k1, k2 : float
        Gains.
    x0 : array_like, optional
        Initial state (default ``[0.1, 0, 0, 0]``: just off the hanging rest).
    t_end : float
        Simulated time [s]; the transient must have died out.
    window : float
        Final window over which amplitude and period are measured [s].
    Ts : float
        Output sample time [s]; the maximum is refined by a parabola
        through the three samples around it.
    controller_Ts : float, optional
        Sample the controller (zero-order hold), as on the rig.
    model : str
        Model name (default the compensated model (9)); other options of
        :func:`iwp.simulate.simulate` pass through ``simulate_kw``.

    Returns
    -------
    SimulatedOscillation
    """
    from .inputs import HopfController
    from .simulate import simulate

    params = _lumped(params)
    x0 = [0.1, 0.0, 0.0, 0.0] if x0 is None else x0
    r = simulate(params, model=model, x0=x0, t_end=t_end, Ts=Ts,
                 input=HopfController(k1, k2, controller_Ts), **simulate_kw)
    sel = r.t >= r.t[-1] - window
    t, q = r.t[sel], r.q1[sel]
    rotating = bool(np.max(np.abs(q)) > math.pi)

    def peak(sig):
        i = int(np.argmax(sig))
        if 0 < i < sig.size - 1:
            a, b, c = sig[i - 1], sig[i], sig[i + 1]
            den = a - 2 * b + c
            if den < 0:
                return b - 0.125 * (a - c) ** 2 / den
        return sig[i]

    amp = float("nan") if rotating else float(peak(q))
    amp_min = float("nan") if rotating else float(peak(-q))
    idx = np.flatnonzero((q[:-1] < 0) & (q[1:] >= 0))
    if idx.size >= 2 and not rotating:
        tc = t[idx] - q[idx] * (t[idx + 1] - t[idx]) / (q[idx + 1] - q[idx])
        period = float(np.mean(np.diff(tc)))
    else:
        period = float("nan")
    return SimulatedOscillation(k1=float(k1), k2=float(k2), amplitude=amp, amplitude_min=amp_min, period=period,
                                rotating=rotating, result=r)


# ==========================================================================
# Balance at the upright: LQR
# ==========================================================================
@dataclass(frozen=True, eq=False)
class LQRBalance:
    """LQR state feedback at the upright, on the reduced state ``(q1 - pi, q3, q4)``.

    ``u = sat(-K [wrap(q1 - pi), q3, q4])`` with ``|u| <= u_max``.

    Attributes
    ----------
    K : ndarray, shape (3,)
        Gains on ``(q1 - pi, q3, q4)`` [input units per rad, per rad/s, per rad/s].
    S : ndarray, shape (3, 3)
        Solution of the Riccati equation.
    poles : ndarray, shape (3,)
        Closed-loop eigenvalues (continuous, or of the sampled loop when ``Ts`` is set).
    Q, R : ndarray
        Weights.
    Ts : float or None
        Sample period of a discrete design (ZOH) [s]; ``None``: continuous.
    u_max : float
        Input saturation [input units].
    unstable_eigenvalue : float
        The open-loop unstable eigenvalue ``lambda_u`` at the upright [1/s].
    unstable_direction : ndarray, shape (3,)
        Left eigenvector ``w`` of ``lambda_u``, scaled so that ``w[0] = 1``:
        ``w . x`` is the unstable mode in radians of ``q1``.
    capture_bound : float
        ``|w . B| u_max / lambda_u`` [rad]: beyond ``|w . x| >`` this no input
        within ``u_max`` can stop the fall (linearised). The swing-up
        switches to the LQR well inside it.
    backend : str
        ``"python-control"`` or ``"scipy"``.
    """

    K: np.ndarray
    S: np.ndarray
    poles: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    Ts: float | None
    u_max: float
    unstable_eigenvalue: float
    unstable_direction: np.ndarray
    capture_bound: float
    backend: str

    @staticmethod
    def error_state(x) -> np.ndarray:
        """``(wrap(q1 - pi), q3, q4)`` from a state ``[q1, q2, q3, q4]``."""
        x = np.asarray(x, dtype=float)
        th = (x[0] - math.pi + math.pi) % (2.0 * math.pi) - math.pi
        return np.array([th, x[2], x[3]])

    def __call__(self, x) -> float:
        """The saturated input for the state ``x = [q1, q2, q3, q4]`` [input units]."""
        u = -float(self.K @ self.error_state(x))
        return min(max(u, -self.u_max), self.u_max)

    def capture_ratio(self, x) -> float:
        """``|w . x| / capture_bound``: below 1 the fall can still be stopped (linearised)."""
        return abs(float(self.unstable_direction @ self.error_state(x))) / self.capture_bound


def lqr_balance(
    params: LumpedParameters,
    *,
    Q=(1.0, 0.01, 1e-4),
    R: float = 0.1,
    u_max: float = 100.0,
    Ts: float | None = None,
    backend: str = "auto",
) -> LQRBalance:
    """LQR for the upright, designed on the linearisation of (9) at ``q1 = pi``.

    The reduced linearisation ``(q1 - pi, q3, q4)`` of
    :func:`iwp.models.linearize` (``q2`` is cyclic and left free). With
    ``Ts`` the design is discrete (zero-order hold), as the controller runs
    on the rig every 5 ms.

    Parameters
    ----------
    params : LumpedParameters
    Q : sequence of 3 floats or (3, 3) array
        State weights on ``(q1 - pi [rad], q3 [rad/s], q4 [rad/s])``.
    R : float
        Input weight [1/input unit^2].
    u_max : float
        Saturation of ``u`` [input units].
    Ts : float, optional
        Sample period [s] for a discrete design.
    backend : str
        ``"auto"`` (python-control when installed, else scipy),
        ``"python-control"`` or ``"scipy"``.

    Returns
    -------
    LQRBalance
    """
    params = _lumped(params)
    u_max = check_positive("u_max", u_max)
    R = check_positive("R", R)
    Qm = np.asarray(Q, dtype=float)
    if Qm.shape == (3,):
        Qm = np.diag(Qm)
    if Qm.shape != (3, 3) or not np.all(np.isfinite(Qm)):
        raise InputError(f"Q must be 3 weights or a 3x3 matrix on (q1 - pi, q3, q4), got shape {Qm.shape}")
    if Ts is not None:
        Ts = check_positive("Ts", Ts)
    if backend not in ("auto", "python-control", "scipy"):
        raise InputError(f"backend must be 'auto', 'python-control' or 'scipy', got {backend!r}")
    A4, B4 = linearize(params, "up")
    A = A4[np.ix_(_RED, _RED)]
    B = B4[list(_RED)]
    Rm = np.array([[R]])
    ctl = None
    if backend in ("auto", "python-control"):
        try:
            import control as ctl
        except ImportError:
            if backend == "python-control":
                raise InputError("backend='python-control' needs python-control: pip install 'iwp[control]'") from None
            ctl = None
    if Ts is None:
        if ctl is not None:
            K, S, _E = ctl.lqr(A, B, Qm, Rm)
        else:
            from scipy.linalg import solve_continuous_are

            S = solve_continuous_are(A, B, Qm, Rm)
            K = np.linalg.solve(Rm, B.T @ S)
        K = np.asarray(K, dtype=float).ravel()
        poles = np.linalg.eigvals(A - B @ K[None, :])
    else:
        from scipy.linalg import expm

        M = np.zeros((4, 4))
        M[:3, :3] = A
        M[:3, 3:] = B
        Md = expm(M * Ts)
        Ad, Bd = Md[:3, :3], Md[:3, 3:]
        if ctl is not None:
            K, S, _E = ctl.dlqr(Ad, Bd, Qm * Ts, Rm * Ts)
        else:
            from scipy.linalg import solve_discrete_are

            S = solve_discrete_are(Ad, Bd, Qm * Ts, Rm * Ts)
            K = np.linalg.solve(Rm * Ts + Bd.T @ S @ Bd, Bd.T @ S @ Ad)
        K = np.asarray(K, dtype=float).ravel()
        poles = np.linalg.eigvals(Ad - Bd @ K[None, :])
    ev, W = np.linalg.eig(A.T)
    iu = int(np.argmax(ev.real))
    lam = float(ev[iu].real)
    w = W[:, iu].real
    w = w / w[0]
    bound = abs(float(w @ B.ravel())) * u_max / lam
    return LQRBalance(K=K, S=np.asarray(S, dtype=float), poles=poles, Q=Qm, R=Rm, Ts=Ts, u_max=u_max,
                      unstable_eigenvalue=lam, unstable_direction=w, capture_bound=bound,
                      backend="python-control" if ctl is not None else "scipy")


# ==========================================================================
# The rig's conditions and the observer on quantised encoders
# ==========================================================================
@dataclass(frozen=True)
class RigConditions:
    """What the controller faces on the rig (sections 5 and 5.1).

    The plant is the raw model (6) with an asymmetric dead zone
    ``v+ = v_dz_pos, v- = v_dz_neg``; the controller compensates it with the
    feedforward (7)-(8) using a single threshold ``v_comp`` (the paper's
    31), measures both angles with encoders of ``counts_per_rev`` counts
    (2000: 318.31 counts/rad), estimates the velocities with an observer,
    and runs every ``Ts``; the ideal input is clipped to ``|u| <= u_max``.

    Attributes
    ----------
    v_dz_pos, v_dz_neg : float
        Dead-zone thresholds of the plant [input units].
    v_comp : float
        Threshold of the feedforward compensation [input units].
    counts_per_rev : int
        Encoder resolution; 0 disables the quantisation.
    Ts : float
        Controller sample period [s].
    u_max : float
        Saturation of the ideal input ``u`` [input units]; the command is
        ``v = u +- v_comp``.
    sigma_q3, sigma_q4 : float
        Process-noise intensities of the observer's Kalman gain on the
        pendulum and disk accelerations [rad/s^2].
    """

    v_dz_pos: float = 33.0
    v_dz_neg: float = 29.0
    v_comp: float = 31.0
    counts_per_rev: int = 2000
    Ts: float = 0.005
    u_max: float = 100.0
    sigma_q3: float = 0.1
    sigma_q4: float = 3.0

    def __post_init__(self):
        from ._util import check_nonnegative

        check_nonnegative("v_dz_pos", self.v_dz_pos)
        check_nonnegative("v_dz_neg", self.v_dz_neg)
        check_nonnegative("v_comp", self.v_comp)
        if int(self.counts_per_rev) != self.counts_per_rev or self.counts_per_rev < 0:
            raise InputError(f"counts_per_rev must be a non-negative integer, got {self.counts_per_rev!r}")
        check_positive("Ts", self.Ts)
        check_positive("u_max", self.u_max)
        check_positive("sigma_q3", self.sigma_q3)
        check_positive("sigma_q4", self.sigma_q4)

    @property
    def quantum(self) -> float:
        """Encoder step [rad] (0: no quantisation)."""
        return 2.0 * math.pi / self.counts_per_rev if self.counts_per_rev else 0.0

    def plant_params(self, params: LumpedParameters) -> LumpedParameters:
        """``params`` with the rig's dead zone."""
        return _lumped(params).replace(v_dz_pos=float(self.v_dz_pos), v_dz_neg=float(self.v_dz_neg))

    def simulate_kwargs(self) -> dict:
        """Model and feedforward options of :func:`iwp.simulate.simulate` for this plant."""
        return {"model": "raw", "feedforward": (float(self.v_comp), float(self.v_comp))}


@njit(cache=True)
def _predict(code, P, x, u, h, n):
    """Advance ``x`` (in place) by ``h`` with input ``u`` held: ``n`` RK4 steps of the compiled model."""
    k1 = np.zeros(4)
    k2 = np.zeros(4)
    k3 = np.zeros(4)
    k4 = np.zeros(4)
    xt = np.zeros(4)
    hs = h / n
    for _ in range(n):
        _rhs(code, x, u, P, k1)
        for i in range(4):
            xt[i] = x[i] + 0.5 * hs * k1[i]
        _rhs(code, xt, u, P, k2)
        for i in range(4):
            xt[i] = x[i] + 0.5 * hs * k2[i]
        _rhs(code, xt, u, P, k3)
        for i in range(4):
            xt[i] = x[i] + hs * k3[i]
        _rhs(code, xt, u, P, k4)
        for i in range(4):
            x[i] += hs * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]) / 6.0


class EncoderObserver:
    """State observer from the two encoder angles (quantised), every ``Ts``.

    Prediction: the compensated model (9) over one sample with the held
    input (compiled RK4, 5 sub-steps). Correction: the steady-state Kalman
    gain of the ZOH-discretised linearisation at the upright, with
    process noise ``sigma_q3, sigma_q4`` on the accelerations and the
    quantisation noise ``quantum^2 / 12`` on the angles.

    Parameters
    ----------
    params : LumpedParameters
        The controller's model.
    Ts : float
        Sample period [s].
    quantum : float
        Encoder step [rad] (for the measurement noise; 0 allowed).
    sigma_q3, sigma_q4 : float
        Process-noise intensities [rad/s^2].
    """

    def __init__(self, params: LumpedParameters, Ts: float, quantum: float, sigma_q3: float = 0.1,
                 sigma_q4: float = 3.0):
        from scipy.linalg import expm, solve_discrete_are

        self.params = _lumped(params)
        self.Ts = check_positive("Ts", Ts)
        self.P = pack("compensated", self.params)[1]
        A, _B = linearize(self.params, "up")
        Ad = expm(A * self.Ts)
        C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
        G = np.zeros((4, 2))
        G[2, 0] = 1.0
        G[3, 1] = 1.0
        Qd = G @ np.diag([sigma_q3**2, sigma_q4**2]) @ G.T * self.Ts
        r = max(quantum, 1e-6) ** 2 / 12.0
        Rm = np.eye(2) * r
        Pp = solve_discrete_are(Ad.T, C.T, Qd, Rm)
        self.L = Pp @ C.T @ np.linalg.inv(C @ Pp @ C.T + Rm)
        self.xhat = None

    def reset(self) -> None:
        self.xhat = None

    def update(self, y, u_prev: float) -> np.ndarray:
        """Fuse the angles ``y = (q1, q2)`` measured now; ``u_prev`` was held since the last sample."""
        y = np.asarray(y, dtype=float)
        if self.xhat is None:
            self.xhat = np.array([y[0], y[1], 0.0, 0.0])
        else:
            _predict(_M_COMP, self.P, self.xhat, float(u_prev), self.Ts, 5)
            self.xhat = self.xhat + self.L @ (y - self.xhat[:2])
        return self.xhat.copy()


# ==========================================================================
# Swing-up by energy pumping, then balance
# ==========================================================================
def pendulum_energy(params: LumpedParameters, x) -> np.ndarray:
    """Energy of the pendulum alone per unit ``I1_hat`` [s^-2]: ``q3^2/2 + p1 (1 - cos q1)``.

    Zero at the hanging rest, ``2 p1`` at the upright rest. It is
    :func:`iwp.models.energy` of the state with the disk at rest in space
    (``q3 + q4 = 0``), so the disk's kinetic energy is left out.
    """
    from .models import energy

    x = np.array(x, dtype=float)
    x[..., 3] = -x[..., 2]
    return energy(_lumped(params), x)["total"]


class SwingUpController:
    """Swing-up by energy pumping with the wheel, then LQR balance at the upright.

    Swing-up (pendulum energy ``E``, target ``E* = 2 p1 (1 + energy_margin)``):
    ``u = sat(k_energy (E - E*) sgn(q3) - k_disk q4)``. The wheel acts on
    the pendulum through its reaction torque (``q3' = ... - p3 u`` in (9)),
    so ``dE/dt = -p3 k_energy (E - E*) |q3| + ...``: energy is pumped in while
    ``E < E*`` and taken out above. The disk velocity stays bounded by the
    back-emf and the ``-k_disk q4`` term (``q4' = ... + p3 (1 + rho) u``).

    Balance: the switch to the LQR (:func:`lqr_balance`) happens when the
    pendulum is within ``theta_in`` of the upright *and* its unstable mode
    is inside the capture region, ``|w . x| < catch * capture_bound`` (with
    ``|u| <= u_max`` the fall cannot be stopped beyond it; the disk velocity
    counts through ``w``). The swing-up law takes over again if the error
    exceeds ``theta_out``.

    Model errors shift the energy the top needs (the controller's ``E``
    uses its own ``p1``), so the target adapts: up by ``adapt_step`` (of
    ``2 p1``) after a swing that turns back within ``theta_in`` of the top
    without being caught, down after an uncaught pass over the top, within
    ``+-adapt_limit``.

    With :class:`RigConditions` the controller measures quantised encoder
    angles and estimates the state with an :class:`EncoderObserver`;
    without, it reads the true state.

    Parameters
    ----------
    params : LumpedParameters
        The controller's model (e.g. Table 1).
    rig : RigConditions, optional
        Measurement conditions (quantisation, sample period, ``u_max``).
    Ts : float
        Sample period [s] when ``rig`` is None.
    u_max : float
        Saturation [input units] when ``rig`` is None.
    k_energy : float
        Energy gain [input units s^2].
    k_disk : float
        Disk-velocity gain [input units s/rad].
    energy_margin : float
        Relative excess of the energy target.
    catch : float
        Fraction of the capture bound at which the LQR takes over.
    theta_in, theta_out : float
        Angle windows around the upright to switch in and out [rad].
    lqr : LQRBalance, optional
        Default: :func:`lqr_balance` with the sample period and ``u_max``.
    adapt_step, adapt_limit : float
        Step and bound of the energy-target adaptation (relative to
        ``2 p1``); ``adapt_step=0`` disables it.

    Attributes
    ----------
    mode : str
        ``"swing-up"`` or ``"balance"``.
    switches : list of (float, str)
        Mode switches so far.
    E_target : float
        Current energy target [s^-2].
    """

    def __init__(self, params: LumpedParameters, *, rig: RigConditions | None = None, Ts: float = 0.005,
                 u_max: float = 100.0, k_energy: float = 100.0, k_disk: float = 0.05, energy_margin: float = 0.0,
                 catch: float = 0.6, theta_in: float = 0.5, theta_out: float = 0.8, lqr: LQRBalance | None = None,
                 adapt_step: float = 0.005, adapt_limit: float = 0.1):
        self.params = _lumped(params)
        self.rig = rig
        self.Ts = rig.Ts if rig is not None else check_positive("Ts", Ts)
        self.u_max = rig.u_max if rig is not None else check_positive("u_max", u_max)
        self.k_energy = check_finite("k_energy", k_energy)
        self.k_disk = check_finite("k_disk", k_disk)
        self.energy_margin = check_finite("energy_margin", energy_margin)
        self.catch = check_positive("catch", catch)
        self.theta_in = check_positive("theta_in", theta_in)
        self.theta_out = check_positive("theta_out", theta_out)
        from ._util import check_nonnegative

        self.adapt_step = check_nonnegative("adapt_step", adapt_step)
        self.adapt_limit = check_nonnegative("adapt_limit", adapt_limit)
        self.lqr = lqr if lqr is not None else lqr_balance(self.params, u_max=self.u_max, Ts=self.Ts)
        self.observer = None
        if rig is not None:
            self.observer = EncoderObserver(self.params, self.Ts, rig.quantum, rig.sigma_q3, rig.sigma_q4)
        self.reset()

    def reset(self) -> None:
        """Forget the mode, the switch log and the observer state."""
        self.mode = "swing-up"
        self.switches: list[tuple[float, str]] = []
        self._u = 0.0
        self._sign = None
        self._err = None
        self.E_target = 2.0 * self.params.p1 * (1.0 + self.energy_margin)
        if self.observer is not None:
            self.observer.reset()

    def measure(self, x) -> np.ndarray:
        """The state the controller works with: observer estimate from quantised angles, or the true state."""
        x = np.asarray(x, dtype=float)
        if self.observer is None:
            return x[:4].copy()
        q = self.rig.quantum
        y = x[:2] if q == 0 else np.round(x[:2] / q) * q
        return self.observer.update(y, self._u)

    def swing_law(self, x) -> float:
        """Energy pumping ``k_energy (E - E*) sgn(q3) - k_disk q4`` (unsaturated)."""
        E = float(pendulum_energy(self.params, x))
        sg = 1.0 if x[2] >= 0.0 else -1.0
        return self.k_energy * (E - self.E_target) * sg - self.k_disk * x[3]

    def __call__(self, t: float, x) -> float:
        xh = self.measure(x)
        err = LQRBalance.error_state(xh)[0]
        th = abs(err)
        if self.mode == "swing-up" and th < self.theta_in and self.lqr.capture_ratio(xh) < self.catch:
            self.mode = "balance"
            self.switches.append((float(t), "balance"))
        elif self.mode == "balance" and th > self.theta_out:
            self.mode = "swing-up"
            self.switches.append((float(t), "swing-up"))
        if self.mode == "balance":
            u = -float(self.lqr.K @ LQRBalance.error_state(xh))
        else:
            self._adapt(xh, err)
            u = self.swing_law(xh)
        self._u = min(max(u, -self.u_max), self.u_max)
        return self._u

    def _adapt(self, xh, err) -> None:
        """Adjust the energy target (model errors shift the energy the top needs): up by
        ``adapt_step`` after a swing that turns back within ``theta_in`` of the upright without
        being caught, down after a pass over the top that was not caught."""
        if self.adapt_step <= 0:
            return
        sg = 1.0 if xh[2] >= 0.0 else -1.0
        E2 = 2.0 * self.params.p1
        if self._sign is not None and sg != self._sign and abs(err) < self.theta_in:
            self.E_target = min(self.E_target + self.adapt_step * E2, E2 * (1.0 + self.adapt_limit))
        if self._err is not None and abs(err) < 0.5 and abs(self._err) < 0.5 and err * self._err < 0:
            self.E_target = max(self.E_target - self.adapt_step * E2, E2 * (1.0 - self.adapt_limit))
        self._sign = sg
        self._err = err

    def as_input(self):
        """This controller as a sampled :class:`~iwp.inputs.CallableController`."""
        from .inputs import CallableController

        return CallableController(self, self.Ts)


@dataclass(frozen=True, eq=False)
class SwingUpResult:
    """A swing-up and balance run.

    Attributes
    ----------
    result : SimulationResult
        The simulation (true states; ``u`` the ideal input, ``command`` the
        driver command after the feedforward).
    success : bool
        Within ``tolerance`` of the upright over the final ``hold`` seconds.
    t_catch : float
        First switch to the balance law [s] (NaN if none).
    t_balanced : float
        From this time on the pendulum stays within ``tolerance`` of the upright [s] (NaN if never).
    switches : list of (float, str)
        Mode switches (time, new mode).
    u_max, q4_max : float
        Largest ``|u|`` [input units] and ``|q4|`` [rad/s].
    tolerance, hold : float
        Success criterion [rad], [s].
    conditions : str
        ``"rig"`` or ``"ideal"``.
    """

    result: object
    success: bool
    t_catch: float
    t_balanced: float
    switches: list
    u_max: float
    q4_max: float
    tolerance: float
    hold: float
    conditions: str

    @property
    def theta(self) -> np.ndarray:
        """Angle from the upright, wrapped to ``(-pi, pi]`` [rad]."""
        return (self.result.q1 - math.pi + math.pi) % (2 * math.pi) - math.pi

    def summary(self) -> dict:
        return {"success": self.success, "t_catch": self.t_catch, "t_balanced": self.t_balanced,
                "switches": [[t, m] for t, m in self.switches], "u_max": self.u_max, "q4_max": self.q4_max,
                "tolerance": self.tolerance, "hold": self.hold, "conditions": self.conditions}

    def plot(self, **kw):
        """Angle, velocities and input; see :func:`iwp.plotting_control.plot_swingup`."""
        from .plotting_control import plot_swingup

        return plot_swingup(self, **kw)

    def animate(self, path, *, frames: int = 100, force: bool = False, **kw):
        """Write a GIF of the pendulum; see :func:`iwp.plotting_control.animate_pendulum`."""
        from ._util import prepare_output_file
        from .plotting_control import animate_pendulum

        p = prepare_output_file(path, force=force)
        return animate_pendulum(self.result.t, self.result.q1, self.result.q2, p, frames=frames,
                                u=self.result.u, **kw)


def swing_up(
    params: LumpedParameters,
    *,
    x0=(0.0, 0.0, 0.0, 0.0),
    t_end: float = 20.0,
    rig: RigConditions | None = RigConditions(),
    controller: SwingUpController | None = None,
    Ts_out: float = 0.005,
    tolerance: float = 0.05,
    hold: float = 3.0,
    plant_params: LumpedParameters | None = None,
    **controller_kw,
) -> SwingUpResult:
    """Swing the pendulum up from ``x0`` and balance it; simulate and judge.

    Parameters
    ----------
    params : LumpedParameters
        The model the controller is designed on (Table 1).
    x0 : array_like
        Initial state ``[q1, q2, q3, q4]`` (default: rest at the bottom).
    t_end : float
        Simulated time [s].
    rig : RigConditions or None
        The rig's conditions (default): raw model (6) with the asymmetric
        dead zone compensated with one threshold, quantised encoders, an
        observer, 5 ms sampling, ``|u| <= 100``. ``None``: the compensated
        model (9) with the true state, sampled every ``Ts``.
    controller : SwingUpController, optional
        Built from ``params``, ``rig`` and ``controller_kw`` when omitted.
    Ts_out : float
        Output sample time [s].
    tolerance, hold : float
        Success: ``|q1 - pi| < tolerance`` [rad] over the final ``hold`` [s].
    plant_params : LumpedParameters, optional
        The plant's parameters if they differ from the controller's (e.g.
        randomised for a robustness check); the rig's dead zone is applied
        on top.

    Returns
    -------
    SwingUpResult
    """
    from .simulate import simulate

    params = _lumped(params)
    t_end = check_positive("t_end", t_end)
    ctrl = controller if controller is not None else SwingUpController(params, rig=rig, **controller_kw)
    ctrl.reset()
    plant = _lumped(plant_params) if plant_params is not None else params
    if rig is not None:
        kw = rig.simulate_kwargs()
        plant = rig.plant_params(plant)
    else:
        kw = {"model": "compensated"}
    res = simulate(plant, x0=list(x0), t_end=t_end, Ts=Ts_out, input=ctrl.as_input(), check=False, **kw)
    th = np.abs((res.q1 - math.pi + math.pi) % (2 * math.pi) - math.pi)
    inside = th < tolerance
    success = bool(res.success and res.t[-1] >= t_end - 1e-9 and np.all(inside[res.t >= t_end - hold]))
    if inside[-1]:
        out = np.flatnonzero(~inside)
        t_bal = float(res.t[out[-1] + 1]) if out.size else float(res.t[0])
    else:
        t_bal = float("nan")
    catches = [t for t, m in ctrl.switches if m == "balance"]
    return SwingUpResult(result=res, success=success, t_catch=catches[0] if catches else float("nan"),
                         t_balanced=t_bal, switches=list(ctrl.switches), u_max=float(np.nanmax(np.abs(res.u))),
                         q4_max=float(np.nanmax(np.abs(res.q4))), tolerance=tolerance, hold=hold,
                         conditions="rig" if rig is not None else "ideal")

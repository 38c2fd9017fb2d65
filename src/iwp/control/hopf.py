"""The Hopf bifurcation of the closed loop ``u = k1 q3 + k2 q3^3`` (section 5.3).

The compensated model (9) with the anticontrol law oscillates with an
amplitude set by ``k1`` and ``k2``; the paper chose them "based on a
bifurcation analysis and numerical continuation". This module is the
bifurcation analysis at the hanging equilibrium:

* :func:`closed_loop_matrix` -- the linearisation of the closed loop;
* :func:`hopf_point` -- the gain ``k1*`` where a complex pair crosses the
  imaginary axis, the first Lyapunov coefficient ``l1`` (its sign, set by
  ``k2``, decides super- or subcritical) and the small-amplitude prediction
  ``A ~ c sqrt(|k1 - k1*|)`` (:class:`HopfPoint`).

The continuation of the orbits born there is :mod:`iwp.control.continuation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..checks import check_finite
from ..errors import InputError
from ..models.analysis import linearize
from ..models.parameters import LumpedParameters
from ..models.plant import Plant
from .closed_loop import REDUCED, hopf_rate, lumped_parameters

__all__ = ["closed_loop_matrix", "HopfPoint", "hopf_point", "LyapunovCoefficient",
           "first_lyapunov_coefficient"]


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

    See Also
    --------
    hopf_point : The ``k1`` where its complex pair crosses the imaginary axis.

    Examples
    --------
    The hanging pendulum loses stability between ``k1 = -0.5`` and ``k1 = -2`` (the Hopf point: -0.945):

    >>> import numpy as np
    >>> from iwp import table1
    >>> from iwp.control import closed_loop_matrix
    >>> for k1 in (-0.5, -2.0):
    ...     print(k1, np.linalg.eigvals(closed_loop_matrix(table1(), k1)).real.max().round(4))
    -0.5 -0.005
    -2.0 0.012
    """
    params = lumped_parameters(params)
    k1 = check_finite("k1", k1)
    A, B = linearize(params, "down")
    K = np.zeros((1, 4))
    K[0, 2] = k1
    Acl = A + B @ K
    return Acl[np.ix_(REDUCED, REDUCED)]


def _critical_pair(A: np.ndarray) -> tuple[float, float] | None:
    """The complex pair of ``A`` with the largest real part: ``(mu, omega)`` [1/s, rad/s], or None."""
    ev = np.linalg.eigvals(A)
    cplx = ev[np.abs(ev.imag) > 1e-9]
    if cplx.size == 0:
        return None
    lam = cplx[np.argmax(cplx.real + 1e-12 * cplx.imag)]
    return float(lam.real), float(abs(lam.imag))


def _hopf_gains(params: LumpedParameters) -> list[float]:
    """All k1 where a complex pair of the reduced closed loop is on the imaginary axis.

    The characteristic polynomial ``s^3 + a2 s^2 + a1 s + a0`` has coefficients
    affine in ``k1`` (``k1`` enters one column), so the Routh-Hurwitz
    condition ``a2 a1 - a0 = 0`` is a polynomial of degree <= 2 in ``k1``;
    its roots are refined on the real part of the critical pair.
    """

    def routh(k1):
        c = np.poly(closed_loop_matrix(params, k1))
        return c[1] * c[2] - c[3]

    ks = np.array([-1.0, 0.0, 1.0])
    hs = np.array([routh(k) for k in ks])
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


@dataclass(frozen=True)
class LyapunovCoefficient:
    """The first Lyapunov coefficient and the eigenvectors it is normalised with.

    Attributes
    ----------
    l1 : float
        [1/(rad^2 s)].
    q : ndarray, shape (3,), complex
        ``A q = i omega q``, ``<q, q> = 1``.
    p : ndarray, shape (3,), complex
        ``A^T p = -i omega p``, ``<p, q> = 1``.
    """

    l1: float
    q: np.ndarray = field(repr=False)
    p: np.ndarray = field(repr=False)


def first_lyapunov_coefficient(params: LumpedParameters, k1: float, k2: float, omega: float) -> LyapunovCoefficient:
    """First Lyapunov coefficient at the origin by the invariant formula (Kuznetsov, eq. (3.20)).

    ``l1 = 1/(2 omega) Re[<p, C(q,q,qb)> - 2 <p, B(q, A^-1 B(q,qb))> + <p, B(qb, (2 i omega - A)^-1 B(q,q))>]``
    with ``A q = i omega q``, ``A^T p = -i omega p``, ``<p, q> = 1`` and
    ``<q, q> = 1``. The multilinear forms ``B`` and ``C`` are finite
    differences, with Richardson extrapolation, of the closed loop evaluated
    through the plant's compiled right-hand side (:func:`hopf_rate`; the
    closed loop is smooth at the origin: ``|cos q1|`` is ``cos q1`` there).

    Parameters
    ----------
    params : LumpedParameters
    k1, k2 : float
        Gains; ``k1`` at the Hopf point.
    omega : float
        Frequency of the critical pair [rad/s].
    """
    params = lumped_parameters(params)
    plant = Plant(params)
    A = closed_loop_matrix(params, k1)
    ev, V = np.linalg.eig(A)
    i = int(np.argmin(np.abs(ev - 1j * omega)))
    q = V[:, i] / np.linalg.norm(V[:, i])
    evT, W = np.linalg.eig(A.T)
    j = int(np.argmin(np.abs(evT + 1j * omega)))
    p = W[:, j]
    p = p / np.conj(np.vdot(p, q))  # <p, q> = conj(p) . q = 1

    def f(z):
        return hopf_rate(plant, k1, k2, z)

    def quad(u, h):  # B(u, u) + O(h^2)
        return (f(h * u) + f(-h * u) - 2.0 * f(0.0 * u)) / h**2

    def cube(u, h):  # C(u, u, u) + O(h^2)
        return (f(2 * h * u) - 2 * f(h * u) + 2 * f(-h * u) - f(-2 * h * u)) / (2 * h**3)

    def rich(fun, u, h):
        return (4.0 * fun(u, h / 2) - fun(u, h)) / 3.0

    def b_sym(u, v, h=1e-3):
        """Symmetric bilinear B(u, v) for real u, v by polarisation."""
        return 0.25 * (rich(quad, u + v, h) - rich(quad, u - v, h))

    def c_uuu(u, h=2e-2):
        return rich(cube, u, h)

    def c_uuv(u, v):
        return (c_uuu(u + v) - c_uuu(u - v) - 2.0 * c_uuu(v)) / 6.0

    def b_complex(x, y):
        a, b = x.real, x.imag
        c, d = y.real, y.imag
        return b_sym(a, c) - b_sym(b, d) + 1j * (b_sym(a, d) + b_sym(b, c))

    a, b = q.real, q.imag
    # C(q, q, qb) = C(aaa) + C(abb) + i (C(aab) + C(bbb))
    c_qqqb = c_uuu(a) + c_uuv(b, a) + 1j * (c_uuv(a, b) + c_uuu(b))
    b_qq = b_complex(q, q)
    b_qqb = b_complex(q, np.conj(q))
    term = (np.vdot(p, c_qqqb) - 2.0 * np.vdot(p, b_complex(q, np.linalg.solve(A, b_qqb)))
            + np.vdot(p, b_complex(np.conj(q), np.linalg.solve(2j * omega * np.eye(3) - A, b_qq))))
    return LyapunovCoefficient(l1=float(term.real / (2.0 * omega)), q=q, p=p)


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
    eigenvector : ndarray, shape (3,), complex
        The critical eigenvector ``q`` on ``(q1, q3, q4)`` (``|q| = 1``).
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
        E.g. :func:`iwp.models.table1`.
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

    Examples
    --------
    >>> from iwp import hopf_point, table1
    >>> h = hopf_point(table1(), k2=0.1)
    >>> round(h.k1, 3), h.criticality  # the hanging equilibrium loses stability at k1*
    (-0.945, 'supercritical')
    """
    params = lumped_parameters(params)
    k2 = check_finite("k2", k2)
    ks = _hopf_gains(params)
    if not ks:
        raise InputError("no Hopf point: no complex pair of the closed loop crosses the imaginary axis for any k1")
    # the crossing nearest to k1 = 0 (where the open loop is stable) destabilises first
    k1s = min(ks, key=abs)
    A = closed_loop_matrix(params, k1s)
    _mu, omega = _critical_pair(A)
    dk = 1e-6 * max(1.0, abs(k1s))
    dmu = (_critical_pair(closed_loop_matrix(params, k1s + dk))[0]
           - _critical_pair(closed_loop_matrix(params, k1s - dk))[0]) / (2 * dk)
    with np.errstate(over="ignore", invalid="ignore"):
        lc = first_lyapunov_coefficient(params, k1s, k2, omega)
        l1, q = lc.l1, lc.q
        slope = first_lyapunov_coefficient(params, k1s, k2 + 1.0, omega).l1 - l1
    if not (math.isfinite(l1) and math.isfinite(slope)):
        raise InputError(f"k2 = {k2:g}: the loop's cubic term overflows (its first Lyapunov coefficient is not a "
                         "number); a cubic gain that large drives no rig (its command, cubic in the speed, beyond "
                         "any input)", argument="k2")
    k2c = k2 - l1 / slope if slope != 0 else float("nan")
    tol = 1e-9 * max(1.0, abs(slope))
    crit = "degenerate" if abs(l1) < tol else ("supercritical" if l1 < 0 else "subcritical")
    coeff = 2.0 * abs(q[0]) * math.sqrt(abs(dmu / (omega * l1))) if l1 != 0 else float("nan")
    return HopfPoint(k1=float(k1s), k2=k2, omega=omega, period=2 * math.pi / omega,
                     eigenvalues=np.linalg.eigvals(A), dmu_dk1=float(dmu), l1=l1, l1_slope=float(slope),
                     k2_critical=float(k2c), criticality=crit, amplitude_coefficient=coeff, eigenvector=q)

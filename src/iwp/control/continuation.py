"""Numerical continuation of the periodic orbits born at the Hopf point (section 5.3).

:func:`continue_hopf` follows the branch of orbits of the closed loop
``u = k1 q3 + k2 q3^3`` in ``k1`` from the Hopf point (:mod:`.hopf`):
shooting (:class:`~iwp.control.orbits.OrbitShooter`), phase condition
``q3(0) = 0`` (the orbit starts at its maximum, so the amplitude ``max q1``
is an unknown), pseudo-arclength in the (amplitude, gain) plane;
amplitude, period and Floquet multipliers along the branch, and the changes
of stability on it. :func:`find_orbit` is the orbit at given gains.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..checks import check_finite, check_positive
from ..errors import GoalNotReached, InputError
from ..models.parameters import LumpedParameters
from .closed_loop import lumped_parameters
from .hopf import HopfPoint, hopf_point
from .orbits import Correction, OrbitShooter, PeriodicOrbit, nontrivial_multipliers

__all__ = ["HopfBranch", "BranchRun", "continue_hopf", "find_orbit", "continue_branch", "hopf_start",
           "correct_at", "locate_bifurcations"]


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

    def amplitude_at(self, k1: float) -> float:
        """The orbit amplitude [rad] at gain ``k1`` [input units s/rad], interpolated along the branch."""
        return float(np.interp(-k1, -self.k1, self.amplitude))

    def stable_at(self, k1: float) -> bool:
        """Whether the orbit at ``k1`` is stable (interpolated between the branch's points: the nearer one's)."""
        return bool(np.interp(-k1, -self.k1, self.stable.astype(float)) > 0.5)

    def stable_gains(self, n: int) -> np.ndarray:
        """``n`` gains ``k1`` evenly inside the branch's range whose orbit is stable (to check by simulation)."""
        k = np.linspace(self.k1[0], self.k1[-1], n + 2)[1:-1]
        return np.array([x for x in k if self.stable_at(x)])

    #: the columns of :meth:`write_csv`
    CSV_COLUMNS = ("k1", "amplitude", "period", "stable", "u_max", "q4_max", "floquet_abs_1", "floquet_abs_2",
                   "floquet_abs_3")

    def write_csv(self, path) -> None:
        """Write the branch as CSV (:data:`CSV_COLUMNS`, a row per orbit; ``#`` lines: ``k2``, the Hopf point,
        the stop reason): the nontrivial Floquet multipliers by modulus, ascending."""
        mult = np.sort(np.abs(self.floquet), axis=1)
        cols = np.column_stack([self.k1, self.amplitude, self.period, self.stable.astype(int), self.u_max,
                                self.q4_max, mult])
        header = (f"# source: iwp design branch\n# k2: {self.k2}\n# k1_star: {self.hopf.k1}\n"
                  f"# l1: {self.hopf.l1}\n# criticality: {self.hopf.criticality}\n"
                  f"# stop_reason: {self.stop_reason}\n" + ",".join(self.CSV_COLUMNS))
        np.savetxt(path, cols, delimiter=",", header=header, comments="", fmt="%.10g")

    def prediction(self, n: int = 60) -> tuple[np.ndarray, np.ndarray]:
        """The normal-form amplitude over the branch's ``k1`` range: ``(k1, amplitude)`` arrays."""
        k = np.linspace(self.hopf.k1, self.k1[-1], n)
        return k, self.hopf.predicted_amplitude(k)

    def plot(self, *, ax=None, simulations=None, design=None, prediction: bool = True, **kw):
        """Bifurcation diagram; see :func:`iwp.plotting.plot_bifurcation`.

        ``prediction=True`` adds the normal-form prediction over the branch.
        """
        from ..plotting import plot_bifurcation  # plotting only when asked

        return plot_bifurcation(self, ax=ax, simulations=simulations, design=design,
                                prediction=self.prediction() if prediction else None, **kw)


@dataclass(frozen=True, eq=False)
class BranchRun:
    """What :func:`continue_branch` found.

    Attributes
    ----------
    orbits : list of PeriodicOrbit
        The converged orbits, the starting one first.
    ys : list of ndarray
        Their unknowns ``(a, q4_0, T, k)``.
    stop_reason : str
    n_shots : int
        Corrector runs.
    """

    orbits: list
    ys: list
    stop_reason: str
    n_shots: int


def continue_branch(shooter: OrbitShooter, first: Correction, *, direction: int, ds: float, ds_min: float,
                    ds_max: float, a_max: float, T_max: float, k_min: float, k_max: float, max_points: int,
                    stop=None) -> BranchRun:
    """Pseudo-arclength continuation from a converged orbit.

    The arclength is measured in the plane (amplitude [rad], gain / k_scale);
    ``direction`` is the sign of the amplitude's change at the start. The
    step adapts to the corrector's iterations; it stops at ``a_max``,
    ``T_max``, outside ``[k_min, k_max]``, after ``max_points`` orbits or
    when ``stop(y)`` is true.

    Parameters
    ----------
    shooter : OrbitShooter
        The periodic-orbit equations, with the free gain ``k``.
    first : Correction
        The converged orbit to start from.
    direction : int
        Sign (+1 or -1) of the amplitude's change along the first step.
    ds : float
        First step along the arclength.
    ds_min : float
        Smallest step; the run stops when the corrector fails below it.
    ds_max : float
        Largest step.
    a_max : float
        Stop at this amplitude [rad].
    T_max : float
        Stop at this period [s].
    k_min : float
        Stop when the free gain falls below this [unit of the gain].
    k_max : float
        Stop when the free gain exceeds this [unit of the gain].
    max_points : int
        Most orbits on the branch, the first included.
    stop : callable, optional
        ``stop(y)`` with the unknowns ``y = (a, q4_0, T, k)`` of the last orbit; the run stops when it is true.

    Returns
    -------
    BranchRun
        The orbits, their unknowns, why the run stopped and the number of corrector runs.
    """
    y_first = first.y
    k_scale = max(1.0, abs(y_first[3]))
    W = np.array([1.0, 0.0, 0.0, 1.0 / k_scale**2])  # metric of the (a, k) plane

    def tangent(jac, prev=None):
        _, _, Vt = np.linalg.svd(jac)
        t = Vt[-1]
        t = t / math.sqrt(t @ (W * t))
        if prev is not None:
            if t @ (W * prev) < 0:
                t = -t
        elif np.sign(t[0]) != direction:
            t = -t
        return t

    orbits = [shooter.orbit(first)]
    ys = [y_first]
    y = y_first
    t = tangent(first.shot.jacobian)
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
        y_new = res.y
        if y_new[0] <= 0:
            reason = "amplitude returned to zero"
            break
        t_new = tangent(res.shot.jacobian, t)
        orbits.append(shooter.orbit(res))
        ys.append(y_new)
        y, t = y_new, t_new
        if res.iterations <= 3:
            ds = min(ds * 1.5, ds_max)
        elif res.iterations >= 6:
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
    return BranchRun(orbits=orbits, ys=ys, stop_reason=reason, n_shots=shots)


def hopf_start(shooter: OrbitShooter, hp: HopfPoint, a_start: float) -> Correction:
    """A converged small orbit of amplitude ``a_start`` near the Hopf point, from the normal-form prediction.

    ``shooter`` continues in ``k1`` at the Hopf point's ``k2``.

    Parameters
    ----------
    shooter : OrbitShooter
        The periodic-orbit equations, free gain ``k1``, ``k2`` fixed at the Hopf point's.
    hp : HopfPoint
        The Hopf point.
    a_start : float
        Amplitude of the first orbit [rad].

    Returns
    -------
    Correction
        The converged orbit.

    Raises
    ------
    GoalNotReached
        If the first orbit does not converge (the message says why and what to change).
    """
    q = hp.eigenvector
    z = a_start * (q / q[0]).real
    y0 = np.array([a_start, z[2], hp.period, hp.predicted_k1(a_start) if hp.l1 != 0 else hp.k1])
    row = np.array([1.0, 0.0, 0.0, 0.0])
    res = shooter.newton(y0, row, y0)
    if res is None:
        raise GoalNotReached(f"could not converge the first orbit of amplitude {a_start:g} rad near the Hopf point "
                             f"k1* = {hp.k1:.6g}: {_why_no_orbit(shooter.plant.lumped, hp)}")
    return res


#: pendulum damping ``sigma_a1 + sigma_v1`` [1/s] below which the Hopf point is called degenerate in a message
DAMPING_FLOOR = 1e-6


def _why_no_orbit(p, hp: HopfPoint) -> str:
    """What makes the small orbits near the Hopf point unreachable with parameters ``p``, and what to change."""
    damping = p.sigma_a1 + p.sigma_v1
    if damping < DAMPING_FLOOR:
        return (f"the parameters give the pendulum no viscous damping (sigma_a1 + sigma_v1 = {damping:.3g} 1/s), so "
                "the loop's linear part barely moves the equilibrium's pair and the orbits near k1* are degenerate; "
                "identify the damping from a free release (iwp identify free.csv --setup free), or hold it at a prior "
                "(iwp fit ... --fix sigma_v1=0.01) and fit again")
    if hp.criticality != "supercritical":
        return (f"the bifurcation is {hp.criticality} at k2 = {hp.k2:g} (first Lyapunov coefficient {hp.l1:.3g}): "
                "its small orbits are unstable or absent; choose k2 on the supercritical side of "
                f"{hp.k2_critical:.4g}")
    return ("Newton's method on the periodic-orbit equations did not converge from the normal form's prediction; "
            "check that the parameters describe the rig (iwp validate) or start from a larger amplitude")


def correct_at(shooter: OrbitShooter, ys, index: int, target: float) -> Correction | None:
    """Correct the orbit with ``y[index] = target`` from the two branch points around it (None if none).

    Parameters
    ----------
    shooter : OrbitShooter
        The periodic-orbit equations.
    ys : sequence of ndarray, shape (4,)
        Unknowns ``(a, q4_0, T, k)`` of consecutive orbits of a branch.
    index : int
        Which unknown is fixed: 0 amplitude [rad], 1 ``q4_0`` [rad/s], 2 period [s], 3 gain ``k``.
    target : float
        Its value (in the unknown's unit).

    Returns
    -------
    Correction or None
        The corrected orbit; None if the branch does not reach ``target`` or the corrector does not converge.
    """
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


def locate_bifurcations(orbits) -> tuple:
    """Changes of stability between consecutive orbits (see :attr:`HopfBranch.bifurcations`).

    Parameters
    ----------
    orbits : sequence of PeriodicOrbit
        Consecutive orbits of a branch.

    Returns
    -------
    tuple of dict
        One per change: ``"kind"`` (``"torus"``, ``"multiplier +1"`` or ``"period doubling"``), ``"k1"``,
        ``"k2"``, ``"amplitude"`` [rad] and ``"multiplier"`` ``[re, im]``, interpolated between the two orbits.
    """
    out = []
    for o_a, o_b in zip(orbits[:-1], orbits[1:]):
        ma, mb = nontrivial_multipliers(o_a.floquet), nontrivial_multipliers(o_b.floquet)
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
        out.append({"kind": kind, "k1": float(o_a.k1 + w * (o_b.k1 - o_a.k1)),
                    "k2": float(o_a.k2 + w * (o_b.k2 - o_a.k2)),
                    "amplitude": float(o_a.amplitude + w * (o_b.amplitude - o_a.amplitude)),
                    "multiplier": [float(mu.real), float(mu.imag)]})
    return tuple(out)


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
    stop=None,
) -> HopfBranch:
    """Continue the periodic orbit born at the Hopf point in ``k1`` (section 5.3).

    Shooting on the reduced state ``(q1, q3, q4)`` with forward
    sensitivities integrated by iwp's adaptive DOP853 engine
    (:func:`iwp.sim.sensitivity.simulate_sensitivities`; tolerances
    :data:`~iwp.control.orbits.SHOOTING_RTOL`, steps of at most
    :data:`~iwp.control.orbits.SHOOTING_MAX_STEP`; the engine crosses the
    ``|cos q1|`` kinks at ``q1 = +-pi/2``), phase condition ``q3(0) = 0``
    (the orbit starts at its maximum, so the amplitude ``max q1`` is an
    unknown), pseudo-arclength in the (amplitude, ``k1``) plane. Amplitudes
    agree with an independent reference within 1e-9 rad.

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
    stop : callable, optional
        ``stop(y) -> bool`` on the unknowns ``y = (a, q4_0, T, k1)`` of each
        new orbit: stop the continuation there.

    Returns
    -------
    HopfBranch

    See Also
    --------
    find_orbit : The orbit at one ``k1`` of the branch.
    design_hopf : The gains for a wanted amplitude.

    Examples
    --------
    The branch of figure 10's law (``k2 = 0.1``) from the Hopf point up to 1 rad:

    >>> from iwp import continue_hopf, table1
    >>> branch = continue_hopf(table1(), 0.1, a_max=1.0)
    >>> branch.stop_reason
    'amplitude reached a_max = 1 rad'
    >>> round(branch.hopf.k1, 3), round(float(branch.k1[-1]), 2), round(float(branch.amplitude[-1]), 2)  # [rad]
    (-0.945, -3.32, 1.05)
    >>> bool(branch.stable.all())  # a supercritical Hopf point: every orbit is stable
    True
    """
    params = lumped_parameters(params)
    a_start = check_positive("a_start", a_start)
    a_max = check_positive("a_max", a_max)
    hp = hopf_point(params, k2)
    shooter = OrbitShooter(params, "k1", k2)
    first = hopf_start(shooter, hp, a_start)
    run = continue_branch(shooter, first, direction=+1, ds=ds, ds_min=ds_min, ds_max=ds_max, a_max=a_max,
                          T_max=T_max_factor * hp.period, k_min=k1_limits[0], k_max=k1_limits[1],
                          max_points=max_points, stop=stop)
    orbits = run.orbits
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
        stop_reason=run.stop_reason, n_shots=run.n_shots, bifurcations=locate_bifurcations(orbits))


def find_orbit(params: LumpedParameters, k1: float, k2: float = 0.1, **continuation) -> PeriodicOrbit:
    """The periodic orbit of the closed loop at gains ``(k1, k2)`` on the Hopf branch.

    Continues the branch from the Hopf point (fixed ``k2``) until it passes
    ``k1``, then corrects the orbit at ``k1``. ``continuation`` overrides the
    keywords of :func:`continue_branch` (``ds``, ``ds_min``, ``ds_max``,
    ``a_max``, ``T_max``, ``k_min``, ``k_max``, ``max_points``).

    Parameters
    ----------
    params : LumpedParameters
        The parameters of model (9).
    k1 : float
        Linear gain of the Hopf law ``u = k1 q3 + k2 q3^3`` (section 5.3)
        [input units per rad/s].
    k2 : float
        Cubic gain [input units per (rad/s)^3].
    **continuation
        Keywords of :func:`continue_branch` (above).

    Returns
    -------
    PeriodicOrbit
        The orbit: amplitude [rad], period [s], Floquet multipliers, stability.

    Raises
    ------
    InputError
        If ``k1`` is not on the branch (the reachable interval is given).

    See Also
    --------
    continue_hopf : The whole branch.

    Examples
    --------
    The paper's gains ``k1 = -10``, ``k2 = 0.1`` (section 5.3, figure 10: ``q1max ~ 2.58`` rad on the rig):

    >>> from iwp import find_orbit, table1
    >>> orbit = find_orbit(table1(), -10.0, 0.1)
    >>> round(orbit.amplitude, 3), round(orbit.period, 3), orbit.stable  # [rad], [s]
    (2.568, 2.082, True)
    >>> round(orbit.u_max, 1)  # the largest input along the orbit [input units]
    38.5
    """
    params = lumped_parameters(params)
    k1 = check_finite("k1", k1)
    k2 = check_finite("k2", k2)
    hp = hopf_point(params, k2)
    side = hp.orbit_side
    if (k1 - hp.k1) * side <= 0:
        raise InputError(f"k1 = {k1:g}: the Hopf branch for k2 = {k2:g} lies on the side k1 {'<' if side < 0 else '>'} "
                         f"k1* = {hp.k1:.6g}")
    shooter = OrbitShooter(params, "k1", k2)
    first = hopf_start(shooter, hp, 0.02)
    if (first.y[3] - k1) * side > 0:  # already beyond k1 with the first orbit: restart smaller
        a = max(1e-4, hp.predicted_amplitude(k1).item() if np.isfinite(hp.predicted_amplitude(k1)) else 1e-3)
        first = hopf_start(shooter, hp, a)
    kw = dict(ds=0.05, ds_min=1e-4, ds_max=0.2, a_max=3.1, T_max=6.0 * hp.period, k_min=-1e3, k_max=1e3,
              max_points=400)
    kw.update(continuation)
    run = continue_branch(shooter, first, direction=+1, stop=lambda yy: (yy[3] - k1) * side >= 0, **kw)
    res = correct_at(shooter, run.ys, 3, k1)
    if res is None:
        ks = [yy[3] for yy in run.ys]
        raise InputError(f"k1 = {k1:g} is beyond the reach of the Hopf branch for k2 = {k2:g}: it covers k1 from "
                         f"{hp.k1:.6g} to {ks[-1]:.6g} ({run.stop_reason})")
    return shooter.orbit(res)

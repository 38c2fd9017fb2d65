"""Periodic orbits of the closed loop ``u = k1 q3 + k2 q3^3`` on model (9), found by shooting.

An orbit is the solution of the shooting equations in the unknowns
``y = (a, q4_0, T, k)``: the orbit starts at its maximum, ``q1(0) = a`` (the
amplitude), ``q3(0) = 0`` (the phase condition), ``q4(0) = q4_0``, returns
to its start after the period ``T``; ``k`` is the free gain. The flow and
its sensitivities to the initial state (the monodromy matrix) and to the
free gain come from :func:`iwp.sim.sensitivity.simulate_sensitivities`: the
one adaptive DOP853 engine of :mod:`iwp.sim.engine`, on ``Plant(params)``
(model (9)) driven by :class:`~iwp.sim.inputs.HopfController`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..models.laws import hopf_law
from ..models.parameters import LumpedParameters
from ..models.plant import Plant
from ..sim.inputs import HopfController
from ..sim.options import SimOptions, Tolerances
from ..sim.sensitivity import simulate_sensitivities
from .closed_loop import REDUCED, hopf_rate, lumped_parameters

__all__ = ["PeriodicOrbit", "OrbitShooter", "Shot", "Correction", "nontrivial_multipliers", "SHOOTING_RTOL",
           "SHOOTING_ATOL", "SHOOTING_MAX_STEP", "TRAJECTORY_STEP"]

#: Relative and absolute error tolerance of the shooting's integration (on the
#: states; the sensitivities ride along). With 1e-10 the orbit amplitudes
#: agree with an independent reference (scipy's DOP853 at 1e-13, restarted at
#: the kinks) within 4e-10 rad along the ``k2 = 0.1`` branch.
SHOOTING_RTOL = 1e-10
SHOOTING_ATOL = 1e-10
#: Largest step of the shooting's integration [s]. The engine's error control
#: acts on the states only; the sensitivities (the monodromy matrix, hence the
#: Floquet multipliers) lose accuracy where a step crosses the ``|cos q1|``
#: kink at ``q1 = +-pi/2`` with a short RK4 bridge, whose length scales with
#: the step size. Bounding the step at 10 ms keeps the trivial Floquet
#: multiplier within 5e-4 of 1 up to the end of the ``k2 = 0.1`` branch
#: (1.7e-3 without; the amplitudes do not depend on it).
SHOOTING_MAX_STEP = 0.01
#: Spacing of the output grid [s] on which an orbit's ``max |u|``, ``max |q3|``,
#: ``max |q4|`` and ``min q1`` are taken (at least 200 intervals per period).
TRAJECTORY_STEP = 2e-3
#: Step limit of one shot (a runaway shot fails instead of running on).
_MAX_STEPS = 200_000

_ROWS = list(REDUCED)


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


def nontrivial_multipliers(mult: np.ndarray) -> np.ndarray:
    """The Floquet multipliers without the trivial one (the one closest to 1).

    Parameters
    ----------
    mult : ndarray, shape (m,)
        Floquet multipliers (complex) of a periodic orbit.

    Returns
    -------
    ndarray, shape (m - 1,)
        The others, in their order.
    """
    i_triv = int(np.argmin(np.abs(mult - 1.0)))
    return np.delete(mult, i_triv)


@dataclass(frozen=True, eq=False)
class Shot:
    """One evaluation of the shooting equations at ``y = (a, q4_0, T, k)``.

    Attributes
    ----------
    residual : ndarray, shape (3,)
        ``z(T) - z(0)`` on ``(q1, q3, q4)``.
    jacobian : ndarray, shape (3, 4)
        ``d residual / d y``.
    monodromy : ndarray, shape (3, 3)
        ``d z(T) / d z(0)``.
    x : ndarray, shape (N, 4) or None
        The trajectory on ``N`` equally spaced times over ``[0, T]`` (when asked for).
    """

    residual: np.ndarray
    jacobian: np.ndarray
    monodromy: np.ndarray
    x: np.ndarray | None = None

    @property
    def finite(self) -> bool:
        return bool(np.all(np.isfinite(self.residual)) and np.all(np.isfinite(self.jacobian)))


@dataclass(frozen=True, eq=False)
class Correction:
    """A converged solution of the shooting equations.

    Attributes
    ----------
    y : ndarray, shape (4,)
        ``(a, q4_0, T, k)``.
    iterations : int
        Newton iterations it took.
    shot : Shot
        The equations at ``y``, with the trajectory.
    """

    y: np.ndarray
    iterations: int
    shot: Shot


class OrbitShooter:
    """The periodic-orbit equations of the closed loop in the unknowns ``y = (a, q4_0, T, k)``.

    Parameters
    ----------
    params : LumpedParameters
    free : str
        The free gain ``k``: ``"k1"`` or ``"k2"``; the other one is fixed.
    k_fixed : float
        Value of the fixed gain.
    rtol, atol : float
        Error control of the integration (:data:`SHOOTING_RTOL`, :data:`SHOOTING_ATOL`).
    max_step : float or None
        Largest step of the integration [s] (:data:`SHOOTING_MAX_STEP`).
    """

    def __init__(self, params: LumpedParameters, free: str, k_fixed: float, *, rtol: float = SHOOTING_RTOL,
                 atol: float = SHOOTING_ATOL, max_step: float | None = SHOOTING_MAX_STEP):
        if free not in ("k1", "k2"):
            raise InputError(f"free must be 'k1' or 'k2', got {free!r}")
        self.plant = Plant(lumped_parameters(params))
        self.free = free
        self.k_fixed = float(k_fixed)
        self.rtol = rtol
        self.atol = atol
        self.max_step = max_step

    def gains(self, k: float) -> tuple[float, float]:
        """``(k1, k2)`` for the free gain ``k``."""
        return (float(k), self.k_fixed) if self.free == "k1" else (self.k_fixed, float(k))

    def shoot(self, y, *, trajectory: bool = False) -> Shot:
        """The shooting equations at ``y = (a, q4_0, T, k)`` (NaN where the integration fails)."""
        a, q40, T, k = (float(v) for v in y)
        if not (math.isfinite(a) and math.isfinite(q40) and math.isfinite(k) and math.isfinite(T) and T > 0):
            nan = np.full(3, np.nan)
            return Shot(nan, np.full((3, 4), np.nan), np.full((3, 3), np.nan))
        k1, k2 = self.gains(k)
        if trajectory:
            t_eval = np.linspace(0.0, T, int(max(200, math.ceil(T / TRAJECTORY_STEP))) + 1)
        else:
            t_eval = np.array([T])
        r = simulate_sensitivities(self.plant, t_eval=t_eval, x0=[a, 0.0, 0.0, q40], input=HopfController(k1, k2),
                                   wrt=(self.free,), wrt_x0=REDUCED, options=SimOptions(
                                       tolerances=Tolerances(rtol=self.rtol, atol=self.atol, max_step=self.max_step,
                                                             max_steps=_MAX_STEPS), check=False))
        xT = r.x[-1]
        S = r.S[-1][_ROWS]  # (3, 4): d z(T) / d k, then d z(T) / d z(0)
        z0 = np.array([a, 0.0, q40])
        zT = xT[_ROWS]
        M = S[:, 1:]
        jac = np.empty((3, 4))
        jac[:, 0] = M[:, 0] - np.array([1.0, 0.0, 0.0])
        jac[:, 1] = M[:, 2] - np.array([0.0, 0.0, 1.0])
        jac[:, 2] = hopf_rate(self.plant, k1, k2, zT) if np.all(np.isfinite(zT)) else np.nan
        jac[:, 3] = S[:, 0]
        return Shot(zT - z0, jac, M, r.x if trajectory else None)

    def newton(self, y0, row, y_ref, *, tol: float = 1e-10, max_iter: int = 12) -> Correction | None:
        """Solve the shooting equations with ``row . (y - y_ref) = 0``; None if Newton fails."""
        y = np.array(y0, dtype=float)
        for it in range(1, max_iter + 1):
            shot = self.shoot(y)
            if not shot.finite:
                return None
            R = shot.residual
            G = np.concatenate([R, [row @ (y - y_ref)]])
            JJ = np.vstack([shot.jacobian, row])
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
        shot = self.shoot(y, trajectory=True)
        if not np.max(np.abs(shot.residual)) < 1e-7 * max(1.0, abs(y[0])):
            return None
        return Correction(y=y, iterations=it, shot=shot)

    def orbit(self, c: Correction) -> PeriodicOrbit:
        """The :class:`PeriodicOrbit` of a converged correction."""
        y = c.y
        k1, k2 = self.gains(y[3])
        mult = np.linalg.eigvals(c.shot.monodromy)
        x = c.shot.x
        q3 = x[:, 2]
        u = hopf_law(k1, k2, q3)
        return PeriodicOrbit(k1=float(k1), k2=float(k2), amplitude=float(y[0]), period=float(y[2]),
                             x0=np.array([y[0], 0.0, 0.0, y[1]]), floquet=mult,
                             stable=bool(np.max(np.abs(nontrivial_multipliers(mult))) < 1.0),
                             u_max=float(np.max(np.abs(u))), q3_max=float(np.max(np.abs(q3))),
                             q4_max=float(np.max(np.abs(x[:, 3]))), q1_min=float(np.min(x[:, 0])))

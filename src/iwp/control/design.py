"""Inverse Hopf design: the gains for a wanted amplitude, and the check by simulation (section 5.3).

:func:`design_hopf` solves for ``k1`` (given ``k2``) or ``k2`` (given
``k1``) of ``u = k1 q3 + k2 q3^3`` so that the closed loop of model (9)
oscillates with ``max q1 = amplitude``: the branch is continued from the
Hopf point (:mod:`.continuation`) until it passes the amplitude, and the
orbit is corrected by Newton's method with the amplitude fixed.
:func:`simulated_amplitude` measures the oscillation a long simulation
reaches (the check).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..checks import check_finite, check_positive
from ..errors import InputError, SimulationError
from ..models.parameters import LumpedParameters
from ..sim.inputs import HopfController
from ..sim.options import SimOptions
from ..sim.simulate import simulate
from .closed_loop import lumped_parameters
from .continuation import continue_branch, correct_at, find_orbit, hopf_start
from .hopf import HopfPoint, hopf_point
from .orbits import OrbitShooter, PeriodicOrbit, nontrivial_multipliers

__all__ = ["HopfDesign", "design_hopf", "SimulatedOscillation", "simulated_amplitude", "refined_peak"]

#: Amplitude at which the continuation for a design gives up [rad] (the upright is pi).
A_MAX_DESIGN = 3.135


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
    unstable_amplitude_min : float
        Amplitude of the first unstable orbit met after them [rad] (the
        stability limit lies between the two); NaN if none was met.
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
    unstable_amplitude_min: float = float("nan")

    @property
    def stable(self) -> bool:
        return self.orbit.stable

    def controller(self, Ts: float | None = None) -> HopfController:
        """The :class:`~iwp.sim.inputs.HopfController` with these gains."""
        return HopfController(self.k1, self.k2, Ts)

    def to_dict(self) -> dict:
        return {"amplitude": self.amplitude, "k1": self.k1, "k2": self.k2, "solved_for": self.solved_for,
                "period": self.period, "frequency": 2 * math.pi / self.period, "stable": self.orbit.stable,
                "floquet_abs": sorted(np.abs(self.orbit.floquet).tolist()), "u_max": self.orbit.u_max,
                "q4_max": self.orbit.q4_max, "x0": self.orbit.x0.tolist(), "k1_star": self.hopf.k1,
                "l1": self.hopf.l1, "criticality": self.hopf.criticality, "k1_normal_form": self.k1_normal_form}


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

    Examples
    --------
    The paper's oscillation of 2.58 rad (section 5.3, figure 10):

    >>> from iwp import design_hopf, table1
    >>> d = design_hopf(table1(), 2.58, k2=0.1)
    >>> round(d.k1, 1), d.stable  # the paper used k1 = -10
    (-10.0, True)
    """
    params = lumped_parameters(params)
    amplitude = check_positive("amplitude", amplitude)
    if amplitude >= math.pi:
        raise InputError(f"amplitude must be below pi (the upright), got {amplitude:g} rad")
    if k1 is not None and k2 is not None:
        raise InputError("give k2 (to solve for k1) or k1 (to solve for k2), not both")
    if k1 is None:
        k2 = 0.1 if k2 is None else check_finite("k2", k2)
        design = _design_k1(params, amplitude, k2, a_start)
    else:
        design = _design_k2(params, amplitude, check_finite("k1", k1))
    if require_stable and not design.orbit.stable:
        mult = np.abs(nontrivial_multipliers(design.orbit.floquet)).max()
        raise InputError(
            f"amplitude = {amplitude:g} rad: the orbit found (k1 = {design.k1:.6g}, k2 = {design.k2:.6g}) is unstable "
            f"(largest Floquet multiplier |mu| = {mult:.4g}); "
            + ("the Hopf bifurcation is subcritical for this k2 (raise k2 above "
               f"{design.hopf.k2_critical:.4g})" if design.hopf.criticality == "subcritical" else
               (f"the orbits of this branch are stable up to an amplitude between {design.stable_amplitude_max:.4g} "
                f"and {min(design.unstable_amplitude_min, amplitude):.4g} rad (the last stable and the first unstable "
                "orbit the continuation met); " if math.isfinite(design.stable_amplitude_max) else "")
               + "lower the amplitude or change k2"))
    return design


def _design_k1(params, amplitude, k2, a_start) -> HopfDesign:
    hp = hopf_point(params, k2)
    if hp.criticality == "degenerate":
        raise InputError(f"k2 = {k2:g} makes the Hopf bifurcation degenerate (l1 = 0); choose another k2")
    k1_nf = hp.predicted_k1(amplitude)
    stable_max = unstable_min = float("nan")
    shooter = OrbitShooter(params, "k1", k2)
    if amplitude <= a_start:
        orbit = shooter.orbit(hopf_start(shooter, hp, amplitude))
    else:
        first = hopf_start(shooter, hp, a_start)
        run = continue_branch(shooter, first, direction=+1, ds=0.05, ds_min=1e-4, ds_max=0.2, a_max=A_MAX_DESIGN,
                              T_max=6.0 * hp.period, k_min=-1e3, k_max=1e3, max_points=400,
                              stop=lambda yy: yy[0] >= amplitude)
        res = correct_at(shooter, run.ys, 0, amplitude)
        if res is None:
            a_reach = max(yy[0] for yy in run.ys)
            raise InputError(f"amplitude = {amplitude:g} rad is beyond the reach of the Hopf branch for k2 = {k2:g}: "
                             f"reachable 0 < amplitude <= {a_reach:.4g} rad ({run.stop_reason})")
        orbit = shooter.orbit(res)
        for o in run.orbits:
            if not o.stable:
                unstable_min = o.amplitude
                break
            stable_max = o.amplitude
    return HopfDesign(amplitude=amplitude, k1=orbit.k1, k2=orbit.k2, solved_for="k1", period=orbit.period,
                      orbit=orbit, hopf=hp, k1_normal_form=float(k1_nf), stable_amplitude_max=stable_max,
                      unstable_amplitude_min=unstable_min)


def _design_k2(params, amplitude, k1) -> HopfDesign:
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
    shooter = OrbitShooter(params, "k2", k1)
    y = np.array([start.amplitude, start.x0[3], start.period, start.k2])
    row = np.array([0.0, 0.0, 0.0, 1.0])
    res = shooter.newton(y, row, y)
    if res is None:  # pragma: no cover - the orbit was just converged
        raise SimulationError("could not re-converge the starting orbit")
    y = res.y
    reason = "the starting orbit has the amplitude"
    if abs(y[0] - amplitude) < 1e-12:
        ys = [y]
    else:
        direction = 1 if amplitude > y[0] else -1
        run = continue_branch(shooter, res, direction=direction, ds=0.05, ds_min=1e-4, ds_max=0.2, a_max=3.1,
                              T_max=6.0 * hp0.period, k_min=-1e4, k_max=1e4, max_points=400,
                              stop=lambda yy: (yy[0] - amplitude) * direction >= 0)
        ys, reason = run.ys, run.stop_reason
    res = correct_at(shooter, ys, 0, amplitude) if len(ys) > 1 else res
    if res is None:
        a_vals = [yy[0] for yy in ys]
        raise InputError(f"amplitude = {amplitude:g} rad is beyond the reach of k2 for k1 = {k1:g}: continuation in k2 "
                         f"reached amplitudes {min(a_vals):.4g}..{max(a_vals):.4g} rad ({reason})")
    orbit = shooter.orbit(res)
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


def refined_peak(sig: np.ndarray) -> float:
    """Largest sample of ``sig``, refined by a parabola through the three samples around it (units of ``sig``).

    Parameters
    ----------
    sig : ndarray, shape (n,)
        Sampled signal.

    Returns
    -------
    float
        The refined peak value (units of ``sig``); the largest sample itself at an end or without a
        downward parabola.
    """
    i = int(np.argmax(sig))
    if 0 < i < sig.size - 1:
        a, b, c = sig[i - 1], sig[i], sig[i + 1]
        den = a - 2 * b + c
        if den < 0:
            return b - 0.125 * (a - c) ** 2 / den
    return sig[i]


def simulated_amplitude(
    params,
    k1: float,
    k2: float,
    *,
    x0=None,
    t_end: float = 300.0,
    window: float = 20.0,
    Ts: float = 0.002,
    controller_Ts: float | None = None,
    options: SimOptions | None = None,
) -> SimulatedOscillation:
    """Simulate ``u = k1 q3 + k2 q3^3`` for a long time and measure the oscillation.

    Parameters
    ----------
    params : LumpedParameters or Plant
        The parameters (of the compensated model (9)), or the plant itself
        (another model: ``Plant(params, model="raw")``).
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
    options : SimOptions, optional
        The feedforward (7)-(8), saturation [input units] and tolerances of
        the run (:func:`iwp.sim.simulate`).

    Returns
    -------
    SimulatedOscillation

    See Also
    --------
    find_orbit : The same orbit by continuation.

    Examples
    --------
    The paper's gains for 60 s, measured over the last 10 s (the orbit itself: 2.568 rad, 2.082 s):

    >>> from iwp import table1
    >>> from iwp.control import simulated_amplitude
    >>> osc = simulated_amplitude(table1(), -10.0, 0.1, t_end=60.0, window=10.0)
    >>> round(osc.amplitude, 3), round(osc.period, 3), osc.rotating  # [rad], [s]
    (2.542, 2.018, False)
    """
    x0 = [0.1, 0.0, 0.0, 0.0] if x0 is None else x0
    r = simulate(params, x0=x0, t_end=t_end, Ts=Ts, input=HopfController(k1, k2, controller_Ts), options=options)
    sel = r.t >= r.t[-1] - window
    t, q = r.t[sel], r.q1[sel]
    rotating = bool(np.max(np.abs(q)) > math.pi)
    amp = float("nan") if rotating else float(refined_peak(q))
    amp_min = float("nan") if rotating else float(refined_peak(-q))
    idx = np.flatnonzero((q[:-1] < 0) & (q[1:] >= 0))
    if idx.size >= 2 and not rotating:
        tc = t[idx] - q[idx] * (t[idx + 1] - t[idx]) / (q[idx + 1] - q[idx])
        period = float(np.mean(np.diff(tc)))
    else:
        period = float("nan")
    return SimulatedOscillation(k1=float(k1), k2=float(k2), amplitude=amp, amplitude_min=amp_min, period=period,
                                rotating=rotating, result=r)

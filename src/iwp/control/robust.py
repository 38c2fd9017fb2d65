"""Robust designs: how a controller designed on a fit fares over the fit's parameter uncertainty (issue 20).

A controller is designed once, on the fit's estimates (the *nominal*
parameters); the closed loop is then simulated with ``N`` parameter sets
drawn from the fit's uncertainty (:meth:`iwp.sim.uncertainty.ParameterUncertainty.draws`:
the normal distribution of the estimates, truncated to physical signs), and
the outcome is reported as a distribution:

* :func:`robust_hopf` -- the Hopf amplitude design (section 5.3,
  :func:`~iwp.control.design.design_hopf`): the orbit's amplitude ``max q1``
  per draw, its median and 95 % interval, and the share of draws with no
  stable orbit (the oscillation dies out, goes over the top, or has not
  settled); :class:`RobustHopf`;
* :func:`robust_balance` -- the balance LQR (:func:`~iwp.control.balance.lqr_balance`):
  the probability of capture from a set of initial states with its Wilson
  score interval, and the distribution of the settling time; :class:`RobustBalance`;
* :func:`robust_swingup` -- the swing-up (:func:`~iwp.control.swingup.swing_up`):
  the probability of success and the distribution of the time to capture;
  :class:`RobustSwingUp`.

The Hopf and balance closed loops of all draws run side by side in
:func:`iwp.sim.simulate.simulate_batch` (the nominal first, so that it is
measured exactly as the draws are). The swing-up controller is a Python
state machine with an observer, which the batch engine does not run: its
draws are simulated one after the other by :func:`~iwp.control.swingup.swing_up`.

Probabilities carry the Wilson score interval (:func:`wilson_interval`;
E. B. Wilson, J. Am. Stat. Assoc. 22 (1927) 209), which keeps its coverage
near 0 and 1 where the normal approximation does not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Sequence

import numpy as np
from scipy import stats

from ..checks import check_finite, check_positive
from ..errors import InputError
from ..files import json_float
from ..models.plant import Plant
from ..sim.inputs import HopfController
from ..sim.options import BatchOptions
from ..sim.simulate import simulate_batch
from ..sim.uncertainty import HELD_NOTE, MAX_DRAWS, ParameterUncertainty
from .balance import LQRBalance, lqr_balance, wrap_angle
from .conditions import RigConditions
from .design import HopfDesign, design_hopf, refined_peak
from .swingup import swing_up

__all__ = ["LEVEL", "Proportion", "Spread", "wilson_interval", "spread_of", "OrbitMeasurement", "measure_orbit",
           "RobustHopf", "robust_hopf",
           "RobustBalance", "robust_balance", "RobustSwingUp", "robust_swingup", "check_draws"]

#: Probability the intervals hold.
LEVEL = 0.95
#: Smallest amplitude counted as an oscillation [rad] (below it the oscillation died out).
AMPLITUDE_FLOOR = 1e-3
#: Largest extrapolation to the orbit, relative to the last peak (beyond it the run has not settled).
EXTRAPOLATION_LIMIT = 0.05
#: Successive peaks closer than this (relative) are on the orbit already.
CONVERGED = 1e-6


def check_draws(draws) -> int:
    """``draws`` as an integer from 1 to :data:`~iwp.sim.uncertainty.MAX_DRAWS`, or an error naming it.

    Parameters
    ----------
    draws : int
        Number of draws.

    Returns
    -------
    int
        ``draws`` as a Python int.

    Raises
    ------
    InputError
        Not an integer (a bool is not one), or outside ``[1, MAX_DRAWS]``.
    """
    if isinstance(draws, bool) or not isinstance(draws, (int, np.integer)) or not 1 <= draws <= MAX_DRAWS:
        raise InputError(f"draws must be an integer from 1 to {MAX_DRAWS}, got {draws!r}", argument="draws")
    return int(draws)


def _uncertainty(u) -> ParameterUncertainty:
    """``u`` checked, with the parameters its fit's logs do not identify held at their estimates
    (:meth:`~iwp.sim.uncertainty.ParameterUncertainty.identified_only`; the results' notes name them)."""
    if not isinstance(u, ParameterUncertainty):
        raise InputError("uncertainty must be a ParameterUncertainty (iwp.sim.uncertainty.load_uncertainty reads "
                         f"one from the parameters.json of iwp fit), got {type(u).__name__}")
    return u.identified_only()


@dataclass(frozen=True)
class Proportion:
    """A probability estimated from ``successes`` of ``trials``, with its Wilson score interval.

    Attributes
    ----------
    successes, trials : int
    p : float
        ``successes / trials``.
    low, high : float
        The Wilson score interval at ``level``.
    level : float
    """

    successes: int
    trials: int
    p: float
    low: float
    high: float
    level: float = LEVEL

    def to_dict(self) -> dict[str, Any]:
        return {"successes": self.successes, "trials": self.trials, "p": json_float(self.p),
                "low": json_float(self.low), "high": json_float(self.high), "level": self.level}

    def __str__(self) -> str:
        return (f"{self.p:.3f} ({self.successes}/{self.trials}; {100 * self.level:g} % Wilson interval "
                f"{self.low:.3f}..{self.high:.3f})")


def wilson_interval(successes: int, trials: int, level: float = LEVEL) -> Proportion:
    """The Wilson score interval of a binomial probability.

    ``(p + z^2/(2n) +- z sqrt(p (1 - p)/n + z^2/(4 n^2))) / (1 + z^2/n)`` with
    ``p = successes/trials``, ``n = trials`` and ``z`` the normal quantile
    of ``(1 + level)/2`` (Wilson 1927; ``scipy.stats.binomtest(...).proportion_ci(method="wilson")``).

    Parameters
    ----------
    successes, trials : int
        ``0 <= successes <= trials``, ``trials >= 1``.
    level : float
        Confidence level, in ``(0, 1)``.

    Returns
    -------
    Proportion

    Examples
    --------
    18 swing-ups out of 20 succeed:

    >>> from iwp.control import wilson_interval
    >>> w = wilson_interval(18, 20)
    >>> print(w)
    0.900 (18/20; 95 % Wilson interval 0.699..0.972)
    >>> round(w.low, 3), round(w.high, 3)
    (0.699, 0.972)
    """
    k, n = int(successes), int(trials)
    if n < 1 or not 0 <= k <= n or k != successes or n != trials:
        raise InputError(f"need whole numbers 0 <= successes <= trials, trials >= 1; got {successes!r} of {trials!r}")
    if not 0.0 < float(level) < 1.0:
        raise InputError(f"level must be in (0, 1), got {level!r}")
    z = float(stats.norm.ppf(0.5 + 0.5 * float(level)))
    p = k / n
    den = 1.0 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z / den * math.sqrt(p * (1.0 - p) / n + z * z / (4.0 * n * n))
    # at k = 0 (k = n) the lower (upper) end is 0 (1) exactly; rounding must not put it beside p
    low = 0.0 if k == 0 else min(p, max(0.0, mid - half))
    high = 1.0 if k == n else max(p, min(1.0, mid + half))
    return Proportion(k, n, p, low, high, float(level))


@dataclass(frozen=True, eq=False)
class Spread:
    """The distribution of an outcome over the draws: median, interval, and the sorted values (the ECDF).

    Attributes
    ----------
    values : ndarray
        The finite outcomes, sorted (units of the outcome).
    probability : ndarray
        The empirical cumulative distribution at ``values``: ``(i + 1)/n``.
    median, low, high : float
        Median and the ``(1 - level)/2``, ``(1 + level)/2`` quantiles (NaN when there are no values); with fewer
        than :attr:`needed` values ``low`` and ``high`` are their range (:attr:`is_interval` False).
    level : float
    """

    values: np.ndarray
    probability: np.ndarray
    median: float
    low: float
    high: float
    level: float = LEVEL

    @property
    def count(self) -> int:
        return int(self.values.size)

    @property
    def width(self) -> float:
        """``high - low``."""
        return self.high - self.low

    @property
    def needed(self) -> int:
        """Outcomes needed for the ``level`` interval: at least one in each tail, ``ceil(2 / (1 - level))``
        (40 at 95 %)."""
        return math.ceil(2.0 / (1.0 - self.level) - 1e-9)

    @property
    def is_interval(self) -> bool:
        """Whether ``[low, high]`` is the ``level`` interval; with fewer than :attr:`needed` outcomes its tails
        hold no outcome and it is only the outcomes' range, narrower than the interval."""
        return self.count >= self.needed

    def interval_text(self, spec: str = ".4g", unit: str = "") -> str:
        """``"95 % interval [low, high] unit"``, or, with too few outcomes, their range said as such."""
        u = f" {unit}" if unit else ""
        if self.is_interval:
            return f"{100 * self.level:g} % interval [{self.low:{spec}}, {self.high:{spec}}]{u}"
        return (f"range [{self.low:{spec}}, {self.high:{spec}}]{u} (too few for a {100 * self.level:g} % "
                f"interval: it needs {self.needed})")

    def to_dict(self) -> dict[str, Any]:
        return {"count": self.count, "median": json_float(self.median), "low": json_float(self.low),
                "high": json_float(self.high), "level": self.level,
                "low_high": "interval" if self.is_interval else "range (too few outcomes for the interval)"}


def spread_of(values, level: float = LEVEL) -> Spread:
    """The :class:`Spread` of the finite entries of ``values``.

    Parameters
    ----------
    values : array_like
        Outcomes over the draws (any shape; NaN and infinite ones are dropped) [units of the outcome].
    level : float, default 0.95
        Probability of the central interval ``[low, high]``.

    Returns
    -------
    Spread
        The spread; all NaN statistics when no value is finite; ``low`` and ``high`` the range when there are
        fewer values than :attr:`Spread.needed`.
    """
    v = np.sort(np.asarray(values, dtype=float).ravel())
    v = v[np.isfinite(v)]
    if v.size == 0:
        nan = float("nan")
        return Spread(v, v.copy(), nan, nan, nan, level)
    lo, med, hi = np.quantile(v, [0.5 - 0.5 * level, 0.5, 0.5 + 0.5 * level])
    out = Spread(v, np.arange(1, v.size + 1) / v.size, float(med), float(lo), float(hi), level)
    if not out.is_interval:  # no outcome in a tail: the quantiles would interpolate inside the range; give the range
        out = replace(out, low=float(v[0]), high=float(v[-1]))
    return out


def _draw_record(uncertainty: ParameterUncertainty, params) -> list[dict[str, float]]:
    return [{n: float(getattr(p, n)) for n in uncertainty.free} for p in params]


def _source(uncertainty: ParameterUncertainty, draws: int, seed: int) -> dict[str, Any]:
    return {"draws": draws, "seed": seed, "free": list(uncertainty.free),
            "stderr": {k: json_float(v) for k, v in uncertainty.stderr.items()},
            "covariance_method": uncertainty.method, "covariance_reliable": bool(uncertainty.reliable),
            "covariance_notes": list(uncertainty.notes)}


# --------------------------------------------------------------------------
# the Hopf amplitude design
# --------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class RobustHopf:
    """The Hopf amplitude design over a fit's uncertainty (:func:`robust_hopf`).

    Attributes
    ----------
    design : HopfDesign
        The design on the nominal parameters (the gains every draw runs with).
    nominal_amplitude : float
        ``max q1`` of the nominal closed loop, measured as the draws' are [rad].
    amplitudes : ndarray, shape (draws,)
        ``max q1`` per draw [rad]; NaN where there is no stable orbit.
    outcome : ndarray of str, shape (draws,)
        Per draw (:func:`measure_orbit`): ``"orbit"``, ``"decayed"`` (the
        oscillation dies out), ``"rotating"`` (over the top), ``"unsettled"``
        (the peaks do not converge to an orbit within ``t_end``) or
        ``"failed"`` (the simulation did not finish).
    amplitude : Spread
        Median and 95 % interval of the amplitude over the draws with an orbit.
    no_orbit : Proportion
        Share of the draws with no stable orbit, with its Wilson interval.
    draws_params : list of dict
        The free parameters of each draw.
    source : dict
        Draws, seed, the covariance's method and verdict.
    t_end, window : float
        Simulated time and the final window the amplitude is measured over [s].
    reliable : bool
        False when the fit flagged its covariance unreliable (the summary says so).
    notes : tuple of str
        The fit's verdict on its covariance.
    """

    design: HopfDesign
    nominal_amplitude: float
    amplitudes: np.ndarray
    outcome: np.ndarray
    amplitude: Spread
    no_orbit: Proportion
    draws_params: list = field(repr=False)
    source: dict = field(repr=False)
    t_end: float = 60.0
    window: float = 10.0
    reliable: bool = True
    notes: Sequence[str] = ()

    def summary(self) -> str:
        d, a = self.design, self.amplitude
        counts = {k: int(np.count_nonzero(self.outcome == k)) for k in ("decayed", "rotating", "unsettled", "failed")}
        why = ", ".join(f"{v} {k}" for k, v in counts.items() if v)
        lines = [f"Hopf design (k1 = {d.k1:.6g}, k2 = {d.k2:.6g}, amplitude {d.amplitude:g} rad) over "
                 f"{self.amplitudes.size} parameter draws ({self.t_end:g} s closed loops):",
                 (f"  nominal amplitude {self.nominal_amplitude:.5g} rad" if math.isfinite(self.nominal_amplitude)
                  else f"  nominal: no stable orbit reached within {self.t_end:g} s"),
                 (f"  amplitude median {a.median:.5g} rad, {a.interval_text('.5g', 'rad')} over {a.count} draws "
                  "with an orbit" if a.count
                  else "  amplitude: no draw reached an orbit"),
                 f"  no stable orbit reached within {self.t_end:g} s: {self.no_orbit}" + (f" -- {why}" if why else "")]
        return "\n".join(lines + _reliability_line_of(self))

    def to_dict(self) -> dict[str, Any]:
        return {"design": self.design.to_dict(), "nominal_amplitude": json_float(self.nominal_amplitude),
                "amplitude": self.amplitude.to_dict(), "no_orbit": self.no_orbit.to_dict(),
                "t_end": self.t_end, "window": self.window, **self.source,
                "runs": [{"amplitude": json_float(a), "outcome": str(o), **p}
                         for a, o, p in zip(self.amplitudes, self.outcome, self.draws_params)]}

    def plot(self, **kw):
        """Histogram and ECDF of the amplitude, the nominal marked; see :func:`iwp.plotting.plot_distribution`."""
        title = (f"Hopf design k1 = {self.design.k1:.4g}, k2 = {self.design.k2:.4g}: no stable orbit in "
                 f"{100 * self.no_orbit.p:.1f} % of {self.no_orbit.trials} draws")
        from ..plotting.robust import plot_distribution  # plotting only when asked

        return plot_distribution(self.amplitude, nominal=self.nominal_amplitude,
                                 label=r"amplitude $\max q_1$ [rad]", title=title, **kw)


def _reliability_line_of(r) -> list[str]:
    """The summary's line on the draws' covariance: the fit's flag, and the parameters held at their estimates."""
    held = [n for n in r.notes if n.startswith(HELD_NOTE)]
    lines = [f"  {n}" for n in held]
    if r.reliable:
        return lines
    others = [n for n in r.notes if n not in held]
    return ["  the fit flagged its covariance as UNRELIABLE: this distribution is no better than it"
            + (f" ({'; '.join(others)})" if others else "")] + lines


@dataclass(frozen=True)
class OrbitMeasurement:
    """The oscillation a closed-loop run approaches (:func:`measure_orbit`).

    Attributes
    ----------
    outcome : str
        ``"orbit"``, ``"decayed"``, ``"rotating"``, ``"unsettled"`` or ``"failed"``.
    amplitude : float
        ``max q1`` of the orbit the peaks converge to [rad]; NaN unless ``outcome == "orbit"``.
    last_peak : float
        The last peak of ``q1`` simulated [rad].
    contraction : float
        The peaks' return-map multiplier ``(p[k+1] - p[k]) / (p[k] - p[k-1])`` (0 when converged; NaN if unknown).
    """

    outcome: str
    amplitude: float
    last_peak: float
    contraction: float


def measure_orbit(t, q1, window: float) -> OrbitMeasurement:
    """The amplitude of the periodic orbit a run of ``q1(t)`` approaches, from its peaks over the last ``2 window``.

    The successive maxima ``p[k]`` of ``q1`` (each refined by a parabola
    through its three samples) are the return map of the orbit: near a
    stable orbit ``p[k] - p* ~ c lambda^k``, ``lambda`` the orbit's
    contracting Floquet multiplier. With ``lambda`` estimated as the median
    ratio of successive differences, ``p* = p[n] + (p[n] - p[n-1]) lambda/(1 - lambda)``
    (Aitken's extrapolation), so that an orbit approached slowly is measured
    where it is, not where the run stopped. The run is

    * ``"rotating"`` if ``|q1| > pi`` in the window (over the top);
    * ``"decayed"`` if its peaks go to below 1 mrad (the hanging rest is stable);
    * ``"unsettled"`` if the peaks do not contract (``|lambda| >= 1``), there
      are fewer than 4, or the extrapolation exceeds 5 % of the last peak;
    * ``"orbit"`` otherwise.

    Parameters
    ----------
    t, q1 : ndarray
        Sample times [s] and the pendulum angle [rad] (samples well below the period).
    window : float
        [s].

    Returns
    -------
    OrbitMeasurement
    """
    t = np.asarray(t, dtype=float)
    q = np.asarray(q1, dtype=float)[t >= t[-1] - 2 * window]
    nan = float("nan")
    if q.size < 3 or not np.all(np.isfinite(q)):
        return OrbitMeasurement("failed", nan, nan, nan)
    if np.max(np.abs(q)) > math.pi:
        return OrbitMeasurement("rotating", nan, nan, nan)
    idx = np.flatnonzero((q[1:-1] > q[:-2]) & (q[1:-1] >= q[2:])) + 1
    peaks = np.array([float(refined_peak(q[i - 1:i + 2])) for i in idx])
    last = float(peaks[-1]) if peaks.size else float(np.max(q))
    if last < AMPLITUDE_FLOOR:
        return OrbitMeasurement("decayed", nan, last, nan)
    if peaks.size < 4:
        return OrbitMeasurement("unsettled", nan, last, nan)
    d = np.diff(peaks)
    if np.max(np.abs(d[-3:])) <= CONVERGED * last:
        return OrbitMeasurement("orbit", last, last, 0.0)
    half = d[-max(3, d.size // 2):]
    use = np.abs(half[:-1]) > 1e-3 * CONVERGED * last
    if np.count_nonzero(use) < 2:
        return OrbitMeasurement("unsettled", nan, last, nan)
    lam = float(np.median(half[1:][use] / half[:-1][use]))
    if not abs(lam) < 1.0:
        return OrbitMeasurement("unsettled", nan, last, lam)
    a = last + float(d[-1]) * lam / (1.0 - lam)
    if a < AMPLITUDE_FLOOR:
        return OrbitMeasurement("decayed", nan, last, lam)
    if abs(a - last) > EXTRAPOLATION_LIMIT * last:
        return OrbitMeasurement("unsettled", nan, last, lam)
    return OrbitMeasurement("orbit", a, last, lam)


def robust_hopf(
    uncertainty: ParameterUncertainty,
    amplitude: float | None = None,
    *,
    k2: float | None = None,
    k1: float | None = None,
    design: HopfDesign | None = None,
    draws: int = 100,
    seed: int = 0,
    t_end: float = 60.0,
    window: float = 10.0,
    Ts: float = 0.005,
) -> RobustHopf:
    """The amplitude the Hopf design reaches over a fit's parameter uncertainty.

    The gains are designed on the nominal parameters (:func:`~iwp.control.design.design_hopf`,
    or ``design`` as given); the closed loop ``u = k1 q3 + k2 q3^3`` of model
    (9) is simulated for the nominal and for ``draws`` parameter draws, side
    by side (:func:`~iwp.sim.simulate.simulate_batch`), each from the
    designed orbit's initial state, for ``t_end`` seconds. Per draw the
    amplitude ``max q1`` of the orbit the run approaches is measured from
    its peaks over the final ``2 window`` (:func:`measure_orbit`: the peaks'
    return map extrapolated to its fixed point); a draw has no stable orbit
    when the run goes over the top, dies out, does not settle or fails.

    Parameters
    ----------
    uncertainty : ParameterUncertainty
        The fit's estimates and covariance (:func:`iwp.sim.uncertainty.load_uncertainty`).
    amplitude : float, optional
        Wanted ``max q1`` [rad] (with ``k2`` or ``k1`` as for ``design_hopf``); or give ``design``.
    k2, k1 : float, optional
        As for :func:`~iwp.control.design.design_hopf`.
    design : HopfDesign, optional
        A design already made on ``uncertainty.params`` (skips the design).
    draws, seed : int
        Number of parameter draws and the seed of the random generator.
    t_end : float
        Simulated time [s]; at least ``2 window``.
    window : float
        The amplitude is measured over the final ``2 window`` [s].
    Ts : float
        Output sample time [s].

    Returns
    -------
    RobustHopf

    Examples
    --------
    Figure 10's amplitude of 2.58 rad over 20 draws of a fit with standard errors of 1 % on ``p1`` and ``p3``
    and 5 % on ``p2`` (short runs: 30 s, measured over the last 12 s):

    >>> import numpy as np
    >>> from iwp import robust_hopf, table1
    >>> from iwp.sim.uncertainty import ParameterUncertainty
    >>> p = table1()
    >>> sd = [0.01 * p.p1, 0.05 * p.p2, 0.01 * p.p3]
    >>> fit = ParameterUncertainty(p, ("p1", "p2", "p3"), np.diag(np.square(sd)))
    >>> r = robust_hopf(fit, 2.58, k2=0.1, draws=20, t_end=30.0, window=6.0)
    >>> round(r.design.k1, 2), round(r.nominal_amplitude, 2)
    (-10.05, 2.58)
    >>> round(r.amplitude.median, 2), round(r.amplitude.low, 2), round(r.amplitude.high, 2)  # [rad]
    (2.58, 2.48, 2.65)
    >>> print(r.no_orbit)  # draws without a stable orbit
    0.000 (0/20; 95 % Wilson interval 0.000..0.161)
    """
    uncertainty = _uncertainty(uncertainty)
    draws = check_draws(draws)
    t_end = check_positive("t_end", t_end)
    window = check_positive("window", window)
    Ts = check_positive("Ts", Ts)
    if t_end < 2 * window:
        raise InputError(f"t_end = {t_end:g} s must be at least twice the window ({window:g} s) the orbit's "
                         "amplitude is measured over", argument="t_end")
    nominal = uncertainty.params
    if design is None:
        if amplitude is None:
            raise InputError("give the amplitude (or a design)", argument="amplitude")
        design = design_hopf(nominal, amplitude, k2=k2, k1=k1)
    elif not isinstance(design, HopfDesign):
        raise InputError(f"design must be a HopfDesign, got {type(design).__name__}")
    params = uncertainty.draws(draws, seed)
    base = Plant(nominal)
    plants = [base] + [base.with_params(p) for p in params]
    batch = simulate_batch(plants, x0=[float(v) for v in design.orbit.x0], t_end=t_end, Ts=Ts,
                           input=HopfController(design.k1, design.k2))
    measured = [measure_orbit(batch.t, batch.x[i, :, 0], window) if batch.status[i] == 0 else
                OrbitMeasurement("failed", float("nan"), float("nan"), float("nan")) for i in range(len(plants))]
    amps = np.array([m.amplitude for m in measured])
    outcome = np.array([m.outcome for m in measured], dtype=object)
    ok = outcome[1:] == "orbit"
    return RobustHopf(design=design, nominal_amplitude=float(amps[0]), amplitudes=amps[1:],
                      outcome=outcome[1:].astype(str), amplitude=spread_of(amps[1:][ok]),
                      no_orbit=wilson_interval(int(np.count_nonzero(~ok)), draws),
                      draws_params=_draw_record(uncertainty, params), source=_source(uncertainty, draws, seed),
                      t_end=t_end, window=window, reliable=bool(uncertainty.reliable), notes=tuple(uncertainty.notes))


# --------------------------------------------------------------------------
# the balance LQR
# --------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class RobustBalance:
    """The balance LQR over a fit's uncertainty (:func:`robust_balance`).

    Attributes
    ----------
    lqr : LQRBalance
        The design on the nominal parameters.
    initial_states : ndarray, shape (m, 4)
        The initial states ``[q1, q2, q3, q4]`` tried.
    captured : ndarray of bool, shape (draws, m)
        Per draw and initial state: within ``tolerance`` of the upright over the final ``hold`` seconds.
    settling : ndarray, shape (draws, m)
        Time from which the pendulum stays within ``tolerance`` of the upright [s]; NaN if not captured.
    nominal_captured : ndarray of bool, shape (m,)
    nominal_settling : ndarray, shape (m,)
        The same for the nominal parameters.
    capture : Proportion
        Probability of capture over all draws and initial states, with its Wilson interval.
    capture_by_state : list of Proportion
        The same per initial state (over the draws).
    settling_time : Spread
        Median and 95 % interval of the settling time over the captured runs [s].
    tolerance, hold, t_end, fall : float
        [rad], [s], [s], [rad].
    reliable : bool
        False when the fit flagged its covariance unreliable (the summary says so).
    notes : tuple of str
        The fit's verdict on its covariance.
    """

    lqr: LQRBalance
    initial_states: np.ndarray
    captured: np.ndarray
    settling: np.ndarray
    nominal_captured: np.ndarray
    nominal_settling: np.ndarray
    capture: Proportion
    capture_by_state: list
    settling_time: Spread
    draws_params: list = field(repr=False)
    source: dict = field(repr=False)
    tolerance: float = 0.01
    hold: float = 1.0
    t_end: float = 5.0
    fall: float = 0.5 * math.pi
    reliable: bool = True
    notes: Sequence[str] = ()

    def summary(self) -> str:
        s = self.settling_time
        lines = [f"balance LQR (K = [{', '.join(f'{k:.4g}' for k in self.lqr.K)}], |u| <= {self.lqr.u_max:g}) "
                 f"over {self.captured.shape[0]} parameter draws x {self.captured.shape[1]} initial states "
                 f"({self.t_end:g} s; captured: within {self.tolerance:g} rad of the upright over the last "
                 f"{self.hold:g} s, never beyond {self.fall:.3g} rad):",
                 f"  probability of capture {self.capture}",
                 (f"  settling time median {s.median:.4g} s, {s.interval_text('.4g', 's')} over {s.count} captured "
                  "runs" if s.count else "  settling time: no run was captured")]
        for x0, pr, nc, ns in zip(self.initial_states, self.capture_by_state, self.nominal_captured,
                                  self.nominal_settling):
            lines.append(f"  from q1 - pi = {wrap_angle(x0[0] - math.pi):+.4g} rad, q3 = {x0[2]:+.4g} rad/s: "
                         f"capture {pr}; nominal "
                         + (f"captured, settles in {ns:.4g} s" if nc else "NOT captured"))
        return "\n".join(lines + _reliability_line_of(self))

    def to_dict(self) -> dict[str, Any]:
        return {"K": self.lqr.K.tolist(), "Ts": self.lqr.Ts, "u_max": self.lqr.u_max,
                "capture_bound": self.lqr.capture_bound, "tolerance": self.tolerance, "hold": self.hold,
                "fall": self.fall,
                "t_end": self.t_end, "capture": self.capture.to_dict(), "settling_time": self.settling_time.to_dict(),
                "initial_states": [
                    {"x0": [float(v) for v in x0], "capture": pr.to_dict(), "nominal_captured": bool(nc),
                     "nominal_settling_time": json_float(ns)}
                    for x0, pr, nc, ns in zip(self.initial_states, self.capture_by_state, self.nominal_captured,
                                              self.nominal_settling)],
                **self.source,
                "runs": [{"captured": [bool(c) for c in cs], "settling_time": [json_float(v) for v in ss], **p}
                         for cs, ss, p in zip(self.captured, self.settling, self.draws_params)]}

    def plot(self, **kw):
        """Capture probability per initial state, histogram and ECDF of the settling time, the nominal marked."""
        labels = [f"{wrap_angle(x0[0] - math.pi):+.3g} rad" for x0 in self.initial_states]
        nominal = float(np.nanmedian(self.nominal_settling)) if np.any(self.nominal_captured) else float("nan")
        from ..plotting.robust import plot_capture  # plotting only when asked

        return plot_capture(self.capture_by_state, labels=labels, nominal_captured=self.nominal_captured,
                            settling=self.settling_time, nominal_settling=nominal,
                            title=f"balance LQR: capture {self.capture.p:.3f} "
                                  f"[{self.capture.low:.3f}, {self.capture.high:.3f}]", **kw)


def _settling(t: np.ndarray, theta: np.ndarray, tolerance: float, hold: float, fall: float):
    """Per run: captured (within ``tolerance`` over the final ``hold``, never beyond ``fall``) and its settling time."""
    inside = np.abs(theta) < tolerance
    final = t >= t[-1] - hold
    with np.errstate(invalid="ignore"):
        fell = ~(np.abs(theta) <= fall).all(axis=1)
    captured = np.all(inside[:, final], axis=1) & ~fell
    settle = np.full(theta.shape[0], np.nan)
    for i in np.flatnonzero(captured):
        out = np.flatnonzero(~inside[i])
        settle[i] = float(t[out[-1] + 1]) - float(t[0]) if out.size else 0.0
    return captured, settle


def robust_balance(
    uncertainty: ParameterUncertainty,
    *,
    initial_states=None,
    angles: Sequence[float] | None = None,
    lqr: LQRBalance | None = None,
    draws: int = 100,
    seed: int = 0,
    t_end: float = 5.0,
    tolerance: float = 0.01,
    hold: float = 1.0,
    fall: float = 0.5 * math.pi,
    Ts: float | None = 0.005,
    u_max: float = 100.0,
    Ts_out: float = 0.005,
) -> RobustBalance:
    """Probability of capture and settling time of the balance LQR over a fit's parameter uncertainty.

    The LQR is designed on the nominal parameters (:func:`~iwp.control.balance.lqr_balance`,
    discrete with ``Ts`` as on the rig, ``|u| <= u_max``), or given as
    ``lqr``; the closed loop of model (9) with it is simulated from each
    initial state for the nominal and each of ``draws`` parameter draws,
    side by side (:func:`~iwp.sim.simulate.simulate_batch`). A run is
    *captured* when ``|wrap(q1 - pi)| < tolerance`` over its final ``hold``
    seconds and it never fell beyond ``fall`` from the upright (a pendulum
    that falls, swings round and is caught again is not a capture); its
    settling time is when it enters that band for good.

    Parameters
    ----------
    uncertainty : ParameterUncertainty
    initial_states : array_like, shape (m, 4), optional
        ``[q1, q2, q3, q4]`` each [rad, rad/s]; default: at rest, ``q1 = pi + angle`` for each of ``angles``.
    angles : sequence of float, optional
        Initial angles from the upright [rad] when ``initial_states`` is not
        given; default 0.25, 0.5, 0.75, 1 and 1.25 times the nominal design's
        capture bound (:attr:`~iwp.control.balance.LQRBalance.capture_bound`:
        at rest, the linearised edge of the region from which ``|u| <= u_max``
        can stop the fall).
    lqr : LQRBalance, optional
        A design to test instead of the nominal one.
    draws, seed : int
    t_end : float
        Simulated time [s].
    tolerance : float
        [rad].
    hold : float
        [s], less than ``t_end``.
    fall : float
        A run that leaves ``|wrap(q1 - pi)| <= fall`` is not captured [rad].
    Ts : float or None
        Sample period of the design and of the controller [s]; ``None``: continuous.
    u_max : float
        Saturation [input units].
    Ts_out : float
        Output sample time [s].

    Returns
    -------
    RobustBalance

    Examples
    --------
    The balance LQR over 20 draws of a fit with standard errors of 1 % on ``p1`` and ``p3`` and 5 % on
    ``p2``, released at rest 0.03 rad and 0.08 rad from the upright:

    >>> import numpy as np
    >>> from iwp import robust_balance, table1
    >>> from iwp.sim.uncertainty import ParameterUncertainty
    >>> p = table1()
    >>> sd = [0.01 * p.p1, 0.05 * p.p2, 0.01 * p.p3]
    >>> fit = ParameterUncertainty(p, ("p1", "p2", "p3"), np.diag(np.square(sd)))
    >>> r = robust_balance(fit, angles=(0.03, 0.08), draws=20, t_end=3.0)
    >>> round(r.lqr.capture_bound, 3)  # the nominal design's reach at rest [rad]
    0.072
    >>> [str(c) for c in r.capture_by_state]  # inside the bound every draw is caught, beyond it none
    ['1.000 (20/20; 95 % Wilson interval 0.839..1.000)', '0.000 (0/20; 95 % Wilson interval 0.000..0.161)']
    >>> r.settling_time.median  # [s]
    0.255
    """
    uncertainty = _uncertainty(uncertainty)
    draws = check_draws(draws)
    t_end = check_positive("t_end", t_end)
    tolerance = check_positive("tolerance", tolerance)
    hold = check_positive("hold", hold)
    if hold >= t_end:
        raise InputError(f"hold = {hold:g} s must be shorter than t_end = {t_end:g} s", argument=("hold", "t_end"))
    fall = check_positive("fall", fall)
    nominal = uncertainty.params
    ctl = lqr if lqr is not None else lqr_balance(nominal, u_max=u_max, Ts=Ts)
    if not isinstance(ctl, LQRBalance):
        raise InputError(f"lqr must be an LQRBalance, got {type(ctl).__name__}")
    if initial_states is None:
        if angles is None:
            angles = [f * ctl.capture_bound for f in (0.25, 0.5, 0.75, 1.0, 1.25)]
        a = np.asarray([check_finite("angles", v) for v in angles], dtype=float)
        if a.size == 0:
            raise InputError("give at least one initial angle", argument="angles")
        X0 = np.column_stack([math.pi + a, np.zeros((a.size, 3))])
    else:
        X0 = np.atleast_2d(np.asarray(initial_states, dtype=float))
        if X0.ndim != 2 or X0.shape[1] != 4 or X0.shape[0] == 0 or not np.all(np.isfinite(X0)):
            raise InputError(f"initial_states must be finite rows of q1, q2, q3, q4; got shape {X0.shape}",
                             argument="initial_states")
    params = uncertainty.draws(draws, seed)
    base = Plant(nominal)
    sets = [base] + [base.with_params(p) for p in params]
    m = X0.shape[0]
    plants = [pl for pl in sets for _ in range(m)]
    x0s = [list(X0[j]) for _ in sets for j in range(m)]
    batch = simulate_batch(plants, x0=x0s, t_end=t_end, Ts=Ts_out, input=ctl.controller(),
                           options=BatchOptions(saturation=ctl.u_max))
    theta = wrap_angle(batch.x[:, :, 0] - math.pi)
    theta[batch.status != 0] = np.nan
    captured, settle = _settling(batch.t, theta, tolerance, hold, fall)
    captured = captured.reshape(len(sets), m)
    settle = settle.reshape(len(sets), m)
    cd, sd = captured[1:], settle[1:]
    return RobustBalance(
        lqr=ctl, initial_states=X0, captured=cd, settling=sd, nominal_captured=captured[0],
        nominal_settling=settle[0], capture=wilson_interval(int(np.count_nonzero(cd)), cd.size),
        capture_by_state=[wilson_interval(int(np.count_nonzero(cd[:, j])), draws) for j in range(m)],
        settling_time=spread_of(sd[cd]), draws_params=_draw_record(uncertainty, params),
        source=_source(uncertainty, draws, seed), tolerance=tolerance, hold=hold, t_end=t_end, fall=fall,
        reliable=bool(uncertainty.reliable), notes=tuple(uncertainty.notes))


# --------------------------------------------------------------------------
# the swing-up
# --------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class RobustSwingUp:
    """The swing-up and balance over a fit's uncertainty (:func:`robust_swingup`).

    Attributes
    ----------
    success : ndarray of bool, shape (draws,)
        Per draw: balanced within ``tolerance`` over the final ``hold`` seconds.
    t_catch : ndarray, shape (draws,)
        Per draw: the first switch to the balance law [s] (NaN if none).
    t_balanced : ndarray, shape (draws,)
        Per draw: from when the pendulum stays within ``tolerance`` of the upright [s] (NaN if never).
    nominal_success : bool
    nominal_t_catch, nominal_t_balanced : float
        The same for the nominal parameters.
    probability : Proportion
        Probability of success, with its Wilson interval.
    time_to_capture : Spread
        Median and 95 % interval of ``t_catch`` over the successful draws [s].
    conditions : str
        ``"rig"`` or ``"ideal"``.
    reliable : bool
        False when the fit flagged its covariance unreliable (the summary says so).
    notes : tuple of str
        The fit's verdict on its covariance.
    """

    success: np.ndarray
    t_catch: np.ndarray
    t_balanced: np.ndarray
    nominal_success: bool
    nominal_t_catch: float
    nominal_t_balanced: float
    probability: Proportion
    time_to_capture: Spread
    draws_params: list = field(repr=False)
    source: dict = field(repr=False)
    conditions: str = "rig"
    t_end: float = 20.0
    tolerance: float = 0.05
    hold: float = 3.0
    reliable: bool = True
    notes: Sequence[str] = ()

    def summary(self) -> str:
        s = self.time_to_capture
        lines = [f"swing-up ({self.conditions}) over {self.success.size} parameter draws ({self.t_end:g} s; success: "
                 f"within {self.tolerance:g} rad of the upright over the last {self.hold:g} s):",
                 f"  probability of success {self.probability}",
                 (f"  time to capture median {s.median:.4g} s, {s.interval_text('.4g', 's')} over {s.count} "
                  "successful draws" if s.count else "  time to capture: no draw succeeded"),
                 "  nominal: " + (f"balanced, caught at {self.nominal_t_catch:.4g} s" if self.nominal_success
                                  else "NOT balanced")]
        return "\n".join(lines + _reliability_line_of(self))

    def to_dict(self) -> dict[str, Any]:
        return {"conditions": self.conditions, "t_end": self.t_end, "tolerance": self.tolerance, "hold": self.hold,
                "probability": self.probability.to_dict(), "time_to_capture": self.time_to_capture.to_dict(),
                "nominal": {"success": bool(self.nominal_success), "t_catch": json_float(self.nominal_t_catch),
                            "t_balanced": json_float(self.nominal_t_balanced)},
                **self.source,
                "runs": [{"success": bool(ok), "t_catch": json_float(tc), "t_balanced": json_float(tb), **p}
                         for ok, tc, tb, p in zip(self.success, self.t_catch, self.t_balanced, self.draws_params)]}

    def plot(self, **kw):
        """Histogram and ECDF of the time to capture, the nominal marked; see :func:`iwp.plotting.plot_distribution`."""
        title = (f"swing-up ({self.conditions}): success {self.probability.p:.3f} "
                 f"[{self.probability.low:.3f}, {self.probability.high:.3f}] over {self.success.size} draws")
        nominal = self.nominal_t_catch if self.nominal_success else float("nan")
        from ..plotting.robust import plot_distribution  # plotting only when asked

        return plot_distribution(self.time_to_capture, nominal=nominal, label="time to capture [s]", title=title,
                                 **kw)


def robust_swingup(
    uncertainty: ParameterUncertainty,
    *,
    draws: int = 20,
    seed: int = 0,
    x0=(0.0, 0.0, 0.0, 0.0),
    t_end: float = 20.0,
    rig: RigConditions | None = RigConditions(),
    tolerance: float = 0.05,
    hold: float = 3.0,
    **controller_kw,
) -> RobustSwingUp:
    """Probability of success and time to capture of the swing-up over a fit's parameter uncertainty.

    The controller is built on the nominal parameters (its energy target,
    its LQR, its observer); each parameter draw is the plant
    (:func:`~iwp.control.swingup.swing_up` with ``plant_params``, the rig's
    dead zone on top when ``rig`` is given). The controller is a Python
    state machine, so the draws run one after the other (about 0.5 s of
    computing per 20 s run).

    Parameters
    ----------
    uncertainty : ParameterUncertainty
    draws, seed : int
    x0 : array_like
        Initial state ``[q1, q2, q3, q4]`` (default rest at the bottom).
    t_end : float
        Simulated time [s].
    rig : RigConditions or None
        As for :func:`~iwp.control.swingup.swing_up` (``None``: ideal conditions).
    tolerance, hold : float
        Success criterion [rad], [s].
    **controller_kw
        Settings of :class:`~iwp.control.swingup.SwingUpController`.

    Returns
    -------
    RobustSwingUp

    Examples
    --------
    Two draws (a real study takes more) of a fit with standard errors of 1 % on ``p1`` and ``p3`` and 5 % on
    ``p2``, 13 s each under the rig's conditions:

    >>> import numpy as np
    >>> from iwp import robust_swingup, table1
    >>> from iwp.sim.uncertainty import ParameterUncertainty
    >>> p = table1()
    >>> sd = [0.01 * p.p1, 0.05 * p.p2, 0.01 * p.p3]
    >>> fit = ParameterUncertainty(p, ("p1", "p2", "p3"), np.diag(np.square(sd)))
    >>> r = robust_swingup(fit, draws=2, t_end=13.0)
    >>> print(r.probability)
    1.000 (2/2; 95 % Wilson interval 0.342..1.000)
    >>> r.nominal_t_catch, r.t_catch  # [s]
    (9.185, array([9.115, 9.26 ]))
    """
    uncertainty = _uncertainty(uncertainty)
    draws = check_draws(draws)
    nominal = uncertainty.params
    params = uncertainty.draws(draws, seed)
    runs = [swing_up(nominal, x0=x0, t_end=t_end, rig=rig, tolerance=tolerance, hold=hold, plant_params=p,
                     **controller_kw) for p in [nominal] + params]
    ok = np.array([r.success for r in runs[1:]], dtype=bool)
    tc = np.array([r.t_catch for r in runs[1:]], dtype=float)
    tb = np.array([r.t_balanced for r in runs[1:]], dtype=float)
    return RobustSwingUp(success=ok, t_catch=tc, t_balanced=tb, nominal_success=bool(runs[0].success),
                         nominal_t_catch=float(runs[0].t_catch), nominal_t_balanced=float(runs[0].t_balanced),
                         probability=wilson_interval(int(np.count_nonzero(ok)), draws),
                         time_to_capture=spread_of(tc[ok]), draws_params=_draw_record(uncertainty, params),
                         source=_source(uncertainty, draws, seed), conditions=runs[0].conditions, t_end=float(t_end),
                         tolerance=float(tolerance), hold=float(hold), reliable=bool(uncertainty.reliable),
                         notes=tuple(uncertainty.notes))

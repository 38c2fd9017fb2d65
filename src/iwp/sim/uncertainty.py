"""What a fit knows about its parameters, carried to predictions: parameter draws and prediction bands.

A fit (:func:`~iwp.ident.refinement.refine`, ``iwp fit``) estimates its free
parameters with a covariance (:mod:`iwp.ident.covariance`) and leaves
residuals of a known spread. :class:`ParameterUncertainty` keeps both with the
parameter set, in memory or in a parameter file (``iwp fit`` writes it into
``parameters.json``), so that a simulation can say how far it can be trusted:

* the **parameter band**: where the simulated output lies for parameters
  within their uncertainty -- linearised, ``var y(t) = S(t) C S(t)^T`` with
  the engine's forward sensitivities ``S = dy/dtheta``
  (:func:`~iwp.sim.sensitivity.simulate_sensitivities`), or by Monte Carlo,
  the quantiles of simulations of parameter draws run side by side
  (:func:`~iwp.sim.simulate.simulate_batch`),
  of which only the tails are kept (:class:`DrawTails`);
* the **prediction band**: the parameter band widened by the measurement
  noise, the spread of the fit's residuals per output, where a new
  measurement falls (:meth:`PredictionBand.coverage`).

Draws keep the physical signs (:data:`iwp.models.parameters.PARAMETER_INFO`):
a draw with a negative friction or inertia ratio is drawn again.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np
from scipy import stats

from ..errors import GoalNotReached, InputError
from ..files import json_float, read_json
from ..jit import jit
from ..models.parameters import PARAMETER_INFO, BeltParameters, LumpedParameters, load_params, stored_belt
from ..models.plant import Plant
from ..threads import fit_threads, thread_map
from .inputs import Input
from .options import BatchOptions, SimOptions, Tolerances
from .sensitivity import simulate_sensitivities
from .simulate import output_times, simulate_batch

__all__ = ["BandOptions", "ParameterUncertainty", "PredictionBand", "StartUncertainty", "identified_names",
           "undetermined", "prediction_band", "uncertainty_record", "load_uncertainty", "DrawTails", "BAND_METHODS",
           "BAND_CHUNK", "BAND_QUANTILES", "SIGNAL_INDEX"]

#: How a band is computed: linearised with the sensitivities, or by Monte Carlo draws.
BAND_METHODS = ("linear", "monte-carlo")
#: The column of each signal in a band's state arrays: ``q1, q2`` [rad], ``q3, q4`` [rad/s].
SIGNAL_INDEX = {"q1": 0, "q2": 1, "q3": 2, "q4": 3}
#: most draws of one Monte Carlo band
MAX_DRAWS = 100_000
#: fewest share of physical draws (the rest drawn again) before the estimate counts as too uncertain to draw from
MIN_ACCEPTED = 0.05
#: the normal quantile of the two-sided 95 % intervals :meth:`ParameterUncertainty.identified` reads
Z95 = 1.959963984540054
#: how the note on the parameters :meth:`ParameterUncertainty.identified_only` held begins
HELD_NOTE = "held at their estimates"
#: the note of :meth:`ParameterUncertainty.with_priors`
PRIOR_NOTE = "held at a prior the logs did not refine, uncertain by its spread"


@dataclass(frozen=True, eq=False)
class ParameterUncertainty:
    """A parameter set and the covariance of its free parameters, as a fit left them.

    Parameters
    ----------
    params : LumpedParameters
        The estimates (and the fixed values).
    free : tuple of str
        The free parameters, in the order of ``covariance``: lumped ones, and the belt's (15) when ``belt`` is given.
    covariance : ndarray, shape (len(free), len(free))
        Their covariance [units of the parameters squared].
    noise : dict of str to float
        Measurement noise per output, the spread of the fit's residuals [rad, rad/s].
    method : str
        How the covariance was formed (:class:`~iwp.ident.covariance.Covariance`).
    reliable : bool
        False where the fit said its intervals cannot be read as they are.
    notes : list of str
        The fit's verdict on its intervals.
    belt : BeltParameters, optional
        The belt (15) of a fit with it (its estimates; ``iwp fit --belt``), whose parameters may be among ``free``.
    """

    params: LumpedParameters
    free: tuple[str, ...]
    covariance: np.ndarray
    noise: Mapping[str, float] = field(default_factory=dict)
    method: str = ""
    reliable: bool = True
    notes: Sequence[str] = ()
    belt: BeltParameters | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.params, LumpedParameters):
            raise InputError(f"params must be LumpedParameters, got {type(self.params).__name__}")
        if self.belt is not None and not isinstance(self.belt, BeltParameters):
            raise InputError(f"belt must be BeltParameters, got {type(self.belt).__name__}")
        free = tuple(self.free)
        for n in free:
            owner = PARAMETER_INFO[n].owner if n in PARAMETER_INFO else None
            if owner == "belt" and self.belt is None:
                raise InputError(f"belt parameter {n!r} in the covariance of a fit without the belt (15)")
            if owner not in ("lumped", "belt"):
                raise InputError(f"unknown lumped parameter {n!r} in the covariance")
        C = np.asarray(self.covariance, dtype=float)
        if C.shape != (len(free), len(free)):
            raise InputError(f"the covariance must be {len(free)} x {len(free)}, got {C.shape}")
        if not np.all(np.isfinite(C)):
            raise InputError("the covariance has NaN or inf: the fit did not determine every free parameter "
                             "(fix the parameters the data cannot tell apart and fit again)")
        if C.size and np.min(np.linalg.eigvalsh(0.5 * (C + C.T))) < -1e-9 * max(np.max(np.abs(np.diag(C))), 1e-300):
            raise InputError("the covariance is not positive semi-definite")
        object.__setattr__(self, "free", free)
        object.__setattr__(self, "covariance", 0.5 * (C + C.T))

    @classmethod
    def from_refinement(cls, r) -> "ParameterUncertainty":
        """From a :class:`~iwp.ident.refinement.RefineResult` (or an ``iwp fit`` result's ``.refinement``)."""
        rel = r.reliability
        return cls(r.params, tuple(r.free), np.asarray(r.covariance, dtype=float), dict(r.residual_std),
                   "" if rel is None else rel.method, True if rel is None else rel.reliable,
                   () if rel is None else tuple(rel.notes), r.belt)

    def value(self, name: str) -> float:
        """The estimate of parameter ``name`` (lumped, or the belt's) [its unit]."""
        owner = self.belt if PARAMETER_INFO[name].owner == "belt" else self.params
        return float(getattr(owner, name))

    @property
    def belt_free(self) -> tuple[str, ...]:
        """The free parameters that are the belt's (15)."""
        return tuple(n for n in self.free if PARAMETER_INFO[n].owner == "belt")

    @property
    def values(self) -> dict[str, float]:
        """The free parameters' estimates, by name."""
        return {n: self.value(n) for n in self.free}

    def plant(self, plant: Plant) -> Plant:
        """``plant`` with these estimates: its lumped parameters, and its belt for a fit with the belt (15).

        Raises
        ------
        InputError
            The belt's parameters are uncertain and ``plant``'s model has no belt (a rigid model would drop them).
        """
        base = plant.with_params(self.params)
        if base.belt is None:
            if self.belt_free:
                raise InputError(f"the fit's belt (15) is uncertain ({', '.join(self.belt_free)}) and model "
                                 f"{plant.model!r} has none: simulate a model with the belt (belt-full) for its band")
            return base
        return base if self.belt is None else base.replace(belt=self.belt)

    @property
    def stderr(self) -> dict[str, float]:
        """Standard error of each free parameter."""
        return {n: float(math.sqrt(max(self.covariance[i, i], 0.0))) for i, n in enumerate(self.free)}

    def identified(self) -> tuple[str, ...]:
        """The free parameters the fit's logs identify: their 95 % interval, ``value +- 1.96`` standard errors,
        lies inside the physical range (:meth:`~iwp.models.parameter_info.ParameterInfo.default_bounds`; for a
        signed parameter, on one side of 0). An interval that reaches past it (a friction estimated at
        ``1e-6 +- 2``, a term the logs barely excite) says the logs cannot tell the value from none."""
        return identified_names(self.values, self.stderr)

    def with_priors(self, spreads: Mapping[str, float]) -> "ParameterUncertainty":
        """This uncertainty with parameters a fit held at a prior taken in as uncertain by their prior's spread.

        A friction the logs do not identify is held at a prior (Table 1's value on another rig); its
        value is then a guess, and a prediction band that treats it as exact is too narrow where it
        acts (the decay of a swing). Each is appended to :attr:`free` at its value in :attr:`params`,
        with variance ``spread^2`` and no covariance with the others: the free parameters'
        re-adjustment to another prior is left out (on the README's 20 s chirp, holding sigma_v1 at
        0 or at twice Table 1's value moved p1, p2, p3, rho by a tenth of their standard errors).

        Parameters
        ----------
        spreads : mapping of str to float
            Held parameter -> the standard deviation of its prior [its unit] (> 0); one already free is refused.

        Returns
        -------
        ParameterUncertainty

        Raises
        ------
        InputError
            A name that is free already, or a spread that is not finite and > 0.

        Examples
        --------
        >>> import numpy as np
        >>> from iwp.models import table1
        >>> from iwp.sim.uncertainty import ParameterUncertainty
        >>> u = ParameterUncertainty(table1(), ("p1",), np.array([[0.01]]))
        >>> w = u.with_priors({"sigma_v1": 0.01})
        >>> w.free, w.stderr["sigma_v1"]
        (('p1', 'sigma_v1'), 0.01)
        """
        extra = tuple(spreads)
        if not extra:
            return self
        for n in extra:
            if n in self.free:
                raise InputError(f"{n} is free in the fit already: its uncertainty is the fit's, not a prior's")
            sd = spreads[n]
            if isinstance(sd, bool) or not isinstance(sd, (int, float)) or not (math.isfinite(sd) and sd > 0):
                raise InputError(f"the prior spread of {n} must be a finite number > 0, got {sd!r}")
        k = len(self.free)
        C = np.zeros((k + len(extra), k + len(extra)))
        C[:k, :k] = self.covariance
        C[k:, k:] = np.diag([float(spreads[n]) ** 2 for n in extra])
        note = f"{PRIOR_NOTE}: " + ", ".join(f"{n} {self.value(n):.3g} +- {spreads[n]:.2g}"
                                              for n in extra)
        return dataclasses.replace(self, free=(*self.free, *extra), covariance=C, notes=(*self.notes, note))

    def identified_only(self) -> "ParameterUncertainty":
        """This uncertainty with the parameters the logs do not identify (:meth:`identified`) held at their
        estimates: the others keep their marginal covariance, and a note names the held ones. What a design drawn
        over a fit's uncertainty uses (:mod:`iwp.control.robust`): drawing an unidentified friction from an
        interval that spans both signs makes half the draws unphysical and says nothing about the rig."""
        keep = self.identified()
        held = [n for n in self.free if n not in keep]
        if not held:
            return self
        idx = [self.free.index(n) for n in keep]
        note = (f"{HELD_NOTE}, as the fit's logs do not identify them (their 95 % interval reaches past the "
                f"physical range): {', '.join(held)}")
        return dataclasses.replace(self, free=keep, covariance=self.covariance[np.ix_(idx, idx)],
                                   notes=(*self.notes, note))

    def draws(self, n: int, seed: int = 0) -> list[LumpedParameters]:
        """``n`` parameter sets drawn from the normal distribution of the estimates, physical signs kept.

        A draw outside the physical range of :data:`~iwp.models.parameters.PARAMETER_INFO`
        (a negative friction, a non-positive inertia ratio) is drawn again (the
        normal distribution truncated to the physical range, correlations kept);
        when fewer than :data:`MIN_ACCEPTED` of the draws are physical, the
        estimate is too uncertain to draw from and an error says so. The lumped
        parameters only: a fit whose belt (15) is uncertain draws whole plants (:meth:`plants`).
        """
        if self.belt_free:
            raise InputError(f"the belt's {', '.join(self.belt_free)} are uncertain too: draw plants "
                             "(ParameterUncertainty.plants), not lumped parameter sets")
        return [self.params.replace(**row) for row in self.draw_values(n, seed)]

    def plants(self, plant: Plant, n: int, seed: int = 0) -> list[Plant]:
        """``n`` plants like ``plant`` with parameters drawn as :meth:`draws` has them, the belt's (15) included.

        Parameters
        ----------
        plant : Plant
            The model and options; its parameters (and belt) are this uncertainty's, then the draws'.
        n : int
            Number of draws, 1 to :data:`MAX_DRAWS`.
        seed : int
            Of the random draws.

        Returns
        -------
        list of Plant
        """
        base = self.plant(plant)
        return [base.with_values(row) for row in self.draw_values(n, seed)]

    def draw_values(self, n: int, seed: int = 0) -> list[dict[str, float]]:
        """``n`` draws of the free parameters' values (:meth:`draws`), by name."""
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_DRAWS:
            raise InputError(f"draws must be an integer from 1 to {MAX_DRAWS}, got {n!r}")
        rng = np.random.default_rng(seed)
        mean = np.array([self.value(k) for k in self.free])
        lo = np.array([PARAMETER_INFO[k].default_bounds()[0] for k in self.free])
        out: list[np.ndarray] = []
        tries = accepted = 0
        while len(out) < n:
            m = 4 * (n - len(out)) + 64
            # the covariance was checked positive semi-definite to rounding (__post_init__)
            z = rng.multivariate_normal(mean, self.covariance, size=m, method="eigh", check_valid="ignore") \
                if self.free else np.zeros((m, 0))
            ok = np.all(z >= lo, axis=1) if self.free else np.ones(m, dtype=bool)
            out.extend(z[ok][: n - len(out)])
            tries += m
            accepted += int(np.count_nonzero(ok))
            if tries >= 20 * n + 256 and accepted < MIN_ACCEPTED * tries:
                below = np.mean(z < lo, axis=0)
                worst = ", ".join(f"{k} in {100 * b:.0f} %" for k, b in
                                  sorted(zip(self.free, below), key=lambda kb: -kb[1]) if b > MIN_ACCEPTED)
                raise GoalNotReached(f"only {100 * accepted / tries:.1f} % of the parameter draws are physical "
                                     f"(outside the physical range: {worst}): the estimates are too uncertain to draw "
                                     "from; hold the parameters the logs do not determine (iwp fit --fix NAME=VALUE) "
                                     "and fit again")
        return [dict(zip(self.free, (float(v) for v in row))) for row in out]


def identified_names(values: Mapping[str, float], stderr: Mapping[str, float]) -> tuple[str, ...]:
    """The parameters of ``values`` that their estimates identify: ``value +- 1.96 stderr`` (:data:`Z95`) inside
    the physical range (:meth:`~iwp.models.parameter_info.ParameterInfo.default_bounds`; a signed parameter: on one
    side of 0). A NaN or infinite standard error identifies nothing.

    Parameters
    ----------
    values : mapping of str to float
        Estimates, by the names of :data:`~iwp.models.parameters.PARAMETER_INFO`.
    stderr : mapping of str to float
        Their standard errors, same names and units.

    Returns
    -------
    tuple of str
        The names identified, in the order of ``values``.
    """
    out = []
    for n, value in values.items():
        lo = PARAMETER_INFO[n].default_bounds()[0]
        margin = value - lo if math.isfinite(lo) else abs(value)
        if Z95 * stderr[n] < margin:
            out.append(n)
    return tuple(out)


#: an estimate whose 95 % interval is more than this many times wider than its distance to its physical bound is
#: undetermined (:func:`undetermined`): at the bound, or ``1e-7 +- 230`` where two terms cannot be told apart
UNDETERMINED_RATIO = 100.0


def undetermined(name: str, value: float, stderr: float) -> bool:
    """Whether an estimate says nothing of parameter ``name``: its 95 % half-width ``1.96 stderr`` is more than
    :data:`UNDETERMINED_RATIO` times its distance to the lower end of the physical range (an estimate at that end, or
    beyond it), or its standard error is not finite. What a fit holds at a prior; an estimate that is merely not
    identified (its interval reaching the bound, :func:`identified_names`) keeps its value and interval.

    Parameters
    ----------
    name : str
        A parameter of :data:`~iwp.models.parameters.PARAMETER_INFO`.
    value, stderr : float
        The estimate and its standard error [the parameter's unit].

    Returns
    -------
    bool
    """
    lo = PARAMETER_INFO[name].default_bounds()[0]
    margin = value - lo if math.isfinite(lo) else abs(value)
    return not (math.isfinite(stderr) and margin * UNDETERMINED_RATIO > Z95 * stderr)


def uncertainty_record(r, priors: Mapping[str, float] | None = None) -> dict[str, Any]:
    """The JSON record of a fit's uncertainty (stored in ``parameters.json`` by ``iwp fit``).

    Parameters
    ----------
    r : RefineResult
        A simulation-error fit (:func:`iwp.ident.refinement.refine`, :func:`iwp.ident.logfit.fit_logs`'s
        refinement): its free parameters, covariance, residual standard deviations and reliability.
    priors : mapping of str to float, optional
        Parameters the fit held at a prior, with the prior's spread (:meth:`ParameterUncertainty.with_priors`):
        recorded as uncertain by it.

    Returns
    -------
    dict
        ``free`` (names), ``matrix`` (the covariance, JSON numbers, NaN as null), ``noise`` (residual standard
        deviation per output, in its unit), ``method``, ``reliable`` and ``notes`` of the reliability verdict;
        :func:`load_uncertainty` reads it back.
    """
    finite = bool(np.all(np.isfinite(r.covariance)))
    free, matrix = list(r.free), np.asarray(r.covariance)
    notes = [] if r.reliability is None else list(r.reliability.notes)
    u = ParameterUncertainty.from_refinement(r) if finite else None
    reliable = bool(u.reliable) if u is not None else False
    if u is not None and priors:
        u = u.with_priors(priors)
        free, matrix, notes = list(u.free), u.covariance, list(u.notes)
    return {"free": free, "matrix": [[json_float(v) for v in row] for row in matrix],
            "noise": {k: json_float(v) for k, v in r.residual_std.items()},
            "method": "" if r.reliability is None else r.reliability.method,
            "reliable": reliable,
            "notes": notes}


def load_uncertainty(path, *, argument: str = "params") -> ParameterUncertainty:
    """The parameter set and its uncertainty from a parameter file written by ``iwp fit`` (its ``covariance``).

    Parameters
    ----------
    path : str or PathLike
        The ``parameters.json`` of ``iwp fit``.
    argument : str
        The argument named in errors (a flag of the command line).

    Returns
    -------
    ParameterUncertainty
        The parameters (Table 1's units), the belt (15) of a fit with it, and their covariance.

    Raises
    ------
    InputError
        Naming the file when it holds no covariance (a parameter set alone:
        Table 1, ``iwp identify --out``).
    """
    params = load_params(path)
    if not isinstance(params, LumpedParameters):
        raise InputError(f"{path}: a band needs lumped parameters", argument=argument)
    doc = read_json(path) if not str(path) == "table1" else {}
    belt = stored_belt(path)
    rec = doc.get("covariance") if isinstance(doc, dict) else None
    if not isinstance(rec, dict):
        raise InputError(f"{path}: holds no covariance of its parameters; bands and parameter draws need the "
                         "parameters.json that iwp fit writes", argument=argument)
    try:
        free = tuple(str(n) for n in rec["free"])
        C = np.array(rec["matrix"], dtype=float)
        noise = {str(k): float(v) for k, v in (rec.get("noise") or {}).items() if v is not None}
    except (KeyError, TypeError, ValueError):
        raise InputError(f"{path}: its 'covariance' entry is malformed (needs 'free' and 'matrix')",
                         argument=argument) from None
    try:
        return ParameterUncertainty(params, free, C, noise, str(rec.get("method", "")), bool(rec.get("reliable", True)),
                                    tuple(rec.get("notes") or ()), belt)
    except InputError as exc:
        raise InputError(f"{path}: {exc}", argument=argument) from None


@dataclass(frozen=True, eq=False)
class PredictionBand:
    """Where a simulation's outputs lie for parameters within their uncertainty (and new measurements, too).

    Attributes
    ----------
    t : ndarray
        Sample times [s].
    nominal : dict of str to ndarray
        The simulation with the estimates, per signal.
    lower, upper : dict of str to ndarray
        The parameter band: outputs for parameters within their uncertainty.
    pred_lower, pred_upper : dict of str to ndarray
        The prediction band: the parameter band widened by the measurement noise.
    method : str
        ``"linear"`` or ``"monte-carlo"``.
    level : float
        Probability the band holds (0.95).
    draws : int
        Simulations of a Monte Carlo band (0 for the linear one).
    """

    t: np.ndarray
    nominal: dict[str, np.ndarray]
    lower: dict[str, np.ndarray]
    upper: dict[str, np.ndarray]
    pred_lower: dict[str, np.ndarray]
    pred_upper: dict[str, np.ndarray]
    method: str
    level: float
    draws: int = 0

    @property
    def signals(self) -> tuple[str, ...]:
        return tuple(self.nominal)

    def coverage(self, measured: Mapping[str, np.ndarray], used: Mapping[str, np.ndarray] | None = None
                 ) -> dict[str, float]:
        """Per signal, the fraction of the measured samples inside the prediction band (``used``: a mask)."""
        out = {}
        for s, y in measured.items():
            if s not in self.nominal:
                continue
            y = np.asarray(y, dtype=float)
            m = np.ones(y.size, dtype=bool) if used is None or s not in used else np.asarray(used[s], dtype=bool)
            inside = (y >= self.pred_lower[s]) & (y <= self.pred_upper[s])
            out[s] = float(np.mean(inside[m])) if np.any(m) else float("nan")
        return out

    def columns(self) -> dict[str, np.ndarray]:
        """The band as log columns: ``<signal>_lo``/``_hi`` (parameter band), ``<signal>_plo``/``_phi`` (prediction)."""
        out = {}
        for s in self.signals:
            out[f"{s}_lo"], out[f"{s}_hi"] = self.lower[s], self.upper[s]
            out[f"{s}_plo"], out[f"{s}_phi"] = self.pred_lower[s], self.pred_upper[s]
        return out


#: The draws a Monte Carlo band simulates side by side at a time. Their samples are held in memory: 64 x 60,001
#: x 4 states is 123 MB, where all 1,000 draws of a 300 s log at 5 ms would be 1.9 GB.
BAND_CHUNK = 64
#: The quantiles of the 95 % band (2.5 % and 97.5 %).
BAND_QUANTILES = (0.025, 0.975)
#: the tolerances of a Monte Carlo band's draws and nominal run
DRAW_TOLERANCES = Tolerances(rtol=1e-8, atol=1e-8)


@jit
def keep_tails(low, neg_high, last, n_kept, Yt):
    """Merge the values ``Yt[i, :]`` into the ascending ``k`` smallest so far of each row ``low[i]`` and the
    ascending ``k`` smallest of their negatives (the largest values) of each row ``neg_high[i]``.

    Draw by draw (the columns of ``Yt``) and time by time, each value is read
    once and compared with the largest value kept on each side, ``last[:, i]``;
    when it beats one, it is put in its place in that sorted row (insertion),
    so that most values of many draws cost two comparisons with an array that
    stays in cache. NaN counts as larger than any number (as in
    :func:`numpy.sort`).

    Parameters
    ----------
    low, neg_high : ndarray, shape (n_times, k_low), (n_times, k_high)
        Per time, the smallest values and the negated largest values so far, each ascending (the first
        ``min(n_kept, k)`` columns).
    last : ndarray, shape (2, n_times)
        ``low[:, k_low - 1]`` and ``neg_high[:, k_high - 1]`` once the rows are full (written here).
    n_kept : int
        The draws merged before this call.
    Yt : ndarray, shape (n_times, m)
        The new values at each time (rows) of ``m`` draws (columns); any strides.
    """
    k_lo = low.shape[1]
    k_hi = neg_high.shape[1]
    for j in range(Yt.shape[1]):
        c = n_kept + j
        if c < k_lo or c < k_hi:
            # a side whose rows are not full yet takes every value
            for i in range(Yt.shape[0]):
                v = Yt[i, j]
                _merge_one(low, last, 0, i, c, k_lo, v)
                _merge_one(neg_high, last, 1, i, c, k_hi, -v)
            continue
        # both sides full (most draws): _merge_one's test written out, the thresholds loaded once (through the
        # helpers, numba's inlining left this loop twice as slow: 1.7 s against 0.8 s for a 1,000-draw band)
        for i in range(Yt.shape[0]):
            v = Yt[i, j]
            lo = last[0, i]
            if v < lo or (lo != lo and v == v):
                _insert_sorted(low, i, k_lo - 1, v)
                last[0, i] = low[i, k_lo - 1]
            w = -v
            hi = last[1, i]
            if w < hi or (hi != hi and w == w):
                _insert_sorted(neg_high, i, k_hi - 1, w)
                last[1, i] = neg_high[i, k_hi - 1]


@jit(inline=True)
def _merge_one(kept, last, side, i, c, k, v):
    """Merge ``v`` into the row ``kept[i]`` holding ``min(c, k)`` values (the filling draws)."""
    if c < k:
        _insert_sorted(kept, i, c, v)
        if c == k - 1:
            last[side, i] = kept[i, k - 1]
    elif v < last[side, i] or (last[side, i] != last[side, i] and v == v):
        _insert_sorted(kept, i, k - 1, v)
        last[side, i] = kept[i, k - 1]


@jit(inline=True)
def _insert_sorted(kept, i, pos, v):
    """Put ``v`` into the ascending ``kept[i, :pos + 1]`` whose slot ``pos`` is free (NaN the largest)."""
    while pos > 0 and (v < kept[i, pos - 1] or (kept[i, pos - 1] != kept[i, pos - 1] and v == v)):
        kept[i, pos] = kept[i, pos - 1]
        pos -= 1
    kept[i, pos] = v


#: the fewest values (times x draws) of a chunk :class:`DrawTails` splits over the threads; a smaller one is merged
#: in the calling thread (a thread pool's hand-over costs about 10 ms on a loaded 2-core machine: 600 chunks of 5
#: draws at 7 times took 5.7 s through it)
TAILS_SPLIT_SIZE = 1 << 16


class DrawTails:
    """The quantiles of many draws of a signal at each time, from only the draws' tails.

    A quantile ``q`` of ``n`` values (numpy's default, linear interpolation)
    needs only the order statistics around position ``(n - 1) q``: for the
    2.5 % quantile of 1,000 draws, the 26 smallest values. At every time the
    ``k`` smallest and the ``k`` largest values so far are kept in order, and
    each chunk of draws is merged into them (:func:`keep_tails`, in slices
    of the times on all cores), so that memory holds ``2 k`` values per time,
    not all the draws; the quantiles are then exactly :func:`numpy.quantile`'s
    over all the draws.

    Parameters
    ----------
    draws : int
        The most draws that will be added (the tails kept are long enough for the quantiles of that many).
    quantiles : tuple of float
        Probabilities in (0, 0.5] and [0.5, 1): a lower and an upper quantile.
    """

    def __init__(self, draws: int, quantiles: tuple[float, float]):
        if isinstance(draws, bool) or not isinstance(draws, (int, np.integer)) or draws < 1:
            raise InputError(f"draws must be a positive integer, got {draws!r}", argument="draws")
        self.probabilities = tuple(float(q) for q in quantiles)
        lo, hi = (self.probabilities + (math.nan, math.nan))[:2]
        if len(self.probabilities) != 2 or not (0.0 <= lo <= 0.5 <= hi <= 1.0):
            raise InputError(f"quantiles must be a lower one in [0, 0.5] and an upper one in [0.5, 1], got "
                             f"{', '.join(f'{q:g}' for q in self.probabilities)}", argument="quantiles")
        self.k_low = min(int(math.floor((draws - 1) * lo)) + 2, int(draws))
        self.k_high = min(int(math.floor((draws - 1) * (1.0 - hi))) + 2, int(draws))
        # time-major, ascending: the smallest values, and the largest negated
        self._low: np.ndarray | None = None
        self._neg_high: np.ndarray | None = None
        self._last: np.ndarray | None = None  # per time, the largest value kept on each side
        self.n = 0

    def add(self, Y: np.ndarray) -> None:
        """Merge a chunk of draws.

        Parameters
        ----------
        Y : array_like, shape (m, n_times)
            The signal of ``m`` draws (rows) at each time (columns), in the signal's unit.
        """
        Y = np.asarray(Y, dtype=float)
        if Y.ndim != 2:
            raise InputError(f"draws must be a (draws, times) array, got shape {Y.shape}", argument="Y")
        self.add_time_major(Y.T)

    def add_time_major(self, Yt: np.ndarray) -> None:
        """Merge a chunk of draws given time-major (the cheaper layout: no transposition).

        Parameters
        ----------
        Yt : array_like, shape (n_times, m)
            The signal at each time (rows) of ``m`` draws (columns), in the signal's unit.
        """
        Yt = np.asarray(Yt, dtype=float)
        if Yt.ndim != 2 or (self._low is not None and Yt.shape[0] != self._low.shape[0]):
            raise InputError(f"draws must be a (draws, times) array with the times of the draws before, got shape "
                             f"{Yt.shape[::-1]}", argument="Y")
        m = Yt.shape[1]
        if m == 0:
            return
        if self._low is None or self._neg_high is None or self._last is None:
            self._low = np.empty((Yt.shape[0], self.k_low))
            self._neg_high = np.empty((Yt.shape[0], self.k_high))
            self._last = np.empty((2, Yt.shape[0]))
        low, neg, last = self._low, self._neg_high, self._last

        def merge(part: tuple[int, int]) -> None:
            a, b = part
            keep_tails(low[a:b], neg[a:b], last[:, a:b], self.n, Yt[a:b])

        if Yt.size < TAILS_SPLIT_SIZE:  # a small chunk: handing it to the threads costs more than merging it
            merge((0, Yt.shape[0]))
        else:
            edges = np.linspace(0, Yt.shape[0], fit_threads() + 1).astype(int)
            thread_map(merge, [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a])
        self.n += m

    def quantiles(self) -> tuple[np.ndarray, np.ndarray]:
        """The lower and upper quantile at each time over the draws added.

        Returns
        -------
        lower, upper : ndarray, shape (n_times,)
            :func:`numpy.quantile` (linear) of all the draws added, at the two probabilities.
        """
        if self.n == 0 or self._low is None or self._neg_high is None:
            raise InputError("no draws to take quantiles of")
        n = self.n
        low = self._low[:, :min(self.k_low, n)].T
        high = (-self._neg_high[:, :min(self.k_high, n)][:, ::-1]).T  # ascending: the largest last
        # the ascending order statistics x[j] of all n draws: the low tail holds x[0..], the high tail x[n - m..]
        return (_linear_quantile(low, 0, (n - 1) * self.probabilities[0]),
                _linear_quantile(high, n - high.shape[0], (n - 1) * self.probabilities[1]))


def _linear_quantile(tail: np.ndarray, first: int, h: float) -> np.ndarray:
    """numpy's linear quantile at position ``h`` of the ascending order, from the sorted order statistics
    ``x[first], x[first + 1], ...`` (the rows of ``tail``)."""
    j = int(math.floor(h))
    g = h - j
    a = tail[j - first]
    b = tail[min(j + 1 - first, tail.shape[0] - 1)]
    d = b - a
    # numpy's lerp to the bit: from the nearer end
    return b - d * (1.0 - g) if g >= 0.5 else a + d * g


@dataclass(frozen=True)
class BandOptions:
    """How :func:`prediction_band` computes the parameter band.

    Parameters
    ----------
    method : {"linear", "monte-carlo"}
        ``"linear"``: ``var y(t) = S(t) C S(t)^T`` from the forward
        sensitivities, normal quantiles; ``"monte-carlo"``: the 2.5 and 97.5 %
        quantiles over ``draws`` simulations of parameter draws, on all cores.
    draws : int
        Simulations of a Monte Carlo band [-], 1 to :data:`MAX_DRAWS`.
    seed : int
        Of the Monte Carlo band's random draws (the parameters; the initial
        states with ``seed + 1``).
    """

    method: str = "linear"
    draws: int = 1000
    seed: int = 0

    def __post_init__(self) -> None:
        if self.method not in BAND_METHODS:
            raise InputError(f"band method must be one of {', '.join(BAND_METHODS)}, got {self.method!r}",
                             argument="band")
        d = self.draws
        if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or not 1 <= d <= MAX_DRAWS:
            raise InputError(f"draws must be an integer from 1 to {MAX_DRAWS}, got {d!r}", argument="draws")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise InputError(f"seed must be a non-negative integer, got {self.seed!r}", argument="seed")


@dataclass(frozen=True, eq=False)
class StartUncertainty:
    """What is uncertain about where a simulated log starts: its measured state, and its angle's zero.

    Parameters
    ----------
    covariance : array_like, shape (4, 4), optional
        The covariance of the measured initial state ``[q1, q2, q3, q4]``
        (:func:`iwp.ident.output_error.measured_state_covariance`) [rad, rad/s squared]; None: exact.
    zero_variance : float
        The variance of the zero of the logged pendulum angle [rad^2]: the
        log's ``q1`` is the model's plus an unknown constant ``d`` (where the
        run zeroed its encoder, known to within a count:
        :class:`iwp.models.EncoderZero`), which moves the measured initial
        angle and every sample alike. A band about a simulation started from
        ``x0 = q1(0) + d`` then spreads by ``(1 - dq1(t)/dq1(0)) d`` in ``q1``
        and ``dq(t)/dq1(0) d`` in the other signals (a hanging pendulum's
        misplaced start swings about the true rest, while the log sits ``d``
        off it). Default 0 (a known zero).

    Raises
    ------
    InputError
        ``covariance`` not a finite 4 x 4 matrix, ``zero_variance`` not finite and >= 0.
    """

    covariance: np.ndarray | None = None
    zero_variance: float = 0.0

    def __post_init__(self) -> None:
        if self.covariance is not None:
            C0 = np.asarray(self.covariance, dtype=float)
            if C0.ndim != 2 or C0.shape[0] < 4 or C0.shape[1] < 4 or not np.all(np.isfinite(C0[:4, :4])):
                raise InputError("start.covariance must be a finite 4 x 4 matrix", argument="covariance")
            object.__setattr__(self, "covariance", C0[:4, :4].copy())
        v = self.zero_variance
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v >= 0.0):
            raise InputError(f"zero_variance must be a finite number >= 0 [rad^2], got {v!r}",
                             argument="zero_variance")
        object.__setattr__(self, "zero_variance", float(v))


def prediction_band(
    plant: Plant,
    uncertainty: ParameterUncertainty,
    *,
    input: Input | None = None,
    x0=None,
    t_eval=None,
    signals: Sequence[str] = ("q1", "q4"),
    start: StartUncertainty | None = None,
    options: BandOptions | None = None,
) -> PredictionBand:
    """The 95 % parameter and prediction bands of a simulation of ``plant`` with the fit's ``uncertainty``.

    Parameters
    ----------
    plant : Plant
        The model; its parameters are replaced by ``uncertainty.params`` (and its belt by ``uncertainty.belt``).
    uncertainty : ParameterUncertainty
        The fit's estimates, their covariance and the measurement noise per output.
    input : Input, optional
        As for :func:`~iwp.sim.simulate.simulate` (a log's input replayed: :class:`~iwp.sim.inputs.Sampled`).
    x0 : array_like, optional
        Initial state [rad, rad, rad/s, rad/s] (default rest).
    t_eval : array_like
        Output times [s] (starting at the initial time).
    signals : sequence of str
        Among ``q1, q2, q3, q4``.
    start : StartUncertainty, optional
        The uncertainty of a measured initial state and of the logged
        angle's zero, carried into the parameter band as well (default none:
        a known start).
    options : BandOptions, optional
        How the band is computed: linearised (default) or by Monte Carlo, with its draws and seed.

    Returns
    -------
    PredictionBand

    Raises
    ------
    InputError
        An argument of the wrong type or value; a Monte Carlo band of which fewer than half the draws simulate.
    """
    if options is None:
        options = BandOptions()
    if not isinstance(options, BandOptions):
        raise InputError(f"options must be an iwp.sim.uncertainty.BandOptions, got {type(options).__name__}",
                         argument="options")
    if not isinstance(plant, Plant):
        raise InputError(f"plant must be a Plant, got {type(plant).__name__}")
    signals = tuple(signals)
    for s in signals:
        if s not in SIGNAL_INDEX:
            raise InputError(f"unknown signal {s!r}; choose among q1, q2, q3, q4")
    if t_eval is None:
        raise InputError("give t_eval, the output times of the band")
    t = output_times(float(np.asarray(t_eval, dtype=float).ravel()[0]),
                     float(np.asarray(t_eval, dtype=float).ravel()[-1]), 0.005, t_eval)
    base = uncertainty.plant(plant)
    z = float(stats.norm.ppf(0.975))
    if start is None:
        start = StartUncertainty()
    if not isinstance(start, StartUncertainty):
        raise InputError(f"start must be an iwp.sim.uncertainty.StartUncertainty, got {type(start).__name__}",
                         argument="start")
    run = _BandRun(base, uncertainty, input, x0, t, signals, start.covariance, start.zero_variance)
    if options.method == "linear":
        nominal, lower, upper, half = _linear_band(run, z)
        n_draws = 0
    else:
        nominal, lower, upper, half, n_draws = _monte_carlo_band(run, options)
    pred_lower, pred_upper = {}, {}
    for s in signals:
        noise = float(uncertainty.noise.get(s, 0.0))
        # the parameters' band and the noise, independent: the half-widths add in quadrature
        ph = np.sqrt(half[s] ** 2 + (z * noise) ** 2)
        mid = 0.5 * (lower[s] + upper[s])
        pred_lower[s], pred_upper[s] = mid - ph, mid + ph
    return PredictionBand(t, nominal, lower, upper, pred_lower, pred_upper, options.method, 0.95, n_draws)


class _BandRun(NamedTuple):
    """A band's checked arguments."""

    plant: Plant  # with the estimates
    uncertainty: ParameterUncertainty
    input: Input | None
    x0: Any  # initial state [rad, rad/s] or None
    t: np.ndarray  # output times [s]
    signals: tuple[str, ...]
    C0: np.ndarray | None  # covariance of the initial state, 4 x 4
    zero_variance: float  # variance of the logged angle's zero [rad^2]


def _linear_band(run: _BandRun, z: float) -> tuple[dict, dict, dict, dict]:
    """The nominal outputs, the linearised band's lower and upper edges and half-widths, per signal."""
    C0, t, signals = run.C0, run.t, run.signals
    states = () if C0 is None else tuple(i for i in range(4) if C0[i, i] > 0)
    zero = run.zero_variance > 0.0
    if zero and 0 not in states:
        states = (0, *states)
    r = simulate_sensitivities(run.plant, t_eval=t, t0=float(t[0]), x0=run.x0, input=run.input,
                               wrt=run.uncertainty.free, wrt_x0=states)
    k = len(run.uncertainty.free)
    m = k + len(states) + (1 if zero else 0)
    C = np.zeros((m, m))
    C[:k, :k] = run.uncertainty.covariance
    if C0 is not None and states:
        C[k:k + len(states), k:k + len(states)] = C0[np.ix_(states, states)]
    if zero:
        C[-1, -1] = run.zero_variance
    nominal = {s: r.x[:, SIGNAL_INDEX[s]] for s in signals}
    half = {}
    for s in signals:
        S = r.S[:, SIGNAL_INDEX[s], :]
        if zero:  # the zero d: the start moved by -d, the logged angle by +d
            dz = -S[:, k + states.index(0)] + (1.0 if s == "q1" else 0.0)
            S = np.concatenate([S, dz[:, None]], axis=1)
        half[s] = z * np.sqrt(np.clip(np.einsum("ij,jk,ik->i", S, C, S), 0.0, None))
    lower = {s: nominal[s] - half[s] for s in signals}
    upper = {s: nominal[s] + half[s] for s in signals}
    return nominal, lower, upper, half


def _monte_carlo_band(run: _BandRun, options: BandOptions) -> tuple[dict, dict, dict, dict, int]:
    """The nominal outputs, the Monte Carlo band's lower and upper edges and half-widths per signal, and the draws
    that simulated."""
    base, x0, t, signals, C0 = run.plant, run.x0, run.t, run.signals, run.C0
    draws, seed = options.draws, options.seed
    plants = run.uncertainty.plants(base, draws, seed)
    x0s = x0
    moved = C0 is not None or run.zero_variance > 0.0
    zeros = np.zeros(draws)
    if moved:
        mean = np.zeros(base.n_states) if x0 is None else np.asarray(x0, dtype=float)
        rng = np.random.default_rng(seed + 1)
        dx = (np.zeros((draws, 4)) if C0 is None
              else rng.multivariate_normal(np.zeros(4), C0, size=draws, method="eigh"))
        if run.zero_variance > 0.0:  # the zero d: the start moved by -d, the logged angle by +d
            zeros = rng.normal(0.0, math.sqrt(run.zero_variance), draws)
            dx[:, 0] -= zeros
        x0s = [np.concatenate([mean[:4] + d, mean[4:]]) for d in dx]
    tails = {s: DrawTails(draws, BAND_QUANTILES) for s in signals}
    n_ok = 0
    # the draws side by side (simulate_batch: vectorised lanes where the model and input allow, single runs on
    # all cores otherwise), in chunks: memory for one chunk's samples, not all
    for a in range(0, draws, BAND_CHUNK):
        m = min(BAND_CHUNK, draws - a)
        b = simulate_batch(plants[a:a + m], x0=x0s[a:a + m] if moved else x0, t0=float(t[0]),
                           t_end=float(t[-1]), t_eval=t, input=run.input,
                           options=BatchOptions(tolerances=DRAW_TOLERANCES, inputs=False))
        good = np.flatnonzero(b.success)
        n_ok += good.size
        if good.size == 0:
            continue
        for s in signals:
            Yt = b.x[:, :, SIGNAL_INDEX[s]].T  # (times, draws): a view, merged without a copy
            Yt = Yt if good.size == m else Yt[:, good]
            if s == "q1" and run.zero_variance > 0.0:
                Yt = Yt + zeros[a:a + m][good]
            tails[s].add_time_major(Yt)
    if n_ok < max(10, draws // 2):
        raise InputError(f"{draws - n_ok} of {draws} draws failed to simulate; the band is not defined")
    X = simulate_sensitivities(base, t_eval=t, t0=float(t[0]), x0=x0, input=run.input,
                               options=SimOptions(tolerances=DRAW_TOLERANCES)).x
    nominal = {s: X[:, SIGNAL_INDEX[s]] for s in signals}
    lower, upper = {}, {}
    for s in signals:
        lower[s], upper[s] = tails[s].quantiles()
    half = {s: 0.5 * (upper[s] - lower[s]) for s in signals}
    return nominal, lower, upper, half, n_ok

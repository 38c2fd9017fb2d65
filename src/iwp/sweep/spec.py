"""What a sweep runs: :class:`SweepSpec`, its varied dimensions, and the lanes of one chunk.

A sweep is a set of closed loops of model (9) ("lanes"), or of the pendulum
with the belt (15) of a fit with it (``model="belt-full"``), each with its own
plant parameters, controller gains and initial state. The lanes are the
Cartesian product of the :class:`Grid` dimensions, times ``samples`` draws of
the random ones (:class:`Normal`, :class:`Uniform`, and the joint normal of a
fit's covariance, :class:`~iwp.sim.uncertainty.ParameterUncertainty`). Lane
``i`` is grid point ``i // samples``, draw ``i % samples``; the first grid
dimension varies slowest.

Lanes are cut into chunks of ``chunk_size``. The random values of chunk ``c``
come from ``numpy.random.SeedSequence(seed, spawn_key=(c,))`` (the ``c``-th
child of ``SeedSequence(seed).spawn``): a chunk's numbers depend on the seed,
the chunk size and the chunk's index only, not on where or in which order the
chunks run.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..checks import check_finite, check_positive
from ..errors import InputError
from ..files import read_json
from ..models.parameters import (
    BELT_INFO,
    LUMPED_INFO,
    PARAMETER_INFO,
    BeltParameters,
    LumpedParameters,
    load_params,
    stored_belt,
    stored_model,
)
from ..models.plant import MODELS, Plant
from ..sim.uncertainty import ParameterUncertainty, load_uncertainty

__all__ = ["Grid", "Normal", "Uniform", "SweepSpec", "LaneSet", "LAWS", "STATE_NAMES", "GAIN_NAMES",
           "lanes_of_chunk", "load_spec", "spec_from_dict", "MAX_LANES", "SWEEP_MODELS"]

#: The closed loops a sweep runs: the Hopf law (section 5.3) and the LQR balance at the upright.
LAWS = ("hopf", "lqr")
#: Names of the initial state's components in ``vary`` [rad, rad, rad/s, rad/s].
STATE_NAMES = ("x0.q1", "x0.q2", "x0.q3", "x0.q4")
#: Gains of the Hopf law ``u = k1 q3 + k2 q3^3`` that a sweep may vary.
GAIN_NAMES = ("k1", "k2")
#: The initial state of each law when none is given [rad, rad, rad/s, rad/s].
DEFAULT_X0 = {"hopf": (0.1, 0.0, 0.0, 0.0), "lqr": (math.pi - 0.02, 0.0, 0.0, 0.0)}
#: The models a sweep's closed loops run: driven by the ideal input ``u``, the pendulum free (model (9), and the
#: pendulum with the belt (15), ``"belt-full"``).
SWEEP_MODELS = tuple(name for name, info in MODELS.items() if info.input == "u" and not info.pendulum_locked
                     and not info.physical)
#: Most lanes of one sweep.
MAX_LANES = 100_000_000
#: Most seconds of one closed loop, and fewest output samples a lane may have.
MAX_SAMPLES_PER_LANE = 1_000_000


def _name_ok(name: str, law: str, belt: bool) -> None:
    if name in STATE_NAMES or name in LUMPED_INFO:
        return
    if name in BELT_INFO:
        if not belt:
            raise InputError(f"vary {name!r}: a parameter of the belt (15); the sweep's model has none (model "
                             "belt-full, with the parameters of a fit with the belt)", argument="vary")
        return
    if name in GAIN_NAMES:
        if law != "hopf":
            raise InputError(f"vary {name!r}: the gains k1, k2 are the Hopf law's; law is {law!r}", argument="vary")
        return
    belts = f", a belt parameter ({', '.join(BELT_INFO)})" if belt else ""
    raise InputError(f"vary {name!r}: unknown name; use a lumped parameter ({', '.join(LUMPED_INFO)}){belts}, "
                     f"{', '.join(GAIN_NAMES)} or {', '.join(STATE_NAMES)}", argument="vary")


@dataclass(frozen=True)
class Grid:
    """A dimension over given values (all lanes of the product take each value in turn).

    Parameters
    ----------
    name : str
        A lumped parameter (``p1`` ...), a gain (``k1``, ``k2``) or an initial state (``x0.q1`` ...).
    values : sequence of float
        In the name's unit.
    """

    name: str
    values: tuple[float, ...]

    def __post_init__(self) -> None:
        vals = tuple(check_finite(f"vary {self.name!r} value", v) for v in np.ravel(np.asarray(self.values, object)))
        if not vals:
            raise InputError(f"vary {self.name!r}: the grid has no values", argument="vary")
        object.__setattr__(self, "values", vals)

    def to_dict(self) -> dict:
        return {"grid": list(self.values)}


@dataclass(frozen=True)
class Normal:
    """A dimension drawn from ``N(mean, std^2)`` independently for every lane.

    Parameters
    ----------
    name : str
    mean, std : float
        In the name's unit; ``std >= 0``.
    """

    name: str
    mean: float
    std: float

    def __post_init__(self) -> None:
        check_finite(f"vary {self.name!r} mean", self.mean)
        if check_finite(f"vary {self.name!r} std", self.std) < 0:
            raise InputError(f"vary {self.name!r}: std must be >= 0, got {self.std!r}", argument="vary")

    def draw(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return rng.normal(self.mean, self.std, size=n)

    def to_dict(self) -> dict:
        return {"normal": [self.mean, self.std]}


@dataclass(frozen=True)
class Uniform:
    """A dimension drawn uniformly from ``[low, high)`` independently for every lane."""

    name: str
    low: float
    high: float

    def __post_init__(self) -> None:
        lo = check_finite(f"vary {self.name!r} low", self.low)
        hi = check_finite(f"vary {self.name!r} high", self.high)
        if not hi > lo:
            raise InputError(f"vary {self.name!r}: uniform needs low < high, got [{lo:g}, {hi:g}]", argument="vary")

    def draw(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return rng.uniform(self.low, self.high, size=n)

    def to_dict(self) -> dict:
        return {"uniform": [self.low, self.high]}


Dimension = Grid | Normal | Uniform


def _check_int(name: str, value, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise InputError(f"{name} must be an integer from {low} to {high}, got {value!r}", argument=name)
    return int(value)


@dataclass(frozen=True)
class SweepSpec:
    """A sweep or Monte Carlo study of closed loops of model (9), or of the pendulum with a belt (15).

    Parameters
    ----------
    params : LumpedParameters
        The nominal plant (and the one the LQR is designed on: with the belt, on its rigid limit).
    law : {"hopf", "lqr"}
        The closed loop: the Hopf law ``u = k1 q3 + k2 q3^3`` (section 5.3), or the
        LQR balance at the upright (:func:`iwp.control.lqr_balance`, designed on
        ``params``, sampled every ``lqr_Ts`` with zero-order hold).
    vary : sequence of Grid, Normal, Uniform
        The varied names; at most one dimension per name.
    samples : int
        Draws per grid point (1 without random dimensions or uncertainty).
    uncertainty : ParameterUncertainty, optional
        A fit's estimates and covariance: every lane's free parameters are drawn
        jointly from it (truncated to the physical range); ``vary`` overrides a name.
    k1, k2 : float
        Hopf gains not varied [input units s/rad, input units s^3/rad^3] (the paper's -10, 0.1).
    controller_Ts : float, optional
        Hopf law sampled every ``controller_Ts`` [s] and held; None: continuous.
    lqr_Q, lqr_R, lqr_u_max, lqr_Ts :
        The LQR design (:func:`iwp.control.lqr_balance`); ``lqr_Ts`` [s] is its sample period.
    x0 : sequence of 4 float, optional
        Initial state ``q1, q2, q3, q4`` not varied [rad, rad, rad/s, rad/s]; default
        ``(0.1, 0, 0, 0)`` (just off the hanging rest) for the Hopf law, ``(pi - 0.02, 0, 0, 0)``
        (near the upright) for the LQR.
    t_end : float
        Length of every closed loop [s].
    sample_time : float
        Output sample time the metrics are measured on [s]. The default 50 ms keeps the
        engine's output cost small (at 10 ms the output costs more than the integration);
        the maxima are refined by a parabola through the samples around them.
    window : float
        Final window of the orbit metrics [s] (:mod:`iwp.sweep.metrics`).
    rtol, atol : float
        Integration tolerances.
    seed : int
        Root of the chunks' seeds.
    chunk_size : int
        Lanes per chunk (part of the numbers: a chunk's draws depend on it).
    source : dict
        Where the parameters came from (file names), for the manifest.
    model : str
        The closed loops' model, one of :data:`SWEEP_MODELS`: ``"compensated"`` (9), or ``"belt-full"``, the
        pendulum with the belt (15) between motor and wheel (needs ``belt``).
    belt : BeltParameters, optional
        The nominal belt of ``model="belt-full"`` (a fit's: ``iwp fit --belt``); its parameters may be varied
        and drawn (an ``uncertainty`` with the belt).
    """

    params: LumpedParameters
    law: str = "hopf"
    vary: tuple = ()
    samples: int = 1
    uncertainty: ParameterUncertainty | None = None
    k1: float = -10.0
    k2: float = 0.1
    controller_Ts: float | None = None
    lqr_Q: tuple[float, float, float] = (1.0, 0.01, 1e-4)
    lqr_R: float = 0.1
    lqr_u_max: float = 100.0
    lqr_Ts: float = 0.005
    x0: tuple[float, ...] | None = None
    t_end: float = 300.0
    sample_time: float = 0.05
    window: float = 20.0
    rtol: float = 1e-8
    atol: float = 1e-8
    seed: int = 0
    chunk_size: int = 100
    source: Mapping[str, str] = field(default_factory=dict)
    model: str = "compensated"
    belt: BeltParameters | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.params, LumpedParameters):
            raise InputError(f"params must be LumpedParameters, got {type(self.params).__name__}", argument="params")
        if self.model not in SWEEP_MODELS:
            raise InputError(f"model must be one of {', '.join(SWEEP_MODELS)}, got {self.model!r}", argument="model")
        if self.belt is not None and not isinstance(self.belt, BeltParameters):
            raise InputError(f"belt must be BeltParameters, got {type(self.belt).__name__}", argument="belt")
        drive = MODELS[self.model].drive
        if drive == "belt" and self.belt is None:
            raise InputError(f"model {self.model!r} needs the belt's parameters (15): give the parameters of a fit "
                             "with the belt", argument="params")
        if drive is None and self.belt is not None:
            object.__setattr__(self, "belt", None)  # a rigid model: the belt's rigid limit is in params
        if self.law not in LAWS:
            raise InputError(f"law must be one of {', '.join(LAWS)}, got {self.law!r}", argument="law")
        vary = tuple(self.vary)
        seen = set()
        for d in vary:
            if not isinstance(d, (Grid, Normal, Uniform)):
                raise InputError(f"vary must hold Grid, Normal or Uniform dimensions, got {type(d).__name__}",
                                 argument="vary")
            _name_ok(d.name, self.law, self.belt is not None)
            if d.name in seen:
                raise InputError(f"vary {d.name!r}: given twice", argument="vary")
            seen.add(d.name)
        object.__setattr__(self, "vary", vary)
        if self.uncertainty is not None and not isinstance(self.uncertainty, ParameterUncertainty):
            raise InputError("uncertainty must be a ParameterUncertainty (iwp.sim.uncertainty.load_uncertainty)",
                             argument="uncertainty")
        if self.uncertainty is not None and self.belt is None:
            drawn = self.uncertainty.belt_free
            if drawn:
                raise InputError(f"uncertainty: the fit's belt (15) is uncertain ({', '.join(drawn)}) and model "
                                 f"{self.model!r} has none: sweep model belt-full", argument="uncertainty")
        random = self.uncertainty is not None or any(not isinstance(d, Grid) for d in vary)
        samples = _check_int("samples", self.samples, 1, MAX_LANES)
        if samples > 1 and not random:
            raise InputError(f"samples = {samples} repeats identical lanes: nothing is random (add a normal or "
                             "uniform dimension or an uncertainty)", argument="samples")
        object.__setattr__(self, "samples", samples)
        for name in ("k1", "k2", "lqr_R", "lqr_u_max", "lqr_Ts", "t_end", "sample_time", "window", "rtol", "atol"):
            val = check_finite(name, getattr(self, name))
            if name not in ("k1", "k2"):
                val = check_positive(name, val)
            object.__setattr__(self, name, val)
        if self.controller_Ts is not None:
            object.__setattr__(self, "controller_Ts", check_positive("controller_Ts", self.controller_Ts))
        # runaway settings: a lane that would take longer than any sweep waits for, in a compiled kernel that no
        # signal interrupts (controller_Ts = 1e-9 s ignored SIGTERM for over 15 s), is refused here, by its key
        for name in ("rtol", "atol"):
            if getattr(self, name) < MIN_TOLERANCE:
                raise InputError(f"{name} = {getattr(self, name):g}: below {MIN_TOLERANCE:g}, beyond what double "
                                 "precision resolves (the step size would shrink without end)", argument=name)
        for name in ("controller_Ts",) if self.law == "hopf" else ("lqr_Ts",):  # the law's own sampling
            period = getattr(self, name)
            if period is not None and self.t_end / period > MAX_CONTROL_STEPS:
                raise InputError(f"{name} = {period:g} s: the law would be sampled {self.t_end / period:.3g} times "
                                 f"over t_end = {self.t_end:g} s, at most {MAX_CONTROL_STEPS:.0e} (lengthen {name})",
                                 argument=name)
        q = tuple(check_finite("lqr_Q", v) for v in np.ravel(np.asarray(self.lqr_Q, dtype=object)))
        if len(q) != 3 or min(q) < 0:
            raise InputError(f"lqr_Q must be 3 weights >= 0 on (q1 - pi, q3, q4), got {list(q)}", argument="lqr_Q")
        object.__setattr__(self, "lqr_Q", q)
        x0 = self.x0 if self.x0 is not None else DEFAULT_X0[self.law]
        x0 = tuple(check_finite("x0", v) for v in np.ravel(np.asarray(x0, dtype=object)))
        if len(x0) != 4:
            raise InputError(f"x0 must be 4 numbers q1, q2, q3, q4 [rad, rad, rad/s, rad/s], got {len(x0)}",
                             argument="x0")
        object.__setattr__(self, "x0", x0)
        if self.window > self.t_end:
            raise InputError(f"window must be <= t_end = {self.t_end:g} s, got {self.window:g} s", argument="window")
        if self.t_end / self.sample_time > MAX_SAMPLES_PER_LANE:
            raise InputError(f"t_end / sample_time = {self.t_end / self.sample_time:.3g} samples per lane; at most "
                             f"{MAX_SAMPLES_PER_LANE} (lengthen sample_time)", argument="sample_time")
        if self.window < 4 * self.sample_time:
            raise InputError(f"window must hold at least 4 samples of sample_time = {self.sample_time:g} s",
                             argument="window")
        object.__setattr__(self, "seed", _check_int("seed", self.seed, 0, 2**63 - 1))
        object.__setattr__(self, "chunk_size", _check_int("chunk_size", self.chunk_size, 1, 1_000_000))
        if self.n_lanes > MAX_LANES:
            raise InputError(f"the sweep has {self.n_lanes} lanes; at most {MAX_LANES}", argument="vary")

    def plant(self, params: LumpedParameters, belt: BeltParameters | None = None) -> Plant:
        """The plant of a lane with these parameters (and belt; default the nominal one)."""
        if MODELS[self.model].drive is None:
            return Plant(params, model=self.model)
        return Plant(params, model=self.model, belt=self.belt if belt is None else belt)

    # ----------------------------------------------------------------- sizes
    @property
    def grids(self) -> tuple[Grid, ...]:
        return tuple(d for d in self.vary if isinstance(d, Grid))

    @property
    def grid_shape(self) -> tuple[int, ...]:
        return tuple(len(g.values) for g in self.grids)

    @property
    def n_lanes(self) -> int:
        """Number of closed loops: the grid's size times ``samples``."""
        return math.prod(self.grid_shape) * self.samples

    @property
    def n_chunks(self) -> int:
        return -(-self.n_lanes // self.chunk_size)

    def chunk_range(self, index: int) -> range:
        """The lanes of chunk ``index``."""
        if not 0 <= index < self.n_chunks:
            raise InputError(f"chunk index must be in 0..{self.n_chunks - 1}, got {index}")
        return range(index * self.chunk_size, min((index + 1) * self.chunk_size, self.n_lanes))

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict:
        """The spec as JSON (the manifest's record; a resumed run must have the same one)."""
        out = {
            "law": self.law, "params": self.params.to_dict(), "source": dict(self.source),
            "vary": {d.name: d.to_dict() for d in self.vary}, "samples": self.samples,
            "x0": list(self.x0), "t_end": self.t_end, "sample_time": self.sample_time, "window": self.window,
            "rtol": self.rtol, "atol": self.atol, "seed": self.seed, "chunk_size": self.chunk_size,
        }
        if self.law == "hopf":
            out.update(k1=self.k1, k2=self.k2, controller_Ts=self.controller_Ts)
        else:
            out.update(lqr={"Q": list(self.lqr_Q), "R": self.lqr_R, "u_max": self.lqr_u_max, "Ts": self.lqr_Ts})
        if self.uncertainty is not None:
            u = self.uncertainty
            out["uncertainty"] = {"free": list(u.free), "matrix": np.asarray(u.covariance).tolist(),
                                  "mean": u.values}
        if self.belt is not None:  # (a rigid sweep's record as before, so that its manifest resumes)
            out.update(model=self.model, belt=self.belt.to_dict())
        return out


@dataclass(frozen=True, eq=False)
class LaneSet:
    """The lanes of one chunk: their indices and everything that differs between them.

    Attributes
    ----------
    lanes : ndarray of int, shape (m,)
        Global lane indices.
    values : dict of str to ndarray
        Each varied name's value per lane (and each free parameter of an uncertainty).
    params : list of LumpedParameters
        The plant of every lane.
    belts : list of BeltParameters or None
        The belt of every lane (None: the sweep's model has none).
    x0 : ndarray, shape (m, 4)
    k1, k2 : ndarray, shape (m,)
        Hopf gains per lane.
    physical : ndarray of bool, shape (m,)
        False where a lane's parameters leave the physical range (that lane is not simulated).
    """

    lanes: np.ndarray
    values: dict
    params: list
    belts: list
    x0: np.ndarray
    k1: np.ndarray
    k2: np.ndarray
    physical: np.ndarray


def lanes_of_chunk(spec: SweepSpec, index: int) -> LaneSet:
    """The lanes of chunk ``index`` with their grid values and draws (seeded by the chunk's index).

    Parameters
    ----------
    spec : SweepSpec
        The sweep.
    index : int
        Chunk index, from 0 to ``spec.n_chunks - 1``.

    Returns
    -------
    LaneSet
        The chunk's lanes; a lane whose parameters leave the physical range keeps ``spec.params`` and is marked
        not physical.

    Raises
    ------
    InputError
        ``index`` outside the chunks.
    """
    lanes = np.arange(spec.chunk_range(index).start, spec.chunk_range(index).stop)
    m = lanes.size
    values: dict[str, np.ndarray] = {}
    point = lanes // spec.samples
    if spec.grids:
        idx = np.unravel_index(point, spec.grid_shape)
        for g, ix in zip(spec.grids, idx):
            values[g.name] = np.asarray(g.values)[ix]
    # the chunk's draws: one generator per chunk, the dimensions in their order
    rng = np.random.default_rng(np.random.SeedSequence(spec.seed, spawn_key=(index,)))
    base = [spec.params] * m
    belts = [spec.belt] * m
    if spec.uncertainty is not None:
        u = spec.uncertainty
        child = np.random.SeedSequence(spec.seed, spawn_key=(index, 1))
        rows = u.draw_values(m, seed=int(child.generate_state(1, np.uint64)[0]))
        base = [u.params.replace(**{n: v for n, v in row.items() if PARAMETER_INFO[n].owner == "lumped"})
                for row in rows]
        if u.belt_free:
            start = u.belt if u.belt is not None else spec.belt
            belts = [dataclasses.replace(start, **{n: v for n, v in row.items() if n in BELT_INFO}) for row in rows]
        named = {d.name for d in spec.vary}
        for n in u.free:
            if n not in named:  # a dimension of vary overrides the fit's draws of its name
                values[n] = np.array([row[n] for row in rows])
    for d in spec.vary:
        if not isinstance(d, Grid):
            values[d.name] = d.draw(rng, m)
    x0 = np.tile(np.asarray(spec.x0, dtype=float), (m, 1))
    for j, s in enumerate(STATE_NAMES):
        if s in values:
            x0[:, j] = values[s]
    k1 = np.asarray(values.get("k1", np.full(m, spec.k1)), float)
    k2 = np.asarray(values.get("k2", np.full(m, spec.k2)), float)
    pnames = [d.name for d in spec.vary if d.name in LUMPED_INFO]
    bnames = [d.name for d in spec.vary if d.name in BELT_INFO]
    if spec.uncertainty is None and not pnames and not bnames:  # one plant for all lanes
        try:
            spec.params.check_physical()
        except InputError:
            return LaneSet(lanes=lanes, values=values, params=base, belts=belts, x0=x0, k1=k1, k2=k2,
                           physical=np.zeros(m, dtype=bool))
        return LaneSet(lanes=lanes, values=values, params=base, belts=belts, x0=x0, k1=k1, k2=k2,
                       physical=np.ones(m, dtype=bool))
    physical = np.ones(m, dtype=bool)
    params, lane_belts = [], []
    for i, (p, b) in enumerate(zip(base, belts)):
        try:
            if pnames:
                p = p.replace(**{n: float(values[n][i]) for n in pnames})
            p.check_physical()
            if bnames:
                b = dataclasses.replace(b, **{n: float(values[n][i]) for n in bnames})
        except InputError:
            physical[i] = False
        params.append(p if physical[i] else spec.params)
        lane_belts.append(b if physical[i] else spec.belt)
    return LaneSet(lanes=lanes, values=values, params=params, belts=lane_belts, x0=x0, k1=k1, k2=k2,
                   physical=physical)


# ---------------------------------------------------------------------- JSON
#: the smallest rtol and atol a sweep takes (double precision resolves about 2.2e-16 of a value)
MIN_TOLERANCE = 1e-14
#: the most samples of a sampled law a lane may take over t_end (controller_Ts, lqr_Ts): 1e7 is 300 s at 30 us
MAX_CONTROL_STEPS = 1e7

_KEYS = {"law", "params", "uncertainty", "vary", "samples", "k1", "k2", "controller_Ts", "lqr", "x0", "t_end",
         "sample_time", "window", "rtol", "atol", "seed", "chunk_size", "model"}
_LQR_KEYS = {"Q": "lqr_Q", "R": "lqr_R", "u_max": "lqr_u_max", "Ts": "lqr_Ts"}


def _dimension(name: str, rec, where: str) -> Dimension:
    if isinstance(rec, list):
        return Grid(name, tuple(rec))
    if not isinstance(rec, dict) or len(rec) != 1:
        raise InputError(f"{where}: 'vary.{name}' must be a list of values or one of {{\"grid\": [...]}}, "
                         "{\"linspace\": [start, stop, n]}, {\"normal\": [mean, std]}, {\"uniform\": [low, high]}")
    (kind, arg), = rec.items()
    if kind not in ("grid", "linspace", "normal", "uniform"):
        raise InputError(f"{where}: 'vary.{name}': unknown kind {kind!r} (grid, linspace, normal, uniform)")
    if not isinstance(arg, list):
        raise InputError(f"{where}: 'vary.{name}.{kind}' must be a list")
    if kind == "grid":
        return Grid(name, tuple(arg))
    want = 3 if kind == "linspace" else 2
    if len(arg) != want:
        raise InputError(f"{where}: 'vary.{name}.{kind}' needs {want} numbers, got {len(arg)}")
    if kind == "linspace":
        n = arg[2]
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_LANES:
            raise InputError(f"{where}: 'vary.{name}.linspace' count must be a positive integer, got {n!r}")
        a = check_finite(f"vary {name!r} start", arg[0])
        b = check_finite(f"vary {name!r} stop", arg[1])
        return Grid(name, tuple(np.linspace(a, b, n).tolist()))
    if kind == "normal":
        return Normal(name, arg[0], arg[1])
    return Uniform(name, arg[0], arg[1])


def spec_from_dict(doc, *, where: str = "spec", base: Path | None = None, **overrides) -> SweepSpec:
    """A :class:`SweepSpec` from its JSON form (see docs/sweeps.md); errors name ``where`` and the key.

    ``params`` and ``uncertainty`` are built-in names or file paths, relative to
    ``base`` (the spec file's folder). ``overrides`` replace keys of ``doc``
    (``chunk_size=...``).

    Parameters
    ----------
    doc : dict
        The spec's JSON form.
    where : str, default "spec"
        What the errors name as the source.
    base : Path, optional
        Folder that relative file names in ``doc`` are relative to; None: the working folder.
    **overrides
        Keys of ``doc`` replaced; None values are ignored.

    Returns
    -------
    SweepSpec
        The sweep.

    Raises
    ------
    InputError
        Not an object, an unknown key, an unreadable parameter or uncertainty file, or a bad value.
    """
    if not isinstance(doc, dict):
        raise InputError(f"{where}: expected a JSON object")
    doc = {**doc, **{k: v for k, v in overrides.items() if v is not None}}
    unknown = sorted(set(doc) - _KEYS)
    if unknown:
        raise InputError(f"{where}: unknown key {unknown[0]!r} (keys: {', '.join(sorted(_KEYS))})")
    kw: dict = {}
    source: dict[str, str] = {}

    def path_of(key: str) -> str:
        val = doc[key]
        if not isinstance(val, str) or not val.strip():
            raise InputError(f"{where}: '{key}' must be a file name or a built-in name")
        p = Path(val)
        if base is not None and not p.is_absolute() and val != "table1":
            p = base / p
        source[key] = val
        return str(p) if val != "table1" else val

    try:
        stored = None  # the model a parameter file names (a fit with the belt: belt-full)
        if "uncertainty" in doc:
            unc = load_uncertainty(path_of("uncertainty"), argument="uncertainty")
            kw["uncertainty"] = unc
            kw["belt"] = unc.belt
            stored = stored_model(path_of("uncertainty"))
        if "params" in doc:
            params = load_params(path_of("params"))
            if not isinstance(params, LumpedParameters):
                params = params.to_lumped()
            kw["params"] = params
            kw["belt"] = stored_belt(path_of("params")) or kw.get("belt")
            stored = stored_model(path_of("params")) or stored
        elif "uncertainty" in kw:
            kw["params"] = kw["uncertainty"].params
        else:
            kw["params"] = load_params("table1")
            source["params"] = "table1"
        # the model: as given, else the one the parameters were fitted with where a sweep runs it (the belt)
        kw["model"] = doc.get("model", stored if stored in SWEEP_MODELS else "compensated")
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(where) else f"{where}: {msg}") from None
    vary = doc.get("vary", {})
    if not isinstance(vary, dict):
        raise InputError(f"{where}: 'vary' must be an object of name: dimension")
    law = doc.get("law", "hopf")
    try:
        kw["vary"] = tuple(_dimension(str(n), r, where) for n, r in vary.items())
        lqr = doc.get("lqr", {})
        if not isinstance(lqr, dict):
            raise InputError("'lqr' must be an object with Q, R, u_max, Ts")
        bad = sorted(set(lqr) - set(_LQR_KEYS))
        if bad:
            raise InputError(f"'lqr' has an unknown key {bad[0]!r} ({', '.join(_LQR_KEYS)})")
        for k, v in lqr.items():
            kw[_LQR_KEYS[k]] = v
        for k in ("law", "samples", "k1", "k2", "controller_Ts", "x0", "t_end", "sample_time", "window", "rtol",
                  "atol", "seed", "chunk_size"):
            if k in doc:
                kw[k] = doc[k]
        if law != "hopf" and any(k in doc for k in ("k1", "k2", "controller_Ts")):
            raise InputError(f"k1, k2 and controller_Ts are the Hopf law's; law is {law!r}")
        return SweepSpec(**kw, source=source)
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(where) else f"{where}: {msg}") from None


def load_spec(path, *, argument: str = "spec", **overrides) -> SweepSpec:
    """The :class:`SweepSpec` of a JSON file (paths inside it are relative to the file's folder).

    Parameters
    ----------
    path : str or path-like
        The spec file (JSON, docs/sweeps.md).
    argument : str, default "spec"
        Name of the argument in error messages.
    **overrides
        Keys of the spec replaced (``chunk_size=...``); None values are ignored.

    Returns
    -------
    SweepSpec
        The sweep.

    Raises
    ------
    InputError
        A file that does not read as JSON, or a bad spec (the message names the file and the key).
    """
    p = Path(path)
    doc = read_json(p, argument=argument)
    return spec_from_dict(doc, where=f"{argument} {p}", base=p.parent, **overrides)


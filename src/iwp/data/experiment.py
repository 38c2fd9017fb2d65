"""The experiment object: a time-series log (:class:`ExperimentData`) or a static curve (:class:`StaticCurve`).

Units: time [s], angles [rad], velocities [rad/s]. The inputs ``u`` (ideal
input of the dead-zone-compensated system) and ``v`` (raw, non-dimensional
input of the motor driver, ``v = V_i / beta``) are in the rig's input units.

A log holds what the rig measured: the pendulum angle ``q1`` always, the
wheel's angle ``q2`` or its speed ``q4`` (or both), the motor current when
logged (the extra column ``current`` [A], :attr:`ExperimentData.current`),
and the glitches found in it (:class:`~iwp.data.glitches.Glitch` records,
:meth:`ExperimentData.with_glitches_found`).
"""

from __future__ import annotations

import hashlib
import json
import math
import warnings
from dataclasses import dataclass, field, replace
from typing import Any, Mapping, Sequence

import numpy as np

from ..checks import check_finite, check_positive
from ..errors import InputError
from .glitches import Glitch, find_glitches, repair, summarize

#: The columns of an iwp log, in order: time [s], angles [rad], velocities [rad/s], inputs ``u`` and ``v``.
CANONICAL_COLUMNS = ("t", "q1", "q2", "q3", "q4", "u", "v")
#: Columns every time-series log must have (``q2`` may be replaced by ``q4``, see :func:`missing_required`).
REQUIRED_COLUMNS = ("t", "q1", "q2")
#: The extra column that holds the motor current [A].
CURRENT_COLUMN = "current"
#: Metadata keys iwp reads: how the wheel speed ``q4`` was sampled (``instant`` or ``mean``, the mean over
#: the preceding sample period, a board's backward difference) and the glitch records (JSON).
Q4_SAMPLING_KEY = "q4_sampling"
GLITCHES_KEY = "glitches"
Q4_SAMPLINGS = ("instant", "mean")


def missing_required(names) -> list[str]:
    """The required columns missing from ``names``: ``t``, ``q1``, and ``q2`` unless the wheel speed ``q4`` is there."""
    have = set(names)
    return [c for c in REQUIRED_COLUMNS if c not in have and not (c == "q2" and "q4" in have)]
#: Input formats known to :func:`read_experiment` (``format=``).
FORMATS = ("csv", "mat", "parquet", "angle-log")

#: A pendulum angle beyond this [rad] (``3 pi``) is checked for degrees (:func:`iwp.data.tables.warn_if_degrees`).
DEGREES_THRESHOLD = 3.0 * math.pi

# --------------------------------------------------------------------------
# in-memory containers
# --------------------------------------------------------------------------
def _vector(owner: str, name: str, value: Any) -> np.ndarray:
    """Return ``value`` as a read-only 1-D float64 copy, or raise naming ``name``."""
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{owner}: {name} must be an array of numbers") from None
    if arr.ndim != 1:
        raise InputError(f"{owner}: {name} must be a 1-D array, got shape {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        i = int(bad[0])
        raise InputError(f"{owner}: {name}[{i}] = {float(arr[i])!r} is not finite")
    arr.setflags(write=False)
    return arr


def _check_metadata(owner: str, metadata: Mapping[str, Any] | None) -> dict[str, str]:
    """Validate metadata keys, turn values into stripped strings."""
    if metadata is None:
        return {}
    if not isinstance(metadata, Mapping):
        raise InputError(f"{owner}: metadata must be a dict of str to str")
    out: dict[str, str] = {}
    for key, value in metadata.items():
        if not isinstance(key, str) or not key.strip() or key != key.strip():
            raise InputError(
                f"{owner}: metadata key {key!r} must be a non-empty string without "
                "surrounding spaces"
            )
        if ":" in key or "\n" in key or "\r" in key:
            raise InputError(f"{owner}: metadata key {key!r} must not contain ':' or a line break")
        text = str(value)
        if "\n" in text or "\r" in text:
            raise InputError(f"{owner}: metadata value of {key!r} must not contain a line break")
        out[key] = text.strip()
    return out


def _parse_glitches(owner: str, text: str) -> tuple[Glitch, ...]:
    try:
        items = json.loads(text)
    except ValueError:
        raise InputError(f"{owner}: metadata {GLITCHES_KEY!r} is not JSON (a list of glitch records)") from None
    if not isinstance(items, list):
        raise InputError(f"{owner}: metadata {GLITCHES_KEY!r} must be a JSON list of glitch records")
    try:
        return tuple(Glitch.from_dict(d) for d in items)
    except (InputError, AttributeError) as exc:
        raise InputError(f"{owner}: metadata {GLITCHES_KEY!r}: {exc}") from None


def _check_extra_name(owner: str, name: Any) -> str:
    if not isinstance(name, str) or not name or name != name.strip():
        raise InputError(
            f"{owner}: extra column name {name!r} must be a non-empty string without "
            "surrounding spaces"
        )
    if name in CANONICAL_COLUMNS:
        raise InputError(
            f"{owner}: extra column {name!r} has a reserved iwp name "
            f"({', '.join(CANONICAL_COLUMNS)}); pass it as its own field"
        )
    if any(c in name for c in ',"\n\r') or name.startswith("#"):
        raise InputError(
            f"{owner}: extra column name {name!r} must not contain a comma, a quote or a "
            "line break, nor start with '#'"
        )
    return name


def check_distinct(logs: Sequence["ExperimentData"], what: str = "logs") -> None:
    """Refuse a log given twice (the same samples under any name).

    Stacked or fitted jointly, a log with itself shrinks the standard errors
    by ``sqrt(2)`` without new information.

    Examples
    --------
    >>> from iwp.data import check_distinct
    >>> from iwp.rig import run_experiment
    >>> a, b = run_experiment("sine-60", duration=1.0), run_experiment("sine-40", duration=1.0)
    >>> check_distinct([a, b])  # two experiments: no error
    >>> check_distinct([a, b, a])
    Traceback (most recent call last):
    ...
    iwp.errors.InputError: logs: virtual rig: sine-60 is given twice; using a log twice shrinks the standard ...
    """
    seen: dict[bytes, int] = {}
    for i, d in enumerate(logs):
        if not isinstance(d, ExperimentData):
            continue
        h = hashlib.sha256()
        for col in d.as_columns().values():
            h.update(np.ascontiguousarray(col, dtype=float).tobytes())
        key = h.digest()
        if key in seen:
            first = logs[seen[key]].source
            same = "given twice" if first == d.source else f"the same log as {first}"
            raise InputError(f"{what}: {d.source} is {same}; using a log twice shrinks the standard errors "
                             "without new information")
        seen[key] = i


@dataclass(frozen=True, eq=False, repr=False)
class ExperimentData:
    """One experiment log of the inertia wheel pendulum.

    All arrays are 1-D float64, of the same length, finite, and read-only
    (copies of what was given). Time must be strictly increasing; sampling
    regularity is checked by the readers, not here.

    Parameters
    ----------
    t : array_like
        Time of each sample [s], strictly increasing.
    q1 : array_like
        Pendulum angle [rad], zero with the pendulum hanging down.
    q2 : array_like or None
        Disk (wheel) angle [rad]; None when only the wheel speed ``q4`` was logged.
    q3 : array_like or None, optional
        Measured pendulum velocity [rad/s]; None if not logged.
    q4 : array_like or None, optional
        Measured disk velocity [rad/s]; None if not logged.
    u : array_like or None, optional
        Ideal input of the dead-zone-compensated system (paper eq. (7)) [input
        units]. At most one of ``u`` and ``v`` may be given.
    v : array_like or None, optional
        Raw input to the motor driver, ``v = V_i / beta`` [input units].
        Neither ``u`` nor ``v``: a free pendulum (zero input).
    extra : dict of str to array_like, optional
        Other logged columns, same length; kept and written back, ignored by
        iwp. Names must not be one of :data:`CANONICAL_COLUMNS`.
    metadata : dict of str to str, optional
        Free-form ``key: value`` pairs (values are converted to stripped
        strings; keys must not contain ``:`` or line breaks).
    source : str, optional
        Where the data came from (file name), used in messages.
    glitches : sequence of Glitch, optional
        Glitches found in the log (:meth:`with_glitches_found`); kept in the
        metadata as JSON under ``glitches`` so that they survive a round trip
        through a file. Default: those of the metadata, if any.

    Raises
    ------
    InputError
        On a wrong shape or length (naming the field), a non-finite value,
        a time that does not strictly increase, both ``u`` and ``v`` given,
        neither ``q2`` nor ``q4``, fewer than 2 samples, or bad metadata.

    Notes
    -----
    Metadata that iwp reads: ``q4_sampling: mean`` (the wheel speed is the
    mean over the preceding sample period, as a board's backward difference
    of an encoder gives it; default ``instant``), ``q1_offset`` (the zero
    offset already removed from ``q1`` [rad], informative), ``glitches``.
    """

    t: np.ndarray
    q1: np.ndarray
    q2: np.ndarray | None = None
    q3: np.ndarray | None = None
    q4: np.ndarray | None = None
    u: np.ndarray | None = None
    v: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)
    source: str = "<memory>"
    glitches: tuple[Glitch, ...] = ()

    def __post_init__(self):
        src = str(self.source) if self.source is not None else "<memory>"
        object.__setattr__(self, "source", src)
        owner = f"ExperimentData({src})"
        t = _vector(owner, "t", self.t)
        n = t.size
        if n < 2:
            raise InputError(f"{owner}: t has {n} sample(s), at least 2 are needed")
        dt = np.diff(t)
        bad = np.flatnonzero(dt <= 0)
        if bad.size:
            i = int(bad[0]) + 1
            raise InputError(
                f"{owner}: t must be strictly increasing, but t[{i}] = {float(t[i])!r} s "
                f"<= t[{i - 1}] = {float(t[i - 1])!r} s"
            )
        object.__setattr__(self, "t", t)
        for name in ("q1", "q2", "q3", "q4", "u", "v"):
            value = getattr(self, name)
            if value is None:
                if name in REQUIRED_COLUMNS and (name != "q2" or self.q4 is None):
                    raise InputError(f"{owner}: {name} is required" + (
                        " (or the wheel speed q4)" if name == "q2" else ""))
                continue
            arr = _vector(owner, name, value)
            if arr.size != n:
                raise InputError(f"{owner}: {name} has {arr.size} samples but t has {n}")
            object.__setattr__(self, name, arr)
        if self.u is not None and self.v is not None:
            raise InputError(
                f"{owner}: both u and v given; a log holds at most one input "
                "(u: dead-zone-compensated, v: raw motor-driver input)"
            )
        if self.extra is None:
            extra_in: Mapping[str, Any] = {}
        elif isinstance(self.extra, Mapping):
            extra_in = self.extra
        else:
            raise InputError(f"{owner}: extra must be a dict of column name to array")
        extra: dict[str, np.ndarray] = {}
        for name, value in extra_in.items():
            name = _check_extra_name(owner, name)
            arr = _vector(owner, f"extra[{name!r}]", value)
            if arr.size != n:
                raise InputError(
                    f"{owner}: extra[{name!r}] has {arr.size} samples but t has {n}"
                )
            extra[name] = arr
        object.__setattr__(self, "extra", extra)
        meta = _check_metadata(owner, self.metadata)
        sampling = meta.get(Q4_SAMPLING_KEY)
        if sampling is not None and sampling not in Q4_SAMPLINGS:
            raise InputError(f"{owner}: metadata {Q4_SAMPLING_KEY!r} must be one of {', '.join(Q4_SAMPLINGS)}, "
                             f"got {sampling!r}")
        glitches = tuple(self.glitches or ())
        if not glitches and meta.get(GLITCHES_KEY):
            glitches = _parse_glitches(owner, meta[GLITCHES_KEY])
        for g in glitches:
            if not isinstance(g, Glitch):
                raise InputError(f"{owner}: glitches must be Glitch records, got {type(g).__name__}")
            if not 0 <= g.index < n:
                raise InputError(f"{owner}: glitch of {g.column} at sample {g.index} is outside the log ({n} samples)")
        if glitches:
            meta[GLITCHES_KEY] = json.dumps([g.to_dict() for g in glitches], separators=(",", ":"))
        else:
            meta.pop(GLITCHES_KEY, None)
        object.__setattr__(self, "glitches", glitches)
        object.__setattr__(self, "metadata", meta)

    # -- properties ---------------------------------------------------------
    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.t.size)

    @property
    def Ts(self) -> float:
        """Sample time [s]: the median of the time steps."""
        return float(np.median(np.diff(self.t)))

    @property
    def duration(self) -> float:
        """Time from the first to the last sample [s]."""
        return float(self.t[-1] - self.t[0])

    @property
    def input_name(self) -> str | None:
        """``'u'``, ``'v'`` or None (no input: free pendulum)."""
        if self.u is not None:
            return "u"
        if self.v is not None:
            return "v"
        return None

    @property
    def input(self) -> np.ndarray:
        """The input samples (``u`` or ``v``); zeros if the log has no input."""
        if self.u is not None:
            return self.u
        if self.v is not None:
            return self.v
        z = np.zeros_like(self.t)
        z.setflags(write=False)
        return z

    @property
    def current(self) -> np.ndarray | None:
        """The motor current [A] (extra column ``current``), or None if not logged."""
        return self.extra.get(CURRENT_COLUMN)

    @property
    def q4_sampling(self) -> str:
        """How ``q4`` was sampled: ``"instant"`` or ``"mean"`` (over the preceding sample period)."""
        return self.metadata.get(Q4_SAMPLING_KEY, "instant")

    def glitch_mask(self, column: str) -> np.ndarray:
        """Boolean array, True at the samples of ``column`` that were replaced (spikes, dropouts)."""
        m = np.zeros(self.n_samples, dtype=bool)
        for g in self.glitches:
            if g.column == column and g.repaired:
                m[g.index] = True
        return m

    def with_glitches_found(self, *, warn: bool = True) -> "ExperimentData":
        """This log with its glitches found, recorded and (spikes, dropouts) replaced.

        Checks the measured signals ``q1``..``q4`` and the current (never the
        input) with :func:`iwp.data.glitches.find_glitches`; glitch samples are
        replaced by the mean of their neighbours, pendulum-angle jumps are
        only recorded. The records are in :attr:`glitches` (and the metadata)
        and, with ``warn``, in one :func:`warnings.warn` line. Glitches
        already recorded are kept and the search is not repeated.
        """
        if self.glitches:
            return self
        cols = {n: getattr(self, n) for n in ("q1", "q2", "q3", "q4") if getattr(self, n) is not None}
        if self.current is not None:
            cols[CURRENT_COLUMN] = self.current
        found = find_glitches(self.t, cols, input=self.input)
        if not found:
            return self
        if warn:
            warnings.warn(f"{self.source}: {summarize(found)}; replaced samples are left out of fits",
                          UserWarning, stacklevel=2)
        fixed = {n: repair(cols[n], [g for g in found if g.column == n]) for n in cols}
        extra = dict(self.extra)
        if CURRENT_COLUMN in fixed:
            extra[CURRENT_COLUMN] = fixed.pop(CURRENT_COLUMN)
        return replace(self, **fixed, extra=extra, glitches=tuple(found))

    def as_columns(self) -> dict[str, np.ndarray]:
        """All present columns, canonical ones first (in :data:`CANONICAL_COLUMNS`
        order), then the extra columns; the order in which they are written."""
        cols = {
            name: getattr(self, name)
            for name in CANONICAL_COLUMNS
            if getattr(self, name) is not None
        }
        cols.update(self.extra)
        return cols

    def __repr__(self) -> str:
        names = [n for n in CANONICAL_COLUMNS if getattr(self, n) is not None]
        return (
            f"ExperimentData(source={self.source!r}, n_samples={self.n_samples}, "
            f"Ts={self.Ts!r}, t=[{float(self.t[0])!r}, {float(self.t[-1])!r}], columns={names}, "
            f"extra={list(self.extra)}, metadata={self.metadata!r})"
        )

    # -- derived logs ---------------------------------------------------------
    def window(self, t_start: float | None = None, t_end: float | None = None) -> "ExperimentData":
        """Return the samples with ``t_start <= t <= t_end`` as a new log.

        Times are kept as they are (not shifted to start at 0).

        Parameters
        ----------
        t_start : float or None, optional
            First time kept [s]; None: from the first sample.
        t_end : float or None, optional
            Last time kept [s]; None: to the last sample.

        Returns
        -------
        ExperimentData

        Raises
        ------
        InputError
            If ``t_start >= t_end`` or the window keeps fewer than 2 samples
            (the message names the argument).
        """
        if t_start is None and t_end is None:
            return self
        lo = check_finite("t_start", t_start) if t_start is not None else None
        hi = check_finite("t_end", t_end) if t_end is not None else None
        if lo is not None and hi is not None and lo >= hi:
            raise InputError(f"t_start ({lo!r} s) must be < t_end ({hi!r} s)", argument=("t_start", "t_end"))
        i0 = 0 if lo is None else int(np.searchsorted(self.t, lo, side="left"))
        i1 = self.n_samples if hi is None else int(np.searchsorted(self.t, hi, side="right"))
        kept = max(0, i1 - i0)
        if kept < 2:
            args = ", ".join(
                f"{name}={val!r} s"
                for name, val in (("t_start", lo), ("t_end", hi))
                if val is not None
            )
            raise InputError(
                f"{args} keeps {kept} sample(s) of {self.source} (t from "
                f"{float(self.t[0])!r} to {float(self.t[-1])!r} s); at least 2 are needed",
                argument=("t_start", "t_end"),
            )
        return replace(
            self,
            **{n: a[i0:i1] for n, a in self.as_columns().items() if n in CANONICAL_COLUMNS},
            extra={n: a[i0:i1] for n, a in self.extra.items()},
            glitches=tuple(replace(g, index=g.index - i0) for g in self.glitches if i0 <= g.index < i1),
        )

    def resample(self, Ts: float | None = None) -> "ExperimentData":
        """Return the log linearly interpolated onto a uniform time grid.

        The grid is ``t[0] + k * Ts`` for ``k = 0, 1, ...`` up to ``t[-1]``.
        Every column (angles, velocities, input, extra columns) is linearly
        interpolated; a signal linear in time is reproduced exactly (up to
        rounding).

        Parameters
        ----------
        Ts : float or None, optional
            Sample time of the new grid [s]; None: the median step of the log
            (:attr:`Ts`).

        Returns
        -------
        ExperimentData
        """
        step = self.Ts if Ts is None else check_positive("Ts", Ts)
        n = int(math.floor((self.t[-1] - self.t[0]) / step * (1.0 + 1e-12) + 1e-9)) + 1
        if n < 2:
            raise InputError(
                f"Ts = {step!r} s leaves fewer than 2 samples over the {self.duration!r} s "
                f"of {self.source}"
            )
        t_new = self.t[0] + step * np.arange(n)
        cols = {
            name: np.interp(t_new, self.t, arr)
            for name, arr in self.as_columns().items()
            if name != "t"
        }
        extra = {name: cols.pop(name) for name in self.extra}
        moved = tuple(replace(g, index=int(np.argmin(np.abs(t_new - g.t))), t=float(t_new[np.argmin(
            np.abs(t_new - g.t))])) for g in self.glitches)
        return replace(self, t=t_new, extra=extra, glitches=moved, **cols)


@dataclass(frozen=True, eq=False, repr=False)
class StaticCurve:
    """Static input / steady-state disk-velocity curve (paper section 5, figure 2).

    One point per steady state: the constant input applied and the disk
    velocity it settled at.

    Parameters
    ----------
    input_name : {'v', 'u'}
        ``'v'``: raw motor-driver input (uncompensated, fig. 2a); ``'u'``:
        ideal input through the dead-zone compensation (fig. 2b).
    input : array_like
        Input values [input units], one per steady state.
    q4 : array_like
        Steady-state disk velocities [rad/s], same length.
    metadata : dict of str to str, optional
        ``key: value`` pairs.
    source : str, optional
        File name, for messages.
    """

    input_name: str
    input: np.ndarray
    q4: np.ndarray
    metadata: dict[str, str] = field(default_factory=dict)
    source: str = "<memory>"

    def __post_init__(self):
        src = str(self.source) if self.source is not None else "<memory>"
        object.__setattr__(self, "source", src)
        owner = f"StaticCurve({src})"
        if self.input_name not in ("u", "v"):
            raise InputError(f"{owner}: input_name must be 'u' or 'v', got {self.input_name!r}")
        x = _vector(owner, "input", self.input)
        y = _vector(owner, "q4", self.q4)
        if x.size != y.size:
            raise InputError(f"{owner}: q4 has {y.size} points but input has {x.size}")
        if x.size < 1:
            raise InputError(f"{owner}: the curve has no points")
        object.__setattr__(self, "input", x)
        object.__setattr__(self, "q4", y)
        object.__setattr__(self, "metadata", _check_metadata(owner, self.metadata))

    @property
    def n_points(self) -> int:
        """Number of steady states."""
        return int(self.input.size)

    def __repr__(self) -> str:
        return (
            f"StaticCurve(source={self.source!r}, input_name={self.input_name!r}, "
            f"n_points={self.n_points}, metadata={self.metadata!r})"
        )


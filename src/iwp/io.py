"""Experiment logs: the iwp data format, its readers and writers.

An experiment log is held in memory as an :class:`ExperimentData` (time,
pendulum angle ``q1``, wheel angle ``q2``, optional measured velocities ``q3``,
``q4`` and at most one input, ``u`` or ``v``). On disk it is one of

* the **iwp CSV** (``.csv`` / ``.txt``): ``# key: value`` metadata lines, one
  header row, then one row per sample (:func:`read_csv`, :func:`write_csv`);
* **Parquet** (``.parquet`` / ``.pq``, needs ``pyarrow``; :func:`read_parquet`,
  :func:`write_parquet`);
* **MATLAB** ``.mat`` (v4 to v7.2, through :func:`scipy.io.loadmat`;
  :func:`read_mat`, :func:`write_mat`);
* a third-party **angle log** (two header lines, then one angle a line;
  :func:`read_angle_log`, read only).

Static input/velocity curves (one row per steady state of the disk, paper
section 5, figure 2) are a :class:`StaticCurve` (:func:`read_static_curve`,
:func:`write_static_curve`).

Units: time [s], angles [rad], velocities [rad/s]. The inputs ``u`` (ideal
input of the dead-zone-compensated system) and ``v`` (raw, non-dimensional
input of the motor driver, ``v = V_i / beta``) are in the rig's input units.

Every reader checks what it reads and stops at the first problem with a
:class:`~iwp.errors.DataFormatError` whose one-line message names the file,
the place (CSV line number, 1-based; Parquet row; MAT variable and sample) and
the column. See ``docs/data-format.md`` for the contract.
"""

from __future__ import annotations

import inspect
import json
import math
import os
import re
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from ._util import check_finite, check_positive, prepare_output_file
from .errors import DataFormatError, InputError

__all__ = [
    "CANONICAL_COLUMNS",
    "REQUIRED_COLUMNS",
    "FORMATS",
    "ExperimentData",
    "StaticCurve",
    "read_experiment",
    "write_experiment",
    "read_csv",
    "write_csv",
    "read_parquet",
    "write_parquet",
    "read_mat",
    "write_mat",
    "read_angle_log",
    "read_static_curve",
    "write_static_curve",
    "convert",
]

#: Column names with a meaning for iwp, in the order they are written.
CANONICAL_COLUMNS = ("t", "q1", "q2", "q3", "q4", "u", "v")
#: Columns every time-series log must have.
REQUIRED_COLUMNS = ("t", "q1", "q2")
#: Input formats known to :func:`read_experiment` (``format=``).
FORMATS = ("csv", "mat", "parquet", "angle-log")

_ANGLES = ("q1", "q2", "q3", "q4")  # converted by degrees=True
_EXTENSIONS = {
    ".csv": "csv",
    ".txt": "csv",
    ".mat": "mat",
    ".parquet": "parquet",
    ".pq": "parquet",
}
#: A pendulum angle whose peak magnitude exceeds this is taken for degrees [rad].
DEGREES_THRESHOLD = 3.0 * math.pi
_MAT_METADATA = "iwp_metadata"
_PARQUET_METADATA_KEY = b"iwp.metadata"
_MAT_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,62}$")


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
    q2 : array_like
        Disk (wheel) angle [rad].
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

    Raises
    ------
    InputError
        On a wrong shape or length (naming the field), a non-finite value,
        a time that does not strictly increase, both ``u`` and ``v`` given,
        fewer than 2 samples, or bad metadata.
    """

    t: np.ndarray
    q1: np.ndarray
    q2: np.ndarray
    q3: np.ndarray | None = None
    q4: np.ndarray | None = None
    u: np.ndarray | None = None
    v: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)
    source: str = "<memory>"

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
                if name in REQUIRED_COLUMNS:
                    raise InputError(f"{owner}: {name} is required")
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
        object.__setattr__(self, "metadata", _check_metadata(owner, self.metadata))

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
            raise InputError(f"t_start ({lo!r} s) must be < t_end ({hi!r} s)")
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
                f"{float(self.t[0])!r} to {float(self.t[-1])!r} s); at least 2 are needed"
            )
        return replace(
            self,
            **{n: a[i0:i1] for n, a in self.as_columns().items() if n in CANONICAL_COLUMNS},
            extra={n: a[i0:i1] for n, a in self.extra.items()},
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
        return replace(self, t=t_new, extra=extra, **cols)

    # -- writers -------------------------------------------------------------
    def to_csv(self, path: str | os.PathLike, force: bool = False) -> Path:
        """Write the log as an iwp CSV; see :func:`write_csv`."""
        return write_csv(self, path, force=force)

    def to_parquet(self, path: str | os.PathLike, force: bool = False) -> Path:
        """Write the log as Parquet; see :func:`write_parquet`."""
        return write_parquet(self, path, force=force)

    def to_mat(self, path: str | os.PathLike, force: bool = False) -> Path:
        """Write the log as a MATLAB ``.mat`` file; see :func:`write_mat`."""
        return write_mat(self, path, force=force)


@dataclass(frozen=True, eq=False, repr=False)
class StaticCurve:
    """Static input / steady-state disk-velocity curve (paper section 5, fig. 2).

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

    def to_csv(self, path: str | os.PathLike, force: bool = False) -> Path:
        """Write the curve; see :func:`write_static_curve`."""
        return write_static_curve(self, path, force=force)


# --------------------------------------------------------------------------
# shared reading machinery
# --------------------------------------------------------------------------
def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _fail(msg: str) -> DataFormatError:
    return DataFormatError(_one_line(msg))


def _check_input_file(path: str | os.PathLike) -> tuple[Path, str]:
    p = Path(path)
    src = str(path)
    if not p.exists():
        raise _fail(f"{src}: no such file")
    if p.is_dir():
        raise _fail(f"{src}: is a folder, expected a file")
    if p.stat().st_size == 0:
        raise _fail(f"{src}: file is empty")
    return p, src


def _read_text_lines(path: str | os.PathLike) -> tuple[str, list[str]]:
    """Read a text file; refuse empty and binary files. Returns (source, lines)."""
    p, src = _check_input_file(path)
    raw = p.read_bytes()
    nul = raw.find(b"\x00")
    if nul >= 0:
        line = raw.count(b"\n", 0, nul) + 1
        raise _fail(f"{src}, line {line}: binary file (NUL byte at offset {nul}); expected a text file")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise _fail(
            f"{src}, line {line}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset "
            f"{exc.start}); binary file?"
        ) from None
    if not text.strip():
        raise _fail(f"{src}: file is empty")
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in text.split("\n")]
    return src, lines


def _parse_comment(line: str) -> tuple[str, str] | None:
    """``# key: value`` -> (key, value); None for other comments."""
    body = line.strip()[1:].strip()
    if ":" not in body:
        return None
    key, value = body.split(":", 1)
    key = key.strip()
    if not key:
        return None
    return key, value.strip()


def _split(line: str, delim: str | None) -> list[str]:
    return line.split(delim) if delim else line.split()


class _Table:
    """Header, numeric rows and line numbers of a delimited text file."""

    def __init__(self, path):
        src, lines = _read_text_lines(path)
        self.source = src
        self.metadata: dict[str, str] = {}
        self.header: list[str] | None = None
        self.header_line = 0
        self.delim: str | None = ","
        raw_rows: list[str] = []
        self.lines: list[int] = []
        for lineno, line in enumerate(lines, start=1):
            stripped = line.strip()
            if not stripped:
                continue
            if stripped.startswith("#"):
                kv = _parse_comment(stripped)
                if kv is not None:
                    self.metadata[kv[0]] = kv[1]
                continue
            if self.header is None:
                self.header_line = lineno
                self.delim = next((d for d in (",", "\t", ";") if d in stripped), None)
                self.header = [
                    f.strip().strip('"').strip() for f in _split(stripped, self.delim)
                ]
                for i, name in enumerate(self.header):
                    if not name:
                        raise _fail(f"{src}, line {lineno}: header column {i + 1} has no name")
                seen = set()
                for name in self.header:
                    if name in seen:
                        raise _fail(
                            f"{src}, line {lineno}: duplicated column name {name!r} in the header"
                        )
                    seen.add(name)
                continue
            raw_rows.append(stripped)
            self.lines.append(lineno)
        if self.header is None:
            raise _fail(f"{src}: no header row (only comments or blank lines)")
        self._raw_rows = raw_rows

    def where(self) -> str:
        return f"{self.source}, line {self.header_line}"

    def numbers(self) -> np.ndarray:
        """Parse the rows into an (n, ncol) float array, naming line and column on error."""
        ncol = len(self.header)
        out = np.empty((len(self._raw_rows), ncol))
        for i, (row, lineno) in enumerate(zip(self._raw_rows, self.lines)):
            fields = _split(row, self.delim)
            if len(fields) != ncol:
                raise _fail(
                    f"{self.source}, line {lineno}: {len(fields)} value(s) but the header "
                    f"(line {self.header_line}) has {ncol} columns"
                )
            try:
                out[i] = [float(f) for f in fields]
            except ValueError:
                for j, f in enumerate(fields):
                    try:
                        float(f)
                    except ValueError:
                        shown = f.strip()
                        what = "empty value" if not shown else f"{shown!r} is not a number"
                        raise _fail(
                            f"{self.source}, line {lineno}, column {self.header[j]!r}: {what}"
                        ) from None
        return out


def _check_mapping(mapping: Mapping[str, str] | None) -> dict[str, str]:
    if mapping is None:
        return {}
    if not isinstance(mapping, Mapping):
        raise InputError("mapping must be a dict such as {'t': 'time', 'q1': 'theta'}")
    out: dict[str, str] = {}
    for key, value in mapping.items():
        if key not in CANONICAL_COLUMNS:
            raise InputError(
                f"mapping key {key!r} is not an iwp column; use one of "
                f"{', '.join(CANONICAL_COLUMNS)}"
            )
        if not isinstance(value, str) or not value:
            raise InputError(f"mapping[{key!r}] must be a column/variable name, got {value!r}")
        out[key] = value
    sources = list(out.values())
    for s in sources:
        if sources.count(s) > 1:
            raise InputError(f"mapping gives column {s!r} to more than one iwp column")
    return out


def _resolve_columns(
    found: list[str],
    mapping: dict[str, str],
    where: str,
    kind: str = "column",
    time_aliases: tuple[str, ...] = (),
) -> tuple[dict[str, str], list[str]]:
    """Match file columns to iwp columns.

    Returns ``(used, leftovers)``: ``used`` maps iwp name -> file name;
    ``leftovers`` are the file names not used, in file order.
    """
    used: dict[str, str] = {}
    listing = ", ".join(found) if found else "nothing"
    for canon, name in mapping.items():
        if name not in found:
            raise _fail(f"{where}: {kind} {name!r} (mapped to {canon}) not found; found: {listing}")
        used[canon] = name
    taken = set(used.values())
    explicit_input = "u" in mapping or "v" in mapping
    for canon in CANONICAL_COLUMNS:
        if canon in used or (canon in ("u", "v") and explicit_input):
            continue
        if canon in found and canon not in taken:
            used[canon] = canon
            taken.add(canon)
        elif canon == "t":
            alias = next((a for a in time_aliases if a in found and a not in taken), None)
            if alias is not None:
                used["t"] = alias
                taken.add(alias)
    missing = [c for c in REQUIRED_COLUMNS if c not in used]
    if missing:
        plural = "s" if len(missing) > 1 else ""
        raise _fail(
            f"{where}: missing required {kind}{plural} {', '.join(missing)}; found: {listing} "
            f"(map other names with mapping= / --map, e.g. t=time,q1=theta,q2=phi)"
        )
    if "u" in used and "v" in used:
        raise _fail(
            f"{where}: both input {kind}s u ({used['u']!r}) and v ({used['v']!r}) present; "
            "a log holds at most one input (u: dead-zone-compensated, v: raw motor-driver input)"
        )
    leftovers = [name for name in found if name not in taken]
    return used, leftovers


def _check_leftover_name(name: str, used: dict[str, str], where: str, kind: str) -> None:
    if name in CANONICAL_COLUMNS:
        given = ", ".join(f"{k}={v}" for k, v in used.items() if v != k)
        raise _fail(
            f"{where}: {kind} {name!r} is not used (mapping: {given or 'none'}) but has a "
            f"reserved iwp name; a log holds at most one input and one column per iwp name"
        )


def _finish(
    cols: dict[str, np.ndarray],
    used: dict[str, str],
    extras: list[str],
    *,
    source: str,
    locate: Callable[[int, str], str],
    metadata: dict[str, str],
    degrees: bool,
    resample: bool,
    min_samples: int,
    sampling_tol: float,
    no_rows: str | None = None,
) -> ExperimentData:
    """Checks common to all time-series readers, then build the log.

    ``cols`` maps file column names to float arrays; ``locate(i, file_name)``
    describes sample ``i`` (0-based) of a column for messages.
    """
    n = len(cols[used["t"]])
    if n == 0:
        raise _fail(no_rows or f"{source}: no data")
    for name, arr in cols.items():
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            i = int(bad[0])
            raise _fail(f"{locate(i, name)}: {float(arr[i])!r} is not a finite number (NaN or inf)")
    if n < min_samples:
        raise _fail(
            f"{source}: {n} sample(s), at least {min_samples} are needed (min_samples)"
        )
    tname = used["t"]
    t = cols[tname]
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise _fail(
            f"{locate(i, tname)}: time not strictly increasing (t = {float(t[i])!r} s after "
            f"{float(t[i - 1])!r} s)"
        )
    if not resample:
        med = float(np.median(dt))
        dev = np.abs(dt - med) / med
        bad = np.flatnonzero(dev > sampling_tol)
        if bad.size:
            i = int(bad[0]) + 1
            raise _fail(
                f"{locate(i, tname)}: irregular sampling: step {float(dt[i - 1])!r} s differs from the "
                f"median step {med!r} s by {100 * dev[i - 1]:.3g}% (tolerance "
                f"{100 * sampling_tol:.3g}%); pass resample=True (--resample) to interpolate "
                "onto a uniform grid"
            )
    fields: dict[str, np.ndarray] = {canon: cols[name] for canon, name in used.items()}
    if degrees:
        for canon in _ANGLES:
            if canon in fields:
                fields[canon] = np.deg2rad(fields[canon])
    else:
        _warn_if_degrees(fields["q1"], source, used["q1"])
    data = ExperimentData(
        **fields,
        extra={name: cols[name] for name in extras},
        metadata=metadata,
        source=source,
    )
    if resample:
        data = data.resample()
    return data


def _warn_if_degrees(q1: np.ndarray, source: str, column: str, hint: str | None = None) -> None:
    """Warn if a pendulum angle [rad] peaks above 3*pi: likely degrees."""
    peak = float(np.max(np.abs(q1))) if q1.size else 0.0
    if peak > DEGREES_THRESHOLD:
        warnings.warn(
            f"{source}: column {column!r}{'' if column == 'q1' else ' (q1)'} looks like degrees (peak |q1| = {peak:.4g} > "
            f"3*pi rad); convert with {hint or '--degrees / degrees=True'}",
            UserWarning,
            stacklevel=4,
        )


def _check_read_options(min_samples: int, sampling_tol: float) -> tuple[int, float]:
    if isinstance(min_samples, bool) or not isinstance(min_samples, (int, np.integer)):
        raise InputError(f"min_samples must be an integer >= 2, got {min_samples!r}")
    if min_samples < 2:
        raise InputError(f"min_samples must be >= 2, got {min_samples!r}")
    return int(min_samples), check_positive("sampling_tol", sampling_tol)


# --------------------------------------------------------------------------
# CSV
# --------------------------------------------------------------------------
def read_csv(
    path: str | os.PathLike,
    *,
    mapping: Mapping[str, str] | None = None,
    degrees: bool = False,
    resample: bool = False,
    min_samples: int = 10,
    sampling_tol: float = 0.01,
) -> ExperimentData:
    """Read an iwp time-series CSV.

    Format: ``# key: value`` lines (anywhere; other comment lines and blank
    lines are ignored) hold the metadata; the first other line is the header
    (comma-separated; tab, semicolon or blanks are accepted if the header has
    no comma); then one row per sample. Required columns ``t`` [s], ``q1``,
    ``q2`` [rad]; optional ``q3``, ``q4`` [rad/s]; at most one input column,
    ``u`` or ``v`` (none: zero input); any other column goes to
    :attr:`ExperimentData.extra`.

    Parameters
    ----------
    path : str or path-like
        The file.
    mapping : dict, optional
        iwp name -> column name in the file, for files with other names,
        e.g. ``{"t": "time", "q1": "theta"}``. Unmapped iwp names are looked
        up under their own name.
    degrees : bool, optional
        Angles ``q1``, ``q2`` are in [deg] and velocities ``q3``, ``q4`` in
        [deg/s]; convert them to [rad] and [rad/s].
    resample : bool, optional
        Accept irregular sampling and interpolate every column linearly onto a
        uniform grid with the median step (see :meth:`ExperimentData.resample`).
    min_samples : int, optional
        Fewest samples accepted (default 10).
    sampling_tol : float, optional
        Largest accepted relative deviation of a time step from the median
        step (default 0.01, i.e. 1%) when ``resample`` is False.

    Returns
    -------
    ExperimentData

    Raises
    ------
    DataFormatError
        One line naming the file, the line (1-based) and the column: empty or
        binary file, no header, duplicated or missing columns, both ``u`` and
        ``v``, a row of the wrong length, text where a number belongs, NaN or
        inf, time not strictly increasing, irregular sampling, too few samples.

    Warns
    -----
    UserWarning
        If ``q1`` looks like degrees (peak ``|q1| > 3*pi``) and ``degrees`` is
        False.
    """
    min_samples, sampling_tol = _check_read_options(min_samples, sampling_tol)
    mapping = _check_mapping(mapping)
    table = _Table(path)
    src = table.source
    used, leftovers = _resolve_columns(table.header, mapping, table.where())
    for name in leftovers:
        _check_leftover_name(name, used, table.where(), "column")
    if not table.lines:
        raise _fail(f"{src}: no data rows after the header (line {table.header_line})")
    values = table.numbers()
    cols = {name: values[:, j].copy() for j, name in enumerate(table.header)}
    lines = table.lines

    def locate(i: int, name: str) -> str:
        return f"{src}, line {lines[i]}, column {name!r}"

    return _finish(
        cols, used, leftovers, source=src, locate=locate, metadata=table.metadata,
        degrees=degrees, resample=resample, min_samples=min_samples, sampling_tol=sampling_tol,
    )


def _atomic_write(path: Path, write: Callable[[Path], None]) -> Path:
    """Write through a temporary file in the same folder, then rename."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def _csv_text(metadata: Mapping[str, str], cols: Mapping[str, np.ndarray]) -> str:
    out = [f"# {k}: {v}".rstrip() + "\n" for k, v in metadata.items()]
    out.append(",".join(cols) + "\n")
    rows = np.column_stack(list(cols.values())).tolist()
    # repr(float) is the shortest string that reads back to the same double.
    out.extend(",".join(map(repr, row)) + "\n" for row in rows)
    return "".join(out)


def write_csv(data: ExperimentData, path: str | os.PathLike, force: bool = False) -> Path:
    """Write a log as an iwp CSV (bit-exact round trip with :func:`read_csv`).

    Metadata first as ``# key: value`` lines, then the header (canonical
    columns in the order ``t,q1,q2,q3,q4,u|v``, then the extra columns), then
    one row per sample with every float written as its shortest exact
    representation (``repr``).

    Parameters
    ----------
    data : ExperimentData
    path : str or path-like
    force : bool, optional
        Overwrite an existing file.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    OutputExistsError
        If ``path`` exists and ``force`` is False.
    """
    if not isinstance(data, ExperimentData):
        raise InputError(f"data must be an ExperimentData, got {type(data).__name__}")
    p = prepare_output_file(path, force)
    text = _csv_text(data.metadata, data.as_columns())
    return _atomic_write(p, lambda tmp: tmp.write_text(text, encoding="utf-8"))


# --------------------------------------------------------------------------
# static curves
# --------------------------------------------------------------------------
def read_static_curve(path: str | os.PathLike, *, min_points: int = 2) -> StaticCurve:
    """Read a static input / steady-state disk-velocity curve.

    CSV with ``# key: value`` metadata lines, a header ``v,q4`` (raw input) or
    ``u,q4`` (compensated input), one row per steady state: the constant
    input [input units] and the disk velocity reached [rad/s]. Rows need not
    be sorted; repeated inputs are allowed.

    Parameters
    ----------
    path : str or path-like
    min_points : int, optional
        Fewest rows accepted (default 2).

    Returns
    -------
    StaticCurve

    Raises
    ------
    DataFormatError
        One line naming the file, line and column (missing or unexpected
        column, both ``u`` and ``v``, text, NaN/inf, too few rows, ...).
    """
    if isinstance(min_points, bool) or not isinstance(min_points, (int, np.integer)) or min_points < 1:
        raise InputError(f"min_points must be an integer >= 1, got {min_points!r}")
    table = _Table(path)
    src, where = table.source, table.where()
    found = table.header
    listing = ", ".join(found)
    inputs = [c for c in ("v", "u") if c in found]
    if "q4" not in found or not inputs:
        missing = [c for c in ("v or u", "q4") if not (inputs if c != "q4" else "q4" in found)]
        raise _fail(
            f"{where}: missing required column(s) {', '.join(missing)}; found: {listing} "
            "(a static curve has columns v,q4 or u,q4)"
        )
    if len(inputs) == 2:
        raise _fail(f"{where}: both input columns u and v present; a static curve has one")
    for name in found:
        if name not in ("q4", inputs[0]):
            raise _fail(
                f"{where}: unexpected column {name!r}; a static curve has columns v,q4 or u,q4"
                + (" (this looks like a time series: use read_experiment)" if name == "t" else "")
            )
    if not table.lines:
        raise _fail(f"{src}: no data rows after the header (line {table.header_line})")
    values = table.numbers()
    for j, name in enumerate(found):
        bad = np.flatnonzero(~np.isfinite(values[:, j]))
        if bad.size:
            i = int(bad[0])
            raise _fail(
                f"{src}, line {table.lines[i]}, column {name!r}: {float(values[i, j])!r} is not a "
                "finite number (NaN or inf)"
            )
    if len(table.lines) < min_points:
        raise _fail(f"{src}: {len(table.lines)} point(s), at least {min_points} are needed (min_points)")
    return StaticCurve(
        input_name=inputs[0],
        input=values[:, found.index(inputs[0])],
        q4=values[:, found.index("q4")],
        metadata=table.metadata,
        source=src,
    )


def write_static_curve(curve: StaticCurve, path: str | os.PathLike, force: bool = False) -> Path:
    """Write a :class:`StaticCurve` as CSV (bit-exact round trip).

    Parameters
    ----------
    curve : StaticCurve
    path : str or path-like
    force : bool, optional
        Overwrite an existing file.

    Returns
    -------
    pathlib.Path
    """
    if not isinstance(curve, StaticCurve):
        raise InputError(f"curve must be a StaticCurve, got {type(curve).__name__}")
    p = prepare_output_file(path, force)
    text = _csv_text(curve.metadata, {curve.input_name: curve.input, "q4": curve.q4})
    return _atomic_write(p, lambda tmp: tmp.write_text(text, encoding="utf-8"))


# --------------------------------------------------------------------------
# Parquet
# --------------------------------------------------------------------------
def _pyarrow(action: str):
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise InputError(
            f"{action} Parquet needs pyarrow: pip install pyarrow (or pip install iwp[parquet])"
        ) from None
    return pa, pq


def read_parquet(
    path: str | os.PathLike,
    *,
    mapping: Mapping[str, str] | None = None,
    degrees: bool = False,
    resample: bool = False,
    min_samples: int = 10,
    sampling_tol: float = 0.01,
) -> ExperimentData:
    """Read a log from a Parquet file (needs ``pyarrow``).

    Same columns and checks as :func:`read_csv` (places are given as 1-based
    rows); every column must be numeric without nulls. Metadata is read from
    the schema key ``iwp.metadata`` (JSON object) written by
    :func:`write_parquet`; other schema metadata (e.g. pandas') is ignored, as
    are pandas index columns ``__index_level_*__``.

    Parameters
    ----------
    path, mapping, degrees, resample, min_samples, sampling_tol
        As for :func:`read_csv`.

    Returns
    -------
    ExperimentData

    Raises
    ------
    InputError
        If pyarrow is not installed.
    DataFormatError
        As for :func:`read_csv`, and for a file that is not Parquet.
    """
    min_samples, sampling_tol = _check_read_options(min_samples, sampling_tol)
    mapping = _check_mapping(mapping)
    pa, pq = _pyarrow("reading")
    p, src = _check_input_file(path)
    try:
        table = pq.read_table(p)
    except Exception as exc:  # pyarrow raises ArrowInvalid, OSError, ...
        raise _fail(f"{src}: not a readable Parquet file ({type(exc).__name__}: {exc})") from None
    names = [n for n in table.column_names if not re.fullmatch(r"__index_level_\d+__", n)]
    seen = set()
    for name in names:
        if name in seen:
            raise _fail(f"{src}: duplicated column name {name!r}")
        seen.add(name)
    used, leftovers = _resolve_columns(names, mapping, src)
    for name in leftovers:
        _check_leftover_name(name, used, src, "column")
    cols: dict[str, np.ndarray] = {}
    for name in names:
        col = table.column(name)
        if not (
            pa.types.is_floating(col.type)
            or pa.types.is_integer(col.type)
            or pa.types.is_boolean(col.type)
            or pa.types.is_decimal(col.type)
        ):
            raise _fail(f"{src}, column {name!r}: type {col.type} where numbers belong")
        if col.null_count:
            mask = col.is_null().to_numpy(zero_copy_only=False)
            i = int(np.flatnonzero(mask)[0])
            raise _fail(f"{src}, row {i + 1}, column {name!r}: missing value (null)")
        cols[name] = np.asarray(col.to_numpy(), dtype=np.float64)
    metadata: dict[str, str] = {}
    schema_md = table.schema.metadata or {}
    if _PARQUET_METADATA_KEY in schema_md:
        try:
            raw = json.loads(schema_md[_PARQUET_METADATA_KEY].decode("utf-8"))
            if not isinstance(raw, dict):
                raise ValueError("not an object")
        except (ValueError, UnicodeDecodeError) as exc:
            raise _fail(f"{src}: schema metadata 'iwp.metadata' is not a JSON object ({exc})") from None
        metadata = {str(k): str(v) for k, v in raw.items()}

    def locate(i: int, name: str) -> str:
        return f"{src}, row {i + 1}, column {name!r}"

    return _finish(
        cols, used, leftovers, source=src, locate=locate, metadata=metadata,
        degrees=degrees, resample=resample, min_samples=min_samples, sampling_tol=sampling_tol,
        no_rows=f"{src}: no data rows",
    )


def write_parquet(data: ExperimentData, path: str | os.PathLike, force: bool = False) -> Path:
    """Write a log as Parquet (float64 columns; metadata in the schema).

    The metadata dict is stored as JSON under the schema key
    ``iwp.metadata``. Needs ``pyarrow``.

    Parameters
    ----------
    data : ExperimentData
    path : str or path-like
    force : bool, optional
        Overwrite an existing file.

    Returns
    -------
    pathlib.Path
    """
    if not isinstance(data, ExperimentData):
        raise InputError(f"data must be an ExperimentData, got {type(data).__name__}")
    pa, pq = _pyarrow("writing")
    p = prepare_output_file(path, force)
    cols = data.as_columns()
    table = pa.table({name: pa.array(arr, type=pa.float64()) for name, arr in cols.items()})
    table = table.replace_schema_metadata(
        {_PARQUET_METADATA_KEY: json.dumps(data.metadata).encode("utf-8")}
    )
    return _atomic_write(p, lambda tmp: pq.write_table(table, str(tmp)))


# --------------------------------------------------------------------------
# MATLAB
# --------------------------------------------------------------------------
def _is_mat_struct(value: Any) -> bool:
    return hasattr(value, "_fieldnames")


def _struct_fields(value: Any) -> dict[str, Any]:
    return {name: getattr(value, name) for name in value._fieldnames}


def _flatten_simulink(container: dict[str, Any]) -> dict[str, Any]:
    """Expand a Simulink 'structure with time' (``time`` + ``signals(k).values``)."""
    signals = container.get("signals")
    if signals is None:
        return container
    items = [signals] if _is_mat_struct(signals) else list(np.atleast_1d(signals))
    if not items or not all(_is_mat_struct(s) and "values" in s._fieldnames for s in items):
        return container
    out = {k: v for k, v in container.items() if k != "signals"}
    for k, sig in enumerate(items, start=1):
        label = ""
        for attr in ("label", "blockName"):
            text = getattr(sig, attr, "")
            if isinstance(text, str) and text.strip():
                label = text.strip().split("/")[-1]
                break
        label = label or f"signal{k}"
        values = np.asarray(sig.values)
        if values.ndim == 2 and values.shape[1] > 1:
            for j in range(values.shape[1]):
                out[f"{label}_{j + 1}"] = values[:, j]
        else:
            out[label] = values
    return out


def _mat_vector(value: Any, where: str) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype.kind not in "biuf":
        kind = "text" if arr.dtype.kind in "US" else ("complex" if arr.dtype.kind == "c" else "not numeric")
        raise _fail(f"{where}: {kind}; expected a numeric vector (one value per sample)")
    arr = np.atleast_1d(np.squeeze(arr))
    if arr.ndim != 1:
        raise _fail(f"{where}: a {'x'.join(map(str, arr.shape))} array; expected a vector")
    return arr.astype(np.float64)


def _parse_metadata_text(text: Any) -> dict[str, str]:
    if isinstance(text, np.ndarray):
        text = "\n".join(str(s) for s in np.atleast_1d(text))
    out: dict[str, str] = {}
    for line in str(text).split("\n"):
        kv = _parse_comment("#" + line)
        if kv is not None:
            out[kv[0]] = kv[1]
    return out


def read_mat(
    path: str | os.PathLike,
    mapping: Mapping[str, str] | None = None,
    struct: str | None = None,
    *,
    degrees: bool = False,
    resample: bool = False,
    min_samples: int = 10,
    sampling_tol: float = 0.01,
) -> ExperimentData:
    """Read a log from a MATLAB ``.mat`` file (v4 to v7.2; not v7.3/HDF5).

    The signals are either top-level variables or the fields of one struct
    (``struct=``; with ``struct=None`` and the needed names not at top level,
    the only struct in the file is used if there is exactly one). A Simulink
    "structure with time" (``time`` plus ``signals(k).values`` / ``.label``)
    is understood: each signal is named by its label. Vectors may be rows or
    columns. The time may also be called ``time``.

    Other numeric vectors of the same length go to
    :attr:`ExperimentData.extra`; scalars, text and matrices are ignored. A
    text variable ``iwp_metadata`` of ``key: value`` lines (as written by
    :func:`write_mat`) becomes the metadata.

    Parameters
    ----------
    path : str or path-like
    mapping : dict, optional
        iwp name -> variable (field) name, e.g. ``{"t": "time", "q1":
        "theta", "q2": "phi", "u": "u"}``; unmapped iwp names are looked up
        under their own names.
    struct : str, optional
        Name of the struct holding the signals (dotted for nested structs,
        e.g. ``"log.data"``).
    degrees, resample, min_samples, sampling_tol
        As for :func:`read_csv`.

    Returns
    -------
    ExperimentData

    Raises
    ------
    DataFormatError
        Naming the file, the variable and the sample (1-based).
    """
    min_samples, sampling_tol = _check_read_options(min_samples, sampling_tol)
    mapping = _check_mapping(mapping)
    p, src = _check_input_file(path)
    from scipy.io import loadmat

    try:
        variables = loadmat(str(p), squeeze_me=True, struct_as_record=False, chars_as_strings=True)
    except NotImplementedError:
        raise _fail(
            f"{src}: MATLAB v7.3 (HDF5) files are not supported; save with "
            "save(..., '-v7') or export to CSV"
        ) from None
    except Exception as exc:  # scipy raises ValueError, MatReadError, TypeError, ...
        raise _fail(f"{src}: not a readable MATLAB .mat file ({type(exc).__name__}: {exc})") from None
    top = {k: v for k, v in variables.items() if not k.startswith("__")}
    needed = [mapping.get(c, c) for c in REQUIRED_COLUMNS]
    prefix = ""
    if struct is not None:
        if not isinstance(struct, str) or not struct:
            raise InputError(f"struct must be a variable name, got {struct!r}")
        parts = struct.split(".")
        if parts[0] not in top:
            raise _fail(f"{src}: no variable {parts[0]!r}; found: {', '.join(top) or 'nothing'}")
        node = top[parts[0]]
        for k, part in enumerate(parts):
            if k:
                if not _is_mat_struct(node) or part not in node._fieldnames:
                    raise _fail(f"{src}: struct {'.'.join(parts[:k])!r} has no field {part!r}")
                node = getattr(node, part)
            if not _is_mat_struct(node):
                raise _fail(f"{src}: variable {'.'.join(parts[:k + 1])!r} is not a struct")
        container = _struct_fields(node)
        prefix = struct + "."
    else:
        container = top
        structs = [k for k, v in top.items() if _is_mat_struct(v)]
        has_all = all(n in top or (n == "t" and "time" in top) for n in needed)
        if not has_all and len(structs) == 1:
            container = _struct_fields(top[structs[0]])
            prefix = structs[0] + "."
    metadata_value = container.pop(_MAT_METADATA, None)
    if metadata_value is None:
        metadata_value = top.get(_MAT_METADATA)
    container = _flatten_simulink(container)
    where = src if not prefix else f"{src}, struct {prefix[:-1]!r}"
    used, leftovers = _resolve_columns(list(container), mapping, where, kind="variable", time_aliases=("time",))
    cols: dict[str, np.ndarray] = {}
    for canon, name in used.items():
        cols[name] = _mat_vector(container[name], f"{src}, variable {prefix + name!r} ({canon})")
    n = cols[used["t"]].size
    for canon, name in used.items():
        if cols[name].size != n:
            raise _fail(
                f"{src}, variable {prefix + name!r} ({canon}): {cols[name].size} samples but "
                f"{prefix + used['t']!r} (t) has {n}"
            )
    extras = []
    for name in leftovers:
        arr = np.asarray(container[name]) if not _is_mat_struct(container[name]) else None
        if arr is None or arr.dtype.kind not in "biuf":
            continue
        arr = np.atleast_1d(np.squeeze(arr))
        if arr.ndim != 1 or arr.size != n or n < 2:
            continue
        _check_leftover_name(name, used, where, "variable")
        if any(c in name for c in ',"\n\r') or name.startswith("#"):
            continue
        cols[name] = arr.astype(np.float64)
        extras.append(name)
    metadata = _parse_metadata_text(metadata_value) if metadata_value is not None else {}

    def locate(i: int, name: str) -> str:
        return f"{src}, variable {prefix + name!r}, sample {i + 1}"

    return _finish(
        cols, used, extras, source=src, locate=locate, metadata=metadata,
        degrees=degrees, resample=resample, min_samples=min_samples, sampling_tol=sampling_tol,
        no_rows=f"{src}: variable {prefix + used['t']!r} (t) is empty",
    )


def write_mat(data: ExperimentData, path: str | os.PathLike, force: bool = False) -> Path:
    """Write a log as a MATLAB v5 ``.mat`` file (bit-exact round trip).

    Top-level column vectors with the canonical names (``t``, ``q1``, ...),
    the extra columns under their own names (which must be valid MATLAB
    names), and the metadata as the text variable ``iwp_metadata`` of
    ``key: value`` lines.

    Parameters
    ----------
    data : ExperimentData
    path : str or path-like
    force : bool, optional
        Overwrite an existing file.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    InputError
        If an extra column name is not a valid MATLAB variable name.
    """
    if not isinstance(data, ExperimentData):
        raise InputError(f"data must be an ExperimentData, got {type(data).__name__}")
    for name in data.extra:
        if not _MAT_NAME.match(name) or name == _MAT_METADATA:
            raise InputError(
                f"extra column {name!r} cannot be a MATLAB variable name (letters, digits, "
                "'_', starting with a letter, at most 63 characters); rename it"
            )
    p = prepare_output_file(path, force)
    from scipy.io import savemat

    out: dict[str, Any] = {name: np.asarray(arr) for name, arr in data.as_columns().items()}
    if data.metadata:
        out[_MAT_METADATA] = "\n".join(f"{k}: {v}" for k, v in data.metadata.items())

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            savemat(fh, out, oned_as="column", do_compression=True)

    return _atomic_write(p, write)


# --------------------------------------------------------------------------
# third-party angle log
# --------------------------------------------------------------------------
def read_angle_log(
    path: str | os.PathLike,
    angle_unit: str = "deg",
    sample_rate: float | None = None,
    zero: str = "down",
    *,
    min_samples: int = 10,
) -> ExperimentData:
    """Read a free-swing angle log: a header line, a values line, one angle a line.

    Format (as written by some rotary-pendulum rigs)::

        trigger_start_deg, sample_rate, duration_sec
        90, 1000, 5
        -90.36
        -90.64
        ...

    Line 1 names the header values, line 2 gives them (both comma-separated);
    every further non-blank line holds one pendulum angle, sampled at
    ``sample_rate`` [Hz]. The header pairs become the metadata (plus
    ``source_format: angle-log``).

    Parameters
    ----------
    path : str or path-like
    angle_unit : {'deg', 'rad'}, optional
        Unit of the angles in the file (default degrees).
    sample_rate : float, optional
        Sampling rate [Hz]; default: the header value ``sample_rate``.
    zero : {'down', 'up'}, optional
        Where the file's zero angle is: ``'down'`` (pendulum hanging down, as
        iwp) or ``'up'`` (upright; pi is added so that iwp's zero is down).
    min_samples : int, optional
        Fewest samples accepted (default 10).

    Returns
    -------
    ExperimentData
        ``t = k / sample_rate`` [s] from 0, ``q1`` [rad], ``q2`` zeros (no
        wheel), no velocities, no input (free pendulum).

    Raises
    ------
    DataFormatError
        Naming the file, line and column (empty/binary file, bad header, no
        sample rate, text or NaN where an angle belongs, too few samples).
    """
    if angle_unit not in ("deg", "rad"):
        raise InputError(f"angle_unit must be 'deg' or 'rad', got {angle_unit!r}")
    if zero not in ("down", "up"):
        raise InputError(f"zero must be 'down' or 'up', got {zero!r}")
    min_samples, _ = _check_read_options(min_samples, 0.01)
    src, lines = _read_text_lines(path)
    numbered = [(k, ln.strip()) for k, ln in enumerate(lines, start=1) if ln.strip()]
    if len(numbered) < 2:
        raise _fail(f"{src}: expected a header line and a values line, found {len(numbered)} line(s)")
    (l1, names_line), (l2, values_line) = numbered[0], numbered[1]
    names = [s.strip() for s in names_line.split(",")]
    values = [s.strip() for s in values_line.split(",")]
    for name in names:
        try:
            float(name)
        except ValueError:
            continue
        raise _fail(
            f"{src}, line {l1}: expected a header of names (e.g. trigger_start_deg, sample_rate, "
            f"duration_sec), found the number {name!r}"
        )
    if any(not n for n in names):
        raise _fail(f"{src}, line {l1}: empty name in the header")
    if len(values) != len(names):
        raise _fail(f"{src}, line {l2}: {len(values)} value(s) but line {l1} names {len(names)}")
    header: dict[str, str] = {}
    for name, value in zip(names, values):
        try:
            float(value)
        except ValueError:
            raise _fail(f"{src}, line {l2}, column {name!r}: {value!r} is not a number") from None
        header[name.replace(":", "_")] = value
    if sample_rate is None:
        if "sample_rate" not in header:
            raise _fail(
                f"{src}, line {l1}: no 'sample_rate' in the header; pass sample_rate= "
                "(--sample-rate) [Hz]"
            )
        try:
            rate = check_positive("sample_rate", header["sample_rate"])
        except InputError as exc:
            raise _fail(f"{src}, line {l2}, column 'sample_rate': {exc}") from None
    else:
        rate = check_positive("sample_rate", sample_rate)
    data_lines = numbered[2:]
    angles = np.empty(len(data_lines))
    for i, (lineno, text) in enumerate(data_lines):
        try:
            angles[i] = float(text)
        except ValueError:
            what = "more than one value; expected one angle a line" if "," in text else f"{text!r} is not a number"
            raise _fail(f"{src}, line {lineno}, column 'angle': {what}") from None
        if not math.isfinite(angles[i]):
            raise _fail(f"{src}, line {lineno}, column 'angle': {text!r} is not a finite number (NaN or inf)")
    if angles.size < min_samples:
        raise _fail(f"{src}: {angles.size} sample(s), at least {min_samples} are needed (min_samples)")
    q1 = np.deg2rad(angles) if angle_unit == "deg" else angles
    if angle_unit == "rad":
        _warn_if_degrees(q1, src, "angle", hint="angle_unit='deg' (--angle-unit deg)")
    if zero == "up":
        q1 = q1 + math.pi
    metadata = dict(header)
    metadata["source_format"] = "angle-log"
    return ExperimentData(
        t=np.arange(angles.size) / rate,
        q1=q1,
        q2=np.zeros(angles.size),
        metadata=metadata,
        source=src,
    )


# --------------------------------------------------------------------------
# dispatch and conversion
# --------------------------------------------------------------------------
_READERS: dict[str, Callable[..., ExperimentData]] = {
    "csv": read_csv,
    "mat": read_mat,
    "parquet": read_parquet,
    "angle-log": read_angle_log,
}
_WRITERS = {"csv": write_csv, "mat": write_mat, "parquet": write_parquet}


def _format_of(path: str | os.PathLike, kinds: dict[str, Any], what: str) -> str:
    ext = Path(path).suffix.lower()
    fmt = _EXTENSIONS.get(ext)
    if fmt is None or fmt not in kinds:
        known = ", ".join(e for e, f in _EXTENSIONS.items() if f in kinds)
        raise InputError(
            f"{path}: cannot tell the {what} format from the extension {ext or '(none)'!r}; "
            f"use one of {known} or give the format ({', '.join(kinds)})"
        )
    return fmt


def read_experiment(path: str | os.PathLike, format: str | None = None, **kw) -> ExperimentData:
    """Read a log, choosing the reader from ``format`` or the file extension.

    ``.csv``/``.txt``: :func:`read_csv`; ``.mat``: :func:`read_mat`;
    ``.parquet``/``.pq``: :func:`read_parquet`. The angle log (also ``.txt``)
    must be asked for with ``format="angle-log"`` (:func:`read_angle_log`).

    Parameters
    ----------
    path : str or path-like
    format : {'csv', 'mat', 'parquet', 'angle-log'}, optional
        Overrides the extension.
    **kw
        Options of the chosen reader (``mapping``, ``struct``, ``degrees``,
        ``resample``, ``min_samples``, ``sampling_tol``, ``angle_unit``,
        ``sample_rate``, ``zero``).

    Returns
    -------
    ExperimentData

    Raises
    ------
    InputError
        Unknown format/extension, or an option the chosen reader does not take.
    DataFormatError
        From the reader.
    """
    if format is None:
        fmt = _format_of(path, _READERS, "input")
    elif format in _READERS:
        fmt = format
    else:
        raise InputError(f"format must be one of {', '.join(_READERS)}, got {format!r}")
    reader = _READERS[fmt]
    accepted = set(inspect.signature(reader).parameters) - {"path"}
    unknown = sorted(set(kw) - accepted)
    if unknown:
        raise InputError(
            f"option(s) {', '.join(unknown)} do not apply to {fmt} files "
            f"(accepted: {', '.join(sorted(accepted))})"
        )
    return reader(path, **kw)


def write_experiment(
    data: ExperimentData, path: str | os.PathLike, format: str | None = None, force: bool = False
) -> Path:
    """Write a log, choosing the writer from ``format`` or the extension.

    Parameters
    ----------
    data : ExperimentData
    path : str or path-like
    format : {'csv', 'parquet', 'mat'}, optional
        Overrides the extension (``.csv``/``.txt``, ``.parquet``/``.pq``, ``.mat``).
    force : bool, optional
        Overwrite an existing file.

    Returns
    -------
    pathlib.Path
    """
    if format is None:
        fmt = _format_of(path, _WRITERS, "output")
    elif format in _WRITERS:
        fmt = format
    else:
        raise InputError(f"output format must be one of {', '.join(_WRITERS)}, got {format!r}")
    return _WRITERS[fmt](data, path, force=force)


def convert(
    src: str | os.PathLike,
    dst: str | os.PathLike,
    *,
    from_format: str | None = None,
    to_format: str | None = None,
    force: bool = False,
    t_start: float | None = None,
    t_end: float | None = None,
    **read_options,
) -> ExperimentData:
    """Read a log in any supported format and write it as iwp CSV/Parquet/MAT.

    Parameters
    ----------
    src : str or path-like
        Input file.
    dst : str or path-like
        Output file; its extension picks the format unless ``to_format``.
    from_format : {'csv', 'mat', 'parquet', 'angle-log'}, optional
        Input format; default from the extension of ``src``.
    to_format : {'csv', 'parquet', 'mat'}, optional
        Output format; default from the extension of ``dst``.
    force : bool, optional
        Overwrite ``dst`` if it exists (checked before reading).
    t_start, t_end : float, optional
        Keep only this time window [s] (see :meth:`ExperimentData.window`).
    **read_options
        Passed to the reader (see :func:`read_experiment`).

    Returns
    -------
    ExperimentData
        The log as written.
    """
    if to_format is None:
        _format_of(dst, _WRITERS, "output")
    prepare_output_file(dst, force)  # fail before reading if dst exists
    data = read_experiment(src, format=from_format, **read_options)
    data = data.window(t_start, t_end)
    write_experiment(data, dst, format=to_format, force=force)
    return data

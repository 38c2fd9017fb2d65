"""Reading another rig's log with its rig description (:mod:`iwp.data.rig_description`).

:func:`read_rig_log` reads a CSV or MATLAB ``.mat`` log whose columns are
named and scaled as the rig logs them (``t,u,theta,phidot,I``: an encoder
in counts or an IMU in degrees, the wheel's speed in rpm at the motor
shaft, a PWM duty, ...) and returns an :class:`~iwp.data.ExperimentData`
in iwp's units and conventions:

* time [s] (``ms``/``us`` scaled; none: ``k * sample_period``), checked
  against the description's ``sample_period``;
* ``q1`` [rad], 0 hanging down: ``sign * x * unit + zero - offset``,
  unwrapped where it steps by more than pi between two samples (a sensor
  that wraps at +-180 degrees) and moved by whole turns so that its median
  lies in (-pi, pi];
* the wheel's ``q2`` [rad] or ``q4`` [rad/s] relative to the arm (divided by
  the drive ratio when measured at the motor shaft); a speed sampled as
  the mean over the preceding period is marked ``q4_sampling: mean``;
* the current [A] as the extra column ``current``;
* the input as ``v`` (or ``u`` when the rig compensates the dead zone)
  in model units, ``scale * (clip(x, limits) - offset)``: logged values
  beyond the limits (a controller's output before saturation) are clipped
  as the driver clips them, counted and reported (warning and metadata),
  and the logged values are kept as the extra column ``input_logged``;
* glitches found and recorded (:meth:`ExperimentData.with_glitches_found`).

Mapping errors are one line naming the file, the description key and the
column: a missing column, a unit that cannot be right (encoder counts that
are not whole numbers, an angle declared in rad that spans more than 3 pi,
a time step of seconds that is a millisecond count, a wheel speed beyond
3000 rad/s, a current beyond 100 A, a PWM duty far outside [-1, 1]).

MATLAB ``timeseries`` objects (and other classdef objects) cannot be read:
:func:`scipy.io.loadmat` returns them as opaque data, and no reader on PyPI
reads them reliably (``mat-io`` 1.0.2 reads classdef objects but lists
``timeseries`` as not yet supported). Such variables are refused with the
MATLAB commands that export them as plain vectors.
"""

from __future__ import annotations

import math
import os
import warnings
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import DataFormatError, InputError
from .experiment import CANONICAL_COLUMNS, CURRENT_COLUMN, GLITCHES_KEY, Q4_SAMPLING_KEY, ExperimentData
from .mat_format import flatten_simulink, is_mat_struct, struct_fields
from .plausibility import SAMPLE_PERIOD_RANGE
from .rig_description import CURRENT_UNITS, TIME_UNITS, RigDescription, load_rig
from .tables import Table, check_input_file, check_read_options, fail, finish_log, warn_if_degrees

__all__ = ["read_rig_log", "MAX_WHEEL_SPEED", "MAX_CURRENT", "MAX_ODD_STEPS", "INPUT_LOGGED_COLUMN"]

#: A wheel (or motor) speed above this [rad/s] cannot be right (about 29,000 rpm).
MAX_WHEEL_SPEED = 3000.0
#: A motor current above this [A] cannot be right for a rig of this kind.
MAX_CURRENT = 100.0
#: More pendulum steps than this share of the samples (and than 2) that are neither motion nor a wrap around a
#: turn (between a half and one and a half turns in one sample) make the angle's unit wrong.
MAX_ODD_STEPS = 0.01
#: The logged input before clipping to its limits, kept as an extra column when something was clipped.
INPUT_LOGGED_COLUMN = "input_logged"


def _check_counts(raw: "_Raw", column: str, x: np.ndarray, fix: str) -> None:
    """Refuse a column declared in encoder counts that holds fractions (naming the sample and the fix)."""
    bad = np.flatnonzero(np.abs(x - np.round(x)) > 1e-6)
    if bad.size:
        i = int(bad[0])
        raise fail(f"{raw.locate(i, column)}: encoder counts must be whole numbers, found {float(x[i]):.10g}; {fix}")


class _Raw:
    """The named numeric columns of a log, and where each sample is (for messages)."""

    def __init__(self, source: str, columns: dict[str, np.ndarray], locate: Callable[[int, str], str],
                 metadata: dict[str, str], fmt: str, others: tuple[str, ...] = ()):
        self.source = source
        self.columns = columns
        self.locate = locate
        self.metadata = metadata
        self.format = fmt
        self.others = others  # what else the file holds, described (a MAT file's matrices)

    def get(self, column: str, key: str, rig: RigDescription) -> np.ndarray:
        if column not in self.columns:
            found = ", ".join([*self.columns, *self.others]) or "nothing"
            hint = ("; name a matrix's columns with the key 'matrix' of the rig description "
                    "(docs/rig-description.md)" if self.others and rig.matrix is None else "")
            raise fail(f"{self.source}: column {column!r} ({rig.source}: key {key!r}) not found; found: {found}"
                       f"{hint}")
        arr = self.columns[column]
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            i = int(bad[0])
            raise fail(f"{self.locate(i, column)}: {float(arr[i])} is not a finite number (NaN or inf)")
        return arr


def _read_csv_raw(path: str | os.PathLike) -> _Raw:
    tab = Table(path)
    data = tab.numbers()
    if data.shape[0] == 0:
        raise fail(f"{tab.source}: no data rows after the header ({tab.where()})")
    cols = {name: data[:, j].copy() for j, name in enumerate(tab.header)}
    lines = tab.lines

    def locate(i: int, name: str) -> str:
        return f"{tab.source}, line {lines[i]}, column {name!r}"

    return _Raw(tab.source, cols, locate, dict(tab.metadata), "csv")


def _read_mat_raw(path: str | os.PathLike, rig: RigDescription, struct: str | None) -> _Raw:
    p, src = check_input_file(path)
    from scipy.io import loadmat
    from scipy.io.matlab import MatlabOpaque

    try:
        variables = loadmat(str(p), squeeze_me=True, struct_as_record=False, chars_as_strings=True)
    except NotImplementedError:
        raise fail(f"{src}: MATLAB v7.3 (HDF5) files are not supported; save with save(..., '-v7') or export "
                   "to CSV") from None
    except Exception as exc:  # scipy raises ValueError, MatReadError, TypeError, ...
        raise fail(f"{src}: not a readable MATLAB .mat file ({type(exc).__name__}: {exc})") from None
    top = {k: v for k, v in variables.items() if not k.startswith("__")}
    wanted = [c for c in rig.columns().values()]
    container, prefix = top, ""
    if struct is not None:
        node: Any = top.get(struct.split(".")[0])
        for part in struct.split(".")[1:]:
            node = getattr(node, part, None) if is_mat_struct(node) else None
        if not is_mat_struct(node):
            raise fail(f"{src}: no struct {struct!r}; found: {', '.join(top) or 'nothing'}")
        container, prefix = struct_fields(node), struct + "."
    else:
        structs = [k for k, v in top.items() if is_mat_struct(v)]
        if not all(w in top for w in wanted) and len(structs) == 1:
            container, prefix = struct_fields(top[structs[0]]), structs[0] + "."
    for name, value in container.items():
        if isinstance(value, MatlabOpaque) and name in wanted:
            cls = _opaque_class(value)
            raise fail(
                f"{src}: variable {prefix + name!r} is a MATLAB {cls} object: scipy.io cannot read it, nor reliably "
                f"any reader on PyPI; export it in MATLAB: s.t = {name}.Time; s.{name} = {name}.Data; "
                "save('log.mat','-struct','s','-v7')")
    container = flatten_simulink(container)
    if rig.matrix is not None:
        return _matrix_raw(src, container, prefix, rig)
    cols: dict[str, np.ndarray] = {}
    others: list[str] = []
    for name, value in container.items():
        if is_mat_struct(value) or isinstance(value, MatlabOpaque):
            continue
        arr = np.asarray(value)
        if arr.dtype.kind not in "biuf":
            if name in wanted:
                raise fail(f"{src}, variable {prefix + name!r}: not numeric; expected one number per sample")
            continue
        arr = np.atleast_1d(np.squeeze(arr))
        if arr.ndim != 1:
            if name in wanted:
                raise fail(f"{src}, variable {prefix + name!r}: a {'x'.join(map(str, arr.shape))} array; "
                           "expected a vector")
            others.append(f"a {'x'.join(map(str, arr.shape))} {'matrix' if arr.ndim == 2 else 'array'} "
                          f"{prefix + name!r}")
            continue
        cols[name] = arr.astype(np.float64)
    if "time" in cols and rig.time.column == "t" and "t" not in cols:
        cols["t"] = cols.pop("time")
    lengths = {cols[w].size for w in wanted if w in cols}
    if len(lengths) > 1:
        sizes = ", ".join(f"{w}: {cols[w].size}" for w in wanted if w in cols)
        raise fail(f"{src}: the mapped variables differ in length ({sizes})")
    n = lengths.pop() if lengths else 0
    cols = {k: v for k, v in cols.items() if v.size == n}

    def locate(i: int, name: str) -> str:
        return f"{src}, variable {prefix + name!r}, sample {i + 1}"

    return _Raw(src, cols, locate, {}, "mat", tuple(others))


#: what MATLAB calls the contents of an array, by numpy's kind
_MATLAB_KINDS = {"b": "logical", "i": "integer", "u": "integer", "f": "numeric", "c": "complex", "O": "cell",
                 "U": "text", "S": "text", "V": "struct"}


def _what_array(arr: np.ndarray) -> str:
    """How a MATLAB user calls an array: ``an empty array``, ``a 2x3 cell array``, ``a text scalar``."""
    if arr.size == 0:
        return "an empty array"
    kind = _MATLAB_KINDS.get(arr.dtype.kind, "non-numeric")
    if arr.ndim == 0:
        return f"a {kind} scalar"
    shape = arr.shape if arr.ndim > 1 else (1, arr.size)  # MATLAB's arrays have two dimensions at least
    return f"a {'x'.join(map(str, shape))} {kind} array"


def _matrix_raw(src: str, container: dict, prefix: str, rig: RigDescription) -> _Raw:
    """The columns of the numeric matrix the rig description's ``matrix`` names (one column per signal, or one
    row per signal when only that orientation fits)."""
    spec = rig.matrix
    k = len(spec.columns)
    mats = {}
    for name, value in container.items():
        arr = np.asarray(value) if not is_mat_struct(value) else None
        if arr is not None and arr.dtype.kind in "biuf" and np.squeeze(arr).ndim == 2:
            mats[name] = np.squeeze(arr)
    held = ", ".join(f"a {'x'.join(map(str, m.shape))} matrix {prefix + n!r}" for n, m in mats.items()) or \
        "no two-dimensional numeric variable"
    if spec.variable is not None:
        if spec.variable not in container:
            raise fail(f"{src}: no variable {prefix + spec.variable!r} ({rig.source}: key 'matrix.variable'); "
                       f"found: {held}")
        if spec.variable not in mats:
            arr = np.asarray(container[spec.variable])
            raise fail(f"{src}: variable {prefix + spec.variable!r} is not a numeric matrix ({_what_array(arr)})")
        name = spec.variable
    else:
        if len(mats) != 1:
            raise fail(f"{src}: {rig.source} key 'matrix' gives no 'variable' and the file holds {held}; name the "
                       "matrix with 'matrix.variable'")
        name = next(iter(mats))
    m = mats[name]
    if m.shape[1] == k:
        data = m
    elif m.shape[0] == k:
        data = m.T
    else:
        raise fail(f"{src}: variable {prefix + name!r} is a {m.shape[0]}x{m.shape[1]} matrix but {rig.source} "
                   f"key 'matrix.columns' names {k} columns ({', '.join(spec.columns)})")
    data = data.astype(np.float64)
    cols = {c: data[:, j].copy() for j, c in enumerate(spec.columns)}

    def locate(i: int, col: str) -> str:
        j = spec.columns.index(col) + 1 if col in spec.columns else 0
        return f"{src}, matrix {prefix + name!r}, row {i + 1}, column {j} ({col!r})"

    return _Raw(src, cols, locate, {}, "mat")


def _opaque_class(value) -> str:
    try:
        rec = np.atleast_1d(value)[0]
        for f in ("s1", "s2", "s0"):
            text = rec[f]
            text = text.decode() if isinstance(text, bytes) else str(text)
            if text and text not in ("MCOS", "java", "handle"):
                return repr(text)
    except Exception:  # noqa: BLE001 - only for the message
        pass
    return "classdef"


def read_rig_log(
    path: str | os.PathLike,
    rig,
    *,
    format: str | None = None,
    struct: str | None = None,
    resample: bool = False,
    min_samples: int = 10,
    sampling_tol: float = 0.01,
    glitches: bool = True,
) -> ExperimentData:
    """Read a log of another rig with its rig description into iwp's units (see the module docstring).

    Parameters
    ----------
    path : str or path-like
        A CSV (``.csv``/``.txt``, header row of column names) or MATLAB ``.mat`` log.
    rig : RigDescription or path
        The rig description (a JSON file, ``--rig``).
    format : {"csv", "mat"}, optional
        Default: from the extension.
    struct : str, optional
        ``.mat``: the struct holding the variables (default: top level, or the only struct).
    resample, min_samples, sampling_tol
        As for :func:`iwp.data.read_csv`.
    glitches : bool
        Find, record and report glitches (:meth:`ExperimentData.with_glitches_found`).

    Returns
    -------
    ExperimentData

    Raises
    ------
    DataFormatError
        One line naming the file, the place and the column (and the description's key).
    InputError
        A bad rig description (naming its key).
    """
    rig = load_rig(rig)
    min_samples, sampling_tol = check_read_options(min_samples, sampling_tol)
    fmt = format
    if fmt is None:
        ext = Path(path).suffix.lower()
        fmt = {".csv": "csv", ".txt": "csv", ".mat": "mat"}.get(ext)
        if fmt is None and Path(path).is_dir():
            raise InputError(f"{path}: is a folder; give a log file in it (.csv, .txt or .mat)")
        if fmt is None:
            got = f"the extension {ext!r}" if ext else "a name without an extension"
            raise InputError(f"{path}: a log read with a rig description must be CSV (.csv, .txt) or MATLAB "
                             f"(.mat), got {got}")
    if fmt not in ("csv", "mat"):
        raise InputError(f"format must be 'csv' or 'mat' for a log read with a rig description, got {fmt!r}")
    if struct is not None and fmt != "mat":
        raise InputError("struct applies to .mat logs only")
    if rig.matrix is not None and fmt != "mat":
        raise InputError(f"{path}: {rig.source} key 'matrix' names the columns of a MATLAB matrix; this log is "
                         f"{fmt.upper()} (its header names its columns): drop 'matrix' or read the .mat log")
    raw = _read_csv_raw(path) if fmt == "csv" else _read_mat_raw(path, rig, struct)
    src = raw.source
    where = rig.source
    meta = dict(raw.metadata)
    cols: dict[str, np.ndarray] = {}
    used: dict[str, str] = {}

    # ---- time
    if rig.time.column is None:
        n = len(next(iter(raw.columns.values()))) if raw.columns else 0
        tname = "t" if "t" not in raw.columns else "t (from sample_period)"
        cols[tname] = rig.sample_period * np.arange(n)
    else:
        tname = rig.time.column
        cols[tname] = raw.get(tname, "time.column", rig) * TIME_UNITS[rig.time.unit]
    used["t"] = tname
    t = cols[tname]
    if t.size >= 2:
        dt = np.diff(t)
        med = float(np.median(dt))
        lo, hi = SAMPLE_PERIOD_RANGE  # the readers' plausible range, with the key to change named
        if med > 0 and not lo <= med <= hi:
            hint = "ms" if med > hi else "s"
            raise fail(f"{raw.locate(1, tname)}: a median time step of {med:.6g} s cannot be the sample period of "
                       f"a rig; is the time in {hint}? set 'time.unit' in {where}")
        if rig.sample_period is not None and med > 0 and abs(med - rig.sample_period) > 0.01 * rig.sample_period:
            raise fail(f"{raw.locate(1, tname)}: the median time step is {med:.6g} s but {where} gives "
                       f"'sample_period' {rig.sample_period:g} s")

    if rig.time.column is None:  # times from sample_period: a time column the log has anyway must agree
        for name in (k for k in ("t", "time", "Time", "timestamp") if k in raw.columns):
            d = np.diff(np.asarray(raw.columns[name], dtype=float))
            med = float(np.median(d)) if d.size else float("nan")
            if math.isfinite(med) and med > 0 and abs(med - rig.sample_period) > 0.01 * rig.sample_period:
                raise fail(f"{raw.locate(1, name)}: the log's column {name!r} steps by {med:.6g} but {where} gives "
                           f"'sample_period' {rig.sample_period:g} s and no time column; name it in 'time.column'")

    # ---- pendulum angle
    ps = rig.pendulum
    x = raw.get(ps.column, "pendulum.column", rig)
    if ps.unit == "counts":
        _check_counts(raw, ps.column, x, f"is the angle in rad or deg? set 'pendulum.unit' in {where}")
    if ps.unit == "rad" and x.size:
        # the readers' heuristic about the median: an angle swinging across it beyond 3 pi is degrees,
        # one that turned over (a swing-up, a spinning pendulum) only gets a warning
        warn_if_degrees(x - np.median(x), raw.source, ps.column, hint=f"'pendulum.unit' in {where}")
    q1 = ps.sign * x * ps.factor + ps.zero
    notes = []
    steps = np.diff(q1)
    big = np.flatnonzero(np.abs(steps) > math.pi)
    # a sensor that wraps steps by about a whole turn; a step of a half to one and a half turns is neither that
    # nor motion (a quarter turn in one sample), and many of them are a wrong unit (counts read as degrees)
    odd = big[np.abs(np.abs(steps[big]) - 2.0 * math.pi) > 0.5 * math.pi]
    if odd.size > max(2, MAX_ODD_STEPS * steps.size):
        k = int(odd[0])
        raw_step = float(x[k + 1] - x[k])
        raise fail(f"{raw.locate(k + 1, ps.column)}: the pendulum angle steps by {raw_step:.4g} {ps.unit} in one "
                   f"sample, and so at {odd.size} of {steps.size} samples: neither motion nor a sensor's wrap "
                   f"around a turn; is the unit right? (set 'pendulum.unit' in {where}: rad, deg or counts with "
                   "'counts_per_rev')")
    wraps = big.size
    if wraps:
        q1 = np.unwrap(q1)
        notes.append(f"q1 unwrapped at {wraps} sample(s) (the sensor wraps around a turn)")
        meta["q1_unwrapped"] = str(wraps)
    if ps.offset is not None:
        q1 = q1 - ps.offset
        meta["q1_offset"] = repr(ps.offset)
    else:
        meta["q1_offset"] = "estimate"
    turns = round(float(np.median(q1)) / (2.0 * math.pi))
    if turns:
        q1 = q1 - 2.0 * math.pi * turns
    cols[ps.column] = q1
    used["q1"] = ps.column

    # ---- wheel
    ws = rig.wheel
    w = raw.get(ws.column, "wheel.column", rig)
    if ws.unit == "counts":
        _check_counts(raw, ws.column, w, f"set 'wheel.unit' in {where}")
    f = ws.factor(rig.drive.ratio)
    if ws.quantity == "speed":
        at_sensor = np.abs(w - ws.bias) * ws.factor(1.0) * (rig.drive.ratio if ws.at == "motor" else 1.0)
        typical = float(np.percentile(at_sensor, 99.0)) if at_sensor.size else 0.0
        if typical > MAX_WHEEL_SPEED:
            raise fail(f"{raw.locate(int(np.argmax(at_sensor)), ws.column)}: a {ws.at} speed of {typical:.4g} "
                       f"rad/s (99th percentile) cannot be right; is it in rpm or deg/s? set 'wheel.unit' in "
                       f"{where}")
        cols[ws.column] = ws.sign * (w - ws.bias) * f
        used["q4"] = ws.column
        meta[Q4_SAMPLING_KEY] = ws.sampling
    else:
        cols[ws.column] = ws.sign * (w - ws.bias) * f
        used["q2"] = ws.column
    meta["wheel_sensor"] = f"{ws.quantity} at the {ws.at} ({ws.unit}, {ws.sampling})"
    meta["drive"] = f"{rig.drive.kind}, ratio {rig.drive.ratio:g}"

    # ---- current
    extras: list[str] = []
    if rig.current is not None:
        cs = rig.current
        c = cs.scale * (raw.get(cs.column, "current.column", rig) - cs.bias) * CURRENT_UNITS[cs.unit]
        peak = float(np.percentile(np.abs(c), 99.0)) if c.size else 0.0
        if peak > MAX_CURRENT:
            raise fail(f"{raw.locate(int(np.argmax(np.abs(c))), cs.column)}: a motor current of {peak:.4g} A (99th "
                       f"percentile) cannot be right; is it in mA? set 'current.unit' in {where}")
        cols[CURRENT_COLUMN] = c
        extras.append(CURRENT_COLUMN)

    # ---- input
    clipped_n = 0
    if rig.input is not None:
        ins = rig.input
        xin = raw.get(ins.column, "input.column", rig)
        if ins.kind == "duty":
            big = float(np.percentile(np.abs(xin), 95.0)) if xin.size else 0.0
            if big > 10.0:
                raise fail(f"{raw.locate(int(np.argmax(np.abs(xin))), ins.column)}: a PWM duty must lie in [-1, 1] "
                           f"(a controller's output before saturation a little beyond), but 95 % of the samples reach "
                           f"{big:.4g}; is it in counts or percent? set 'input.kind'/'input.scale' in {where}")
        if ins.kind == "dac" and ins.bits is not None:
            hi = 2 ** ins.bits - 1
            bad = np.flatnonzero((xin < 0) | (xin > hi))
            if bad.size:
                i = int(bad[0])
                raise fail(f"{raw.locate(i, ins.column)}: {float(xin[i]):.10g} is not a count of a {ins.bits}-bit DAC "
                           f"(0 to {hi}); check 'input.bits' in {where}")
        xc = xin
        if ins.limits is not None:
            lo, hi = ins.limits
            clipped = (xin < lo) | (xin > hi)
            clipped_n = int(np.count_nonzero(clipped))
            if clipped_n:
                xc = np.clip(xin, lo, hi)
                cols[INPUT_LOGGED_COLUMN] = xin.copy()
                extras.append(INPUT_LOGGED_COLUMN)
                notes.append(f"the input {ins.column!r} exceeds its limits [{lo:g}, {hi:g}] at {clipped_n} of "
                             f"{xin.size} samples (a controller's output before saturation): clipped as the driver "
                             f"clips it; the logged values are kept as {INPUT_LOGGED_COLUMN!r}")
                meta["input_saturated"] = f"{clipped_n} samples clipped to [{lo:g}, {hi:g}]"
        cols[ins.column] = ins.scale * (xc - ins.offset)
        used[ins.name] = ins.column
        meta["input_kind"] = ins.kind
        meta["input_scale"] = f"model input = {ins.scale:g} * (logged - {ins.offset:g})"
        if ins.limits is not None:
            meta["input_limits"] = f"[{ins.limits[0]:g}, {ins.limits[1]:g}]"

    # ---- other columns are kept
    taken = set(used.values()) | {c for c in (rig.current.column if rig.current else None,) if c}
    for name, arr in raw.columns.items():
        if name in taken or name in cols or name in CANONICAL_COLUMNS or name == CURRENT_COLUMN:
            continue
        if any(ch in name for ch in ',"\n\r') or name.startswith("#") or name != name.strip() or not name:
            continue
        if not np.all(np.isfinite(arr)):
            continue
        cols[name] = arr
        extras.append(name)
    meta.pop(GLITCHES_KEY, None)
    meta.setdefault("source_format", raw.format)
    meta["rig"] = rig.name or where
    try:
        data = finish_log(cols, used, extras, source=src, locate=raw.locate, metadata=meta, degrees=False,
                          resample=resample, min_samples=min_samples, sampling_tol=sampling_tol,
                          units_checked=True)
    except DataFormatError:
        raise
    except InputError as exc:
        raise fail(f"{src}: {exc}") from None
    for note in notes:
        warnings.warn(f"{src}: {note}", UserWarning, stacklevel=2)
    if glitches:
        data = data.with_glitches_found()
    return data

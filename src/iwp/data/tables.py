"""Reading tables of numbers: the shared machinery of the readers (internal to :mod:`iwp.data`).

Every reader checks what it reads and stops at the first problem with a
:class:`~iwp.errors.DataFormatError` whose one-line message names the file,
the place (CSV line number, 1-based; Parquet row; MAT variable and sample) and
the column.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from ..checks import check_positive
from ..errors import DataFormatError, InputError
from .experiment import (
    CANONICAL_COLUMNS,
    DEGREES_THRESHOLD,
    ExperimentData,
    missing_required,
)
from .plausibility import check_log_values

_ANGLES = ("q1", "q2", "q3", "q4")  # converted by degrees=True
#: Zero crossings of a pendulum angle beyond 3 pi that make it degrees, not a pendulum that turned over.
DEGREES_CROSSINGS = 4

# --------------------------------------------------------------------------
# shared reading machinery
# --------------------------------------------------------------------------
#: A message never echoes more than this many characters of a file.
MAX_MESSAGE = 300


def one_line(text: str) -> str:
    """``text`` on one line, cut to :data:`MAX_MESSAGE` characters."""
    text = " ".join(str(text).split())
    return text if len(text) <= MAX_MESSAGE else text[: MAX_MESSAGE - 3] + "..."


def fail(msg: str) -> DataFormatError:
    return DataFormatError(one_line(msg))


def check_input_file(path: str | os.PathLike) -> tuple[Path, str]:
    p = Path(path)
    src = str(path)
    if not p.exists():
        raise fail(f"{src}: no such file")
    if p.is_dir():
        raise fail(f"{src}: is a folder, expected a file")
    if p.stat().st_size == 0:
        raise fail(f"{src}: file is empty")
    return p, src


def read_text_lines(path: str | os.PathLike) -> tuple[str, list[str]]:
    """Read a text file; refuse empty and binary files. Returns (source, lines)."""
    p, src = check_input_file(path)
    raw = p.read_bytes()
    nul = raw.find(b"\x00")
    if nul >= 0:
        line = raw.count(b"\n", 0, nul) + 1
        raise fail(f"{src}, line {line}: binary file (NUL byte at offset {nul}); expected a text file")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise fail(
            f"{src}, line {line}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset "
            f"{exc.start}); binary file?"
        ) from None
    if not text.strip():
        raise fail(f"{src}: file is empty")
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in text.split("\n")]
    return src, lines


def parse_comment(line: str) -> tuple[str, str] | None:
    """``# key: value`` -> (key, value); None for other comments."""
    body = line.strip()[1:].strip()
    if ":" not in body:
        return None
    key, value = body.split(":", 1)
    key = key.strip()
    if not key:
        return None
    return key, value.strip()


def split_fields(line: str, delim: str | None) -> list[str]:
    return line.split(delim) if delim else line.split()


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


class Table:
    """Header, numeric rows and line numbers of a delimited text file."""

    def __init__(self, path):
        src, lines = read_text_lines(path)
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
                kv = parse_comment(stripped)
                if kv is not None:
                    self.metadata[kv[0]] = kv[1]
                continue
            if self.header is None:
                self.header_line = lineno
                self.delim = next((d for d in (",", "\t", ";") if d in stripped), None)
                self.header = [
                    f.strip().strip('"').strip() for f in split_fields(stripped, self.delim)
                ]
                if all(_is_number(name) for name in self.header):
                    raise fail(f"{src}, line {lineno}: no header row: the first row holds numbers; add a header "
                               "line naming the columns, e.g. t,q1,q2,u")
                for i, name in enumerate(self.header):
                    if not name:
                        raise fail(f"{src}, line {lineno}: header column {i + 1} has no name")
                seen = set()
                for name in self.header:
                    if name in seen:
                        raise fail(
                            f"{src}, line {lineno}: duplicated column name {name!r} in the header"
                        )
                    seen.add(name)
                continue
            raw_rows.append(stripped)
            self.lines.append(lineno)
        if self.header is None:
            raise fail(f"{src}: no header row (only comments or blank lines)")
        self._raw_rows = raw_rows

    def where(self) -> str:
        return f"{self.source}, line {self.header_line}"

    def numbers(self) -> np.ndarray:
        """Parse the rows into an (n, ncol) float array, naming line and column on error."""
        ncol = len(self.header)
        out = np.empty((len(self._raw_rows), ncol))
        for i, (row, lineno) in enumerate(zip(self._raw_rows, self.lines)):
            fields = split_fields(row, self.delim)
            if len(fields) != ncol:
                raise fail(
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
                        raise fail(
                            f"{self.source}, line {lineno}, column {self.header[j]!r}: {what}"
                        ) from None
        return out


def check_mapping(mapping: Mapping[str, str] | None) -> dict[str, str]:
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


def resolve_columns(
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
            raise fail(f"{where}: {kind} {name!r} (mapped to {canon}) not found; found: {listing}")
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
    missing = missing_required(used)  # q2 may be replaced by the wheel speed q4
    if missing:
        plural = "s" if len(missing) > 1 else ""
        raise fail(
            f"{where}: missing required {kind}{plural} {', '.join(missing)}; found: {listing} "
            f"(rename them with iwp convert --map t=time,q1=theta,q2=phi, or mapping= in Python)"
        )
    if "u" in used and "v" in used:
        raise fail(
            f"{where}: both input {kind}s u ({used['u']!r}) and v ({used['v']!r}) present; "
            "a log holds at most one input (u: dead-zone-compensated, v: raw motor-driver input)"
        )
    leftovers = [name for name in found if name not in taken]
    return used, leftovers


def check_leftover_name(name: str, used: dict[str, str], where: str, kind: str) -> None:
    if name in CANONICAL_COLUMNS:
        given = ", ".join(f"{k}={v}" for k, v in used.items() if v != k)
        raise fail(
            f"{where}: {kind} {name!r} is not used (mapping: {given or 'none'}) but has a "
            f"reserved iwp name; a log holds at most one input and one column per iwp name"
        )


def finish_log(
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
    units_checked: bool = False,
) -> ExperimentData:
    """Checks common to all time-series readers, then build the log.

    ``units_checked``: the angles' units were declared (a rig description) and checked by the caller; the
    degrees heuristic is skipped.

    ``cols`` maps file column names to float arrays; ``locate(i, file_name)``
    describes sample ``i`` (0-based) of a column for messages.
    """
    n = len(cols[used["t"]])
    if n == 0:
        raise fail(no_rows or f"{source}: no data")
    for name, arr in cols.items():
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            i = int(bad[0])
            raise fail(f"{locate(i, name)}: {float(arr[i])!r} is not a finite number (NaN or inf)")
    if n < min_samples:
        raise fail(
            f"{source}: {n} sample(s), at least {min_samples} are needed (min_samples)"
        )
    tname = used["t"]
    t = cols[tname]
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise fail(
            f"{locate(i, tname)}: time not strictly increasing (t = {float(t[i]):.12g} s after "
            f"{float(t[i - 1]):.12g} s)"
        )
    if not resample:
        med = float(np.median(dt))
        dev = np.abs(dt - med) / med
        bad = np.flatnonzero(dev > sampling_tol)
        if bad.size:
            i = int(bad[0]) + 1
            raise fail(
                f"{locate(i, tname)}: irregular sampling: step {float(dt[i - 1]):.6g} s differs from the "
                f"median step {med:.6g} s by {100 * dev[i - 1]:.3g}% (tolerance "
                f"{100 * sampling_tol:.3g}%); interpolate it onto a uniform grid with iwp convert --resample "
                "(resample=True in Python)"
            )
    fields: dict[str, np.ndarray] = {canon: cols[name] for canon, name in used.items()}
    check_log_values(fields, source=source, locate=locate, names=used)
    if degrees:
        for canon in _ANGLES:
            if canon in fields:
                fields[canon] = np.deg2rad(fields[canon])
    elif not units_checked:
        warn_if_degrees(fields["q1"], source, used["q1"])
    data = ExperimentData(
        **fields,
        extra={name: cols[name] for name in extras},
        metadata=metadata,
        source=source,
    )
    if resample:
        data = data.resample()
    return data


def warn_if_degrees(q1: np.ndarray, source: str, column: str, hint: str | None = None) -> None:
    """Refuse, or warn about, a pendulum angle [rad] that looks like degrees.

    Beyond ``3 pi`` (:data:`DEGREES_THRESHOLD`) a pendulum angle in radians
    has turned over at least once. If it also swings back and forth across
    zero (at least :data:`DEGREES_CROSSINGS` zero crossings, as a swing in
    degrees does, and a pendulum that turned over does not), the column is
    refused; otherwise (a pendulum that turned over, a swing-up) a warning.
    """
    peak = float(np.max(np.abs(q1))) if q1.size else 0.0
    if peak <= DEGREES_THRESHOLD:
        return
    crossings = int(np.count_nonzero(np.diff(np.signbit(q1[q1 != 0.0]))))
    what = (f"{source}: column {column!r}{'' if column == 'q1' else ' (q1)'} looks like degrees "
            f"(peak |q1| = {peak:.4g} > 3*pi rad")
    fix = f"convert it with {hint or 'iwp convert --degrees (degrees=True in Python)'}"
    if crossings >= DEGREES_CROSSINGS and peak <= 400.0:
        raise fail(f"{what} while it swings across zero {crossings} times); {fix}")
    warnings.warn(f"{what}); {fix}", UserWarning, stacklevel=4)


def check_read_options(min_samples: int, sampling_tol: float) -> tuple[int, float]:
    if isinstance(min_samples, bool) or not isinstance(min_samples, (int, np.integer)):
        raise InputError(f"min_samples must be an integer >= 2, got {min_samples!r}")
    if min_samples < 2:
        raise InputError(f"min_samples must be >= 2, got {min_samples!r}")
    return int(min_samples), check_positive("sampling_tol", sampling_tol)


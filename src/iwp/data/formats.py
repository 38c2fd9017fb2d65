"""Reading and writing experiment logs by file format (picked from the extension or given)."""

from __future__ import annotations

import inspect
import os
from pathlib import Path
from typing import Any, Callable

from ..errors import InputError
from ..files import LOG_SUFFIXES, check_output_file
from .angle_log import read_angle_log
from .csv_format import read_csv, write_csv
from .experiment import ExperimentData
from .mat_format import read_mat, write_mat
from .parquet_format import read_parquet, write_parquet
from .rig_log import read_rig_log

#: Input formats known to :func:`read_experiment` (``format=``).
FORMATS = ("csv", "mat", "parquet", "angle-log")

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


def format_of(path: str | os.PathLike, *, writing: bool = False) -> str:
    """The log format of ``path`` from its extension (one a reader, or with ``writing`` a writer, handles).

    Examples
    --------
    >>> from iwp.data import format_of
    >>> format_of("sine60.pq"), format_of("log.txt"), format_of("run.mat", writing=True)
    ('parquet', 'csv', 'mat')
    >>> format_of("run.xlsx")
    Traceback (most recent call last):
    ...
    iwp.errors.InputError: run.xlsx: cannot tell the input format from the extension '.xlsx'; use one of ...
    """
    return _format_of(path, _WRITERS if writing else _READERS, "output" if writing else "input")


def _format_of(path: str | os.PathLike, kinds: dict[str, Any], what: str) -> str:
    if what == "input" and Path(path).is_dir():
        raise InputError(f"{path}: is a folder; give a log file in it ({', '.join(sorted(set(LOG_SUFFIXES)))})")
    ext = Path(path).suffix.lower()
    fmt = LOG_SUFFIXES.get(ext)
    if fmt is None or fmt not in kinds:
        known = ", ".join(e for e, f in LOG_SUFFIXES.items() if f in kinds)
        got = f"the extension {ext!r}" if ext else "a name without an extension"
        raise InputError(f"{path}: cannot tell the {what} format from {got}; use one of {known} or give the format "
                         f"({', '.join(kinds)})")
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
        ``sample_rate``, ``zero``), or ``rig=`` a rig description
        (:func:`iwp.data.rig_log.read_rig_log`: another rig's CSV or ``.mat`` log,
        its columns and units mapped by the description).

    Returns
    -------
    ExperimentData

    Raises
    ------
    InputError
        Unknown format/extension, or an option the chosen reader does not take.
    DataFormatError
        From the reader.

    Examples
    --------
    >>> from iwp import Plant, read_experiment, simulate, table1, write_experiment
    >>> log = simulate(Plant(table1(), model="free"), x0=[1.0, 0, 0, 0], t_end=2.0).to_experiment()
    >>> path = write_experiment(log, "free.csv")
    >>> back = read_experiment("free.csv")
    >>> back.n_samples, float(back.q1[0])
    (401, 1.0)
    """
    if format is None:
        fmt = _format_of(path, _READERS, "input")
    elif format in _READERS:
        fmt = format
    else:
        raise InputError(f"format must be one of {', '.join(_READERS)}, got {format!r}")
    rig = kw.pop("rig", None)
    if rig is not None:
        if fmt not in ("csv", "mat"):
            raise InputError(f"rig: a rig description reads CSV and .mat logs, not {fmt} files", argument="rig")
        bad = sorted(set(kw) - {"struct", "resample", "min_samples", "sampling_tol"})
        if bad:
            raise InputError(f"{bad[0]}: does not apply with a rig description (it gives the columns and units)",
                             argument=bad[0])
        return read_rig_log(path, rig, format=fmt, **kw)
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

    Examples
    --------
    >>> from iwp import Plant, simulate, table1, write_experiment
    >>> log = simulate(Plant(table1(), model="free"), x0=[1.0, 0, 0, 0], t_end=2.0).to_experiment()
    >>> write_experiment(log, "free.mat").name  # the format from the extension
    'free.mat'
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

    Examples
    --------
    >>> from iwp import Plant, convert, simulate, table1, write_experiment
    >>> log = simulate(Plant(table1(), model="free"), x0=[1.0, 0, 0, 0], t_end=2.0).to_experiment()
    >>> path = write_experiment(log, "free.csv")
    >>> convert("free.csv", "free.mat", t_start=0.5).n_samples  # the window from 0.5 s on
    301
    """
    if to_format is None:
        check_output_file(dst, force=force, argument="out", suffixes=LOG_SUFFIXES)
    else:
        check_output_file(dst, force=force, argument="out")  # fail before reading if dst exists
        says = LOG_SUFFIXES.get(Path(dst).suffix.lower())
        if says is not None and says != to_format:
            raise InputError(f"out {dst}: its extension says {says}, not {to_format} (to_format = {to_format!r}); "
                             f"name it {Path(dst).with_suffix('.' + to_format).name}", argument=("out", "to_format"))
    try:
        same = Path(dst).exists() and Path(src).exists() and Path(dst).samefile(src)
    except OSError:
        same = False
    if same:
        raise InputError(f"out {dst}: is the input file; write the converted log to another file", argument="out")
    data = read_experiment(src, format=from_format, **read_options)
    data = data.window(t_start, t_end)
    write_experiment(data, dst, format=to_format, force=force)
    return data

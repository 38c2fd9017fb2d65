"""Writing what the virtual rig returns: static curves as CSV, logs in any format of :mod:`iwp.data`."""

from __future__ import annotations

import os
from pathlib import Path

from ..data import ExperimentData, StaticCurve, write_experiment, write_static_curve
from ..errors import InputError
from ..files import LOG_SUFFIXES, check_output_file
from .experiments import ExperimentKind, RunKind, experiment_spec

__all__ = ["check_output_path", "write_result", "result_suffixes"]

_STATIC_EXT = (".csv", ".txt")
_SERIES_EXT = tuple(LOG_SUFFIXES)  # those of iwp.data.write_experiment


def check_output_path(name: str, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Check, before running experiment ``name``, that its result may be written to ``path``.

    Static curves are CSV (``.csv``/``.txt``); time series are CSV, Parquet
    or MAT by extension (see :func:`iwp.data.write_experiment`). Refuses an
    existing file unless ``force``.

    Parameters
    ----------
    name : str
        Experiment name.
    path : str or path-like
        Output file.
    force : bool, default False
        Allow overwriting an existing file.

    Returns
    -------
    Path
        The checked path.

    Raises
    ------
    InputError
        Unknown experiment, an extension the result cannot be written as, a folder, or an existing file
        without ``force``.

    See Also
    --------
    write_result : Write the result once the experiment has run.

    Examples
    --------
    A log may be Parquet; a static curve only CSV:

    >>> from iwp.rig import check_output_path
    >>> check_output_path("sine-60", "sine60.parquet").name
    'sine60.parquet'
    >>> check_output_path("static-curve", "curve.mat")
    Traceback (most recent call last):
    ...
    iwp.errors.InputError: out curve.mat: extension '.mat'; use one of .csv, .txt
    """
    return check_output_file(path, force=force, argument="out", suffixes=result_suffixes(experiment_spec(name).kind))


def result_suffixes(kind: ExperimentKind) -> tuple[str, ...]:
    """The file extensions the result of an experiment of ``kind`` may be written as.

    Parameters
    ----------
    kind : ExperimentKind
        How the experiment runs.

    Returns
    -------
    tuple of str
        ``(".csv", ".txt")`` for a static curve, the extensions of :func:`iwp.data.write_experiment` for a
        time series.
    """
    return _STATIC_EXT if kind.run is RunKind.STATIC_CURVE else _SERIES_EXT


def write_result(result, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Write what :meth:`iwp.rig.VirtualRig.run` returned: a static curve as CSV, a log by extension.

    Parameters
    ----------
    result : ExperimentData or StaticCurve
        What the experiment returned.
    path : str or path-like
        Output file; a static curve needs ``.csv`` or ``.txt``, a log ``.csv``, ``.parquet`` or ``.mat``.
    force : bool, default False
        Allow overwriting an existing file.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    InputError
        Another kind of result, or an extension the result cannot be written as.

    See Also
    --------
    check_output_path : The same check before the experiment runs.

    Examples
    --------
    >>> from iwp.rig import run_experiment, write_result
    >>> log = run_experiment("sine-60", duration=2.0)
    >>> write_result(log, "sine60.csv").name
    'sine60.csv'
    >>> curve = run_experiment("static-curve", step=20.0, duration=2.0)
    >>> write_result(curve, "curve.csv").name  # a static curve: CSV only
    'curve.csv'
    """
    if isinstance(result, StaticCurve):
        if Path(path).suffix.lower() not in _STATIC_EXT:
            raise InputError(f"{path}: a static curve is written as CSV; use the extension .csv or .txt")
        return write_static_curve(result, path, force=force)
    if isinstance(result, ExperimentData):
        return write_experiment(result, path, force=force)
    raise InputError(f"result must be ExperimentData or StaticCurve, got {type(result).__name__}")

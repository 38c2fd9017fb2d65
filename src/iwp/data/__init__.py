"""Experiment logs: the iwp data format, its readers and writers.

An experiment log is held in memory as an :class:`ExperimentData` (time,
pendulum angle ``q1``, wheel angle ``q2``, optional measured velocities ``q3``,
``q4`` and at most one input, ``u`` or ``v``). On disk it is one of

* the **iwp CSV** (``.csv`` / ``.txt``): ``# key: value`` metadata lines, one
  header row, then one row per sample (:mod:`.csv_format`);
* **Parquet** (``.parquet`` / ``.pq``, needs ``pyarrow``; :mod:`.parquet_format`);
* **MATLAB** ``.mat`` (v4 to v7.2, through :func:`scipy.io.loadmat`; :mod:`.mat_format`);
* a third-party **angle log** (two header lines, then one angle a line;
  :mod:`.angle_log`, read only).

Static input/velocity curves (one row per steady state of the disk, paper
section 5, figure 2) are a :class:`StaticCurve`.

Every reader checks what it reads and stops at the first problem with a
:class:`~iwp.errors.DataFormatError` whose one-line message names the file,
the place (CSV line number, 1-based; Parquet row; MAT variable and sample) and
the column. See ``docs/data-format.md`` for the contract.
"""

from __future__ import annotations

from .angle_log import read_angle_log
from .csv_format import read_csv, read_static_curve, write_csv, write_static_curve
from .experiment import (
    CANONICAL_COLUMNS,
    DEGREES_THRESHOLD,
    REQUIRED_COLUMNS,
    ExperimentData,
    StaticCurve,
    check_distinct,
)
from .formats import FORMATS, convert, format_of, read_experiment, write_experiment
from .mat_format import read_mat, write_mat
from .parquet_format import read_parquet, write_parquet

__all__ = [
    "CANONICAL_COLUMNS",
    "DEGREES_THRESHOLD",
    "FORMATS",
    "REQUIRED_COLUMNS",
    "ExperimentData",
    "StaticCurve",
    "check_distinct",
    "convert",
    "format_of",
    "read_angle_log",
    "read_csv",
    "read_experiment",
    "read_mat",
    "read_parquet",
    "read_static_curve",
    "write_csv",
    "write_experiment",
    "write_mat",
    "write_parquet",
    "write_static_curve",
]

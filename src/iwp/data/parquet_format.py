"""Parquet logs (``.parquet`` / ``.pq``; needs ``pyarrow``)."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import Mapping

import numpy as np

from ..errors import InputError
from ..files import atomic_write, prepare_output_file
from .experiment import ExperimentData
from .tables import (
    check_input_file,
    check_leftover_name,
    check_mapping,
    check_read_options,
    fail,
    finish_log,
    resolve_columns,
)

_PARQUET_METADATA_KEY = b"iwp.metadata"

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

    See Also
    --------
    write_parquet : Write a log as Parquet.

    Examples
    --------
    >>> from iwp.data import read_parquet, write_parquet
    >>> from iwp.rig import run_experiment
    >>> _ = write_parquet(run_experiment("free-pendulum", duration=2.0), "free.parquet")
    >>> log = read_parquet("free.parquet")
    >>> log.n_samples, log.metadata["experiment"], log.input_name
    (401, 'free-pendulum', None)
    """
    min_samples, sampling_tol = check_read_options(min_samples, sampling_tol)
    mapping = check_mapping(mapping)
    pa, pq = _pyarrow("reading")
    p, src = check_input_file(path)
    try:
        table = pq.read_table(p)
    except Exception as exc:  # pyarrow raises ArrowInvalid, OSError, ...
        raise fail(f"{src}: not a readable Parquet file ({type(exc).__name__}: {exc})") from None
    names = [n for n in table.column_names if not re.fullmatch(r"__index_level_\d+__", n)]
    seen = set()
    for name in names:
        if name in seen:
            raise fail(f"{src}: duplicated column name {name!r}")
        seen.add(name)
    used, leftovers = resolve_columns(names, mapping, src)
    for name in leftovers:
        check_leftover_name(name, used, src, "column")
    cols: dict[str, np.ndarray] = {}
    for name in names:
        col = table.column(name)
        if not (
            pa.types.is_floating(col.type)
            or pa.types.is_integer(col.type)
            or pa.types.is_boolean(col.type)
            or pa.types.is_decimal(col.type)
        ):
            raise fail(f"{src}, column {name!r}: type {col.type} where numbers belong")
        if col.null_count:
            mask = col.is_null().to_numpy(zero_copy_only=False)
            i = int(np.flatnonzero(mask)[0])
            raise fail(f"{src}, row {i + 1}, column {name!r}: missing value (null)")
        cols[name] = np.asarray(col.to_numpy(), dtype=np.float64)
    metadata: dict[str, str] = {}
    schema_md = table.schema.metadata or {}
    if _PARQUET_METADATA_KEY in schema_md:
        try:
            raw = json.loads(schema_md[_PARQUET_METADATA_KEY].decode("utf-8"))
            if not isinstance(raw, dict):
                raise ValueError("not an object")
        except (ValueError, UnicodeDecodeError) as exc:
            raise fail(f"{src}: schema metadata 'iwp.metadata' is not a JSON object ({exc})") from None
        metadata = {str(k): str(v) for k, v in raw.items()}

    def locate(i: int, name: str) -> str:
        return f"{src}, row {i + 1}, column {name!r}"

    return finish_log(
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

    See Also
    --------
    read_parquet : Read it back.

    Examples
    --------
    >>> import numpy as np
    >>> import pyarrow.parquet as pq
    >>> from iwp.data import read_parquet, write_parquet
    >>> from iwp.rig import run_experiment
    >>> log = run_experiment("sine-60", duration=1.0)
    >>> write_parquet(log, "sine60.parquet").name
    'sine60.parquet'
    >>> pq.read_schema("sine60.parquet").names[:4]  # float64 columns, for pandas, polars, ...
    ['t', 'q1', 'q2', 'u']
    >>> np.array_equal(read_parquet("sine60.parquet").u, log.u)  # bit-exact
    True
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
    return atomic_write(p, lambda tmp: pq.write_table(table, str(tmp)), force=force)


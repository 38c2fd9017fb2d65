"""MATLAB ``.mat`` logs (v4 to v7.2, through :func:`scipy.io.loadmat`)."""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..errors import InputError
from ..files import atomic_write, prepare_output_file
from .experiment import REQUIRED_COLUMNS, ExperimentData
from .tables import (
    check_input_file,
    check_leftover_name,
    check_mapping,
    check_read_options,
    fail,
    finish_log,
    parse_comment,
    resolve_columns,
)

_MAT_METADATA = "iwp_metadata"
_MAT_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,62}$")

# --------------------------------------------------------------------------
# MATLAB
# --------------------------------------------------------------------------
def is_mat_struct(value: Any) -> bool:
    return hasattr(value, "_fieldnames")


def struct_fields(value: Any) -> dict[str, Any]:
    return {name: getattr(value, name) for name in value._fieldnames}


def flatten_simulink(container: dict[str, Any]) -> dict[str, Any]:
    """Expand a Simulink 'structure with time' (``time`` + ``signals(k).values``)."""
    signals = container.get("signals")
    if signals is None:
        return container
    items = [signals] if is_mat_struct(signals) else list(np.atleast_1d(signals))
    if not items or not all(is_mat_struct(s) and "values" in s._fieldnames for s in items):
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
        raise fail(f"{where}: {kind}; expected a numeric vector (one value per sample)")
    arr = np.atleast_1d(np.squeeze(arr))
    if arr.ndim != 1:
        raise fail(f"{where}: a {'x'.join(map(str, arr.shape))} array; expected a vector")
    return arr.astype(np.float64)


def _parse_metadata_text(text: Any) -> dict[str, str]:
    if isinstance(text, np.ndarray):
        text = "\n".join(str(s) for s in np.atleast_1d(text))
    out: dict[str, str] = {}
    for line in str(text).split("\n"):
        kv = parse_comment("#" + line)
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
        The iwp name -> variable (field) name, e.g. ``{"t": "time", "q1":
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

    See Also
    --------
    write_mat : Write a log as MATLAB file.

    Examples
    --------
    A MATLAB struct ``logdata`` with other names, as another rig's software saves it:

    >>> import numpy as np
    >>> import scipy.io
    >>> from iwp.data import read_mat
    >>> t = np.arange(400) * 0.005
    >>> scipy.io.savemat("rig.mat", {"logdata": {"time": t, "theta": 0.5 * np.cos(5.1 * t), "phi": 0 * t}})
    >>> log = read_mat("rig.mat", mapping={"t": "time", "q1": "theta", "q2": "phi"})
    >>> log.n_samples, round(log.Ts, 3), round(float(log.q1[0]), 2)
    (400, 0.005, 0.5)
    """
    min_samples, sampling_tol = check_read_options(min_samples, sampling_tol)
    mapping = check_mapping(mapping)
    p, src = check_input_file(path)
    from scipy.io import loadmat

    try:
        variables = loadmat(str(p), squeeze_me=True, struct_as_record=False, chars_as_strings=True)
    except NotImplementedError:
        raise fail(
            f"{src}: MATLAB v7.3 (HDF5) files are not supported; save with "
            "save(..., '-v7') or export to CSV"
        ) from None
    except Exception as exc:  # scipy raises ValueError, MatReadError, TypeError, ...
        raise fail(f"{src}: not a readable MATLAB .mat file ({type(exc).__name__}: {exc})") from None
    top = {k: v for k, v in variables.items() if not k.startswith("__")}
    needed = [mapping.get(c, c) for c in REQUIRED_COLUMNS]
    prefix = ""
    if struct is not None:
        if not isinstance(struct, str) or not struct:
            raise InputError(f"struct must be a variable name, got {struct!r}")
        parts = struct.split(".")
        if parts[0] not in top:
            raise fail(f"{src}: no variable {parts[0]!r}; found: {', '.join(top) or 'nothing'}")
        node = top[parts[0]]
        for k, part in enumerate(parts):
            if k:
                if not is_mat_struct(node) or part not in node._fieldnames:
                    raise fail(f"{src}: struct {'.'.join(parts[:k])!r} has no field {part!r}")
                node = getattr(node, part)
            if not is_mat_struct(node):
                raise fail(f"{src}: variable {'.'.join(parts[:k + 1])!r} is not a struct")
        container = struct_fields(node)
        prefix = struct + "."
    else:
        container = top
        structs = [k for k, v in top.items() if is_mat_struct(v)]
        has_all = all(n in top or (n == "t" and "time" in top) for n in needed)
        if not has_all and len(structs) == 1:
            container = struct_fields(top[structs[0]])
            prefix = structs[0] + "."
    metadata_value = container.pop(_MAT_METADATA, None)
    if metadata_value is None:
        metadata_value = top.get(_MAT_METADATA)
    container = flatten_simulink(container)
    where = src if not prefix else f"{src}, struct {prefix[:-1]!r}"
    used, leftovers = resolve_columns(list(container), mapping, where, kind="variable", time_aliases=("time",))
    cols: dict[str, np.ndarray] = {}
    for canon, name in used.items():
        cols[name] = _mat_vector(container[name], f"{src}, variable {prefix + name!r} ({canon})")
    n = cols[used["t"]].size
    for canon, name in used.items():
        if cols[name].size != n:
            raise fail(
                f"{src}, variable {prefix + name!r} ({canon}): {cols[name].size} samples but "
                f"{prefix + used['t']!r} (t) has {n}"
            )
    extras = []
    for name in leftovers:
        arr = np.asarray(container[name]) if not is_mat_struct(container[name]) else None
        if arr is None or arr.dtype.kind not in "biuf":
            continue
        arr = np.atleast_1d(np.squeeze(arr))
        if arr.ndim != 1 or arr.size != n or n < 2:
            continue
        check_leftover_name(name, used, where, "variable")
        if any(c in name for c in ',"\n\r') or name.startswith("#"):
            continue
        cols[name] = arr.astype(np.float64)
        extras.append(name)
    metadata = _parse_metadata_text(metadata_value) if metadata_value is not None else {}

    def locate(i: int, name: str) -> str:
        return f"{src}, variable {prefix + name!r}, sample {i + 1}"

    return finish_log(
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

    See Also
    --------
    read_mat : Read it back.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.io
    >>> from iwp.data import read_mat, write_mat
    >>> from iwp.rig import run_experiment
    >>> log = run_experiment("sine-60", duration=1.0)
    >>> write_mat(log, "sine60.mat").name
    'sine60.mat'
    >>> sorted(scipy.io.loadmat("sine60.mat"))[3:7]  # what MATLAB sees
    ['iwp_metadata', 'q1', 'q2', 't']
    >>> np.array_equal(read_mat("sine60.mat").u, log.u)  # bit-exact
    True
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

    return atomic_write(p, write, force=force)


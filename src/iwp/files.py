"""Files that iwp writes and reads: overwrite policy and JSON."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .errors import InputError, OutputExistsError


def prepare_output_file(path: str | Path, force: bool = False) -> Path:
    """Check that ``path`` may be written: refuse an existing file unless ``force``.

    Creates the parent folder if needed.
    """
    p = Path(path)
    if p.exists() and not force:
        raise OutputExistsError(f"{p}: file exists; pass --force (force=True) to overwrite it")
    if p.exists() and p.is_dir():
        raise InputError(f"{p}: is a folder, expected a file path")
    p.parent.mkdir(parents=True, exist_ok=True)
    return p


def read_json(path: str | Path) -> Any:
    """Parse a JSON file; raise :class:`InputError` naming the file if it is not valid JSON."""
    p = Path(path)
    try:
        return json.loads(p.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{p}: not valid JSON ({exc})") from None


def atomic_write(path: Path, write: Callable[[Path], None]) -> Path:
    """Write through a temporary file in the same folder, then rename: never a half-written ``path``."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def json_float(x) -> float | None:
    """A float for JSON: NaN and infinities become ``None`` (JSON has no NaN)."""
    x = float(x)
    return x if math.isfinite(x) else None


def jsonable(obj: Any) -> Any:
    """Numpy scalars and arrays, tuples and NaN turned into JSON-ready values (NaN, inf -> None)."""
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [jsonable(v) for v in obj.tolist()]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return json_float(obj)
    return obj

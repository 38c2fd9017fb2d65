"""Small shared helpers (argument checks, safe output paths)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from .errors import InputError, OutputExistsError


def check_finite(name: str, value: float) -> float:
    """Return ``float(value)`` or raise :class:`InputError` naming ``name``."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise InputError(f"{name} must be finite, got {x!r}")
    return x


def check_positive(name: str, value: float) -> float:
    """Return ``value`` as float if finite and > 0, else raise naming ``name``."""
    x = check_finite(name, value)
    if x <= 0.0:
        raise InputError(f"{name} must be > 0, got {x!r}")
    return x


def check_nonnegative(name: str, value: float) -> float:
    """Return ``value`` as float if finite and >= 0, else raise naming ``name``."""
    x = check_finite(name, value)
    if x < 0.0:
        raise InputError(f"{name} must be >= 0, got {x!r}")
    return x


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

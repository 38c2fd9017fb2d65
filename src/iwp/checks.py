"""Argument checks shared by the API: one clear error that names the argument."""

from __future__ import annotations

import math

from .errors import InputError


def check_finite(name: str, value: float) -> float:
    """Return ``float(value)`` or raise :class:`InputError` naming ``name``."""
    if isinstance(value, bool):
        raise InputError(f"{name} must be a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
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

"""Argument checks shared by the API: one clear error that names the argument."""

from __future__ import annotations

import math

from .errors import InputError

#: Most samples a simulated or generated log may hold (a 5 ms log of about 14 hours; 0.5 GB in memory).
MAX_SAMPLES = 10_000_000


def _short(value, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters (error messages stay one short line)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def check_finite(name: str, value: float) -> float:
    """Return ``float(value)`` or raise :class:`InputError` naming ``name``."""
    if isinstance(value, bool):
        raise InputError(f"{name} must be a number, got {_short(value)}", argument=name)
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{name} must be a number, got {_short(value)}", argument=name) from None
    if not math.isfinite(x):
        raise InputError(f"{name} must be finite, got {x!r}", argument=name)
    return x


def check_positive(name: str, value: float) -> float:
    """Return ``value`` as float if finite and > 0, else raise naming ``name``."""
    x = check_finite(name, value)
    if x <= 0.0:
        raise InputError(f"{name} must be > 0, got {x!r}", argument=name)
    return x


def check_nonnegative(name: str, value: float) -> float:
    """Return ``value`` as float if finite and >= 0, else raise naming ``name``."""
    x = check_finite(name, value)
    if x < 0.0:
        raise InputError(f"{name} must be >= 0, got {x!r}", argument=name)
    return x


def check_samples(n_samples: float, *, argument: str | tuple[str, ...], what: str) -> int:
    """Refuse a log of more than :data:`MAX_SAMPLES` samples, or of fewer than 2, before any allocation.

    Parameters
    ----------
    n_samples : float
        The number of samples the arguments ask for (a float: it may be astronomically large).
    argument : str or tuple of str
        The API names of the arguments that set it (named in the error).
    what : str
        How the count arises, for the message (``"(t_end - t0) / Ts + 1"``).
    """
    if not math.isfinite(n_samples) or n_samples > MAX_SAMPLES:
        raise InputError(f"{what} gives {n_samples:.3g} samples; at most {MAX_SAMPLES:.0e} fit in memory "
                         "(shorten the time span or lengthen the sample time)", argument=argument)
    if n_samples < 2:
        raise InputError(f"{what} gives {max(n_samples, 0):.3g} sample(s); a log needs at least 2 "
                         "(the sample time must be shorter than the time span)", argument=argument)
    return int(n_samples)

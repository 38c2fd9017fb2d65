"""How well a simulation matches a measurement: the fit in percent (NRMSE)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError

__all__ = ["fit_percent"]


def fit_percent(y, y_hat) -> float:
    """Fit in percent, ``100 (1 - ||y - y_hat|| / ||y - mean(y)||)`` (MATLAB's ``compare``, NRMSE).

    100 for a perfect match, 0 for a prediction no better than the mean of
    ``y``, negative when worse. NaN when ``y`` is constant (the fit is not
    defined).

    Parameters
    ----------
    y : array_like
        The measured signal (any unit).
    y_hat : array_like
        The simulated signal, same unit and length.

    Returns
    -------
    float
        The fit [%].

    Examples
    --------
    >>> from iwp import fit_percent
    >>> fit_percent([1.0, 2.0, 3.0], [1.0, 2.0, 3.0])  # a perfect fit
    100.0
    >>> fit_percent([1.0, 2.0, 3.0], [2.0, 2.0, 2.0])  # no better than the mean
    0.0
    """
    y = np.asarray(y, dtype=float).ravel()
    y_hat = np.asarray(y_hat, dtype=float).ravel()
    if y.shape != y_hat.shape:
        raise InputError(f"y and y_hat must have the same length, got {y.size} and {y_hat.size}")
    if y.size == 0:
        raise InputError("y is empty")
    den = float(np.linalg.norm(y - y.mean()))
    if den == 0.0 or not math.isfinite(den):
        return float("nan")
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / den)

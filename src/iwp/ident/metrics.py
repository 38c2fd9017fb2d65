"""How well a simulation matches a measurement: the fit in percent (NRMSE)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError

__all__ = ["JUDGED", "POOR_FIT", "fit_percent", "poor_fits"]

#: the signals a prediction of held-out data is judged on (``iwp fit``'s ladder scores, held-out means, a poor
#: prediction; ``iwp validate``'s exit status): the pendulum's angle and the wheel's speed, the states the dynamics
#: depend on. The wheel's angle enters no equation of the models: its prediction error is the time integral of the
#: speed's, so a speed predicted at 92 % over 15 s leaves an angle predicted at 26 % (the README's logs), and its fit
#: measures the log's length more than the model. It is still computed and shown.
JUDGED = ("q1", "q4")

#: a mean fit below this [%] on data the model was not fitted to is a poor prediction, and said so
POOR_FIT = 50.0


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


def poor_fits(fits, outputs) -> list[str]:
    """The signals predicted poorly on data the model was not fitted to, each as ``"q2 37.0 %"``.

    A signal is predicted poorly when its mean fit (:func:`fit_percent`) over
    the logs is below :data:`POOR_FIT` %, or when it is below zero (worse than
    the measured mean) or undefined on any log.

    Parameters
    ----------
    fits : sequence of mapping of str to float
        Per log, the fit [%] of each signal.
    outputs : sequence of str
        The signals to judge (``"q1"``, ``"q2"``, ...).

    Returns
    -------
    list of str
        One entry per poorly predicted signal (empty: none); a signal below zero on some logs says on how many.
    """
    bad = []
    for o in outputs:
        vals = [f.get(o, float("nan")) for f in fits]
        finite = [v for v in vals if math.isfinite(v)]
        neg = sum(1 for v in vals if not math.isfinite(v) or v < 0)
        mean = float(np.mean(finite)) if finite else float("nan")
        if not (mean >= POOR_FIT) or neg:
            bad.append(f"{o} {mean:.1f} %" + (f" (below zero or failed on {neg} of {len(vals)} logs)" if neg else ""))
    return bad

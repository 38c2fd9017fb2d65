"""How well a simulation matches a measurement: the fit in percent (NRMSE)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError

__all__ = ["JUDGED", "POOR_FIT", "STILL_SPAN", "fit_percent", "judged_fits", "poor_fits"]

#: the signals a prediction of held-out data is judged on (``iwp fit``'s ladder scores, held-out means, a poor
#: prediction; ``iwp validate``'s exit status): the pendulum's angle and the wheel's speed, the states the dynamics
#: depend on. The wheel's angle enters no equation of the models: its prediction error is the time integral of the
#: speed's, so a speed predicted at 92 % over 15 s leaves an angle predicted at 26 % (the README's logs), and its fit
#: measures the log's length more than the model. It is still computed and shown.
JUDGED = ("q1", "q4")

#: a judged signal whose measured range is below this is still (a pendulum clamped [rad], a wheel held to the arm
#: [rad/s]): its fit compares noise with noise and says nothing of the model, so it is not judged
STILL_SPAN = {"q1": 0.01, "q4": 1.0}

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


def poor_fits(fits, outputs) -> list[str]:
    """The signals predicted poorly on data the model was not fitted to, each as ``"q2 37.0 %"``.

    A signal is predicted poorly when its mean fit (:func:`fit_percent`) over
    the logs is below :data:`POOR_FIT` %, or when it is below zero (worse than
    the measured mean) or undefined on any log.

    Parameters
    ----------
    fits : sequence of mapping of str to float
        Per log, the fit [%] of each signal it holds (NaN: failed); a signal no log holds is not judged.
    outputs : sequence of str
        The signals to judge (``"q1"``, ``"q2"``, ...).

    Returns
    -------
    list of str
        One entry per poorly predicted signal (empty: none); a signal below zero on some logs says on how many.
    """
    bad = []
    for o in outputs:
        vals = [f[o] for f in fits if o in f]  # a log that does not hold the signal (or holds it still) says nothing
        if not vals:
            continue
        finite = [v for v in vals if math.isfinite(v)]
        neg = sum(1 for v in vals if not math.isfinite(v) or v < 0)
        mean = float(np.mean(finite)) if finite else float("nan")
        if not (mean >= POOR_FIT) or neg:
            bad.append(f"{o} {mean:.1f} %" + (f" (below zero or failed on {neg} of {len(vals)} logs)" if neg else ""))
    return bad


def judged_fits(fit, measured) -> dict[str, float]:
    """The fits [%] of a log that judge a model: those of :data:`JUDGED` whose measured signal moves.

    Parameters
    ----------
    fit : mapping of str to float
        The log's fit [%] per signal.
    measured : mapping of str to ndarray
        The log's measured signals (rad, rad/s).

    Returns
    -------
    dict of str to float
        The fits of the judged signals the log holds whose range is at least :data:`STILL_SPAN`.
    """
    return {o: fit[o] for o in JUDGED if o in fit and o in measured and np.size(measured[o])
            and float(np.ptp(np.asarray(measured[o], dtype=float))) >= STILL_SPAN[o]}

"""What a sweep records of every closed loop: :func:`closed_loop_metrics`.

One row per lane (see docs/sweeps.md):

================  ========  ==============================================================
column            unit      meaning
================  ========  ==============================================================
status            --        0 reached ``t_end``; 1 diverged; 2 step too small; 3 step limit;
                            -1 the lane's parameters are unphysical (not simulated)
q1_end .. q4_end  rad, rad/s  the state at ``t_end``
max_abs_q1        rad       largest ``|q1|`` over the run: the largest sample, refined by a
                            parabola through it and its neighbours
amplitude         rad       Hopf: the orbit's largest ``q1`` in the final window (refined by a
                            parabola through the samples around it, as
                            :func:`iwp.control.simulated_amplitude`); NaN when rotating.
                            LQR: largest ``|wrap(q1 - pi)|`` in the final window
amplitude_change  --        Hopf: ``|A - A_prev| / A`` between the final window and the one
                            before it (NaN when the run is shorter than two windows)
period            s         Hopf: mean spacing of the upward zero crossings of ``q1`` in the
                            final window (NaN with fewer than two)
rotating          --        Hopf: ``|q1| > pi`` in the final window (the pendulum goes over the
                            top). LQR: fallen, ``|wrap(q1 - pi)| > pi/2`` in the final window
captured          --        Hopf: on a steady orbit (reached ``t_end``, not rotating,
                            ``amplitude_change <= CAPTURE_CHANGE``). LQR: held upright through
                            the final window (``|wrap(q1 - pi)| <= CAPTURE_ANGLE`` and
                            ``|q3| <= CAPTURE_SPEED``)
nfev              --        right-hand-side evaluations
================  ========  ==============================================================
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["closed_loop_metrics", "METRICS", "CAPTURE_CHANGE", "CAPTURE_ANGLE", "CAPTURE_SPEED"]

#: The metric columns, in order.
METRICS = ("status", "q1_end", "q2_end", "q3_end", "q4_end", "max_abs_q1", "amplitude", "amplitude_change",
           "period", "rotating", "captured", "nfev")
#: Hopf: largest relative change of the amplitude between the last two windows of a steady orbit.
CAPTURE_CHANGE = 0.01
#: LQR: largest ``|wrap(q1 - pi)|`` [rad] and ``|q3|`` [rad/s] in the final window of a balanced pendulum.
CAPTURE_ANGLE = 0.05
CAPTURE_SPEED = 0.5


def _refined_max(sig: np.ndarray) -> np.ndarray:
    """Per row: largest sample, refined by a parabola through it and its neighbours."""
    m, n = sig.shape
    i = np.argmax(sig, axis=1)
    rows = np.arange(m)
    b = sig[rows, i]
    inner = (i > 0) & (i < n - 1)
    a = np.where(inner, sig[rows, np.clip(i - 1, 0, n - 1)], b)
    c = np.where(inner, sig[rows, np.clip(i + 1, 0, n - 1)], b)
    den = a - 2 * b + c
    with np.errstate(divide="ignore", invalid="ignore"):
        refined = b - 0.125 * (a - c) ** 2 / den
    return np.where(inner & (den < 0), refined, b)


def _period(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Per row: mean spacing of the upward zero crossings of ``q`` (linearly interpolated) [s]; NaN with fewer than 2.

    The mean of the spacings is (last - first) / (count - 1).
    """
    up = (q[:, :-1] < 0) & (q[:, 1:] >= 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        tc = t[:-1] - q[:, :-1] * (t[1:] - t[:-1]) / (q[:, 1:] - q[:, :-1])
    count = up.sum(axis=1)
    first = np.where(up, tc, np.inf).min(axis=1)
    last = np.where(up, tc, -np.inf).max(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(count >= 2, (last - first) / (count - 1), np.nan)


def closed_loop_metrics(t: np.ndarray, x: np.ndarray, status: np.ndarray, *, law: str, window: float
                        ) -> dict[str, np.ndarray]:
    """The metrics of :data:`METRICS` (but ``nfev``) of a batch of closed loops.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Output times [s].
    x : ndarray, shape (m, n, 4)
        States of ``m`` lanes [rad, rad, rad/s, rad/s]; NaN after a failure.
    status : ndarray of int, shape (m,)
        The engine's status per lane (-1: not simulated).
    law : {"hopf", "lqr"}
    window : float
        Final window [s].

    Returns
    -------
    dict of str to ndarray, shape (m,)
    """
    m = x.shape[0]
    ok = status == 0
    q1 = x[:, :, 0]
    end = x[:, -1, :].copy()
    end[~ok] = np.nan
    win = t >= t[-1] - window - 1e-9 * max(1.0, abs(t[-1]))
    prev = (t >= t[-1] - 2 * window - 1e-9) & ~win
    have_prev = t[0] <= t[-1] - 2 * window + 1e-9
    out = {f"q{j + 1}_end": end[:, j] for j in range(4)}
    safe = np.where(ok[:, None], q1, 0.0)
    out["max_abs_q1"] = np.where(ok, _refined_max(np.abs(safe)), np.nan)
    nan = np.full(m, np.nan)
    if law == "hopf":
        rotating = ok & (np.max(np.abs(safe[:, win]), axis=1) > math.pi)
        amp = np.where(ok & ~rotating, _refined_max(safe[:, win]), np.nan)
        if have_prev:
            amp_prev = _refined_max(safe[:, prev])
            with np.errstate(divide="ignore", invalid="ignore"):
                change = np.where(ok & ~rotating, np.abs(amp - amp_prev) / np.abs(amp), np.nan)
        else:
            change = nan.copy()
        period = np.where(ok & ~rotating, _period(t[win], safe[:, win]), np.nan)
        captured = ok & ~rotating & (change <= CAPTURE_CHANGE)
    else:
        err = np.abs((safe[:, win] - math.pi + math.pi) % (2 * math.pi) - math.pi)
        amp = np.where(ok, np.max(err, axis=1), np.nan)
        rotating = ok & (np.max(err, axis=1) > 0.5 * math.pi)
        change = nan.copy()
        period = nan.copy()
        speed = np.max(np.abs(np.where(ok[:, None], x[:, :, 2], 0.0)[:, win]), axis=1)
        captured = ok & (amp <= CAPTURE_ANGLE) & (speed <= CAPTURE_SPEED)
    out.update(amplitude=amp, amplitude_change=change, period=period, rotating=rotating.astype(np.int64),
               captured=captured.astype(np.int64))
    return out

"""The start of ``iwp fit``'s refinement: least squares of model (9) on the training logs, differentiated.

:func:`least_squares_start` regresses the row sum and the ``q3'`` row of (9)
(:mod:`iwp.ident.regressors`) on smoothed derivatives of the logs. Before
the fit goes on it checks what a wrong rig description makes plain here,
in a fraction of a second, where the refinement would take minutes to a
wrong model:

* the signs (:func:`sign_errors`): in (9) the input accelerates the wheel
  (``rho p3 > 0`` in the row sum) and pushes the pendulum back
  (``p3 > 0`` in the ``q3'`` row). A log whose wheel, input or pendulum
  counts the other way gives one or both of them negative, hundreds of
  standard errors from 0;
* the pendulum's period (:func:`check_period`): that of a rig of this kind
  lies between 0.1 and 20 s (:data:`PENDULUM_PERIOD_RANGE`); a time column
  in minutes read as seconds gives 60 times less, one in milliseconds 1000
  times more.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import optimize

from ..data import ExperimentData
from ..errors import InputError
from ..models.parameters import TYPICAL, LumpedParameters
from .differentiate import Differentiator
from .regressors import columns, q3_row, row_sum

__all__ = ["LeastSquaresStart", "least_squares_start", "sign_errors", "MIN_SAMPLES_PER_PERIOD",
           "PENDULUM_PERIOD_RANGE", "SIGN_T", "MOVES", "check_period"]

#: The pendulum's small-swing period ``2 pi / sqrt(p1)`` a rig of this kind has [s]: the paper's 1.23 s, a
#: real rig's 0.57 s, a long pendulum's 2.1 s. Outside, the time column's unit is wrong (a fit refuses it).
PENDULUM_PERIOD_RANGE = (0.1, 20.0)
#: A sign is wrong when its estimate lies this many standard errors below 0 (white-noise errors: correlated
#: noise makes them 2-5 times too small, still far from this; a wrong sign on the twin's 20 s chirp gives 150-540).
SIGN_T = 20.0
#: A pendulum that moves by more than this peak to peak [rad] has a period to check (a clamped one does not).
MOVES = 0.02
#: length of the Savitzky-Golay filters of the least-squares start [s] (at least 7 samples)
SG_SECONDS = 0.15
#: Least squares on differentiated data needs at least this many samples per pendulum period.
MIN_SAMPLES_PER_PERIOD = 8
def _differentiator(Ts: float, n: int) -> Differentiator:
    """Savitzky-Golay (value, slope, curvature from one cubic) over about :data:`SG_SECONDS`, at least 5 samples."""
    half = max(3, int(round(0.5 * SG_SECONDS / Ts)))
    window = max(min(2 * half + 1, n - (1 - n % 2)), 5)
    return Differentiator("savgol_direct", window=window, polyorder=min(3, window - 2))


@dataclass
class _Terms:
    """The terms of the rows of (9) at the smoothed states of the logs (:mod:`iwp.ident.regressors`)."""

    q1: np.ndarray
    q3: np.ndarray
    dq3: np.ndarray
    q4: np.ndarray
    dq4: np.ndarray
    u: np.ndarray

    @property
    def S(self) -> np.ndarray:
        return np.sin(self.q1)

    @property
    def C(self) -> np.ndarray:
        return np.abs(np.cos(self.q1)) * self.q3

    @property
    def B(self) -> np.ndarray:
        return self.q3 ** 3


def _terms(d: ExperimentData) -> _Terms:
    """Smoothed q1, q3, q3', q4, q4', u (held input moved to the instants) of one log, glitches and edges left out."""
    if d.n_samples < 7:
        raise InputError(f"{d.source}: {d.n_samples} samples are too few for the least-squares start")
    diff = _differentiator(d.Ts, d.n_samples)
    win = diff.window
    if d.n_samples < win + 2:
        raise InputError(f"{d.source}: {d.n_samples} samples are too few for the least-squares start")
    q1, q3, dq3 = diff.derivatives(d.Ts, d.q1)
    if d.q2 is not None and d.q4 is None:
        _q2, q4, dq4 = diff.derivatives(d.Ts, d.q2)
    else:
        q4 = np.asarray(d.q4, dtype=float)
        if d.q4_sampling == "mean":  # means over [t_k - Ts, t_k]: move to the instants
            q4 = np.concatenate([0.5 * (q4[1:] + q4[:-1]), q4[-1:]])
        q4, dq4, _ = diff.derivatives(d.Ts, q4)
    u = np.asarray(d.input, dtype=float)
    held = np.concatenate([u[:1], 0.5 * (u[1:] + u[:-1])])  # the mean input over [t_k - Ts/2, t_k + Ts/2]
    u = diff.smooth(d.Ts, held)
    edge = win // 2 + 1
    mask = np.ones(d.n_samples, dtype=bool)
    mask[:edge] = False
    mask[-edge:] = False
    for col in ("q1", "q4"):
        src = "q4" if col == "q4" and d.q4 is not None else ("q2" if col == "q4" else "q1")
        for k in np.flatnonzero(d.glitch_mask(src)):
            mask[max(0, k - win // 2): k + win // 2 + 1] = False
    return _Terms(*(np.asarray(x)[mask] for x in (q1, q3, dq3, q4, dq4, u)))


@dataclass(frozen=True)
class LeastSquaresStart:
    """The start of ``iwp fit``'s refinement (:func:`least_squares_start`).

    Attributes
    ----------
    params : LumpedParameters
    method : str
        ``"least squares"`` or ``"spectrum and wheel row"`` (the fallback).
    details : dict
        The least-squares values.
    notes : list of str
        Why a fallback was taken, what was replaced.
    """

    params: LumpedParameters
    method: str
    details: dict
    notes: list[str]


def least_squares_start(logs: Sequence[ExperimentData], *, base: LumpedParameters | None = None
                        ) -> LeastSquaresStart:
    """A start for the refinement by least squares of model (9) on differentiated logs.

    The row sum ``q3' + q4' = -rho p2 q4 + rho p3 u`` gives ``rho p2`` and
    ``rho p3`` free of the pendulum terms; the ``q3'`` row of (11)
    (:mod:`iwp.ident.regressors`) with a column ``cos q1`` for the zero offset
    ``d`` of the angle (``-p1 sin(q1 - d) = -p1 sin q1 + p1 d cos q1``) gives
    ``p1``, the friction, ``p2``, ``p3``. Where the sampling does not allow it
    (fewer than :data:`MIN_SAMPLES_PER_PERIOD` samples per pendulum period) or
    the values are not physical, ``p1`` comes from the spectrum of ``q1``.

    Parameters
    ----------
    logs : sequence of ExperimentData
        Training logs, with the input ``u`` and the wheel velocity.
    base : LumpedParameters, optional
        Parameters whose other entries (dead zone, Coulomb friction, ...) the start keeps; None (default):
        zero frictions and defaults.

    Returns
    -------
    LeastSquaresStart
        The start (``p1``, ``p2``, ``p3``, ``rho``, ``sigma_a1``, ``sigma_v1``, ``sigma_b1``), the method used,
        the least-squares values and notes.
    """
    notes: list[str] = []
    check_period(logs)
    parts = [_terms(d) for d in logs]
    sig = _Terms(*(np.concatenate([getattr(t, k) for t in parts]) for k in ("q1", "q3", "dq3", "q4", "dq4", "u")))
    (A, y), (B, yp) = _rows(sig)
    (rp2, rp3), *_ = np.linalg.lstsq(A, y, rcond=None)
    scale = np.linalg.norm(B, axis=0)
    scale[scale == 0] = 1.0
    # the physical signs as bounds (p1, the frictions, p2 >= 0): the friction columns |cos q1| q3 and q3 are
    # nearly collinear, and unbounded least squares trades a large positive one for a large negative one
    lo = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -np.inf, -np.inf])
    th = optimize.lsq_linear(B / scale, yp, bounds=(lo, np.full(7, np.inf)), method="bvls").x
    p1, sa, sv, sb, p2b, p3b, c1 = (float(v) for v in th / scale)
    details = {"rho_p2": float(rp2), "rho_p3": float(rp3), "p1": p1, "sigma_a1": sa, "sigma_v1": sv, "sigma_b1": sb,
               "p2": p2b, "p3": p3b, "q1_offset": c1 / p1 if p1 else float("nan")}
    errors = sign_errors(sig, rows=((A, y), (B, yp)))
    if errors:
        raise InputError(errors[0], argument="rig")
    Ts = max(d.Ts for d in logs)
    ok = p1 > 0 and rp3 > 0 and p3b > 0 and rp2 >= 0 and math.isfinite(p1)
    per_period = 2 * math.pi / math.sqrt(p1) / Ts if p1 > 0 else 0.0
    if ok and per_period >= MIN_SAMPLES_PER_PERIOD:
        rho = rp3 / p3b
        method = "least squares"
    else:
        why = (f"{per_period:.1f} samples per pendulum period (< {MIN_SAMPLES_PER_PERIOD})" if ok
               else "unphysical least-squares values (" + ", ".join(
                   f"{k} = {v:.3g}" for k, v in details.items() if k != "q1_offset") + ")")
        notes.append(f"the least-squares start is not usable ({why}); starting from the spectrum of q1 and the "
                     "wheel row instead")
        p1 = _spectral_p1(logs)
        rho = (rp3 / p3b) if (rp3 > 0 and p3b > 0) else 10.0
        rp3 = rp3 if rp3 > 0 else TYPICAL["p3"] * (1 + rho)
        rp2 = max(rp2, 1e-3 * rp3)
        method = "spectrum and wheel row"
    rho = float(np.clip(rho, 0.5, 1e4))
    damp = sa + sv
    if not (damp > 0):
        notes.append(f"least squares gave no positive pendulum damping (sigma_a1 + sigma_v1 = {damp:.3g}); "
                     "starting from sigma_v1 = 0.01")
        sa, sv = 0.0, 0.01
    sa, sv = max(sa, 0.0), max(sv, 0.0)
    if sa == 0 and sv == 0:
        sv = 0.01
    start = (base or LumpedParameters(p1=p1, p2=1.0, p3=1.0, rho=rho, sigma_a1=0.0, sigma_v1=0.0, sigma_b1=0.0))
    start = start.replace(p1=p1, p2=max(rp2 / rho, 1e-9), p3=rp3 / rho, rho=rho, sigma_a1=sa, sigma_v1=sv,
                          sigma_b1=max(sb, 0.0))
    return LeastSquaresStart(start, method, details, notes)


def _spectral_p1(logs, lowest: int = 1) -> float:
    """``p1`` from the strongest frequency of the pendulum angle (its resonance, for a chirp or a swing), from
    the ``lowest`` bin of each log's spectrum up (bin k: k periods in the log)."""
    best = (0.0, 0.0)
    for d in logs:
        q = d.q1 - np.mean(d.q1)
        f = np.fft.rfftfreq(q.size, d.Ts)
        a = np.abs(np.fft.rfft(q * np.hanning(q.size)))
        a[:lowest] = 0.0
        k = int(np.argmax(a))
        if a[k] > best[0]:
            best = (a[k], 2 * math.pi * f[k])
    w = best[1]
    return float(w * w) if w > 0 else TYPICAL["p1"]


#: A column whose variance inflation (``1 / (1 - R^2)`` on the other columns) exceeds this is not determined by
#: the regression: its t value is not read. An input a feedback law computes from the state is nearly the
#: friction's columns again: the twin's Hopf closed loop (``u = k1 q3 + k2 q3^3``, 30 s) read p3 = -0.168, 24
#: standard errors below 0, in the pendulum's row.
MAX_INFLATION = 100.0


def _t_values(A: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ordinary least squares of ``y`` on ``A``: the estimates and their t values (NaN where not determined: a
    zero column, or one that the others nearly are, :data:`MAX_INFLATION`)."""
    th, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ th
    s2 = float(r @ r) / max(1, y.size - A.shape[1])
    centred = A - A.mean(axis=0)
    g = A.T @ A
    inv = np.linalg.pinv(g)
    with np.errstate(divide="ignore", invalid="ignore"):
        se = np.sqrt(s2 * np.diag(inv))
        # the inflation on the centred columns (a constant column, cos q1 near the bottom, is its own)
        gc = centred.T @ centred
        inflation = np.diag(np.linalg.pinv(gc)) * np.diag(gc)
        t = np.where((se > 0) & ~(inflation > MAX_INFLATION), th / se, np.nan)
    return th, t


#: The columns of the ``q3'`` row the start regresses on (then ``cos q1``, the angle's zero offset).
Q3_COLUMNS = ("p1", "sigma_a1", "sigma_v1", "sigma_b1", "p2", "p3")


def _rows(sig) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """The two regressions of the start: the row sum on ``(rho p2, rho p3)`` and the ``q3'`` row on
    :data:`Q3_COLUMNS` and ``cos q1``, each as ``(columns, left-hand side)``."""
    n = sig.q1.size
    return ((columns(row_sum(sig), ("rho_p2", "rho_p3"), n), sig.dq3 + sig.dq4),
            (np.column_stack([columns(q3_row(sig), Q3_COLUMNS, n), np.cos(sig.q1)]), sig.dq3))


def sign_errors(sig, rows=None) -> list[str]:
    """What the signs of the input's effects in the logs say of the rig description: a line per wrong sign.

    Parameters
    ----------
    sig : _Terms
        The logs' smoothed states, derivatives and input (as :func:`least_squares_start` makes them).
    rows : tuple, optional
        Their regressions (:func:`_rows`), where the caller has them already.

    Returns
    -------
    list of str
        Empty when ``rho p3`` (row sum) and ``p3`` (``q3'`` row) are positive or not determined; otherwise why the
        logs cannot be model (9) as described, and the key of the rig description that changes it.
    """
    wheel, pendulum = _rows(sig) if rows is None else rows
    th_w, t_w = _t_values(*wheel)
    th_p, t_p = _t_values(*pendulum)
    wheel_wrong, pend_wrong = bool(t_w[1] < -SIGN_T), bool(t_p[5] < -SIGN_T)
    said = (f"rho p3 = {th_w[1]:.3g} in the row sum ({-t_w[1]:.0f} standard errors below 0)",
            f"p3 = {th_p[5]:.3g} in the pendulum's row ({-t_p[5]:.0f} standard errors below 0)")
    if wheel_wrong and pend_wrong:
        return [f"the input turns the wheel and pushes the pendulum the other way than model (9) has it ({said[0]}, "
                f"{said[1]}): the input counts the other way; give the rig description a negative 'input.scale' "
                "(or negate the logs' input column)"]
    if wheel_wrong:
        return [f"the input turns the wheel the other way than model (9) has it, while the pendulum reacts as (9) "
                f"has it ({said[0]}): the wheel counts the other way; give the rig description 'wheel.sign': -1 "
                "(or negate the logs' wheel column)"]
    if pend_wrong:
        return [f"the input pushes the pendulum the other way than model (9) has it, while the wheel turns as (9) "
                f"has it ({said[1]}): the pendulum counts the other way; give the rig description "
                "'pendulum.sign': -1 (or negate the logs' pendulum column)"]
    return []


def check_period(logs: Sequence[ExperimentData]) -> None:
    """Refuse logs whose pendulum swings with a period no rig of this kind has (a wrong time unit).

    The period is that of the strongest frequency of ``q1`` (:func:`_spectral_p1`), of at least three periods
    in its log, in the logs whose pendulum moves by more than :data:`MOVES` rad peak to peak (a clamped pendulum
    has no period to check). A time column in milliseconds read as seconds is refused by its sample period
    before (:func:`iwp.data.plausibility.check_sample_period`); one in minutes is refused here.

    Raises
    ------
    InputError
        The period is outside :data:`PENDULUM_PERIOD_RANGE` (argument ``rig``: the time unit is the rig
        description's).
    """
    moving = [d for d in logs if d.n_samples > 8 and float(np.ptp(d.q1)) > MOVES]
    if not moving:
        return
    p1 = _spectral_p1(moving, lowest=3)  # a period longer than a third of a log is no period it shows
    period = 2 * math.pi / math.sqrt(p1)
    lo, hi = PENDULUM_PERIOD_RANGE
    if lo <= period <= hi:
        return
    hint = ("are the times in minutes? give the rig description 'time.unit': \"min\""
            if period < lo else "are the times in milliseconds? give the rig description 'time.unit': \"ms\"")
    raise InputError(f"the pendulum swings with a period of {period:.3g} s in the logs (its strongest frequency); "
                     f"no rig of this kind has a period outside {lo:g} to {hi:g} s: {hint}", argument="rig")

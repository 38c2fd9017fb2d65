"""Plausibility of a log: the checks a domain expert makes before trusting one.

The readers (:mod:`iwp.data.csv_format`, :mod:`~iwp.data.mat_format`,
:mod:`~iwp.data.parquet_format`) call :func:`check_log_values` on every
time-series log they read. A log that fails is refused with one line naming
the file, the place and the column, and the likely cause:

* the sample period is outside :data:`SAMPLE_PERIOD_RANGE` (1e-5 s to
  0.25 s): rigs of this kind sample every 1-50 ms, and a pendulum of
  ``sqrt(p1)`` near 5 rad/s cannot be identified from samples slower than a
  quarter of its period. A period of 1-100 "s" is the classic time column in
  milliseconds;
* the time resolution: ``|t|`` so large against the sample period that the
  times lose their digits (a float carries 16);
* magnitudes beyond any rig: angles and velocities beyond :data:`MAX_STATE`
  (rad, rad/s), inputs beyond :data:`MAX_INPUT`, times beyond :data:`MAX_TIME`.
"""

from __future__ import annotations

from typing import Callable, Mapping

import numpy as np

from ..errors import DataFormatError

__all__ = ["SAMPLE_PERIOD_RANGE", "MAX_STATE", "MAX_INPUT", "MAX_TIME", "check_log_values", "check_sample_period"]

#: Plausible sample periods of an inertia wheel pendulum log [s].
SAMPLE_PERIOD_RANGE = (1e-5, 0.25)
#: Largest plausible angle [rad] or velocity [rad/s] (a wheel at 1e6 rad/s would be 10 million rpm).
MAX_STATE = 1e6
#: Largest plausible input [input units] (PWM duty, volts, DAC counts or the paper's units all stay far below).
MAX_INPUT = 1e9
#: Largest plausible time stamp [s] (about 300 years: absolute UNIX times still pass).
MAX_TIME = 1e10
#: Fewest significant digits the time stamps must keep for the sample period (|t| / Ts below 1e12).
_TIME_DIGITS = 1e12
_STATES = ("q1", "q2", "q3", "q4")
_INPUTS = ("u", "v")


def check_sample_period(t: np.ndarray, *, where: str) -> float:
    """The median sample period of ``t`` [s], refused outside :data:`SAMPLE_PERIOD_RANGE`.

    Parameters
    ----------
    t : ndarray
        Strictly increasing times [s].
    where : str
        The file and column, for the message.
    """
    if t.size < 2:
        return float("nan")
    Ts = float(np.median(np.diff(t)))
    lo, hi = SAMPLE_PERIOD_RANGE
    if Ts > hi:
        hint = " (are the times in milliseconds? divide them by 1000)" if 0.5 <= Ts <= 100.0 else ""
        raise DataFormatError(
            f"{where}: sample period {Ts:.4g} s is implausible for a pendulum log "
            f"(expected {lo:g} to {hi:g} s){hint}")
    if Ts < lo:
        hint = " (are the times in microseconds? divide them by 1e6)" if 1e-4 <= Ts * 1e3 <= 5e-2 else ""
        raise DataFormatError(
            f"{where}: sample period {Ts:.4g} s is implausible for a pendulum log "
            f"(expected {lo:g} to {hi:g} s){hint}")
    t_abs = float(np.max(np.abs(t)))
    if t_abs > _TIME_DIGITS * Ts:
        raise DataFormatError(
            f"{where}: times up to {t_abs:.4g} s at a sample period of {Ts:.4g} s keep too few digits; "
            "subtract the start time")
    return Ts


def check_log_values(fields: Mapping[str, np.ndarray], *, source: str, locate: Callable[[int, str], str],
                     names: Mapping[str, str]) -> None:
    """Refuse magnitudes beyond any rig and an implausible sample period.

    Parameters
    ----------
    fields : mapping
        Canonical name (``t, q1..q4, u, v``) -> finite values.
    source : str
        The file, for messages.
    locate : callable
        ``locate(i, file_column)`` describes sample ``i`` of a column for messages.
    names : mapping
        Canonical name -> the column's name in the file.
    """
    for canon, arr in fields.items():
        if canon == "t":
            limit, what = MAX_TIME, "s"
        elif canon in _STATES:
            limit, what = MAX_STATE, "rad" if canon in ("q1", "q2") else "rad/s"
        elif canon in _INPUTS:
            limit, what = MAX_INPUT, "input units"
        else:
            continue
        big = np.flatnonzero(np.abs(arr) > limit)
        if big.size:
            i = int(big[0])
            raise DataFormatError(f"{locate(i, names.get(canon, canon))}: {float(arr[i]):.4g} {what} is beyond any "
                                  f"rig of this kind (|{canon}| <= {limit:.0e})")
    check_sample_period(fields["t"], where=f"{source}, column {names.get('t', 't')!r}")

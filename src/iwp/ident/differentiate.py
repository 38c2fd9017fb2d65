"""Velocities and accelerations from sampled (encoder-quantised) positions.

Section 5 of the paper obtains the angular velocities ``q3 = dq1/dt``,
``q4 = dq2/dt`` and the accelerations ``dq3/dt``, ``dq4/dt`` needed by the
least-squares set-up (10)-(13) "via an off-line numerical differentiation of
the position measures with a sample time of Ts = 5 ms"; the encoders have
2000 counts/rev, i.e. a quantisation step of ``2*pi/2000 = 3.14e-3 rad``.

Plain differences of quantised positions are very noisy: with a uniform
quantisation error (standard deviation ``delta/sqrt(12) = 9.1e-4 rad``) the
second central difference at Ts = 5 ms has a noise of about ``90 rad/s^2``.
A low-pass filter is therefore part of the differentiator.  Three methods
are offered:

``"central"``
    Second-order central differences for the first and second derivative;
    the two end samples use one-sided second-order formulas.  No filtering.
``"savgol"``
    Savitzky-Golay, made *consistent*: the acceleration is exactly
    :func:`scipy.signal.savgol_filter` with ``deriv=2`` (a polynomial of
    degree ``polyorder`` fitted by least squares over ``window`` samples,
    ``delta = Ts``).  Its FIR kernel ``S2`` has a double zero at DC, so it
    factors as ``S2 = D2 K / Ts^2`` with ``D2 = [1, -2, 1]`` and ``K`` a
    smoothing kernel of ``window - 2`` taps with unit DC gain (for
    ``polyorder`` 2 or 3 a positive, Epanechnikov-like bump).  The position
    is ``K q`` and the velocity its central difference, so that all three
    outputs (and :meth:`Differentiator.smooth`) carry the same filter ``K``
    and differ only by exact difference operators.
``"savgol_direct"``
    Savitzky-Golay as usually applied: ``savgol_filter`` with ``deriv`` =
    0, 1, 2.  Each output is exact for polynomials of degree
    ``polyorder``, but the three FIR filters are *not* derivatives of one
    another (for window 21 / cubic at Ts = 5 ms, ``S2`` is 0.8 % weaker than
    ``d^2/dt^2 S0`` at 1 Hz), which biases identified parameters by a
    similar amount (-0.25 % for the motor-disk set-up of section 5.1;
    -1 % with window 41).  Kept for comparison.
``"butter"``
    Zero-phase Butterworth low-pass (:func:`scipy.signal.butter` +
    :func:`scipy.signal.sosfiltfilt`) of order ``order`` and cut-off
    ``cutoff`` [Hz], followed by the central differences above.

Identification must filter the regressors and the targets with the *same*
filter, otherwise the filter's attenuation and delay end up in the parameter
estimates.  :meth:`Differentiator.derivatives` returns the filtered position
together with its derivatives, and :meth:`Differentiator.smooth` applies the
identical zero-th-derivative filter to any other signal (e.g. the input
``u``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy import ndimage, signal

from ..checks import check_positive
from ..errors import InputError

__all__ = [
    "METHODS",
    "METHOD_DEFAULTS",
    "Derivatives",
    "Differentiator",
    "DEFAULT_DIFFERENTIATOR",
    "central_first",
    "central_second",
]

#: The differentiation methods understood by :class:`Differentiator`.
METHODS = ("central", "savgol", "savgol_direct", "butter")

#: Default settings per method (used for the fields left at ``None``).
#: Savitzky-Golay 21 samples / cubic: a 100 ms window at Ts = 5 ms, about
#: 15 Hz bandwidth; Butterworth 10 Hz, order 4.  Both pass the pendulum
#: dynamics (natural frequency ~5 rad/s = 0.8 Hz, chirps up to ~1.5 Hz)
#: nearly unattenuated and suppress the quantisation noise, which is spread
#: up to the Nyquist frequency of 100 Hz.
METHOD_DEFAULTS: dict[str, dict[str, float | int | None]] = {
    "central": {"window": None, "polyorder": None, "cutoff": None, "order": None},
    "savgol": {"window": 21, "polyorder": 3, "cutoff": None, "order": None},
    "savgol_direct": {"window": 21, "polyorder": 3, "cutoff": None, "order": None},
    "butter": {"window": None, "polyorder": None, "cutoff": 10.0, "order": 4},
}

# which method uses which setting (for error messages)
_USED_BY = {
    "window": ("savgol", "savgol_direct"),
    "polyorder": ("savgol", "savgol_direct"),
    "cutoff": ("butter",),
    "order": ("butter",),
}

# relative level below which the Butterworth impulse response is taken as
# settled when estimating the edge transient of the forward-backward filter
_EDGE_SETTLE = 1e-3


class Derivatives(NamedTuple):
    """Filtered position and its first two time derivatives.

    Unpacks like a tuple: ``q_f, dq, ddq = d.derivatives(Ts, q)``.

    Attributes
    ----------
    position : ndarray
        Filtered position, same unit as the input (e.g. rad).
    velocity : ndarray
        First derivative [unit/s] (e.g. rad/s).
    acceleration : ndarray
        Second derivative [unit/s^2] (e.g. rad/s^2).
    """

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


def _is_int(value: object) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


@dataclass(frozen=True)
class Differentiator:
    """A numerical differentiator with an explicit, shared low-pass filter.

    Parameters
    ----------
    method : {"savgol", "savgol_direct", "central", "butter"}
        Differentiation method, see the module docstring.
    window : int, optional
        ``"savgol"``, ``"savgol_direct"`` only: window length [samples], odd and > ``polyorder``.
        Default 21 (100 ms at Ts = 5 ms).
    polyorder : int, optional
        ``"savgol"``, ``"savgol_direct"`` only: degree of the local polynomial, 2 <= polyorder <
        window and <= 12 (degree >= 2 so that the second derivative is not zero; a higher
        degree than 12 follows the noise).
        Default 3.
    cutoff : float, optional
        ``"butter"`` only: -3 dB cut-off frequency [Hz] of the (single-pass)
        Butterworth filter; must be below the Nyquist frequency ``0.5/Ts``
        (checked when the sample time is known).  Default 10 Hz.
    order : int, optional
        ``"butter"`` only: filter order, 1 to 12.  Default 4.  The
        forward-backward pass doubles the effective order and squares the
        magnitude response (-6 dB at ``cutoff``), with zero phase.

    Notes
    -----
    Settings that belong to another method must be left at ``None``; the
    ones left at ``None`` get the defaults of :data:`METHOD_DEFAULTS`.

    Examples
    --------
    >>> d = Differentiator("savgol", window=21, polyorder=3)
    >>> q_f, dq, ddq = d.derivatives(0.005, q)          # doctest: +SKIP
    >>> u_f = d.smooth(0.005, u)                         # doctest: +SKIP
    >>> keep = slice(d.edge_samples_at(0.005), -d.edge_samples_at(0.005))
    """

    method: str = "savgol"
    window: int | None = None
    polyorder: int | None = None
    cutoff: float | None = None
    order: int | None = None

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise InputError(
                f"method must be one of {', '.join(map(repr, METHODS))}, got {self.method!r}"
            )
        for name, users in _USED_BY.items():
            if getattr(self, name) is not None and self.method not in users:
                raise InputError(
                    f"{name} is a setting of method={users[0]!r}, not of method={self.method!r}; "
                    f"leave {name} unset (None) or use method={users[0]!r}"
                )
        for name, default in METHOD_DEFAULTS[self.method].items():
            if getattr(self, name) is None and default is not None:
                object.__setattr__(self, name, default)
        if self.method in ("savgol", "savgol_direct"):
            self._check_savgol()
        elif self.method == "butter":
            self._check_butter()

    # -- validation ---------------------------------------------------------
    def _check_savgol(self) -> None:
        w, p = self.window, self.polyorder
        if not _is_int(w):
            raise InputError(f"window must be an odd integer number of samples, got {w!r}")
        if not _is_int(p):
            raise InputError(f"polyorder must be an integer, got {p!r}")
        if w < 3 or w % 2 == 0:
            hint = f"; try window={w + 1}" if w >= 2 else ""
            raise InputError(f"window must be an odd integer >= 3 [samples], got {w}{hint}")
        if p < 2:
            raise InputError(
                f"polyorder must be >= 2 so that the second derivative is not identically zero, got {p}"
            )
        if p > 12:  # the Butterworth filter's order has the same bound
            raise InputError(f"polyorder must be at most 12 (a higher degree follows the noise, not the motion), "
                             f"got {p}")
        if p >= w:
            raise InputError(
                f"window ({w}) must be larger than polyorder ({p}); "
                f"use window >= {p + 1 + (p % 2 == 0)} or a smaller polyorder",
                argument=("window", "polyorder"),
            )
        object.__setattr__(self, "window", int(w))
        object.__setattr__(self, "polyorder", int(p))

    def _check_butter(self) -> None:
        c = check_positive("cutoff", self.cutoff)
        o = self.order
        if not _is_int(o) or not 1 <= o <= 12:
            raise InputError(f"order must be an integer from 1 to 12, got {o!r}")
        object.__setattr__(self, "cutoff", c)
        object.__setattr__(self, "order", int(o))

    def _check_ts(self, Ts: float) -> float:
        Ts = check_positive("Ts", Ts)
        if self.method == "butter":
            nyquist = 0.5 / Ts
            if self.cutoff >= nyquist:
                raise InputError(
                    f"cutoff ({self.cutoff:g} Hz) must be below the Nyquist frequency "
                    f"0.5/Ts = {nyquist:g} Hz for Ts = {Ts:g} s; lower cutoff or Ts"
                )
        return Ts

    def _check_signal(self, name: str, x: object, Ts: float) -> np.ndarray:
        try:
            a = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{name} must be an array of numbers") from None
        if a.ndim == 0:
            raise InputError(f"{name} must be an array of samples (time along axis 0), got a scalar")
        bad = ~np.isfinite(a)
        if bad.any():
            idx = np.argwhere(bad)[0]
            where = int(idx[0]) if a.ndim == 1 else tuple(int(i) for i in idx)
            raise InputError(
                f"{name} contains NaN or inf (first at sample {where}); "
                "remove or interpolate the bad samples before differentiating"
            )
        n = a.shape[0]
        need = self.min_samples(Ts)
        if n < need:
            raise InputError(
                f"{name} has {n} samples, too few for {self._describe()}: need at least {need}"
            )
        return a

    def _describe(self) -> str:
        if self.method in ("savgol", "savgol_direct"):
            return f"method={self.method!r} with window={self.window}"
        if self.method == "butter":
            return f"method='butter' with order={self.order}"
        return "method='central'"

    def _sos(self, Ts: float) -> np.ndarray:
        return signal.butter(self.order, self.cutoff, btype="low", output="sos", fs=1.0 / Ts)

    # -- public -------------------------------------------------------------
    @classmethod
    def savgol_spanning(cls, seconds: float, Ts: float, *, min_window: int) -> "Differentiator":
        """A cubic Savitzky-Golay filter over about ``seconds`` of a log sampled every ``Ts`` [s].

        ``window = 2 round(seconds / (2 Ts)) + 1`` samples, at least ``min_window`` (odd): the same span in
        seconds whatever the sample time (:func:`~iwp.ident.identification.default_differentiator`,
        :func:`~iwp.ident.output_error.state_differentiator`).

        Parameters
        ----------
        seconds : float
            Span of the window [s].
        Ts : float
            Sample time [s].
        min_window : int
            Fewest samples of the window (odd, at least 5: a cubic over 5 samples keeps one degree of freedom).

        Returns
        -------
        Differentiator
        """
        half = max((min_window - 1) // 2, int(round(0.5 * seconds / check_positive("Ts", Ts))))
        return cls("savgol", window=2 * half + 1, polyorder=3)

    def min_samples(self, Ts: float) -> int:
        """Smallest number of samples the method accepts.

        Parameters
        ----------
        Ts : float
            Sample time [s].

        Returns
        -------
        int
            4 for ``"central"`` (one-sided second derivative), ``window`` for
            ``"savgol"``, and the padding length of
            :func:`scipy.signal.sosfiltfilt` plus one for ``"butter"``.
        """
        if self.method in ("savgol", "savgol_direct"):
            return self.window
        if self.method == "butter":
            sos = self._sos(self._check_ts(Ts))
            # the default padding of scipy.signal.sosfiltfilt
            zeros = min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
            padlen = 3 * (2 * len(sos) + 1 - zeros)
            return max(padlen + 1, 4)
        return 4

    @property
    def edge_samples(self) -> int:
        """Number of unreliable samples at *each* end of the outputs.

        ``"central"``: 1 (the one-sided end formulas have 2-13 times the
        noise of the central ones).  ``"savgol"``, ``"savgol_direct"``:
        ``window // 2`` (the edge values come from the polynomial fitted to
        the first / last window, not from the common filter).  ``"butter"``: the length of the edge
        transient of the forward-backward filter *at the nominal sample time
        Ts = 5 ms* of the rig; it depends on the sample time, so for any
        other Ts use :meth:`edge_samples_at`.
        """
        return self.edge_samples_at(0.005)

    def edge_samples_at(self, Ts: float) -> int:
        """Number of unreliable samples at each end for sample time ``Ts``.

        Parameters
        ----------
        Ts : float
            Sample time [s].

        Returns
        -------
        int
            Samples to drop at the start and at the end before using the
            derivatives (e.g. ``x[k:-k]`` with ``k`` this value, ``k >= 1``).
            For ``"butter"`` this is the number of samples until the
            filter's impulse response has decayed below 1e-3 of its peak,
            plus one for the difference formulas.
        """
        Ts = self._check_ts(Ts)
        if self.method == "central":
            return 1
        if self.method in ("savgol", "savgol_direct"):
            return self.window // 2
        sos = self._sos(Ts)
        # impulse response long enough to contain the slowest pole's decay:
        # time constant 1 / (wc sin(pi/(2 order))) [s]
        wc = 2.0 * math.pi * self.cutoff
        tau = 1.0 / (wc * math.sin(math.pi / (2 * self.order)))
        n = int(math.ceil(20.0 * tau / Ts)) + 16
        imp = np.zeros(n)
        imp[0] = 1.0
        h = np.abs(signal.sosfilt(sos, imp))
        above = np.nonzero(h > _EDGE_SETTLE * h.max())[0]
        return int(above[-1]) + 2

    def derivatives(self, Ts: float, q: object) -> Derivatives:
        """Filtered position and its first and second derivatives.

        Parameters
        ----------
        Ts : float
            Sample time [s] (> 0), e.g. 0.005.
        q : array_like
            Positions [rad] (or any unit), time along axis 0; several signals
            may be given as columns of a 2-D array.  Must be finite.

        Returns
        -------
        Derivatives
            ``(position, velocity, acceleration)`` with the shape of ``q``:
            filtered position [rad], velocity [rad/s], acceleration
            [rad/s^2].  For ``"central"`` the position is ``q`` itself.
            The first and last :meth:`edge_samples_at` samples are less
            accurate.

        Raises
        ------
        InputError
            Non-positive ``Ts``, NaN/inf in ``q``, fewer samples than the
            method needs, ``cutoff`` at or above the Nyquist frequency.
        """
        Ts = self._check_ts(Ts)
        x = self._check_signal("q", q, Ts)
        if self.method in ("savgol", "savgol_direct"):
            kw = dict(window_length=self.window, polyorder=self.polyorder, delta=Ts, axis=0, mode="interp")
            vel = signal.savgol_filter(x, deriv=1, **kw)
            acc = signal.savgol_filter(x, deriv=2, **kw)
            if self.method == "savgol_direct":
                return Derivatives(signal.savgol_filter(x, deriv=0, **kw), vel, acc)
            pos = self._savgol_smooth(x, Ts)
            m, n = self.window // 2, x.shape[0]
            vel[m : n - m] = (pos[m + 1 : n - m + 1] - pos[m - 1 : n - m - 1]) / (2.0 * Ts)
            return Derivatives(pos, vel, acc)
        if self.method == "butter":
            pos = signal.sosfiltfilt(self._sos(Ts), x, axis=0)
        else:
            pos = x.copy()
        return Derivatives(pos, central_first(pos, Ts), central_second(pos, Ts))

    def smooth(self, Ts: float, x: object) -> np.ndarray:
        """Apply the zero-th derivative of the same filter to another signal.

        Use it for signals that enter the regressor without being
        differentiated (e.g. the input ``u`` in (11)), so that regressors and
        targets carry the same filter.

        Parameters
        ----------
        Ts : float
            Sample time [s] (> 0).
        x : array_like
            Signal (any unit), time along axis 0.  Must be finite.

        Returns
        -------
        ndarray
            The filtered signal, same shape and unit as ``x``; identical to
            ``derivatives(Ts, x).position``.  For ``"central"`` a copy of
            ``x``.
        """
        Ts = self._check_ts(Ts)
        a = self._check_signal("x", x, Ts)
        if self.method == "savgol":
            return self._savgol_smooth(a, Ts)
        if self.method == "savgol_direct":
            return signal.savgol_filter(
                a, self.window, self.polyorder, deriv=0, delta=Ts, axis=0, mode="interp"
            )
        if self.method == "butter":
            return signal.sosfiltfilt(self._sos(Ts), a, axis=0)
        return a.copy()

    def smoothing_kernel(self) -> np.ndarray:
        """FIR kernel ``K`` of the common filter of method ``"savgol"``.

        Returns
        -------
        ndarray, shape (window - 2,)
            Symmetric taps with unit sum such that the Savitzky-Golay
            second-derivative kernel is ``[1, -2, 1] * K / Ts^2``
            (convolution).  Independent of ``Ts``.
        """
        if self.method != "savgol":
            raise InputError(f"smoothing_kernel is defined for method='savgol' only, not {self.method!r}")
        return _savgol_kernel(self.window, self.polyorder)

    def _savgol_smooth(self, a: np.ndarray, Ts: float) -> np.ndarray:
        """``K a`` inside; the first/last ``window//2 - 1`` samples from the edge polynomial fit."""
        K = _savgol_kernel(self.window, self.polyorder)
        out = signal.savgol_filter(a, self.window, self.polyorder, deriv=0, delta=Ts, axis=0, mode="interp")
        half, n = (len(K) - 1) // 2, a.shape[0]
        inner = ndimage.correlate1d(a, K[::-1], axis=0, mode="nearest")
        out[half : n - half] = inner[half : n - half]
        return out

    def settings(self) -> dict[str, object]:
        """The settings that the method uses, as a JSON-able dict."""
        out: dict[str, object] = {"method": self.method}
        for name, users in _USED_BY.items():
            if self.method in users:
                out[name] = getattr(self, name)
        return out


@functools.lru_cache(maxsize=64)
def _savgol_kernel_cached(window: int, polyorder: int) -> tuple[float, ...]:
    c = signal.savgol_coeffs(window, polyorder, deriv=2, delta=1.0, use="conv")
    # c = [1, -2, 1] (*) K  <=>  K = double cumulative sum of c (first window-2 taps)
    K = np.cumsum(np.cumsum(c))[: window - 2]
    K = 0.5 * (K + K[::-1])  # exact symmetry
    return tuple(K / K.sum())


def _savgol_kernel(window: int, polyorder: int) -> np.ndarray:
    return np.array(_savgol_kernel_cached(window, polyorder))


def central_first(x: np.ndarray, Ts: float) -> np.ndarray:
    """First derivative by second-order central differences.

    ``(x[k+1] - x[k-1]) / (2 Ts)`` inside; at the ends the one-sided
    second-order formulas ``(-3 x0 + 4 x1 - x2) / (2 Ts)`` and its mirror.
    Exact for quadratics.

    Parameters
    ----------
    x : ndarray
        Samples, time along axis 0, at least 3.
    Ts : float
        Sample time [s].

    Returns
    -------
    ndarray
        Derivative [unit of x per s], same shape as ``x``.
    """
    x = np.asarray(x, dtype=float)
    Ts = check_positive("Ts", Ts)
    if x.shape[0] < 3:
        raise InputError(f"x has {x.shape[0]} samples; central differences need at least 3")
    d = np.empty_like(x)
    d[1:-1] = (x[2:] - x[:-2]) / (2.0 * Ts)
    d[0] = (-3.0 * x[0] + 4.0 * x[1] - x[2]) / (2.0 * Ts)
    d[-1] = (3.0 * x[-1] - 4.0 * x[-2] + x[-3]) / (2.0 * Ts)
    return d


def central_second(x: np.ndarray, Ts: float) -> np.ndarray:
    """Second derivative by second-order central differences.

    ``(x[k+1] - 2 x[k] + x[k-1]) / Ts^2`` inside; at the ends the one-sided
    second-order formulas ``(2 x0 - 5 x1 + 4 x2 - x3) / Ts^2`` and its
    mirror.  Exact for cubics at interior points and quadratics everywhere.

    Parameters
    ----------
    x : ndarray
        Samples, time along axis 0, at least 4.
    Ts : float
        Sample time [s].

    Returns
    -------
    ndarray
        Second derivative [unit of x per s^2], same shape as ``x``.
    """
    x = np.asarray(x, dtype=float)
    Ts = check_positive("Ts", Ts)
    if x.shape[0] < 4:
        raise InputError(f"x has {x.shape[0]} samples; the second derivative needs at least 4")
    h2 = Ts * Ts
    d = np.empty_like(x)
    d[1:-1] = (x[2:] - 2.0 * x[1:-1] + x[:-2]) / h2
    d[0] = (2.0 * x[0] - 5.0 * x[1] + 4.0 * x[2] - x[3]) / h2
    d[-1] = (2.0 * x[-1] - 5.0 * x[-2] + 4.0 * x[-3] - x[-4]) / h2
    return d


#: The project-wide default differentiator (Savitzky-Golay, 21 samples,
#: cubic).  Provisional: the lead chooses the final default by a study.
DEFAULT_DIFFERENTIATOR = Differentiator("savgol")

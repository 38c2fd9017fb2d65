"""The signals of an identification: windowed, differentiated, filtered and stacked logs.

How the signals are formed
--------------------------
Each file is windowed (``t_start``, ``t_end``), then differentiated on its
own with one :class:`~iwp.ident.differentiate.Differentiator` ``D`` whose
low-pass filter is ``K``. The targets are ``dq3/dt = K D2 q1 / Ts^2`` and
``dq4/dt = K D2 q2 / Ts^2`` with ``D2`` the second difference. Every term
``f`` of the model enters as ``K S f`` with ``S`` the triangle average
``[1, 10, 1] / 12`` of the term's point values (see :mod:`iwp.ident.identification`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.fft as sfft

from ..data import ExperimentData, StaticCurve
from ..errors import InputError
from .differentiate import Differentiator, central_first

__all__ = ["Signals", "prepare_signals", "fast_derivatives", "apply_K", "apply_KS", "corr_len", "EDGE_MIN", "PD1_GAIN",
           "point_velocity", "position_noise", "acceleration_noise_gain", "held_input", "hold_of"]

@dataclass
class Signals:
    """Stacked, filtered signals of one or more files (internal)."""

    q1: np.ndarray  # measured pendulum angle [rad]
    q3: np.ndarray  # filtered pendulum velocity [rad/s]
    q4: np.ndarray  # filtered disk velocity [rad/s]
    dq3: np.ndarray  # filtered pendulum acceleration [rad/s^2]
    dq4: np.ndarray  # filtered disk acceleration [rad/s^2]
    u: np.ndarray  # filtered input [in]
    S: np.ndarray  # K sin q1
    Z: np.ndarray  # K cos q1 (the column of an offset of the logged angle's zero)
    C: np.ndarray  # K |cos q1| q3
    B: np.ndarray  # K q3^3
    G: np.ndarray | None  # K sgn q4
    sidx: np.ndarray  # sample numbers, distinct across files
    n_files: int
    corr_len: float  # correlation length of the filter [samples]
    q1_range: list[float]  # per file, range of the measured q1 [rad]
    input_max: list[float]  # per file, max |input| (raw)
    q4_max: list[float]  # per file, max |filtered q4|
    #: per file: n_full, kk, Ts, start, q1, v1 (for the noise covariance)
    files: list[dict] = field(default_factory=list)

    @property
    def n(self) -> int:
        return int(self.q1.size)

    def file_rows(self, k: int) -> slice:
        """The rows of file ``k`` in the stacked signals: its samples less ``kk`` at each end."""
        f = self.files[k]
        return slice(f["start"], f["start"] + f["n_full"] - 2 * f["kk"])


#: samples dropped at least at each end (reach of the central difference, point correction and _tri3)
EDGE_MIN = 3


def point_velocity(v_cd: np.ndarray) -> np.ndarray:
    """Point values of the velocity from central differences: ``(-v[k-1] + 8 v[k] - v[k+1]) / 6``.

    The central difference is the mean of the velocity over two samples,
    ``v_cd = v + (Ts^2 / 6) d2v/dt2 + O(Ts^4)``; subtracting a sixth of its
    second difference removes the ``Ts^2`` term. End samples are left as they
    are (they are dropped).
    """
    out = v_cd.copy()
    out[1:-1] -= (v_cd[2:] - 2.0 * v_cd[1:-1] + v_cd[:-2]) / 6.0
    return out


#: ``||P D1||^2 Ts^2``: noise gain of the point velocity ``P D1`` (taps [-1, 8, 0, -8, 1] / (12 Ts)).
PD1_GAIN = 130.0 / 144.0


def position_noise(q: np.ndarray) -> np.ndarray:
    """White-equivalent position noise [rad] per column from the fourth difference.

    ``D4 q = q[k-2] - 4 q[k-1] + 6 q[k] - 4 q[k+1] + q[k+2]`` removes any
    motion of the rig (``Ts^4 d4q/dt4`` is below 1e-4 rad at 5 ms) and
    multiplies white noise by ``sqrt(70)``. Includes the quantisation
    (``step / sqrt(12)`` when the encoder moves by several counts per sample,
    less for slow motion).
    """
    d4 = q[:-4] - 4.0 * q[1:-3] + 6.0 * q[2:-2] - 4.0 * q[3:-1] + q[4:]
    return np.sqrt(np.mean(d4 * d4, axis=0) / 70.0)


def _tri3(x: np.ndarray) -> np.ndarray:
    """Triangle average of samples, ``(x[k-1] + 10 x[k] + x[k+1]) / 12``.

    Equals the continuous average of ``x(t)`` over the triangle of width
    ``2 Ts`` to ``O(Ts^4)``: the weight that the second difference
    ``(q[k+1] - 2 q[k] + q[k-1]) / Ts^2`` gives to the acceleration.
    Regressor terms averaged this way match the differentiated target
    without the ``(omega Ts)^2 / 12`` bias of plain samples (1e-4 at
    10 rad/s).
    """
    out = x.copy()
    out[1:-1] += (x[2:] - 2.0 * x[1:-1] + x[:-2]) / 12.0
    return out


def _convolve_same(X: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Columns of ``X`` (n x m, or 1-D) convolved with an odd-length ``kernel``, centred ("same" size).

    One real FFT of the whole length per column (on the transposed, contiguous array), about twice as
    fast as overlap-add for the 60,000-sample logs of section 5; zeros are assumed outside ``X``.
    """


    one = X.ndim == 1
    XT = np.ascontiguousarray((X[:, None] if one else X).T)
    n, L = XT.shape[1], kernel.size
    nf = sfft.next_fast_len(n + L - 1, real=True)
    Y = sfft.irfft(sfft.rfft(XT, nf, axis=1) * sfft.rfft(kernel, nf)[None, :], nf, axis=1)
    h = (L - 1) // 2
    out = Y[:, h: h + n].T
    return out[:, 0] if one else out


def fast_derivatives(d: Differentiator, Ts: float, q: np.ndarray):
    """``d.derivatives(Ts, q)``, computed faster for method ``"savgol"``.

    For ``"savgol"`` the outputs are ``K q``, ``D1 K q`` and ``D2 K q / Ts^2``
    (see :mod:`iwp.ident.differentiate`); here ``K`` is applied by FFT
    convolution to the increments ``q[k+1] - q[k]`` (small numbers even when
    the disk has turned thousands of radians, so no digits are lost), which
    gives the same values as ``d.derivatives`` away from the ends (the
    samples identification keeps; checked in the tests), 5-10 times faster
    for a 101-sample window.

    Parameters
    ----------
    d : Differentiator
        The differentiator.
    Ts : float
        Sample time [s].
    q : ndarray, shape (n, m)
        Positions, one signal per column [rad].

    Returns
    -------
    pos : ndarray, shape (n, m)
        Smoothed positions [rad].
    vel : ndarray, shape (n, m)
        Velocities [rad/s].
    acc : ndarray, shape (n, m)
        Accelerations [rad/s^2].
    """
    if d.method != "savgol":
        return d.derivatives(Ts, q)
    K = d.smoothing_kernel()
    if q.shape[0] < K.size + 4:
        return d.derivatives(Ts, q)
    Kdq = _convolve_same(np.diff(q, axis=0), K)
    vel = np.empty_like(q)
    acc = np.empty_like(q)
    vel[1:-1] = (Kdq[1:] + Kdq[:-1]) / (2.0 * Ts)
    acc[1:-1] = (Kdq[1:] - Kdq[:-1]) / (Ts * Ts)
    vel[0], vel[-1], acc[0], acc[-1] = vel[1], vel[-2], acc[1], acc[-2]  # end samples are dropped
    pos = q[0] + np.concatenate([np.zeros((1, q.shape[1])), np.cumsum(Kdq, axis=0)])  # K q up to a constant
    return pos, vel, acc


def corr_len(d: Differentiator, Ts: float) -> float:
    """Rough correlation length [samples] of the filter's output noise.

    Parameters
    ----------
    d : Differentiator
        The differentiator.
    Ts : float
        Sample time [s].

    Returns
    -------
    float
        The window for Savitzky-Golay filters, ``0.5 / (cutoff Ts)`` (at least 2) for Butterworth, else 2.
    """
    if d.method in ("savgol", "savgol_direct"):
        return float(d.window)
    if d.method == "butter":
        return max(2.0, 0.5 / (d.cutoff * Ts))
    return 2.0


def as_list(data: Any) -> list:
    if isinstance(data, (list, tuple)):
        if not data:
            raise InputError("data is empty: give at least one experiment log")
        return list(data)
    return [data]


def prepare_signals(setup, datas: list, d: Differentiator, t_start, t_end, *, nonlinear: str = "filter-terms",
                    input_hold: str = "auto"
                    ) -> Signals:
    """Window, differentiate, filter and stack the logs of one set-up (``setup``: a :class:`~.setups.Setup`).

    Parameters
    ----------
    setup : Setup
        The identification set-up (its columns, input and Coulomb needs).
    datas : list of ExperimentData
        Time-series logs with uniform sampling and the wheel angle ``q2``.
    d : Differentiator
        The differentiator (and common low-pass ``K``).
    t_start : float or None
        Start of the window of every log [s]; None: from the first sample.
    t_end : float or None
        End of the window [s]; None: to the last sample.
    nonlinear : {"filter-terms", "filtered-states"}, default "filter-terms"
        ``"filter-terms"``: the model's terms evaluated at the samples, then filtered by ``K`` (consistent with
        the target); ``"filtered-states"``: the terms of the filtered states (for comparison).
    input_hold : {"auto", "zoh", "continuous"}, default "auto"
        ``"zoh"``: each logged input held until the next sample, as a digital controller applies it
        (:func:`held_input`); ``"continuous"``: the value at the sample of an input that varies continuously;
        ``"auto"``: each log's metadata ``input_hold``, else ``"zoh"``.

    Returns
    -------
    Signals
        The stacked signals without the ends each filter spoils, and per-file records.

    Raises
    ------
    InputError
        A static curve or another object, an input the set-up cannot use (no ``u``, a raw ``v``, or a motor
        that is on for set-up ``free``), a bad window, too few samples, non-uniform sampling, or no ``q2``.
    """
    parts: list[_FileSignals] = []
    files: list[dict] = []
    offset = 0
    corr = 0.0
    for data in datas:
        _check_log(setup, data)
        w = _checked_window(setup, data, d, t_start, t_end)
        part = _file_signals(setup, w, d, nonlinear, hold_of(data, input_hold))
        f = part.file
        files.append(dict(n_full=f["n_full"], kk=f["kk"], Ts=f["Ts"], start=sum(p.n for p in parts), noise=f["noise"],
                          q1=f["q1"], v1=f["v1"]))
        parts.append(replace(part, sidx=offset + part.sidx))
        # the next file's sample numbers start after a gap longer than any HAC bandwidth used
        offset += part.n + part.n // 4 + 2 * int(math.ceil(corr_len(d, w.Ts))) + 8
        corr = max(corr, corr_len(d, w.Ts))
    cat = {key: (np.concatenate([getattr(p, key) for p in parts]) if getattr(parts[0], key) is not None else None)
           for key in _STACKED}
    return Signals(**cat, n_files=len(parts), corr_len=corr, q1_range=[p.q1_range for p in parts],
                   input_max=[p.input_max for p in parts], q4_max=[p.q4_max for p in parts], files=files)


#: the signals stacked over the files, in the order of :class:`Signals`
_STACKED = ("q1", "q3", "q4", "dq3", "dq4", "u", "S", "Z", "C", "B", "G", "sidx")


@dataclass(frozen=True, eq=False)
class _FileSignals:
    """One file's signals without the ends the filters spoil, and its record for the noise covariance.

    ``file``: ``n_full``, ``kk`` (samples dropped at each end), ``Ts`` [s],
    ``noise`` (position noise per encoder [rad]), ``q1`` [rad] and ``v1``
    (point velocity [rad/s], None for ``"filtered-states"``).
    """

    q1: np.ndarray
    q3: np.ndarray
    q4: np.ndarray
    dq3: np.ndarray
    dq4: np.ndarray
    u: np.ndarray
    S: np.ndarray
    Z: np.ndarray
    C: np.ndarray
    B: np.ndarray
    G: np.ndarray | None
    sidx: np.ndarray
    file: dict[str, Any]
    q1_range: float
    input_max: float
    q4_max: float

    @property
    def n(self) -> int:
        return int(self.sidx.size)


@dataclass(frozen=True, eq=False)
class _Terms:
    """The filtered model terms of one file: ``sin q1``, ``|cos q1| q3``, ``q3^3``, the input (and ``sgn q4``)
    as columns of ``terms``, the filtered velocities ``q3``, ``q4`` [rad/s], the point velocity ``v1`` and ``Z``,
    ``cos q1`` filtered as ``sin q1`` is (the column of an offset of the angle's zero)."""

    terms: np.ndarray
    q3: np.ndarray
    q4: np.ndarray
    v1: np.ndarray | None
    Z: np.ndarray


def _check_log(setup, data: Any) -> None:
    """A time-series log whose input the set-up can use (u for a driven set-up, none or zero for ``free``)."""
    if isinstance(data, StaticCurve):
        raise InputError(f"{data.source}: is a static curve (input, q4); set-up {setup.name!r} needs a time-series "
                         "log (t, q1, q2, ...). Use setup 'dead-zone' for static curves")
    if not isinstance(data, ExperimentData):
        raise InputError(f"data must be ExperimentData (or a list of them), got {type(data).__name__}")
    src = data.source
    if setup.needs_input and data.input_name != "u":
        if data.input_name is None:
            raise InputError(f"{src}: set-up {setup.name!r} needs the input column u; the log has no input")
        raise InputError(
            f"{src}: set-up {setup.name!r} needs the dead-zone-compensated input u (model (9)); the log has the "
            "raw driver input v. Identify v+, v- (set-up 'dead-zone') and log u with the feedforward (7)-(8)")
    if setup.motor_off and data.input_name is not None:
        amax = float(np.max(np.abs(data.input))) if data.n_samples else 0.0
        if amax > 0:
            raise InputError(
                f"{src}: set-up 'free' needs the motor off (u = 0), but the log's input {data.input_name} "
                f"reaches |{data.input_name}| = {amax:.4g}; use a window where it is zero, or set-up "
                "'full'/'two-step'")


def _checked_window(setup, data: ExperimentData, d: Differentiator, t_start, t_end) -> ExperimentData:
    """The log's window [s]: enough samples for the filter and the parameters, uniform sampling, a ``q2``."""
    src = data.source
    try:
        w = data.window(t_start, t_end)
    except InputError as exc:
        raise InputError(f"{src}: {exc}", argument=exc.argument) from None
    Ts = w.Ts
    k = d.edge_samples_at(Ts)
    n_params = len(setup.columns)
    need = max(d.min_samples(Ts), 4) + 2 * max(k, EDGE_MIN) + n_params + 1
    if w.n_samples < need:
        win = "" if t_start is None and t_end is None else f" (t_start={t_start}, t_end={t_end})"
        raise InputError(
            f"{src}: {w.n_samples} samples{win}, too few for set-up {setup.name!r}: the differentiator "
            f"({d.method}) drops {k} at each end and {n_params} parameters need at least {need}")
    dt = np.diff(w.t)
    if float(np.max(np.abs(dt - Ts))) > 0.01 * Ts:
        raise InputError(
            f"{src}: the sampling is not uniform (steps from {dt.min():.6g} to {dt.max():.6g} s); "
            "resample the log first (ExperimentData.resample)")
    if w.q2 is None:
        raise InputError(f"{src}: set-up {setup.name!r} differentiates the wheel angle q2, which this log does "
                         "not have (only the wheel speed q4); fit it with `iwp fit` (iwp.ident.logfit)")
    return w


def hold_of(data: ExperimentData, input_hold: str) -> str:
    """How ``data``'s input acted between samples: ``input_hold``, or for ``"auto"`` the log's metadata
    ``input_hold`` (``"zoh"`` or ``"continuous"``), ``"zoh"`` when it says nothing (a rig's controller holds)."""
    if input_hold != "auto":
        return input_hold
    said = str(data.metadata.get("input_hold", "zoh")).strip().lower()
    return "continuous" if said == "continuous" else "zoh"


def held_input(u: np.ndarray) -> np.ndarray:
    """The average of an input held from each sample to the next (zero-order hold) over the triangle of the second
    difference centred on each sample: ``(u[k-1] + u[k]) / 2`` (``u[0]`` at the first sample).

    A digital controller applies ``u[k]`` from ``t[k]`` to ``t[k+1]``; the second difference of the angles at
    ``t[k]`` integrates the acceleration against the triangle over ``[t[k-1], t[k+1]]``, whose two halves see
    ``u[k-1]`` and ``u[k]``. Taking ``u[k]`` there instead (an input that varies smoothly) shifts the input half a
    sample late, which biases a chirp's ``p2`` and ``p3`` by about -1.1 % and -0.6 % at 5 ms.

    Parameters
    ----------
    u : ndarray, shape (n,)
        The logged input, one value per sample.

    Returns
    -------
    ndarray, shape (n,)
        The held input's average at each sample, in ``u``'s units.

    Examples
    --------
    >>> import numpy as np
    >>> from iwp.ident.signals import held_input
    >>> held_input(np.array([0.0, 2.0, 2.0, -4.0]))
    array([ 0.,  1.,  2., -1.])
    """
    u = np.asarray(u, dtype=float)
    out = u.copy()
    out[1:] = 0.5 * (u[1:] + u[:-1])
    return out


def _filtered_terms(w: ExperimentData, d: Differentiator, coulomb: bool, noise_sd: np.ndarray,
                    vel: np.ndarray, input_hold: str) -> _Terms:
    """The model's terms evaluated at the samples, then filtered by ``K`` (``"filter-terms"``).

    The target ``K D2 q / Ts^2`` equals ``K (tri * d2q/dt2)`` exactly, tri the
    triangle of width ``2 Ts`` (Peano kernel of the second difference). Each
    term of the model is therefore evaluated at the sample points (position
    as measured, velocity from the central difference corrected to a point
    value), triangle-averaged by ``_tri3`` and filtered by ``K``.
    """
    Ts = w.Ts
    q = np.column_stack([w.q1, w.q2])
    v_pt = point_velocity(central_first(q, Ts))
    q1r = w.q1
    u_raw = np.asarray(w.input, dtype=float)
    # errors in variables: E[(v + n)^3] = v^3 + 3 var(n) v, removed with the noise of the
    # point velocity estimated from the positions
    var_v = float(noise_sd[0]) ** 2 * PD1_GAIN / (Ts * Ts)
    cube = v_pt[:, 0] ** 3 - 3.0 * var_v * v_pt[:, 0]
    terms = [np.sin(q1r), np.abs(np.cos(q1r)) * v_pt[:, 0], cube, v_pt[:, 0], v_pt[:, 1], u_raw]
    if coulomb:
        terms.append(np.sign(vel[:, 1]))
    terms.append(np.cos(q1r))  # last: Z
    sm = apply_KS(d, Ts, np.column_stack(terms))
    if input_hold == "zoh":  # the triangle average of the held input is exact: no point values to average
        sm[:, 5] = apply_K(d, Ts, held_input(u_raw)[:, None])[:, 0]
    return _Terms(terms=np.delete(sm[:, :-1], [3, 4], axis=1), q3=sm[:, 3], q4=sm[:, 4], v1=v_pt[:, 0],
                  Z=sm[:, -1])


def _terms_of_filtered_states(w: ExperimentData, d: Differentiator, coulomb: bool, pos: np.ndarray,
                              vel: np.ndarray, input_hold: str) -> _Terms:
    """The terms of the filtered states, ``f(K q1, K q3)``: the usual way (``"filtered-states"``, for comparison)."""
    u = np.asarray(w.input, dtype=float)
    uf = d.smooth(w.Ts, held_input(u) if input_hold == "zoh" else u)
    q1f, q3f = pos[:, 0], vel[:, 0]
    cols = [np.sin(q1f), np.abs(np.cos(q1f)) * q3f, q3f ** 3, uf]
    if coulomb:
        cols.append(np.sign(vel[:, 1]))
    return _Terms(terms=np.column_stack(cols), q3=vel[:, 0], q4=vel[:, 1], v1=None, Z=np.cos(q1f))


def _file_signals(setup, w: ExperimentData, d: Differentiator, nonlinear: str, input_hold: str) -> _FileSignals:
    """Differentiate and filter one windowed log; drop the ends the filters spoil (sample numbers from 0)."""
    coulomb = setup.coulomb
    Ts = w.Ts
    q = np.column_stack([w.q1, w.q2])
    pos, vel, acc = fast_derivatives(d, Ts, q)
    noise_sd = position_noise(q)
    if nonlinear == "filter-terms":
        tm = _filtered_terms(w, d, coulomb, noise_sd, vel, input_hold)
    else:
        tm = _terms_of_filtered_states(w, d, coulomb, pos, vel, input_hold)
    sm = tm.terms
    kk = max(d.edge_samples_at(Ts), EDGE_MIN)
    keep = slice(kk, w.n_samples - kk)
    n = w.n_samples - 2 * kk
    return _FileSignals(
        q1=w.q1[keep], q3=tm.q3[keep], q4=tm.q4[keep], dq3=acc[keep, 0], dq4=acc[keep, 1],
        S=sm[keep, 0], Z=tm.Z[keep], C=sm[keep, 1], B=sm[keep, 2], u=sm[keep, 3], G=sm[keep, 4] if coulomb else None,
        sidx=np.arange(n, dtype=np.int64),
        file=dict(n_full=w.n_samples, kk=kk, Ts=Ts, noise=noise_sd, q1=np.asarray(w.q1, dtype=float), v1=tm.v1),
        q1_range=float(np.ptp(w.q1)), input_max=float(np.max(np.abs(w.input))),
        q4_max=float(np.max(np.abs(vel[kk : w.n_samples - kk, 1]))),
    )


def apply_K(d: Differentiator, Ts: float, X: np.ndarray) -> np.ndarray:
    """The common low-pass ``K`` of the differentiator on columns that are zero near both ends.

    Parameters
    ----------
    d : Differentiator
        The differentiator.
    Ts : float
        Sample time [s].
    X : ndarray, shape (n, m)
        Columns to filter.

    Returns
    -------
    ndarray, shape (n, m)
        The filtered columns, in ``X``'s units.
    """
    if d.method == "savgol":
        return _convolve_same(X, d.smoothing_kernel())
    return d.smooth(Ts, X)


def apply_KS(d: Differentiator, Ts: float, X: np.ndarray) -> np.ndarray:
    """``K`` after the triangle average ``S`` of :func:`_tri3` (one convolution for ``"savgol"``).

    Parameters
    ----------
    d : Differentiator
        The differentiator.
    Ts : float
        Sample time [s].
    X : ndarray, shape (n, m)
        Columns to average and filter.

    Returns
    -------
    ndarray, shape (n, m)
        The filtered columns, in ``X``'s units.
    """
    if d.method == "savgol":
        KS = np.convolve(d.smoothing_kernel(), np.array([1.0, 10.0, 1.0]) / 12.0)
        return _convolve_same(X, KS)
    return apply_K(d, Ts, _tri3(X))



def acceleration_noise_gain(d: Differentiator, Ts: float) -> float:
    """``||f||^2`` of the acceleration operator ``f = K D2 / Ts^2`` [1/s^4]: white position noise of variance
    ``s^2`` [rad^2] becomes target noise of variance ``s^2 ||f||^2`` [rad^2/s^4].

    Parameters
    ----------
    d : Differentiator
        The differentiator (its common low-pass ``K``).
    Ts : float
        Sample time [s].

    Returns
    -------
    float
        The squared norm of the operator's taps [1/s^4].
    """
    half = max(d.edge_samples_at(Ts), 3)
    imp = np.zeros(4 * half + 9)
    imp[imp.size // 2] = 1.0
    k = apply_K(d, Ts, imp[:, None])[:, 0]
    f = np.zeros_like(k)
    f[1:-1] = (k[2:] - 2.0 * k[1:-1] + k[:-2]) / (Ts * Ts)
    return float(f @ f)

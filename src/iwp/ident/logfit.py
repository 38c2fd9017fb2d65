"""From logs to a validated model in one call: least squares, joint simulation-error fit, validation.

:func:`fit_logs` (the command ``iwp fit TRAIN... --rig RIG.json --validate
HELDOUT... --out DIR``) takes a rig's logs as they are (read with its rig
description, :func:`iwp.data.read_rig_log`, or iwp logs) and

1. finds and reports glitches (:meth:`ExperimentData.with_glitches_found`);
   replaced samples are left out of every residual and fit;
2. computes a start by **least squares** of the two rows of model (9)
   (:func:`least_squares_start`): the row sum ``q3' + q4' = -rho (p2 q4 - p3 u)``
   gives ``rho p2`` and ``rho p3`` free of the pendulum terms; the first row
   gives ``p1``, the friction, ``p2``, ``p3`` and the angle's zero offset; velocities and
   accelerations from cubic Savitzky-Golay filters over 0.15 s; a wheel speed
   sampled as the mean over the preceding period is moved to the sample
   instants first. Where the sampling does not allow it (fewer than 8
   samples per pendulum period) or the values are not physical, a start from
   the spectrum of ``q1`` and the wheel row alone is taken instead, and said so;
3. **refines** model (9) -- or (6) with its dead zone, with Coulomb friction
   of the wheel and of the pendulum and an input offset as options -- by
   simulation error on all training logs jointly (:func:`iwp.ident.refinement.refine`),
   from whatever the logs measure (``q1`` and the wheel's ``q2`` or ``q4``; a
   mean-sampled speed is modelled as the mean over the period), with the
   initial state and, unless the rig gives it, the pendulum angle's zero
   offset estimated per log;
4. **validates** on held-out logs without re-fitting: each is simulated from
   its measured initial state (:func:`measured_initial_state`) with the
   pendulum offset of the rig, or else the
   mean of the training logs' offsets (one encoder reset position), and
   compared per signal (fit in percent, RMS and largest error).

The result (:class:`LogFitResult`) holds the parameters with standard errors
and correlations, the fits per log and signal, the series for the error
plots, and every warning (glitches, saturated input, parameters the data
cannot separate, a fallback start). :meth:`LogFitResult.write` writes
``fit.json``, ``parameters.json`` and a self-contained ``report.html``
(:mod:`iwp.report.fit_page`).
"""

from __future__ import annotations

import math
import os
import time
import warnings as _warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from scipy import signal

from ..data import ExperimentData, read_experiment
from ..data.rig_description import RigDescription, load_rig
from ..data.rig_log import read_rig_log
from ..errors import InputError
from ..files import json_float
from ..models.parameters import TYPICAL, LumpedParameters
from .fit import fit_percent
from .refinement import RefineResult, refine

__all__ = ["fit_logs", "LogFitResult", "LogFit", "least_squares_start", "load_logs", "measured_initial_state",
           "MIN_SAMPLES_PER_PERIOD"]

#: Least squares on differentiated data needs at least this many samples per pendulum period.
MIN_SAMPLES_PER_PERIOD = 8
#: length of the Savitzky-Golay filters of the least-squares start [s] (at least 7 samples)
_SG_SECONDS = 0.15
_BASE_FREE = ("p1", "p2", "p3", "rho", "sigma_a1", "sigma_v1", "sigma_b1")


@dataclass
class LogFit:
    """How the model fits one log (training: at the optimum; held out: simulated from its measured state).

    Attributes
    ----------
    source : str
    role : {"train", "validate"}
    fit, rms, max_abs_error : dict of str to float
        Per signal: fit [%], RMS and largest error (unit of the signal).
    t : ndarray
        Sample times [s].
    measured, simulated : dict of str to ndarray
    used : dict of str to ndarray
        True where a sample enters the fit (False at replaced glitches).
    x0 : ndarray
        Initial state of the simulation.
    q1_offset : float
        The pendulum zero offset removed from ``q1`` [rad].
    glitches : list of str
    """

    source: str
    role: str
    fit: dict[str, float]
    rms: dict[str, float]
    max_abs_error: dict[str, float]
    t: np.ndarray
    measured: dict[str, np.ndarray]
    simulated: dict[str, np.ndarray]
    used: dict[str, np.ndarray]
    x0: np.ndarray
    q1_offset: float = 0.0
    glitches: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"source": self.source, "role": self.role,
                "fit": {k: json_float(v) for k, v in self.fit.items()},
                "rms": {k: json_float(v) for k, v in self.rms.items()},
                "max_abs_error": {k: json_float(v) for k, v in self.max_abs_error.items()},
                "samples": int(self.t.size), "t_start": float(self.t[0]), "t_end": float(self.t[-1]),
                "x0": [json_float(v) for v in self.x0], "q1_offset": json_float(self.q1_offset),
                "glitches": list(self.glitches)}


@dataclass(eq=False)
class LogFitResult:
    """The outcome of :func:`fit_logs`.

    Attributes
    ----------
    params : LumpedParameters
        The refined parameters.
    refinement : RefineResult
        The joint simulation-error fit (stderr, correlations, warnings, ...).
    start : LumpedParameters
        Its start; ``start_method`` says how it was found (``least squares`` or the fallback).
    least_squares : dict
        The least-squares values and notes.
    model : str
        ``"compensated"`` (9) or ``"raw"`` (6).
    outputs : tuple of str
    options : dict
        The model options used (dead zone, Coulomb terms, input offset).
    train, validation : list of LogFit
    warnings : list of str
    rig : RigDescription or None
    elapsed : float
        Wall time [s].
    """

    params: LumpedParameters
    refinement: RefineResult
    start: LumpedParameters
    start_method: str
    least_squares: dict
    model: str
    outputs: tuple[str, ...]
    options: dict
    train: list[LogFit]
    validation: list[LogFit]
    warnings: list[str]
    rig: RigDescription | None = None
    elapsed: float = 0.0

    @property
    def validation_fit(self) -> dict[str, float]:
        """Mean fit [%] per signal over the held-out logs (NaN without held-out logs)."""
        return _mean_fit(self.validation, self.outputs)

    @property
    def training_fit(self) -> dict[str, float]:
        """Mean fit [%] per signal over the training logs."""
        return _mean_fit(self.train, self.outputs)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able summary (NaN -> None)."""
        r = self.refinement
        return {
            "kind": "iwp-fit",
            "model": self.model,
            "outputs": list(self.outputs),
            "options": dict(self.options),
            "rig": None if self.rig is None else self.rig.to_dict(),
            "parameters": {k: v.to_dict() for k, v in r.parameters.items()},
            "free": list(r.free),
            "correlation": r.to_dict()["correlation"],
            "start": {"method": self.start_method, "values": self.start.to_dict()},
            "least_squares": self.least_squares,
            "train": [f.to_dict() for f in self.train],
            "validation": [f.to_dict() for f in self.validation],
            "training_fit": {k: json_float(v) for k, v in self.training_fit.items()},
            "validation_fit": {k: json_float(v) for k, v in self.validation_fit.items()},
            "refinement": {k: r.to_dict()[k] for k in ("cost_start", "cost", "success", "message", "nfev", "njev",
                                                        "n_samples", "residual_std")},
            "warnings": list(self.warnings),
            "elapsed_s": json_float(self.elapsed),
            "lumped": self.params.to_dict(),
        }

    def summary(self, warnings: bool = True) -> str:
        """Readable lines: parameters, fits per log and signal, (with ``warnings``) the warnings."""
        lines = [f"model {self.model} ({'(6) with dead zone' if self.model == 'raw' else '(9)'}), outputs "
                 f"{', '.join(self.outputs)}, start: {self.start_method}"]
        for n in self.refinement.free:
            pe = self.refinement.parameters[n]
            lines.append(f"  {n:<9} {pe.value:>12.6g} +- {pe.stderr:.2g}")
        for f in self.train + self.validation:
            fits = ", ".join(f"{k} {v:.2f} %" for k, v in f.fit.items())
            lines.append(f"{f.role:>8} {f.source}: fit {fits}")
        for w in self.warnings if warnings else ():
            lines.append(f"warning: {w}")
        lines.append(f"{self.elapsed:.3g} s")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()

    def write(self, out: str | os.PathLike, *, force: bool = False) -> dict:
        """Write ``fit.json``, ``parameters.json``, ``report.html`` and the figures into the folder ``out``.

        See :func:`iwp.report.fit_page.write_fit_report`.
        """
        from ..report.fit_page import write_fit_report

        return write_fit_report(self, out, force=force)


def _mean_fit(fits: list[LogFit], outputs) -> dict[str, float]:
    out = {}
    for o in outputs:
        vals = [f.fit[o] for f in fits if o in f.fit and math.isfinite(f.fit[o])]
        out[o] = float(np.mean(vals)) if vals else float("nan")
    return out


# --------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------
def load_logs(items, rig: RigDescription | None, *, argument: str = "logs") -> list[ExperimentData]:
    """Logs as :class:`ExperimentData`: paths are read with the rig description (or as iwp logs without one);
    glitches are found and recorded."""
    if isinstance(items, (str, os.PathLike, ExperimentData)):
        items = [items]
    out = []
    for it in items:
        if isinstance(it, ExperimentData):
            d = it
        elif isinstance(it, (str, os.PathLike)):
            p = Path(it)
            if not p.is_file():
                raise InputError(f"{argument}: {p}: no such file", argument=argument)
            d = read_rig_log(p, rig) if rig is not None else read_experiment(p)
        else:
            raise InputError(f"{argument}: expected log files or ExperimentData, got {type(it).__name__}",
                             argument=argument)
        out.append(d.with_glitches_found())
    return out


# --------------------------------------------------------------------------
# least squares start
# --------------------------------------------------------------------------
def _sg(Ts: float, n: int) -> tuple[int, int]:
    half = max(3, int(round(0.5 * _SG_SECONDS / Ts)))
    window = min(2 * half + 1, n - (1 - n % 2))
    return max(window, 5), 3


def _signals(d: ExperimentData) -> dict[str, np.ndarray]:
    """Smoothed q1, q3, q3', q4, q4', u (held input moved to the instants) of one log."""
    Ts = d.Ts
    win, po = _sg(Ts, d.n_samples)
    if d.n_samples < win + 2:
        raise InputError(f"{d.source}: {d.n_samples} samples are too few for the least-squares start")
    sg = dict(window_length=win, polyorder=min(po, win - 2), delta=Ts)
    q1 = d.q1
    out = {"q1": signal.savgol_filter(q1, deriv=0, **sg), "q3": signal.savgol_filter(q1, deriv=1, **sg),
           "dq3": signal.savgol_filter(q1, deriv=2, **sg)}
    if d.q2 is not None and d.q4 is None:
        out["q4"] = signal.savgol_filter(d.q2, deriv=1, **sg)
        out["dq4"] = signal.savgol_filter(d.q2, deriv=2, **sg)
    else:
        q4 = np.asarray(d.q4, dtype=float)
        if d.q4_sampling == "mean":  # means over [t_k - Ts, t_k]: move to the instants
            q4 = np.concatenate([0.5 * (q4[1:] + q4[:-1]), q4[-1:]])
        out["q4"] = signal.savgol_filter(q4, deriv=0, **sg)
        out["dq4"] = signal.savgol_filter(q4, deriv=1, **sg)
    u = np.asarray(d.input, dtype=float)
    held = np.concatenate([u[:1], 0.5 * (u[1:] + u[:-1])])  # the mean input over [t_k - Ts/2, t_k + Ts/2]
    out["u"] = signal.savgol_filter(held, deriv=0, **sg)
    edge = win // 2 + 1
    mask = np.ones(d.n_samples, dtype=bool)
    mask[:edge] = False
    mask[-edge:] = False
    for col in ("q1", "q4"):
        src = "q4" if col == "q4" and d.q4 is not None else ("q2" if col == "q4" else "q1")
        bad = np.flatnonzero(d.glitch_mask(src))
        for k in bad:
            mask[max(0, k - win // 2): k + win // 2 + 1] = False
    return {k: v[mask] for k, v in out.items()}


def least_squares_start(logs: Sequence[ExperimentData], *, base: LumpedParameters | None = None
                        ) -> tuple[LumpedParameters, str, dict, list[str]]:
    """A start for the refinement by least squares of model (9) on differentiated logs.

    Returns ``(params, method, details, notes)``: ``method`` is ``"least squares"`` or
    ``"spectrum and wheel row"`` (the fallback); ``details`` holds the least-squares values.
    """
    notes: list[str] = []
    sigs = [_signals(d) for d in logs]
    cat = {k: np.concatenate([s[k] for s in sigs]) for k in sigs[0]}
    q1, q3, dq3, q4, dq4, u = (cat[k] for k in ("q1", "q3", "dq3", "q4", "dq4", "u"))
    # row sum: q3' + q4' = -rho p2 q4 + rho p3 u (no pendulum terms)
    A = np.column_stack([-q4, u])
    (rp2, rp3), *_ = np.linalg.lstsq(A, dq3 + dq4, rcond=None)
    # first row: q3' = -p1 sin q1 - sa |cos q1| q3 - sv q3 - sb q3^3 + p2 q4 - p3 u
    # with the zero offset d of the angle, -p1 sin(q1 - d) = -p1 sin q1 + p1 d cos q1: a column cos q1
    B = np.column_stack([-np.sin(q1), -np.abs(np.cos(q1)) * q3, -q3, -q3 ** 3, q4, -u, np.cos(q1)])
    scale = np.linalg.norm(B, axis=0)
    scale[scale == 0] = 1.0
    th, *_ = np.linalg.lstsq(B / scale, dq3, rcond=None)
    th = th / scale
    p1, sa, sv, sb, p2b, p3b, c1 = (float(v) for v in th)
    details = {"rho_p2": float(rp2), "rho_p3": float(rp3), "p1": p1, "sigma_a1": sa, "sigma_v1": sv, "sigma_b1": sb,
               "p2": p2b, "p3": p3b, "q1_offset": c1 / p1 if p1 else float("nan")}
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
    return start, method, details, notes


def _spectral_p1(logs) -> float:
    """``p1`` from the strongest frequency of the pendulum angle (its resonance, for a chirp or a swing)."""
    best = (0.0, 0.0)
    for d in logs:
        q = d.q1 - np.mean(d.q1)
        f = np.fft.rfftfreq(q.size, d.Ts)
        a = np.abs(np.fft.rfft(q * np.hanning(q.size)))
        a[0] = 0.0
        k = int(np.argmax(a))
        if a[k] > best[0]:
            best = (a[k], 2 * math.pi * f[k])
    w = best[1]
    return float(w * w) if w > 0 else TYPICAL["p1"]


# --------------------------------------------------------------------------
# the fit
# --------------------------------------------------------------------------
def fit_logs(
    train,
    *,
    rig: RigDescription | str | os.PathLike | None = None,
    validate=(),
    dead_zone: bool = False,
    coulomb: bool = False,
    pendulum_coulomb: bool = False,
    input_offset: bool = False,
    loss: str = "linear",
    start: LumpedParameters | None = None,
    t_start: float | None = None,
    t_end: float | None = None,
    warn: bool = True,
) -> LogFitResult:
    """Identify model (9) (or (6)) from a rig's training logs and validate it on held-out logs.

    Parameters
    ----------
    train : path, ExperimentData or sequence of them
        Training logs (e.g. chirps), fitted jointly.
    rig : RigDescription or path, optional
        How the logs map onto iwp's signals (``--rig``); without it they must be iwp logs.
    validate : path, ExperimentData or sequence of them
        Held-out logs (e.g. pseudo-random inputs), simulated from their measured state, not fitted.
    dead_zone : bool
        Model (6) with the dead zone (5) (thresholds ``v_dz_pos``, ``v_dz_neg`` fitted); the logs
        must hold the raw command ``v``. Default: model (9).
    coulomb, pendulum_coulomb, input_offset : bool
        Also fit Coulomb friction of the wheel (``sigma_c2``), of the pendulum (``sigma_c1``), and an
        offset of the input (``u_offset``).
    loss : str
        ``"linear"`` or a robust loss of :func:`~iwp.ident.refinement.refine`.
    start : LumpedParameters, optional
        Start of the refinement instead of the least squares.
    t_start, t_end : float, optional
        Window of every training log [s].
    warn : bool
        Also issue the warnings with :func:`warnings.warn`.

    Returns
    -------
    LogFitResult
    """
    t0 = time.perf_counter()
    rig_d = load_rig(rig) if rig is not None else None
    with _warnings.catch_warnings(record=True) as caught:
        _warnings.simplefilter("always")
        train_logs = load_logs(train, rig_d, argument="train")
        val_logs = load_logs(validate, rig_d, argument="validate") if validate else []
    msgs = [str(w.message) for w in caught]
    if not train_logs:
        raise InputError("train: no training logs given", argument="train")
    model = "raw" if dead_zone else "compensated"
    train_logs = [_as_model_input(d, model, "train") for d in train_logs]
    val_logs = [_as_model_input(d, model, "validate") for d in val_logs]
    has_q2 = all(d.q2 is not None for d in train_logs + val_logs)
    outputs = ("q1", "q2") if has_q2 else ("q1", "q4")
    for d in train_logs + val_logs:
        if d.q2 is None and d.q4 is None:
            raise InputError(f"{d.source}: logs no wheel signal (q2 or q4)")
    offset_given = rig_d is not None and rig_d.pendulum.offset is not None
    # ---- start
    wtrain = [d.window(t_start, t_end) for d in train_logs]
    ls_details: dict = {}
    if start is None:
        start_p, method, ls_details, notes = least_squares_start(wtrain)
        msgs.extend(notes)
    else:
        if not isinstance(start, LumpedParameters):
            raise InputError(f"start must be LumpedParameters, got {type(start).__name__}", argument="start")
        start_p, method = start, "given"
    free = list(_BASE_FREE)
    options = {"dead_zone": bool(dead_zone), "coulomb": bool(coulomb), "pendulum_coulomb": bool(pendulum_coulomb),
               "input_offset": bool(input_offset), "loss": loss,
               "q1_offset": "given by the rig" if offset_given else "estimated per log"}
    umax = max(float(np.max(np.abs(d.input))) for d in wtrain)
    if dead_zone:
        free += ["v_dz_pos", "v_dz_neg"]
        if start is None:
            start_p = start_p.replace(v_dz_pos=0.05 * umax, v_dz_neg=0.05 * umax)
    if coulomb:
        free.append("sigma_c2")
        if start is None:
            start_p = start_p.replace(sigma_c2=0.02 * start_p.p3 * umax)
    if pendulum_coulomb:
        free.append("sigma_c1")
        if start is None:
            start_p = start_p.replace(sigma_c1=0.01 * start_p.p1)
    if input_offset:
        free.append("u_offset")
    r = refine(train_logs, start_p, model=model, free=tuple(free), outputs=outputs, estimate_x0=True,
               windows=(t_start, t_end), loss=loss, output_offsets=() if offset_given else ("q1",), warn=False)
    msgs.extend(r.warnings)
    params = r.params
    # ---- training fits
    train_fits = []
    offs = []
    for i, d in enumerate(train_logs):
        off = r.offsets[i].get("q1", (0.0, 0.0))[0] if r.offsets else 0.0
        offs.append(off)
        train_fits.append(_log_fit(d, "train", r.times[i], r.measured[i], r.simulated[i], r.weights[i], r.x0[i], off))
    # ---- validation: measured initial state, no re-fitting
    val_off = 0.0 if offset_given else float(np.mean(offs))
    if val_logs and not offset_given:
        msgs.append(f"held-out logs: the pendulum zero offset is taken as the training logs' mean, "
                    f"{val_off:+.4g} rad (offsets of the training logs: "
                    + ", ".join(f"{o:+.4g}" for o in offs) + ")")
    val_fits = []
    for d in val_logs:
        dc = replace(d, q1=d.q1 - val_off) if val_off else d
        x0 = measured_initial_state(dc)
        v = refine(dc, params, model=model, free=(), outputs=outputs, estimate_x0=False, x0=[x0], warn=False)
        val_fits.append(_log_fit(d, "validate", v.times[0], v.measured[0], v.simulated[0], v.weights[0], v.x0[0],
                                 val_off))
        if not v.success or not all(math.isfinite(x) for x in v.fit[0].values()):
            msgs.append(f"{d.source}: the validation simulation failed or diverged")
    res = LogFitResult(params=params, refinement=r, start=start_p, start_method=method, least_squares=ls_details,
                       model=model, outputs=outputs, options=options, train=train_fits, validation=val_fits,
                       warnings=_unique(msgs), rig=rig_d, elapsed=time.perf_counter() - t0)
    if warn:
        for m in res.warnings:
            _warnings.warn(m, stacklevel=2)
    return res


#: the measured initial state: a quadratic fitted to the first samples over about this long [s]
X0_SECONDS = 0.1


def measured_initial_state(d: ExperimentData) -> np.ndarray:
    """The state ``[q1, q2, q3, q4]`` a log measures at its first sample.

    ``q1`` and ``q3``: a quadratic fitted by least squares to the first
    ``max(5, 0.1 s / Ts)`` samples of the angle (a short one-sided window: a
    longer filter at the start of a log is biased by the input's steps),
    its value and slope at ``t[0]``; ``q2``: the same, or 0 without a wheel
    angle; ``q4``: the measured speed at ``t[0]`` (a glitch replaced: the
    quadratic through the next samples), or for a speed sampled as the mean
    over the preceding period, the next two means extrapolated to ``t[0]``
    (``1.5 y[1] - 0.5 y[2]``).
    """
    m = max(5, int(round(X0_SECONDS / d.Ts)) + 1)
    m = min(m, d.n_samples)
    tt = d.t[:m] - d.t[0]

    def value_slope(y):
        c = np.polyfit(tt, y[:m], 2)
        return float(c[2]), float(c[1])

    q1, q3 = value_slope(d.q1)
    q2, q4 = value_slope(d.q2) if d.q2 is not None else (0.0, 0.0)
    if d.q4 is not None:
        y = np.asarray(d.q4, dtype=float)
        if d.q4_sampling == "mean":
            q4 = 1.5 * y[1] - 0.5 * y[2]
        elif d.glitch_mask("q4")[0]:
            c = np.polyfit(tt[1:], y[1:m], 2)
            q4 = float(c[2])
        else:
            q4 = float(y[0])
    return np.array([q1, q2, q3, q4])


def _unique(msgs: list[str]) -> list[str]:
    seen, out = set(), []
    for m in msgs:
        if m not in seen:
            seen.add(m)
            out.append(m)
    return out


def _as_model_input(d: ExperimentData, model: str, argument: str) -> ExperimentData:
    """The log with the input the model takes: model (9) reads a raw ``v`` as its ``u`` (no dead zone)."""
    if model == "compensated" and d.input_name == "v":
        return replace(d, u=d.v, v=None)
    if model == "raw" and d.input_name == "u":
        raise InputError(f"{argument}: {d.source} logs the compensated input u (the rig compensates its dead "
                         "zone); the dead-zone model (6) needs the raw command v", argument="dead_zone")
    return d


def _log_fit(d: ExperimentData, role: str, t, measured, simulated, weights, x0, off) -> LogFit:
    fit, rms, mx, used = {}, {}, {}, {}
    for o, y in measured.items():
        m = weights[o] > 0
        used[o] = m
        fit[o] = fit_percent(y[m], simulated[o][m])
        e = (y - simulated[o])[m]
        rms[o] = float(np.sqrt(np.mean(e ** 2)))
        mx[o] = float(np.max(np.abs(e)))
    return LogFit(d.source, role, fit, rms, mx, np.asarray(t), dict(measured), dict(simulated), used,
                  np.asarray(x0, dtype=float), float(off), [g.describe() for g in d.glitches])

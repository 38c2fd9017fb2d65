"""The rubber belt (15) identified by simulation error from the disk velocity alone.

The paper models the belt between motor and disk by eq. (15) with the
hysteresis of figure 5 and sets its parameters by hand: "since the angular
position of the motor shaft of the experimental system is not measured, the
parameters of this model cannot be obtained by the proposed identification
procedure" (section 5.1). The least squares (13) indeed need every state of
the model, but a simulation-error fit needs only an output: :func:`refine_belt`
simulates the belt model (``"belt"``: pendulum locked, motor inertia
neglected, the play of half-width ``d``) with the logged input ``u`` replayed
and fits its disk velocity ``q4`` to the measured one (differentiated from
the encoder's ``q2``) over one or more logs, typically the sinusoids
``u = A sin 5t`` of figures 3 and 4.

The fitted parameters are those of :class:`~iwp.models.parameters.BeltParameters`
(``k_over_I2``, ``d``, ``b2_over_I2``, ``k_over_gamma``,
``kTbeta_over_Rgamma``, ``gain_neg``; ``N`` is measured, 13.5) and the disk's
Coulomb friction ``sigma_c2``; all positive, fitted on a log scale within
bounds. The play makes the model non-smooth in ``d`` (the response depends
on ``d`` through the times the play closes, not through the right-hand side
between them), so the Jacobian is taken by forward differences of whole
simulations rather than by forward sensitivities. The result is a
:class:`~iwp.ident.refinement.RefineResult` with :attr:`belt` set.
:func:`iwp.ident.refinement.refine` with ``model="belt"`` calls this.
"""

from __future__ import annotations

import math
import time
import warnings as _warnings
from dataclasses import fields
from typing import Mapping, Sequence

import numpy as np
from scipy import optimize, stats

from ..data import ExperimentData
from ..errors import InputError
from ..models.parameters import BeltParameters, LumpedParameters
from ..models.plant import Plant
from ..sim.simulate import simulate
from .fit import fit_percent
from .lsq import ParameterEstimate

__all__ = ["refine_belt", "BELT_FREE", "BELT_PARAMETERS"]

#: The parameters :func:`refine_belt` can fit: the belt's, and the disk's Coulomb friction.
BELT_PARAMETERS = ("k_over_I2", "d", "b2_over_I2", "k_over_gamma", "kTbeta_over_Rgamma", "gain_neg", "sigma_c2")
#: What it fits by default: the five of the paper's eq. (15) besides the measured N.
BELT_FREE = ("k_over_I2", "d", "b2_over_I2", "k_over_gamma", "kTbeta_over_Rgamma")
#: default bounds (positive; the play may close to nearly nothing)
_BOUNDS = {"k_over_I2": (1.0, 1e6), "d": (1e-4, 20.0), "b2_over_I2": (1e-4, 100.0), "k_over_gamma": (1e-2, 1e9),
           "kTbeta_over_Rgamma": (1e-2, 1e4), "gain_neg": (0.3, 3.0), "sigma_c2": (1e-5, 10.0)}
#: forward-difference step on the log scale, per square root of the simulation's rtol (the step's
#: truncation error against the simulation's error)
_STEP_PER_SQRT_RTOL = 3.0
_BAD = 1e6


def _logs(experiments) -> list[ExperimentData]:
    exps = [experiments] if isinstance(experiments, ExperimentData) else list(experiments)
    if not exps:
        raise InputError("no experiments given")
    for i, e in enumerate(exps):
        if not isinstance(e, ExperimentData):
            raise InputError(f"experiments[{i}] must be an ExperimentData, got {type(e).__name__}")
        if e.input_name != "u":
            raise InputError(f"experiment {i} ({e.source}) must log the compensated input u (the belt model (15) is "
                             f"driven by u), it logs {e.input_name!r}")
        if e.q2 is None:
            raise InputError(f"experiment {i} ({e.source}) has no disk angle q2")
        if np.ptp(e.q1) > 0.02:
            raise InputError(f"experiment {i} ({e.source}): the pendulum moves (q1 range {np.ptp(e.q1):.3g} rad); "
                             "the belt model (15) is identified with the pendulum locked (section 5.1)")
    return exps


def refine_belt(
    experiments,
    start: LumpedParameters,
    belt: BeltParameters,
    *,
    free: Sequence[str] = BELT_FREE,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    windows=None,
    max_nfev: int | None = None,
    tol: float = 1e-6,
    rtol: float = 1e-6,
    atol: float = 1e-6,
    warn: bool = True,
):
    """Fit the belt (15) to the disk velocity of locked, compensated logs by simulation error.

    Parameters
    ----------
    experiments : ExperimentData or sequence of ExperimentData
        Logs with the pendulum locked and the compensated input ``u``
        (``sine-60``, ``sine-40``, ``sine-20``, ``motor-disk-chirp``).
    start : LumpedParameters
        The lumped parameters (``rho`` and ``sigma_c2`` enter the belt model).
    belt : BeltParameters
        Starting point, e.g. the paper's ``k/I2 = 60``, ``d = 2`` with the
        rigid limit of the identified motor-disk model
        (:meth:`BeltParameters.from_rigid`).
    free : sequence of str
        Among :data:`BELT_PARAMETERS`; default :data:`BELT_FREE`.
    bounds : dict, optional
        ``{name: (low, high)}`` (both > 0); default wide physical ranges.
    windows : (t_start, t_end) or list of them, optional
        Time window per experiment [s].
    max_nfev : int, optional
        Most iterations (default 50 x (number of free parameters + 1)).
    tol : float
        ``ftol``, ``xtol``, ``gtol`` of :func:`scipy.optimize.least_squares`.
    rtol, atol : float
        Simulation tolerances (default 1e-6: the simulated disk velocity is
        then far more accurate than the one differentiated from the encoder,
        whose step is 3.1e-3 rad; tighter tolerances cost ten times more,
        for the play's kinks).
    warn : bool
        Also issue the warnings with :func:`warnings.warn`.

    Returns
    -------
    RefineResult
        ``belt`` holds the fitted belt; ``parameters`` the free parameters'
        estimates with standard errors (from the Jacobian at the optimum,
        a lower bound: simulation residuals are correlated in time); ``fit``
        and ``fit_start`` the fit of ``q4`` per log [%].
    """
    from .refinement import RefineResult, initial_state, measured_signals, replay

    t_begin = time.perf_counter()
    if not isinstance(start, LumpedParameters):
        raise InputError(f"start must be LumpedParameters, got {type(start).__name__}")
    if not isinstance(belt, BeltParameters):
        raise InputError(f"belt must be BeltParameters, got {type(belt).__name__}")
    free = (free,) if isinstance(free, str) else tuple(free)
    if not free:
        raise InputError("free is empty: give at least one belt parameter")
    for n in free:
        if n not in BELT_PARAMETERS:
            raise InputError(f"unknown belt parameter {n!r}; choose among {', '.join(BELT_PARAMETERS)}")
    if len(set(free)) != len(free):
        raise InputError(f"free lists a parameter twice: {free}")
    lim = dict(_BOUNDS)
    for n, b in (bounds or {}).items():
        if n not in free:
            raise InputError(f"bounds given for {n!r}, which is not free (free: {', '.join(free)})")
        try:
            a, c = float(b[0]), float(b[1])
        except (TypeError, ValueError, IndexError):
            raise InputError(f"bounds[{n!r}] must be a pair (low, high), got {b!r}") from None
        if not 0 < a < c or not math.isfinite(c):
            raise InputError(f"bounds[{n!r}] = ({a}, {c}): need 0 < low < high")
        lim[n] = (a, c)
    exps = _logs(experiments)
    if windows is None or (isinstance(windows, tuple) and len(windows) == 2
                           and all(w is None or isinstance(w, (int, float)) for w in windows)):
        wins = [windows or (None, None)] * len(exps)
    else:
        wins = list(windows)
        if len(wins) != len(exps):
            raise InputError(f"windows must be one (t_start, t_end) pair or one per experiment ({len(exps)})")

    prepared = []
    for e, (a, b) in zip(exps, wins):
        w = e.window(a, b)
        i0 = int(np.searchsorted(e.t, w.t[0]))
        if w.n_samples < 10:
            raise InputError(f"{e.source}: the window keeps {w.n_samples} samples, at least 10 are needed")
        y = measured_signals(e, ("q4",))["q4"][i0:i0 + w.n_samples]
        x0 = np.zeros(6)
        x0[:4] = initial_state(e, i0, "compensated", locked=True)
        prepared.append((w, np.ascontiguousarray(w.t, dtype=float), replay(w, "u"), np.ascontiguousarray(y), x0))
    scale = math.sqrt(np.mean([np.var(y) for (_w, _t, _u, y, _x) in prepared]))
    if not scale > 0:
        raise InputError("the disk velocity is constant in every experiment: nothing to fit")

    def value_of(name: str, b: BeltParameters, p: LumpedParameters) -> float:
        return float(getattr(p, name)) if name == "sigma_c2" else float(getattr(b, name))

    v0 = np.array([value_of(n, belt, start) for n in free])
    lo = np.log([lim[n][0] for n in free])
    hi = np.log([lim[n][1] for n in free])
    msgs: list[str] = []
    if np.any(v0 <= 0):
        bad = free[int(np.argmax(v0 <= 0))]
        raise InputError(f"start value of {bad} must be > 0 to be fitted on a log scale, got "
                         f"{value_of(bad, belt, start)}")
    z0 = np.log(v0)
    zc = np.clip(z0, lo, hi)
    for n, a, c in zip(free, z0, zc):
        if a != c:
            msgs.append(f"start value {n} = {math.exp(a):.6g} is outside its bounds; started from {math.exp(c):.6g}")
    z0 = zc

    def models(z):
        vals = dict(zip(free, np.exp(z).tolist()))
        p = start.replace(sigma_c2=vals.pop("sigma_c2")) if "sigma_c2" in vals else start
        return p, BeltParameters(**{**{f.name: getattr(belt, f.name) for f in fields(BeltParameters)}, **vals})

    counters = {"nfev": 0}

    def simulate_all(z):
        p, b = models(z)
        plant = Plant(p, model="belt", belt=b)
        out = []
        for (w, t, u, _y, x0) in prepared:
            r = simulate(plant, x0=x0, t0=float(t[0]), t_end=float(t[-1]), t_eval=t, input=u, rtol=rtol, atol=atol,
                         check=False)
            q4 = np.full(t.size, np.nan)
            q4[:r.q4.size] = r.q4
            out.append(q4)
        counters["nfev"] += 1
        return out

    def residuals(z):
        sims = simulate_all(z)
        r = np.concatenate([(s - y) / scale for s, (_w, _t, _u, y, _x) in zip(sims, prepared)])
        return np.where(np.isfinite(r), r, _BAD)

    step = max(_STEP_PER_SQRT_RTOL * math.sqrt(rtol), 1e-6)

    def jac(z):
        f0 = residuals(z)
        J = np.empty((f0.size, z.size))
        for j in range(z.size):
            h = step if z[j] + step <= hi[j] else -step
            zj = z.copy()
            zj[j] += h
            J[:, j] = (residuals(zj) - f0) / h
        return J

    sims0 = simulate_all(z0)
    r0 = np.concatenate([(s - y) / scale for s, (_w, _t, _u, y, _x) in zip(sims0, prepared)])
    r0 = np.where(np.isfinite(r0), r0, _BAD)
    sol = optimize.least_squares(residuals, z0, jac=jac, bounds=(lo, hi), method="trf", x_scale=1.0, ftol=tol,
                                 xtol=tol, gtol=tol, max_nfev=max_nfev or 50 * (len(free) + 1))
    z = sol.x
    J = jac(z)
    r = residuals(z)
    sims = simulate_all(z)
    n_rows, npar = r.size, z.size
    dof = max(n_rows - npar, 1)
    s2 = float(r @ r) / dof
    U, S, Vt = np.linalg.svd(J, full_matrices=False)
    keep = S > 1e-10 * (S[0] if S.size else 1.0)
    if not np.all(keep):
        msgs.append("the disk velocity does not determine every belt parameter (rank-deficient Jacobian); the "
                    "standard errors of the parameters in that direction are not estimates")
    inv = np.where(keep, 1.0 / np.where(keep, S, 1.0) ** 2, np.inf)
    cov_z = (Vt.T * inv) @ Vt * s2
    cov_z = np.where(np.isfinite(cov_z), cov_z, np.nan)
    theta = np.exp(z)
    cov = cov_z * np.outer(theta, theta)  # delta method: d theta = theta d z
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    tq = float(stats.t.ppf(0.975, dof))
    p_opt, b_opt = models(z)
    parameters: dict[str, ParameterEstimate] = {}
    for f in fields(LumpedParameters):
        v = float(getattr(p_opt, f.name))
        parameters[f.name] = ParameterEstimate(f.name, v, 0.0, v, v, True)
    for f in fields(BeltParameters):
        v = float(getattr(b_opt, f.name))
        parameters[f.name] = ParameterEstimate(f.name, v, 0.0, v, v, True)
    for i, n in enumerate(free):
        parameters[n] = ParameterEstimate(n, float(theta[i]), float(sd[i]), float(theta[i] - tq * sd[i]),
                                          float(theta[i] + tq * sd[i]), False)
        if z[i] <= lo[i] + 1e-9 or z[i] >= hi[i] - 1e-9:
            msgs.append(f"{n} = {theta[i]:.6g} is at its bound [{math.exp(lo[i]):.6g}, {math.exp(hi[i]):.6g}]")
    for i in range(npar):
        for j in range(i + 1, npar):
            if math.isfinite(corr[i, j]) and abs(corr[i, j]) > 0.95:
                msgs.append(f"{free[i]} and {free[j]} are strongly correlated ({corr[i, j]:+.3f}): the disk velocity "
                            "determines a combination of them")
    if not sol.success:
        msgs.append(f"the optimiser did not converge: {sol.message}")
    fit, fit0, rms, rms0 = [], [], [], []
    for s, s0, (_w, _t, _u, y, _x) in zip(sims, sims0, prepared):
        ok, ok0 = np.isfinite(s), np.isfinite(s0)
        fit.append({"q4": fit_percent(y[ok], s[ok]) if ok.all() else float("nan")})
        fit0.append({"q4": fit_percent(y[ok0], s0[ok0]) if ok0.all() else float("nan")})
        rms.append({"q4": float(np.sqrt(np.mean((y - s)[ok] ** 2)))})
        rms0.append({"q4": float(np.sqrt(np.mean((y - s0)[ok0] ** 2)))})
    if warn:
        for m in msgs:
            _warnings.warn(m, stacklevel=2)
    return RefineResult(
        params=p_opt, parameters=parameters, free=free, covariance=cov, correlation=corr, fit=fit, fit_start=fit0,
        rms=rms, rms_start=rms0, x0=[x.copy() for (_w, _t, _u, _y, x) in prepared],
        x0_stderr=[np.zeros(6) for _ in prepared],
        windows=[(float(t[0]), float(t[-1])) for (_w, t, _u, _y, _x) in prepared],
        success=bool(sol.success), message=str(sol.message), warnings=msgs,
        cost_start=0.5 * float(r0 @ r0), cost=0.5 * float(r @ r), nfev=counters["nfev"], njev=0, model="belt",
        outputs=("q4",), loss="linear", start=start,
        residual_std={"q4": float(np.sqrt(np.mean((r * scale) ** 2)))}, n_samples=n_rows,
        elapsed=time.perf_counter() - t_begin, sources=[e.source for e in exps],
        simulated=[{"q4": s} for s in sims], measured=[{"q4": y} for (_w, _t, _u, y, _x) in prepared],
        times=[t for (_w, t, _u, _y, _x) in prepared],
        weights=[{"q4": np.ones(t.size)} for (_w, t, _u, _y, _x) in prepared],
        offsets=[{} for _ in prepared], belt=b_opt, belt_start=belt,
    )

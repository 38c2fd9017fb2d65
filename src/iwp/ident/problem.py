"""One fit problem: parameters, a residual model and a loss; solved, with its statistics.

Every nonlinear fit of iwp -- the refinement by simulation error
(:func:`iwp.ident.refinement.refine`), the belt (15) from the disk velocity,
the initial state of a validation, ``iwp fit``'s joint fit of a rig's logs,
and the calibration of the virtual twin -- is a :class:`FitProblem`:

* **prepare**: :class:`~iwp.ident.fit_parameters.Parameters` (values, bounds,
  free or fixed, expressions, the optimiser's scale) and a residual model
  that turns parameter values into weighted residuals, and, where it can,
  their derivatives (:class:`~iwp.ident.output_error.OutputError` for logs);
* **solve**: :meth:`FitProblem.solve`, bounded trust-region least squares
  (:func:`scipy.optimize.least_squares`, ``trf``) with a linear or robust
  :class:`Loss`; the Jacobian comes from the model (forward sensitivities)
  or from forward differences of whole evaluations
  (:func:`~iwp.ident.jacobian.forward_difference_jacobian`);
* **report**: a :class:`FitResult` as lmfit has it -- the parameters with
  standard errors, 95 % intervals and correlations, the covariance, the
  statistics, success and a message, and warnings on what the data cannot
  support (rank deficiency, parameters not told apart, bounds reached, an
  optimiser that did not converge).

The covariance of the unknowns is ``(J_w^T J_w)^-1`` with the residuals of
each block (an output) divided by their standard deviation
(:mod:`iwp.ident.covariance`); intervals use the Student t quantile.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Protocol, Sequence

import numpy as np
from scipy import optimize

from ..errors import InputError
from ..threads import one_blas_thread
from .covariance import (
    MIN_HAC_BLOCKS,
    Reliability,
    across_and_within,
    block_sigmas,
    cluster_covariance,
    correlation_messages,
    experiments_agree,
    hac_sandwich,
    loss_weights,
    reliability,
    white_covariance,
)
from .fit_parameters import Parameters
from .jacobian import forward_difference_jacobian

__all__ = ["FitProblem", "FitResult", "Loss", "SolverOptions", "ResidualModel", "LOSSES"]

#: A free parameter this close to a bound (in the optimiser's coordinates, which are of order 1) is at it: the
#: trust-region reflective method keeps iterates strictly inside, about 1e-7 away.
BOUND_TOL = 1e-6
#: The losses of :func:`scipy.optimize.least_squares`.
LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")


@dataclass(frozen=True)
class Loss:
    """The loss of the residuals.

    Parameters
    ----------
    name : {"linear", "soft_l1", "huber", "cauchy", "arctan"}
        ``"linear"``: least squares; the others are robust (large residuals weigh less).
    scale : float, optional
        Residual scale beyond which residuals count as outliers (``f_scale``),
        in the units of the weighted residuals. Default for a robust loss: a
        first fit with the linear loss, then 2.5 robust standard deviations
        (1.4826 x the median absolute deviation) of its residuals.
    """

    name: str = "linear"
    scale: float | None = None

    def __post_init__(self) -> None:
        if self.name not in LOSSES:
            raise InputError(f"loss must be one of {', '.join(LOSSES)}, got {self.name!r}")
        s = self.scale
        if s is not None and not (isinstance(s, (int, float)) and not isinstance(s, bool) and s > 0
                                  and math.isfinite(s)):
            raise InputError(f"f_scale must be a positive number, got {s!r}")


@dataclass(frozen=True)
class SolverOptions:
    """Options of the optimiser.

    Parameters
    ----------
    tol : float
        ``ftol``, ``xtol`` and ``gtol`` of :func:`scipy.optimize.least_squares`
        (1e-6: the parameters then stop moving by far less than their standard errors).
    max_nfev : int, optional
        Most evaluations (default 100 x (number of unknowns + 1)).
    tr_solver : {"exact", "lsmr"}
        Trust-region subproblem solver: ``"exact"`` (an SVD of the Jacobian
        per iteration; robust) or ``"lsmr"`` (products with the Jacobian only;
        cheaper per iteration on long logs, more iterations on ill-conditioned
        problems such as Coulomb friction).
    rtol, atol : float
        Tolerances of the simulations that produce the residuals (residual
        models that simulate, :class:`~iwp.ident.output_error.OutputError`);
        1e-8: the simulated outputs are then far more accurate than an encoder
        step (3.1e-3 rad).
    scaling : {"jacobian", "start"}
        The trust region's scale of each coordinate: ``"jacobian"`` (the
        inverse norms of the Jacobian's columns, updated as the fit goes,
        scipy's ``x_scale="jac"``) or ``"start"`` (the coordinates as they are,
        each parameter relative to its start or scale). With ``"start"``, a
        fit whose parameters move the residuals at very different rates (a
        Coulomb width next to a friction level near 0) crawled: the ladder's
        fits on a rig without friction ran out of 200 evaluations three times
        (27 s), where ``"jacobian"`` converged in 16 to 37 (5 s). Where
        neither stalls they take the same time (eight ladders on the virtual
        rig of issue 21: 81.6 s against 81.7 s).
    """

    tol: float = 1e-6
    max_nfev: int | None = None
    tr_solver: str = "exact"
    rtol: float = 1e-8
    atol: float = 1e-8
    scaling: str = "jacobian"

    def __post_init__(self) -> None:
        if self.tr_solver not in ("exact", "lsmr"):
            raise InputError(f"tr_solver must be 'exact' or 'lsmr', got {self.tr_solver!r}")
        if self.scaling not in ("jacobian", "start"):
            raise InputError(f"scaling must be 'jacobian' or 'start', got {self.scaling!r}")
        m = self.max_nfev
        if m is not None and (isinstance(m, bool) or not isinstance(m, int) or m < 1):
            raise InputError(f"max_nfev must be a positive integer, got {m!r}")


class ResidualModel(Protocol):
    """What a :class:`FitProblem` needs of its residual model (:class:`~iwp.ident.output_error.OutputError`)."""

    #: forward-difference step of the optimiser's coordinates, or None when :meth:`evaluate` differentiates
    differences: float | None

    @property
    def n_rows(self) -> int: ...

    def evaluate(self, values: dict[str, float], wrt: Sequence[str] = ()) -> Any:
        """An object with the residuals ``r`` and, for the names ``wrt``, ``J = d r / d value``."""

    def row_blocks(self) -> np.ndarray:
        """Block (0, 1, ...) of each row: rows of a block share one standard deviation."""

    def row_used(self) -> np.ndarray:
        """True for the rows that enter the fit."""


@dataclass(eq=False)
class FitResult:
    """The outcome of :meth:`FitProblem.solve`.

    Attributes
    ----------
    parameters : Parameters
        Every parameter at the optimum, with stderr, 95 % interval and correlations.
    free : tuple of str
        The free parameters, in the order of :attr:`covariance`.
    covariance, correlation : ndarray, shape (n_free, n_free)
        Of the free parameters' values (every unknown, nuisance ones included).
    success, message : bool, str
        From the optimiser.
    warnings : list of str
    cost_start, cost : float
        ``0.5 sum r^2`` of the weighted residuals at the start and at the optimum.
    nfev, njev : int
        Evaluations without and with derivatives.
    loss : str
    f_scale : float
        The residual scale of the loss.
    dof : int
        Residual degrees of freedom (rows used minus unknowns).
    critical : float
        Multiplier of the standard errors giving the 95 % intervals.
    covariance_method : str
        ``"hac"``, ``"white"`` or ``"none"`` (:class:`~iwp.ident.covariance.Covariance`).
    bandwidth : int or None
        Bartlett lags of the HAC covariance [samples].
    inflation : dict of str to float
        Per free parameter, its variance over what white residuals would give.
    reliability : Reliability or None
        How far the intervals can be trusted (:func:`~iwp.ident.covariance.reliability`).
    block_sigma : ndarray
        Standard deviation of the weighted residuals per block.
    start, optimum : object
        The residual model's evaluations at the start and at the optimum.
    jacobian : ndarray
        ``d r / d z`` at the optimum (rows: residuals; columns: the free parameters).
    elapsed : float
        Wall time [s].
    """

    parameters: Parameters
    free: tuple[str, ...]
    covariance: np.ndarray
    correlation: np.ndarray
    success: bool
    message: str
    warnings: list[str]
    cost_start: float
    cost: float
    nfev: int
    njev: int
    loss: str
    f_scale: float
    dof: int
    critical: float
    block_sigma: np.ndarray
    start: Any
    optimum: Any
    jacobian: np.ndarray = field(repr=False)
    elapsed: float = 0.0
    covariance_method: str = "white"
    bandwidth: int | None = None
    inflation: dict[str, float] = field(default_factory=dict)
    reliability: Reliability | None = None


class _Objective:
    """``z -> residuals`` and ``z -> Jacobian`` of a problem, caching the last evaluations."""

    def __init__(self, params: Parameters, model: ResidualModel):
        self.params = params
        self.model = model
        self.free = params.free
        self.wrt = tuple(n for n in params if params.depends_on_free(n))
        self.nfev = 0
        self.njev = 0
        self.evals: dict[bytes, Any] = {}
        self.jacs: dict[bytes, np.ndarray] = {}
        self.upper = params.internal_bounds()[1]

    def evaluation(self, z: np.ndarray) -> Any:
        key = np.asarray(z, dtype=float).tobytes()
        if key not in self.evals:
            self.nfev += 1
            self.evals = {key: self.model.evaluate(self.params.from_internal(z))}
        return self.evals[key]

    def residuals(self, z: np.ndarray) -> np.ndarray:
        return self.evaluation(z).r.copy()

    def trial_residuals(self, z: np.ndarray) -> np.ndarray:
        """The residuals at a point the optimiser tries; non-finite where the model refuses its values (a
        width the Jacobian's scaling sent beyond any rig, 1e9 rad/s): the optimiser then shrinks its step, as
        for a simulation that failed. The start and the optimum go through :meth:`evaluation`, which raises."""
        try:
            return self.residuals(z)
        except InputError:  # counted in nfev by evaluation()
            return np.full(self.model.n_rows, np.inf)

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        key = np.asarray(z, dtype=float).tobytes()
        if key in self.jacs:
            return self.jacs[key]
        self.njev += 1
        if self.model.differences is not None:
            base = self.evaluation(z)
            J = forward_difference_jacobian(self.residuals, z, self.model.differences, f0=base.r, upper=self.upper,
                                            refused=InputError)
            self.evals = {key: base}
        else:
            ev = self.model.evaluate(self.params.from_internal(z), wrt=self.wrt)
            self.evals = {key: ev}
            J = ev.J @ self.params.value_derivatives(z, self.wrt) if self.wrt else np.zeros((ev.r.size, 0))
        self.jacs = {key: J}
        return J


@dataclass(eq=False)
class FitProblem:
    """Parameters, a residual model and a loss: one nonlinear least-squares fit.

    Parameters
    ----------
    parameters : Parameters
        Every parameter the model reads; the free ones are estimated.
    model : ResidualModel
        Turns values into weighted residuals (e.g. :class:`~iwp.ident.output_error.OutputError`).
    loss : Loss
    statistics : bool
        Estimate the covariance of the parameters at the optimum (default).
        False where the residuals are not measurements with noise (the
        calibration of the twin matches published numbers): the parameters
        then carry no standard error (NaN).
    covariance : {"auto", "experiments", "hac", "white"}
        ``"experiments"``: the cluster-robust sandwich over experiments
        (:func:`~iwp.ident.covariance.cluster_covariance`): each experiment's
        summed score one independent draw, bias-reduced, Student t with each
        parameter's Bell-McCaffrey dof (at most ``G - 1``);
        ``"hac"``: the heteroscedasticity-and-autocorrelation-consistent
        sandwich within experiments (:func:`~iwp.ident.covariance.hac_sandwich`);
        ``"white"``: ``(J_w^T J_w)^-1``, for white residuals only. ``"auto"``
        (default): ``"experiments"`` with two experiments or more, ``"hac"``
        with one, ``"white"`` for residual models without time
        (:class:`~iwp.ident.output_error.OutputError` has it). Chosen by the
        coverage measured on the virtual rig (``docs/uncertainty.md``): with
        model-structure error a simulation's error lasts about the pendulum's
        damping time, longer than a log, and only independent experiments
        show the estimate's spread.
    """

    parameters: Parameters
    model: ResidualModel
    loss: Loss = field(default_factory=Loss)
    statistics: bool = True
    covariance: str = "auto"

    def __post_init__(self) -> None:
        if self.covariance not in ("auto", "hac", "white", "experiments") and not self.covariance.startswith("hac:"):
            raise InputError(f"covariance must be 'auto', 'experiments', 'hac' or 'white', got {self.covariance!r}")

    def solve(self, options: SolverOptions | None = None) -> FitResult:
        """Minimise the loss of the residuals over the free parameters; their statistics at the optimum.

        The linear algebra runs on one BLAS thread (:func:`iwp.threads.one_blas_thread`).
        """
        with one_blas_thread():
            return self._solve(options)

    def _solve(self, options: SolverOptions | None) -> FitResult:
        t0 = time.perf_counter()
        options = options or SolverOptions()
        params, msgs = _clipped_start(self.parameters)
        nz = len(params.free)
        if self.model.n_rows <= nz:
            raise InputError(f"{self.model.n_rows} residuals for {nz} unknowns: give longer windows or fewer free "
                             "parameters")
        obj = _Objective(params, self.model)
        z0 = params.to_internal()
        start = obj.evaluation(z0)
        if not np.all(np.abs(start.r) < 1e6):
            msgs.append("the simulation from the start point diverged or failed; the fit may be poor")
        z, success, message, f_scale = _minimise(obj, z0, self.loss, options)
        if self.statistics:
            J = obj.jacobian(z)
            optimum = obj.evaluation(z)
            broken = ("the residuals at the optimum are" if not np.all(np.isfinite(optimum.r)) else
                      "the Jacobian at the optimum is" if not np.all(np.isfinite(J)) else None)
            if broken is None:
                result = _statistics(self, obj, z, J, optimum, f_scale)
            else:  # a simulation near the optimum failed: no curvature, so no honest interval
                result = _no_statistics(params, z)
                result["warnings"].append(f"{broken} not finite (a simulation near it failed or diverged): no "
                                          "standard errors or intervals are given")
        else:
            J = np.zeros((self.model.n_rows, 0))
            optimum = obj.evaluation(z)
            result = _no_statistics(params, z)
        msgs.extend(result.pop("warnings"))
        msgs.extend(_bound_messages(params, z))
        if not success:
            msgs.append(f"the optimiser did not converge: {message}")
        r0, r = start.r, optimum.r
        return FitResult(**result, success=success, message=message, warnings=msgs,
                         cost_start=0.5 * float(r0 @ r0), cost=0.5 * float(r @ r), nfev=obj.nfev, njev=obj.njev,
                         loss=self.loss.name, f_scale=f_scale, start=start, optimum=optimum, jacobian=J,
                         elapsed=time.perf_counter() - t0)


def _clipped_start(params: Parameters) -> tuple[Parameters, list[str]]:
    """The start moved inside the bounds, with a message for each value that was outside."""
    msgs = []
    changes = {}
    for n in params.free:
        p = params[n]
        v = min(max(p.value, p.min), p.max)
        if v != p.value:
            msgs.append(f"start value {n} = {p.value:.6g} is outside its bounds [{p.min:.6g}, {p.max:.6g}]; "
                        f"started from {v:.6g}")
            changes[n] = v
    return (params.with_values(changes) if changes else params), msgs


def _minimise(obj: _Objective, z0: np.ndarray, loss: Loss, options: SolverOptions):
    """Trust-region least squares; a robust loss without a scale first fits with the linear loss.

    Returns ``(z, success, message, f_scale)``.
    """
    nz = z0.size
    if nz == 0:
        return z0, True, "nothing to estimate", 1.0
    lo, hi = obj.params.internal_bounds()
    auto_scale = loss.name != "linear" and loss.scale is None
    stages = [("linear", 1.0), (loss.name, None)] if auto_scale else [(loss.name, float(loss.scale or 1.0))]
    budget = options.max_nfev or 100 * (nz + 1)
    z = z0.copy()
    scale = 1.0
    success, message = True, ""
    for stage_loss, scale in stages:
        if scale is None:
            rr = obj.residuals(z)
            mad = 1.4826 * float(np.median(np.abs(rr - np.median(rr))))
            scale = 2.5 * mad if mad > 0 else 1.0
        sol = optimize.least_squares(obj.trial_residuals, z, jac=obj.jacobian, bounds=(lo, hi), method="trf",
                                     loss=stage_loss, f_scale=scale, ftol=options.tol,
                                     x_scale="jac" if options.scaling == "jacobian" else 1.0,
                                     xtol=options.tol, gtol=options.tol, max_nfev=budget,
                                     tr_solver=options.tr_solver)
        z = sol.x
        success, message = bool(sol.success) and sol.status != 0, str(sol.message).replace("`", "")  # plain words
        budget = max(budget - sol.nfev, 1)
    return z, success, message, float(scale)


def _statistics(problem: "FitProblem", obj: _Objective, z: np.ndarray, J: np.ndarray, optimum: Any,
                f_scale: float) -> dict[str, Any]:
    """Covariance, correlations and intervals at the optimum (the residuals of each block weighted by their std)."""
    params = obj.params
    free = params.free
    model = problem.model
    blocks = model.row_blocks()
    used = model.row_used()
    sig = block_sigmas(optimum.r, blocks, used, len(free))
    dof = max(int(np.count_nonzero(used)) - len(free), 1)
    # the sandwiches take the criterion as the estimator minimised it (its own weights per output); a robust
    # loss enters through its weights at the optimum (iteratively reweighted least squares)
    w = np.ones(optimum.r.size)
    if problem.loss.name != "linear":
        w = np.sqrt(loss_weights(problem.loss.name, optimum.r, f_scale))
    Jw = J * w[:, None] if J.size else J
    rw = optimum.r * w
    timed = hasattr(model, "row_times")
    kinds = [i for i, n in enumerate(free) if params[n].kind == "model"]
    groups = model.row_experiments() if timed else np.zeros(rw.size, dtype=np.int64)
    n_exp = int(np.unique(groups).size)
    n_out = int(np.max(blocks)) + 1 if blocks.size else 1
    method = problem.covariance
    auto = method == "auto"
    if auto:
        method = ("experiments" if n_exp >= 2 else "hac") if timed else "white"
    within = None
    if timed and (method in ("experiments", "hac") or method.startswith("hac:")):
        b = float(method.split(":")[1]) if method.startswith("hac:") else None
        within = hac_sandwich(Jw, rw, groups, model.row_times(), free, dof, b)
    length = int(min(np.count_nonzero(groups == g) for g in np.unique(groups))) if rw.size else 0
    # blocks of the HAC lags in the shortest experiment (its samples over the lags + 1; n_out rows a sample)
    hac_blocks = None if within is None else length // n_out // (int(within.bandwidth or 0) + 1)
    across = agreement = None
    if method == "experiments" and n_exp >= 2:
        across = cluster_covariance(Jw, rw, groups, free)
        if within is not None:
            agreement = experiments_agree(Jw, rw, groups, model.row_times(), kinds, int(within.bandwidth or 0), dof)
        if auto and agreement is not None and agreement.agree and hac_blocks >= MIN_HAC_BLOCKS:
            # the experiments agree within their noise and each holds many blocks of the HAC lags: the noise within
            # them sets the intervals; Student t over G experiments is kept for a disagreement or few blocks
            cov_z = within
        else:
            cov_z = across_and_within(across, within) if within is not None else across
    elif within is not None:
        cov_z = within
    else:
        cov_z = white_covariance(Jw, sig[blocks] * w, free, dof)
    verdict = reliability(cov_z, n_exp, kinds, length // n_out, within=within, across=across, agreement=agreement,
                          blocks=hac_blocks)
    estimates = params.with_estimates(z, cov_z.matrix, cov_z.critical_of)
    D = params.value_derivatives(z, free)
    cov = D @ cov_z.matrix @ D.T if free else np.zeros((0, 0))
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    names = [free[i] for i in kinds]
    msgs = list(cov_z.messages)
    msgs.extend(correlation_messages(names, np.array([estimates[n].value for n in names]),
                                     cov[np.ix_(kinds, kinds)], [params[n].unit for n in names], J[:, kinds]))
    return dict(parameters=estimates, free=free, covariance=cov, correlation=corr, dof=dof, critical=cov_z.critical,
                block_sigma=sig, warnings=msgs, covariance_method=cov_z.method, bandwidth=cov_z.bandwidth,
                inflation=dict(zip(free, (float(x) for x in cov_z.inflation))), reliability=verdict)


def _no_statistics(params: Parameters, z: np.ndarray) -> dict[str, Any]:
    """The parameters at the optimum without uncertainty (NaN standard errors)."""
    n = len(params.free)
    nan = np.full((n, n), np.nan)
    estimates = params.with_estimates(z, nan, math.nan)
    return dict(parameters=estimates, free=params.free, covariance=nan, correlation=nan.copy(), dof=0,
                critical=math.nan, block_sigma=np.zeros(0), warnings=[], covariance_method="none", bandwidth=None,
                inflation={}, reliability=None)


def _bound_messages(params: Parameters, z: np.ndarray) -> list[str]:
    """Parameters of the model that ended at a bound."""
    lo, hi = params.internal_bounds()
    vals = params.from_internal(z)
    out = []
    for i, n in enumerate(params.free):
        p = params[n]
        if p.kind != "model":
            continue
        if math.isfinite(lo[i]) and z[i] <= lo[i] + BOUND_TOL * max(1.0, abs(lo[i])):
            out.append(f"{n} = {vals[n]:.6g} is at its lower bound {p.min:.6g}")
        elif math.isfinite(hi[i]) and z[i] >= hi[i] - BOUND_TOL * max(1.0, abs(hi[i])):
            out.append(f"{n} = {vals[n]:.6g} is at its upper bound {p.max:.6g}")
    return out

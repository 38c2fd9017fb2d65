"""Linear least squares of the paper's (13), solved stably, with honest uncertainty.

The identification set-up (10)-(12) stacks, for every sample ``k``, the two
equations ``Phi(k Ts) theta = phi(k Ts)`` of the ``dq3/dt`` and ``dq4/dt``
rows of (9), and (13) writes the solution with the normal matrix
``sum Phi^T Phi``.  This module solves the same problem

* **stably**: the columns are scaled to unit norm and the system is solved
  through the singular value decomposition of the scaled regressor; the
  normal matrix is never formed or inverted, so an ill-conditioned but
  full-rank problem keeps about twice as many correct digits;
* **with weights per equation block**: in practice the ``dq4/dt`` equation
  is about 100 times noisier than the ``dq3/dt`` one; with
  ``LeastSquaresOptions(weights="blocks")`` (the default) a first ordinary least-squares pass estimates each
  block's residual standard deviation and the rows are rescaled by its
  inverse (feasible weighted least squares);
* **with honest uncertainty**: residuals of differentiated, low-pass
  filtered signals are strongly autocorrelated over roughly the filter
  window, so the textbook ``sigma^2 (X^T X)^-1`` understates the spread.
  The default covariance is the Newey-West (Bartlett kernel) HAC sandwich
  with an automatic bandwidth (twice the Andrews 1991 AR(1) plug-in), and
  the 95 % intervals use the fixed-b critical value of Kiefer and
  Vogelsang (2005) for that bandwidth;
* **loudly**: a rank-deficient regressor raises :class:`IdentificationError`
  naming the parameter combination that is not identifiable, ill
  conditioning and strongly correlated pairs are reported as warnings.

Units: the parameters have the units that make ``Phi theta`` match the
target ``phi`` (e.g. ``p1`` [1/s^2] when ``phi = dq3/dt`` [rad/s^2]); the
standard errors and intervals have the unit of their parameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping, Sequence

import numpy as np
from scipy import stats
from scipy.linalg.lapack import dgeqrf as _dgeqrf

from ..checks import check_finite
from ..errors import IdentificationError, InputError
from ..files import json_float
from .covariance import (
    BANDWIDTH_RULES,
    bartlett_long_run_covariance,
    fixed_b_critical_value,
    hac_bandwidth,
    null_space_message,
)
from .fit_parameters import Parameter, closing_lines, parameter_table

__all__ = [
    "LeastSquaresOptions",
    "LeastSquaresResult",
    "LinearSystem",
    "solve_least_squares",
    "stack_rows",
    "lstsq_projection",
    "DEFAULT_RCOND",
    "DEFAULT_COND_WARN",
    "DEFAULT_CORR_WARN",
]

#: Relative singular-value threshold (on the column-scaled regressor) below
#: which a direction counts as not identifiable.
DEFAULT_RCOND = 1e-10
#: Condition number of the column-scaled regressor above which a warning
#: about poor excitation is given.
DEFAULT_COND_WARN = 1e8
#: Absolute correlation of two estimates above which a warning is given.
DEFAULT_CORR_WARN = 0.95

_WEIGHT_FLOOR = 1e-8  # smallest block sigma relative to the largest one


# ---------------------------------------------------------------------------
# result types
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class LeastSquaresResult:
    """Result of :func:`solve_least_squares`.

    Attributes
    ----------
    names : tuple of str
        Parameter names, in column order of the regressor.
    parameters : dict of str to Parameter
        The estimates by name; also reachable as ``result["p1"]``.
    values, stderr : ndarray, shape (n_params,)
        Estimates and standard errors in the order of ``names``.
    covariance : ndarray, shape (n_params, n_params)
        Covariance of the estimates (rows/columns of fixed parameters are
        0, of non-identifiable ones NaN).
    correlation : ndarray, shape (n_params, n_params)
        Correlation matrix of the estimates.
    condition_number : float
        2-norm condition number of the column-scaled (and, with weights,
        row-weighted) regressor that was solved; ``inf`` if rank deficient.
    rank : int
        Numerical rank of that regressor (out of the number of free
        parameters).
    residual_rms : dict
        Root mean square of the (unweighted) residuals ``phi - Phi theta``
        per equation block, in the unit of the target, keyed by block label.
    block_sigma : dict
        Residual standard deviation per block with the degrees-of-freedom
        correction (the basis of the block weights).
    n_samples : int
        Number of distinct samples (sample indices).
    n_equations : int
        Number of rows (equations) of the regressor.
    dof : int
        Residual degrees of freedom, ``n_equations - rank``.
    covariance_method : str
        ``"hac"`` or ``"ols"``.
    bandwidth : int or None
        HAC bandwidth [samples] (Bartlett lags), None for ``"ols"``.
    critical_value : float
        Multiplier of the standard error giving the 95 % interval half
        width (Student t for ``"ols"``, fixed-b for ``"hac"``).
    weights : str
        ``"none"``, ``"blocks"`` or ``"user"``.
    residuals : ndarray, shape (n_equations,)
        Unweighted residuals ``phi - Phi theta`` [unit of the target].
    warnings : list of str
        Rank deficiency, ill conditioning, strongly correlated pairs, ...
    success : bool
        False if some parameter could not be identified.
    message : str
        One-line verdict.
    """

    names: tuple[str, ...]
    parameters: dict[str, Parameter]
    values: np.ndarray
    stderr: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    condition_number: float
    rank: int
    residual_rms: dict[Any, float]
    block_sigma: dict[Any, float]
    n_samples: int
    n_equations: int
    dof: int
    covariance_method: str
    bandwidth: int | None
    critical_value: float
    weights: str
    residuals: np.ndarray = field(repr=False)
    warnings: list[str] = field(default_factory=list)
    success: bool = True
    message: str = ""

    # dict-like access --------------------------------------------------
    def __getitem__(self, name: str) -> Parameter:
        try:
            return self.parameters[name]
        except KeyError:
            raise KeyError(f"no parameter {name!r}; known: {', '.join(self.names)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self.parameters

    def value(self, name: str) -> float:
        """Estimate of parameter ``name``."""
        return self[name].value

    def value_dict(self) -> dict[str, float]:
        """``{name: value}`` of all parameters."""
        return {n: p.value for n, p in self.parameters.items()}

    def ci95(self, name: str) -> tuple[float, float]:
        """95 % confidence interval ``(low, high)`` of parameter ``name``."""
        p = self[name]
        return (p.ci95_low, p.ci95_high)

    # export --------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-able summary (NaN and inf become None).

        Returns
        -------
        dict
            ``{"parameters": {name: {"value", "stderr", "ci95", "fixed"}},
            "condition_number", "rank", "residual_rms": {block: rms},
            "block_sigma", "samples", "equations", "dof", "covariance",
            "bandwidth", "critical_value", "weights",
            "correlation": {name: {name: r}}, "warnings", "success",
            "message"}``.
        """
        corr = {
            a: {b: json_float(self.correlation[i, j]) for j, b in enumerate(self.names)}
            for i, a in enumerate(self.names)
        }
        return {
            "parameters": {n: p.to_dict() for n, p in self.parameters.items()},
            "condition_number": json_float(self.condition_number),
            "rank": int(self.rank),
            "residual_rms": {str(k): json_float(v) for k, v in self.residual_rms.items()},
            "block_sigma": {str(k): json_float(v) for k, v in self.block_sigma.items()},
            "samples": int(self.n_samples),
            "equations": int(self.n_equations),
            "dof": int(self.dof),
            "covariance": self.covariance_method,
            "bandwidth": self.bandwidth,
            "critical_value": json_float(self.critical_value),
            "weights": self.weights,
            "correlation": corr,
            "warnings": list(self.warnings),
            "success": bool(self.success),
            "message": self.message,
        }

    def summary(self) -> str:
        """A readable table of the estimates and the diagnostics."""
        cov = self.covariance_method
        if cov == "hac":
            cov = f"hac (Bartlett, bandwidth {self.bandwidth} samples)"
        lines = [
            f"Least squares: {self.n_samples} samples, {self.n_equations} equations, "
            f"{len(self.residual_rms)} block(s), dof {self.dof}; covariance {cov}; "
            f"weights {self.weights}",
        ]
        lines += parameter_table(self.parameters[n] for n in self.names)
        lines.append(f"condition number {self.condition_number:.3g}, rank {self.rank}")
        rms = ", ".join(f"{k}: {v:.4g}" for k, v in self.residual_rms.items())
        lines.append(f"residual rms per block: {rms}")
        return "\n".join(lines + closing_lines(self.warnings, self.message))

    def __str__(self) -> str:
        return self.summary()


@dataclass(frozen=True)
class LeastSquaresOptions:
    """Options of :func:`solve_least_squares`.

    Parameters
    ----------
    covariance : {"hac", "ols"}
        ``"hac"`` (default): Newey-West sandwich ``B^-1 M B^-1`` with the
        Bartlett kernel, where ``M`` sums the lagged products of the
        per-sample scores; valid under heteroscedastic and autocorrelated
        residuals, as produced by differentiated, filtered encoder data.
        ``"ols"``: ``sigma^2 (X^T X)^-1``, valid for white residuals only.
        Both are computed from the SVD, never by inverting ``X^T X``.
    weights : {"blocks", "none"}
        ``"blocks"`` (default): feasible weighted least squares, each row
        divided by its block's residual standard deviation estimated by an
        ordinary least-squares first pass.  ``"none"``: ordinary least
        squares.  (Weights per row: ``row_weights`` of
        :func:`solve_least_squares`.)
    bandwidth : int or {"auto", "andrews", "nw94", "rule"}, optional
        HAC bandwidth: number of Bartlett lags [samples], or an automatic
        rule (see :func:`hac_bandwidth`).  Default ``"auto"``: twice the
        Andrews (1991) AR(1) plug-in, at most a quarter of the samples.
        Why: residuals of differentiated, low-pass filtered signals are
        correlated over about the filter window, and the usual rules are
        far too short for that.  Measured 95 % coverage (600 Monte Carlo
        runs, 3 regressors incl. a constant, 3000 samples): residuals =
        white noise through a 21-sample moving average (the correlation
        length of the default Savitzky-Golay window) -- OLS 0.33, fixed
        rule ``4 (T/100)^(2/9)`` (8 lags) ~0.75, Andrews (125 lags)
        0.93-0.95, ``"auto"`` (250 lags) 0.93-0.95; AR(1) residuals with
        rho = 0.9 / 0.95 -- Andrews 0.92-0.94 / 0.90-0.93, ``"auto"``
        0.94-0.95 / 0.92-0.95; white residuals -- all 0.94-0.96.  The
        doubled bandwidth widens the intervals by only ~4 % (the fixed-b
        critical value accounts for it).  With fewer samples (1000)
        coverage drops to ~0.92 because few effectively independent samples
        remain.  If the correlation length ``m`` of the residuals is known,
        ``bandwidth`` of ``3 m`` to ``10 m`` is a sound manual choice.
    rcond : float
        Singular values of the column-scaled regressor below ``rcond``
        times the largest count as zero (rank deficiency).  Default 1e-10.
    cond_warn : float
        Condition number above which a warning is issued (default 1e8).
    corr_warn : float
        Absolute correlation above which a pair of estimates is reported
        (default 0.95).
    allow_rank_deficient : bool
        If False (default), a rank-deficient regressor raises
        :class:`IdentificationError`.  If True, the minimum-norm solution is
        returned with ``success=False``, NaN standard errors for the
        parameters involved in the non-identifiable combinations, and a
        warning.

    Raises
    ------
    InputError
        An unknown covariance or weighting, ``rcond`` outside (0, 1), a
        bandwidth that is neither a number of lags >= 0 nor a rule name.
    """

    covariance: str = "hac"
    weights: str = "blocks"
    bandwidth: int | str | None = None
    rcond: float = DEFAULT_RCOND
    cond_warn: float = DEFAULT_COND_WARN
    corr_warn: float = DEFAULT_CORR_WARN
    allow_rank_deficient: bool = False

    def __post_init__(self) -> None:
        if self.covariance not in ("hac", "ols"):
            raise InputError(f"covariance must be 'hac' or 'ols', got {self.covariance!r}")
        if self.weights not in ("blocks", "none"):
            raise InputError(f"weights must be 'blocks' or 'none' (row weights: row_weights=), got {self.weights!r}")
        if not (isinstance(self.rcond, (int, float)) and 0.0 < self.rcond < 1.0):
            raise InputError(f"rcond must be in (0, 1), got {self.rcond!r}")
        bw = self.bandwidth
        if isinstance(bw, str):
            if bw not in BANDWIDTH_RULES:
                raise InputError(
                    "bandwidth must be a number of lags or one of "
                    f"{', '.join(map(repr, BANDWIDTH_RULES))}, got {bw!r}"
                )
        elif bw is not None:
            if not isinstance(bw, (int, np.integer)) or isinstance(bw, bool) or bw < 0:
                raise InputError(f"bandwidth must be an integer >= 0 [samples] or a rule name, got {bw!r}")


@dataclass(frozen=True, eq=False)
class LinearSystem:
    """A stacked regression ``Phi theta = phi`` with block labels.

    Built by :func:`stack_rows`; :meth:`solve` passes everything on to
    :func:`solve_least_squares`.

    Attributes
    ----------
    Phi : ndarray, shape (n_rows, n_params)
        Regressor.
    phi : ndarray, shape (n_rows,)
        Target.
    names : tuple of str or None
        Parameter (column) names.
    blocks : ndarray, shape (n_rows,)
        Equation-block label of every row.
    sample_index : ndarray of int, shape (n_rows,)
        Sample number of every row (rows of one sample share it).
    """

    Phi: np.ndarray
    phi: np.ndarray
    names: tuple[str, ...] | None
    blocks: np.ndarray
    sample_index: np.ndarray

    def solve(
        self,
        names: Sequence[str] | None = None,
        *,
        fixed: Mapping[str, float] | None = None,
        row_weights: object = None,
        options: LeastSquaresOptions | None = None,
    ) -> LeastSquaresResult:
        """Solve with :func:`solve_least_squares` (``fixed``, ``row_weights`` and ``options`` as there)."""
        names = names if names is not None else self.names
        if names is None:
            raise InputError("names is required: the stacked blocks were given as arrays without column names")
        return solve_least_squares(
            self.Phi, self.phi, names, blocks=self.blocks, sample_index=self.sample_index, fixed=fixed,
            row_weights=row_weights, options=options,
        )


# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------

def _as_int_array(name: str, a: object, n: int) -> np.ndarray:
    arr = np.asarray(a)
    if arr.shape != (n,):
        raise InputError(f"{name} must have shape ({n},) (one entry per row), got {arr.shape}")
    if arr.dtype.kind == "f":
        if not np.all(np.isfinite(arr)) or not np.all(arr == np.round(arr)):
            raise InputError(f"{name} must contain integers")
        arr = arr.astype(np.int64)
    if arr.dtype.kind not in "iu":
        raise InputError(f"{name} must contain integers, got dtype {arr.dtype}")
    return arr.astype(np.int64)


def _position_in_block(blocks: np.ndarray) -> np.ndarray:
    """0, 1, 2, ... counted separately within each block label, in row order."""
    _, inv = np.unique(blocks, return_inverse=True)
    inv = inv.ravel()
    out = np.empty(len(blocks), dtype=np.int64)
    for b in range(int(inv.max()) + 1 if len(inv) else 0):
        rows = np.nonzero(inv == b)[0]
        out[rows] = np.arange(len(rows))
    return out


def _block_labels(blocks: np.ndarray) -> list[Any]:
    """Block labels in order of first appearance, as plain Python objects."""
    if blocks.dtype.kind in "iu" and blocks.size:
        lo, hi = int(blocks.min()), int(blocks.max())
        if lo == hi:
            return [blocks[0].item()]
        if hi - lo <= 64:  # a few integer labels: no sort needed
            present = np.flatnonzero(np.bincount(blocks - lo, minlength=hi - lo + 1))
            first = [int(np.argmax(blocks == lo + k)) for k in present]
            return [blocks[i].item() for i in sorted(first)]
    _, first = np.unique(blocks, return_index=True)
    return [blocks[i].item() if hasattr(blocks[i], "item") else blocks[i] for i in sorted(first)]


def _svd_scaled(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Column norms D and the thin SVD of X / D (zero columns kept at zero)."""
    D = np.sqrt(np.einsum("ij,ij->j", X, X))
    Ds = np.where(D > 0, D, 1.0)
    U, s, Vt = np.linalg.svd(X / Ds, full_matrices=False)
    return D, U, s, Vt


# ---------------------------------------------------------------------------
# main entry point: check -> factorise -> solve -> covariance -> report
# ---------------------------------------------------------------------------
def solve_least_squares(
    Phi: object,
    phi: object,
    names: Sequence[str],
    *,
    blocks: object = None,
    sample_index: object = None,
    fixed: Mapping[str, float] | None = None,
    row_weights: object = None,
    options: LeastSquaresOptions | None = None,
) -> LeastSquaresResult:
    """Solve ``Phi theta ~= phi`` in the least-squares sense (paper, (13)).

    Parameters
    ----------
    Phi : array_like, shape (n_rows, n_params)
        Regressor; column ``j`` multiplies parameter ``names[j]``.  With the
        paper's (11), each sample contributes one row per equation.
    phi : array_like, shape (n_rows,)
        Target, e.g. ``dq3/dt`` and ``dq4/dt`` [rad/s^2] as in (10).
    names : sequence of str
        Parameter names, one per column, unique.
    blocks : array_like, shape (n_rows,), optional
        Equation-block label per row (int or str), e.g. ``"q3"`` for the
        ``dq3/dt`` rows and ``"q4"`` for the ``dq4/dt`` rows.  Default: one
        block.
    sample_index : array_like of int, shape (n_rows,), optional
        Sample number of each row; rows with the same number are treated
        jointly in the HAC sum, and the lag between rows is the difference
        of their numbers.  Default: the position of the row within its
        block (rows in time order, one block after another).  When joining
        separate experiments, offset their numbers by more than the
        bandwidth.
    fixed : mapping of str to float, optional
        Parameters held at given values (e.g. from a separate experiment,
        as in the paper's set-up (d)); their columns are moved to the
        target.  They are reported with ``fixed=True`` and zero stderr.
    row_weights : array_like, shape (n_rows,), optional
        Inverse variances per row (> 0) [1/(unit of the target)^2]; given,
        they replace ``options.weights`` (the result's ``weights`` is
        ``"user"``).
    options : LeastSquaresOptions, optional
        Covariance, block weights, HAC bandwidth, rank threshold, warning
        thresholds and whether a rank-deficient regressor raises (default
        ``LeastSquaresOptions()``).

    Returns
    -------
    LeastSquaresResult

    Raises
    ------
    InputError
        Wrong shapes, duplicate names, NaN/inf in ``Phi`` (naming the
        parameter column and the first bad row) or in ``phi``, fewer rows
        than parameters, bad row weights.
    IdentificationError
        The regressor is rank deficient and
        ``options.allow_rank_deficient`` is False; the message names the
        collinear columns.

    Notes
    -----
    The 95 % interval is ``value +- c * stderr`` with ``c`` the Student t
    quantile (``dof`` degrees of freedom) for ``"ols"`` and the fixed-b
    critical value ``1.96 + 2.9694 b + 0.4160 b^2 - 0.5324 b^3``,
    ``b = bandwidth / n_samples`` (Kiefer & Vogelsang 2005), for ``"hac"``,
    which accounts for the extra randomness of the HAC variance estimate.
    The HAC covariance includes the small-sample factor
    ``n_rows / (n_rows - rank)``.

    Examples
    --------
    The pendulum's row of (10), ``dq3/dt = -p1 sin q1 - sigma q3``, on 200 synthetic samples with Table 1's
    ``p1`` and ``sigma = 0.013`` [1/s]:

    >>> import numpy as np
    >>> from iwp.ident import solve_least_squares
    >>> rng = np.random.default_rng(0)
    >>> q1, q3 = np.linspace(-1.4, 1.4, 200), rng.normal(size=200)
    >>> dq3 = -26.095 * np.sin(q1) - 0.013 * q3 + rng.normal(scale=0.01, size=200)
    >>> res = solve_least_squares(np.column_stack([-np.sin(q1), -q3]), dq3, ["p1", "sigma"])
    >>> p1, sigma = res.parameters["p1"], res.parameters["sigma"]
    >>> round(p1.value, 3), round(p1.stderr, 4)
    (26.095, 0.001)
    >>> [round(x, 4) for x in sigma.ci95]  # its 95 % interval holds 0.013
    [0.0122, 0.0151]
    """
    opts = LeastSquaresOptions() if options is None else options
    if not isinstance(opts, LeastSquaresOptions):
        raise InputError(f"options must be a LeastSquaresOptions, got {type(opts).__name__}")
    problem = _check_problem(Phi, phi, names, blocks, sample_index)
    user_sw = _user_row_scale(row_weights, problem.n_rows)
    part = _free_part(problem, fixed)
    factor = _factorise(problem, part, user_sw, opts)
    fit = _solve_factor(problem, part, factor, opts)
    if opts.covariance == "ols":
        unc = _ols_covariance(problem, fit)
    else:
        unc = _hac_covariance(problem, part, factor, fit, opts)
    return _report(problem, part, factor, fit, unc, opts)


@dataclass(frozen=True, eq=False)
class _Problem:
    """The checked inputs: regressor ``X``, target ``y``, names, block labels and sample numbers per row."""

    X: np.ndarray
    y: np.ndarray
    names: tuple[str, ...]
    blk: np.ndarray
    sidx: np.ndarray

    @property
    def n_rows(self) -> int:
        return self.X.shape[0]

    @property
    def n_par(self) -> int:
        return self.X.shape[1]


@dataclass(frozen=True, eq=False)
class _FreePart:
    """The free parameters' regression: fixed columns moved to the target."""

    fixed: dict[str, float]
    free: list[int]
    free_names: list[str]
    Xf: np.ndarray
    y_free: np.ndarray

    @property
    def p(self) -> int:
        return len(self.free)


@dataclass(frozen=True, eq=False)
class _Factor:
    """The small stacked triangular factor of the weighted ``[X | y]`` and the row scale ``sw`` it used."""

    Msmall: np.ndarray
    sw: np.ndarray
    unit_w: bool
    wmode: str
    block_rows: dict[Any, Any]


@dataclass(frozen=True, eq=False)
class _Fit:
    """The SVD solution: rank, condition number, the free values and residuals (plain and weighted)."""

    rank: int
    cond: float
    Vt: np.ndarray
    sr: np.ndarray
    Dsafe: np.ndarray
    theta_free: np.ndarray
    res: np.ndarray
    res_w: np.ndarray
    yw: np.ndarray
    warnings: tuple[str, ...]

    @property
    def Vr(self) -> np.ndarray:
        return self.Vt[: self.rank].T

    @property
    def dof(self) -> int:
        return self.res.shape[0] - self.rank


@dataclass(frozen=True, eq=False)
class _Uncertainty:
    """Covariance of the scaled free coordinates ``theta_s = D theta``, samples, bandwidth, critical value."""

    cov_s: np.ndarray
    n_samples: int
    bandwidth: int | None
    critical: float
    warnings: tuple[str, ...] = ()


def _check_problem(Phi: object, phi: object, names: Sequence[str], blocks: object, sample_index: object) -> _Problem:
    """Shapes, names, finiteness, block labels and sample numbers of the regression."""
    try:
        X = np.asarray(Phi, dtype=float)
    except (TypeError, ValueError):
        raise InputError("Phi must be a 2-D array of numbers (rows: equations, columns: parameters)") from None
    if X.ndim != 2:
        raise InputError(f"Phi must be 2-D (rows: equations, columns: parameters), got shape {X.shape}")
    n_rows = X.shape[0]
    names = _checked_names(names, X.shape[1])
    try:
        y = np.asarray(phi, dtype=float)
    except (TypeError, ValueError):
        raise InputError("phi (the target) must be a 1-D array of numbers") from None
    if y.shape != (n_rows,):
        raise InputError(f"phi (the target) must have shape ({n_rows},) to match Phi, got {y.shape}")
    badX = ~np.isfinite(X)
    if badX.any():
        rows, cols = np.nonzero(badX)
        j = int(cols[np.argmin(rows)])
        i = int(rows.min())
        raise InputError(
            f"Phi column {names[j]!r} has NaN or inf at row {i}; drop or repair those samples "
            "(e.g. trim the differentiator's edge samples)"
        )
    bady = ~np.isfinite(y)
    if bady.any():
        raise InputError(
            f"phi (the target) has NaN or inf at row {int(np.argmax(bady))}; drop or repair those samples"
        )
    if blocks is None:
        blk = np.zeros(n_rows, dtype=np.int64)
    else:
        blk = np.asarray(blocks)
        if blk.shape != (n_rows,):
            raise InputError(f"blocks must have shape ({n_rows},) (one label per row), got {blk.shape}")
    if sample_index is None:
        sidx = _position_in_block(blk)
    else:
        sidx = _as_int_array("sample_index", sample_index, n_rows)
    return _Problem(X=X, y=y, names=names, blk=blk, sidx=sidx)


def _checked_names(names: Sequence[str], n_par: int) -> tuple[str, ...]:
    """The column names as a tuple: one per column, non-empty strings, unique."""
    if isinstance(names, str) or not isinstance(names, Iterable):
        raise InputError("names must be a sequence of parameter names, one per column of Phi")
    names = tuple(names)
    if len(names) != n_par:
        raise InputError(f"names has {len(names)} entries but Phi has {n_par} columns")
    for nm in names:
        if not isinstance(nm, str) or not nm:
            raise InputError(f"names must be non-empty strings, got {nm!r}")
    dup = sorted({nm for nm in names if names.count(nm) > 1})
    if dup:
        raise InputError(f"names must be unique; repeated: {', '.join(dup)}")
    return names


def _user_row_scale(row_weights: object, n_rows: int) -> np.ndarray | None:
    """Square roots of the user's inverse variances per row (None when not given)."""
    if row_weights is None:
        return None
    try:
        wa = np.asarray(row_weights, dtype=float)
    except (TypeError, ValueError):
        raise InputError("row_weights must be an array of inverse variances, one per row") from None
    if wa.shape != (n_rows,):
        raise InputError(f"row_weights must have shape ({n_rows},) (inverse variance per row), got {wa.shape}")
    if not np.all(np.isfinite(wa)) or np.any(wa <= 0):
        i = int(np.argmax(~np.isfinite(wa) | (wa <= 0)))
        raise InputError(f"row_weights must be finite and > 0; row {i} has {wa[i]!r}")
    return np.sqrt(wa)


def _free_part(problem: _Problem, fixed: Mapping[str, float] | None) -> _FreePart:
    """Move the columns of the fixed parameters to the target; what remains is estimated."""
    names, X, y = problem.names, problem.X, problem.y
    fixed = dict(fixed or {})
    for nm, v in fixed.items():
        if nm not in names:
            raise InputError(f"fixed names unknown parameter {nm!r}; known: {', '.join(names)}")
        fixed[nm] = check_finite(f"fixed[{nm!r}]", v)
    free = [j for j, nm in enumerate(names) if nm not in fixed]
    if not free:
        raise InputError("all parameters are fixed; nothing to estimate")
    if fixed:
        y_free = y.copy()
        for nm, v in fixed.items():
            y_free -= X[:, names.index(nm)] * float(v)
        Xf = X[:, free]
    else:
        y_free, Xf = y, X
    if problem.n_rows <= len(free):
        raise InputError(
            f"need more equations (rows of Phi) than free parameters: {problem.n_rows} rows for {len(free)} "
            "parameters"
        )
    return _FreePart(fixed=fixed, free=free, free_names=[names[j] for j in free], Xf=Xf, y_free=y_free)


def _factorise(problem: _Problem, part: _FreePart, user_sw: np.ndarray | None,
               opts: LeastSquaresOptions) -> _Factor:
    """The weighted problem as a small stacked triangular factor.

    Orthogonal factorisation of the augmented ``[X | y]`` (per block,
    tall-skinny Householder QR in chunks): ``X_b = Q_b R_b``.  The weighted
    problem is then the small stacked system ``[w_b R_b]``; its SVD is the
    SVD of the weighted regressor up to the orthogonal factor, and
    ``||y_b - X_b theta|| = ||R_b [theta; -1]||``.  The normal matrix is
    never formed.
    """
    n_rows, p = problem.n_rows, part.p
    labels = _block_labels(problem.blk)
    block_rows = {lab: _rows_of(problem.blk, lab, len(labels)) for lab in labels}
    if user_sw is not None:
        Msmall = tsqr_augmented(part.Xf, part.y_free, slice(None), user_sw)
        return _Factor(Msmall=Msmall, sw=user_sw, unit_w=False, wmode="user", block_rows=block_rows)
    Rs = {lab: tsqr_augmented(part.Xf, part.y_free, rows, None) for lab, rows in block_rows.items()}
    wb = {lab: 1.0 for lab in labels}
    if opts.weights == "blocks" and len(labels) > 1:
        counts = {lab: _count(rows, n_rows) for lab, rows in block_rows.items()}
        wb = _block_weights_R(Rs, counts, opts.rcond, p, n_rows)
    Msmall = np.vstack([wb[lab] * Rs[lab] for lab in labels])
    unit_w = all(w == 1.0 for w in wb.values())
    if unit_w:
        sw = np.ones(n_rows)
    else:
        sw = np.empty(n_rows)
        for lab, rows in block_rows.items():
            sw[rows] = wb[lab]
    return _Factor(Msmall=Msmall, sw=sw, unit_w=unit_w, wmode=opts.weights, block_rows=block_rows)


def _solve_factor(problem: _Problem, part: _FreePart, factor: _Factor, opts: LeastSquaresOptions) -> _Fit:
    """Column-scaled SVD of the small factor: rank, condition number, minimum-norm solution, residuals."""
    p, rcond = part.p, opts.rcond
    Bm, cm = factor.Msmall[:, :p], factor.Msmall[:, p]
    D = np.sqrt(np.einsum("ij,ij->j", Bm, Bm))
    Dsafe = np.where(D > 0, D, 1.0)
    Ub, s, Vt = np.linalg.svd(Bm / Dsafe, full_matrices=False)
    smax = s[0] if s.size else 0.0
    rank = int(np.sum(s > rcond * smax)) if smax > 0 else 0
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    warnings: tuple[str, ...] = ()
    if rank < p:
        msg = null_space_message(Vt[rank:], part.free_names)
        text = (
            f"regressor is rank deficient (numerical rank {rank} of {p}, rcond {rcond:g}): "
            f"{msg}. Excite the system so that these columns differ, or fix/remove a parameter"
        )
        if not opts.allow_rank_deficient:
            raise IdentificationError(text)
        warnings = (text,)
    sr, Vr = s[:rank], Vt[:rank].T  # Vr: p x rank
    coef_u = (Ub[:, :rank].T @ cm) / sr  # coordinates in the row space
    theta_s = Vr @ coef_u
    theta_free = theta_s / Dsafe
    res = part.y_free - _mv(part.Xf, theta_free)
    res_w = res if factor.unit_w else res * factor.sw
    yw = part.y_free if factor.unit_w else part.y_free * factor.sw
    return _Fit(rank=rank, cond=cond, Vt=Vt, sr=sr, Dsafe=Dsafe, theta_free=theta_free, res=res, res_w=res_w,
                yw=yw, warnings=warnings)


def _ols_covariance(problem: _Problem, fit: _Fit) -> _Uncertainty:
    """``sigma^2 (X^T X)^-1`` in the scaled coordinates, from the SVD; Student t critical value."""
    n_rows, sidx, dof = problem.n_rows, problem.sidx, fit.dof
    s_min, s_max = int(sidx.min()), int(sidx.max())
    if s_max - s_min + 1 <= 10 * n_rows + 1000:  # count distinct sample numbers without sorting
        present = np.zeros(s_max - s_min + 1, dtype=bool)
        present[sidx - s_min] = True
        n_samples = int(np.count_nonzero(present))
    else:
        n_samples = int(np.unique(sidx).size)
    A = fit.Vr / fit.sr  # p x rank; theta_s - true = A @ (Ur^T e)
    sigma2 = _dot(fit.res_w, fit.res_w) / dof if dof > 0 else math.nan
    crit = float(stats.t.ppf(0.975, dof)) if dof > 0 else math.nan
    return _Uncertainty(cov_s=sigma2 * (A @ A.T), n_samples=n_samples, bandwidth=None, critical=crit)


def _hac_covariance(problem: _Problem, part: _FreePart, factor: _Factor, fit: _Fit,
                    opts: LeastSquaresOptions) -> _Uncertainty:
    """Newey-West (Bartlett) sandwich of the per-sample scores in the scaled coordinates; fixed-b critical value."""
    n_rows, sidx, dof, rank = problem.n_rows, problem.sidx, fit.dof, fit.rank
    s_min, s_max = int(sidx.min()), int(sidx.max())
    span = s_max - s_min + 1
    if span > 10 * n_rows + 1000:
        raise InputError(
            f"sample_index spans {span} samples for {n_rows} rows; number the samples "
            "consecutively (gaps only between separate experiments)"
        )
    present = np.zeros(span, dtype=bool)
    present[sidx - s_min] = True
    n_samples = int(np.count_nonzero(present))
    # left singular vectors of the weighted, column-scaled regressor: U = (Xw / D) V S^-1
    Ur = _mm(part.Xf, fit.Vr / (fit.Dsafe[:, None] * fit.sr[None, :]))
    if not factor.unit_w:
        Ur *= factor.sw[:, None]
    Hrows = Ur * fit.res_w[:, None]
    H = np.zeros((span, rank))
    for rows in factor.block_rows.values():
        _scatter_add(H, sidx[rows] - s_min, Hrows[rows])
    bandwidth = opts.bandwidth
    if bandwidth is None or isinstance(bandwidth, str):
        L_used = hac_bandwidth(H if n_samples == span else H[present], bandwidth or "auto")
    else:
        L_used = int(bandwidth)
    if L_used > n_samples // 2:
        raise InputError(
            f"bandwidth ({L_used}) must not exceed half the number of samples ({n_samples})"
        )
    res_w, yw = fit.res_w, fit.yw
    exact = float(np.sqrt(np.mean(res_w**2))) <= 1e-10 * max(float(np.sqrt(np.mean(yw**2))), 1e-300)
    warnings: tuple[str, ...] = ()
    if L_used > n_samples // 10 and not exact:
        warnings = (
            f"HAC bandwidth {L_used} is more than a tenth of the {n_samples} samples: "
            "few effectively independent samples, the uncertainty itself is uncertain",
        )
    A = fit.Vr / fit.sr  # p x rank; theta_s - true = A @ (Ur^T e)
    M = bartlett_long_run_covariance(H, L_used) * (n_rows / dof if dof > 0 else math.nan)
    crit = fixed_b_critical_value(L_used / max(n_samples, 1))
    return _Uncertainty(cov_s=A @ M @ A.T, n_samples=n_samples, bandwidth=L_used, critical=crit, warnings=warnings)


def _not_identifiable(fit: _Fit, p: int) -> np.ndarray:
    """Mask of the free parameters that take part in a direction of the null space."""
    if fit.rank < p:
        return np.sum(fit.Vt[fit.rank:] ** 2, axis=0) > 1e-12
    return np.zeros(p, dtype=bool)


def _full_covariance(problem: _Problem, part: _FreePart, fit: _Fit, unc: _Uncertainty) -> np.ndarray:
    """Covariance of all parameters: fixed ones 0, non-identifiable ones NaN."""
    Dsafe = fit.Dsafe
    cov_free = unc.cov_s / np.outer(Dsafe, Dsafe)
    bad_free = _not_identifiable(fit, part.p)
    if bad_free.any():
        cov_free[bad_free, :] = np.nan
        cov_free[:, bad_free] = np.nan
    cov = np.zeros((problem.n_par, problem.n_par))
    cov[np.ix_(part.free, part.free)] = cov_free
    return cov


def _correlation(names: tuple[str, ...], fixed: Mapping[str, float], cov: np.ndarray,
                 stderr: np.ndarray) -> np.ndarray:
    """Correlation of the estimates (rows/columns of fixed parameters 0, diagonal 1 or NaN)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(stderr, stderr)
    for j in range(len(names)):
        if names[j] in fixed:
            corr[j, :] = 0.0
            corr[:, j] = 0.0
        corr[j, j] = 1.0 if math.isfinite(stderr[j]) else math.nan
    return np.clip(corr, -1.0, 1.0)


def _diagnostics(names: tuple[str, ...], fit: _Fit, corr: np.ndarray, p: int,
                 opts: LeastSquaresOptions) -> list[str]:
    """Warnings on ill conditioning and on strongly correlated pairs of estimates."""
    out = []
    if fit.rank == p and fit.cond > opts.cond_warn:
        out.append(
            f"poor excitation / ill-conditioned regressor: condition number {fit.cond:.3g} of the "
            f"column-scaled regressor exceeds {opts.cond_warn:.3g}; the estimates are sensitive to noise"
        )
    pairs = []
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            r = corr[a, b]
            if math.isfinite(r) and abs(r) > opts.corr_warn:
                pairs.append(f"{names[a]} & {names[b]} (r = {r:+.3f})")
    if pairs:
        out.append(
            f"strongly correlated estimates (|r| > {opts.corr_warn:g}): {', '.join(pairs)}; "
            "their individual values are poorly determined, only combinations are"
        )
    return out


def _report(problem: _Problem, part: _FreePart, factor: _Factor, fit: _Fit, unc: _Uncertainty,
            opts: LeastSquaresOptions) -> LeastSquaresResult:
    """Assemble the full-size estimates, their statistics and the diagnostics into the result."""
    names, n_rows, p = problem.names, problem.n_rows, part.p
    values = np.empty(problem.n_par)
    for k, j in enumerate(part.free):
        values[j] = fit.theta_free[k]
    for nm, v in part.fixed.items():
        values[names.index(nm)] = float(v)
    cov = _full_covariance(problem, part, fit, unc)
    stderr = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    stderr[np.isnan(np.diag(cov))] = np.nan
    corr = _correlation(names, part.fixed, cov, stderr)
    params: dict[str, Parameter] = {}
    for j, nm in enumerate(names):
        if nm in part.fixed:
            params[nm] = Parameter.given(nm, float(values[j]))
        else:
            params[nm] = Parameter.estimate(nm, float(values[j]), float(stderr[j]), unc.critical)
    warnings = [*fit.warnings, *unc.warnings, *_diagnostics(names, fit, corr, p, opts)]
    res, block_rows = fit.res, factor.block_rows
    success = fit.rank == p
    if success:
        message = f"identified {p} parameter(s) from {unc.n_samples} samples ({n_rows} equations)"
    else:
        lost = ", ".join(part.free_names[k] for k in np.nonzero(_not_identifiable(fit, p))[0])
        message = f"rank deficient: {lost} not identifiable; values are a minimum-norm solution"
    return LeastSquaresResult(
        names=names, parameters=params, values=values, stderr=stderr, covariance=cov, correlation=corr,
        condition_number=fit.cond if success else math.inf, rank=fit.rank,
        residual_rms={lab: float(np.sqrt(np.mean(res[rows] ** 2))) for lab, rows in block_rows.items()},
        block_sigma=_block_sigmas(res, block_rows, fit.rank, n_rows), n_samples=unc.n_samples,
        n_equations=n_rows, dof=fit.dof, covariance_method=opts.covariance, bandwidth=unc.bandwidth,
        critical_value=float(unc.critical), weights=factor.wmode, residuals=res, warnings=warnings,
        success=success, message=message,
    )


def _lstsq_svd(X: np.ndarray, y: np.ndarray, rcond: float) -> np.ndarray | None:
    """Minimum-norm least-squares solution via the SVD of the column-scaled X."""
    D, U, s, Vt = _svd_scaled(X)
    if s.size == 0 or s[0] <= 0:
        return None
    r = int(np.sum(s > rcond * s[0]))
    return (Vt[:r].T @ ((U[:, :r].T @ y) / s[:r])) / np.where(D > 0, D, 1.0)


#: Rows per chunk of the tall-skinny QR (any value gives the same R up to rounding). Below ~1000
#: rows OpenBLAS factorises each chunk on one thread: larger chunks get threaded BLAS inside dgeqrf,
#: which on a busy machine can stall for hundreds of milliseconds (measured: 2048 rows, 2 cores, one
#: busy), and its worker threads keep spinning afterwards, taking the CPU from the main thread.
_TSQR_CHUNK = 768


#: Rows per block of the tall matrix products below (small enough for single-threaded BLAS).
_BLAS_ROWS = 512


def _mv(X: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``X @ v`` for a tall ``X`` without threaded BLAS (einsum loops)."""
    return np.einsum("ij,j->i", X, v)


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """``a @ b`` for long vectors without threaded BLAS."""
    return float(np.einsum("i,i->", a, b))


def _mm(X: np.ndarray, S: np.ndarray) -> np.ndarray:
    """``X @ S`` for a tall ``X`` and a small ``S``, in row blocks (single-threaded BLAS)."""
    out = np.empty((X.shape[0], S.shape[1]))
    for i in range(0, X.shape[0], _BLAS_ROWS):
        np.matmul(X[i: i + _BLAS_ROWS], S, out=out[i: i + _BLAS_ROWS])
    return out


def _gram(X: np.ndarray, Y: np.ndarray | None = None) -> np.ndarray:
    """``X.T @ Y`` (default ``Y = X``) for tall ``X``, ``Y``, summed over row blocks (single-threaded BLAS)."""
    Y = X if Y is None else Y
    out = np.zeros((X.shape[1], Y.shape[1]))
    for i in range(0, X.shape[0], 4 * _BLAS_ROWS):
        out += X[i: i + 4 * _BLAS_ROWS].T @ Y[i: i + 4 * _BLAS_ROWS]
    return out


def tsqr_augmented(X: np.ndarray, y: np.ndarray, rows: Any, sw: np.ndarray | None) -> np.ndarray:
    """Upper-triangular R of the Householder QR of ``[X[rows] | y[rows]]`` (optionally row-scaled by ``sw``).

    Tall-skinny QR: the rows are factorised in chunks, the stacked chunk R
    factors once more (LAPACK ``dgeqrf``). ``y`` may be 1-D or 2-D (several
    right-hand sides). Rows of the result: ``min(m, k)`` with ``k`` the
    number of columns of ``[X | y]``.
    """
    Xb = X[rows]
    yb = y[rows]
    if yb.ndim == 1:
        yb = yb[:, None]
    m, p = Xb.shape
    k = p + yb.shape[1]
    Rs = []
    for i in range(0, m, _TSQR_CHUNK):
        c = min(_TSQR_CHUNK, m - i)
        A = np.empty((c, k), order="F")
        A[:, :p] = Xb[i : i + c]
        A[:, p:] = yb[i : i + c]
        if sw is not None:
            A *= sw[i : i + c, None]
        qr, _, _, info = _dgeqrf(A, overwrite_a=1)
        Rs.append(np.triu(qr[: min(c, k)]))
    if len(Rs) == 1:
        return Rs[0]
    A = np.asfortranarray(np.vstack(Rs))
    qr, _, _, info = _dgeqrf(A, overwrite_a=1)
    return np.triu(qr[: min(A.shape[0], k)])


def lstsq_projection(X: object, Y: object, row_scale: object = None, rcond: float = DEFAULT_RCOND) -> np.ndarray:
    """Least-squares coefficients ``B`` minimising ``||diag(w) (X B - Y)||`` for several targets.

    Same numerics as :func:`solve_least_squares` (tall-skinny Householder QR
    of ``[X | Y]``, column scaling, SVD of the small triangular factor; no
    normal matrix), without the statistics. Used e.g. to propagate the
    uncertainty of known parameters that enter the target linearly.

    Parameters
    ----------
    X : array_like, shape (n, p)
        Regressor.
    Y : array_like, shape (n,) or (n, r)
        Target(s).
    row_scale : array_like, shape (n,), optional
        Row scale factors ``w`` (square roots of the weights).
    rcond : float
        Relative singular-value threshold of the column-scaled regressor.

    Returns
    -------
    ndarray, shape (p,) or (p, r)
        Minimum-norm solution(s).
    """
    Xa = np.asarray(X, dtype=float)
    Ya = np.asarray(Y, dtype=float)
    one = Ya.ndim == 1
    if Xa.ndim != 2 or Ya.shape[0] != Xa.shape[0] or Ya.ndim > 2:
        raise InputError(f"X must be (n, p) and Y (n,) or (n, r); got {Xa.shape} and {Ya.shape}")
    sw = None if row_scale is None else np.asarray(row_scale, dtype=float)
    p = Xa.shape[1]
    R = tsqr_augmented(Xa, Ya, slice(None), sw)
    B, C = R[:, :p], R[:, p:]
    D = np.sqrt(np.einsum("ij,ij->j", B, B))
    Ds = np.where(D > 0, D, 1.0)
    U, s, Vt = np.linalg.svd(B / Ds, full_matrices=False)
    if s.size == 0 or s[0] <= 0:
        out = np.zeros((p, C.shape[1]))
    else:
        r = int(np.sum(s > rcond * s[0]))
        out = (Vt[:r].T @ ((U[:, :r].T @ C) / s[:r, None])) / Ds[:, None]
    return out[:, 0] if one else out


def _scatter_add(H: np.ndarray, idx: np.ndarray, rows: np.ndarray) -> None:
    """``H[idx] += rows`` with repeated indices summed (like ``np.add.at``), fast for consecutive runs."""
    n = idx.size
    if n == 0:
        return
    brk = np.flatnonzero(np.diff(idx) != 1)
    if brk.size <= 64:  # a few runs of consecutive sample numbers (one per file): slice adds
        starts = np.concatenate([[0], brk + 1])
        ends = np.concatenate([brk + 1, [n]])
        for a, b in zip(starts.tolist(), ends.tolist()):
            i0 = int(idx[a])
            H[i0 : i0 + (b - a)] += rows[a:b]
    else:
        np.add.at(H, idx, rows)


def _rows_of(blk: np.ndarray, lab: Any, n_labels: int) -> Any:
    """Rows of block ``lab``: a slice when they are contiguous (the usual stacking), else indices."""
    if n_labels == 1:
        return slice(0, blk.shape[0])
    rows = np.nonzero(blk == lab)[0]
    if rows.size and rows[-1] - rows[0] + 1 == rows.size:
        return slice(int(rows[0]), int(rows[-1]) + 1)
    return rows


def _count(rows: Any, n: int) -> int:
    if isinstance(rows, slice):
        return len(range(*rows.indices(n)))
    return int(len(rows))


def _block_weights_R(
    Rs: Mapping[Any, np.ndarray], counts: Mapping[Any, int], rcond: float, p: int, n: int
) -> dict[Any, float]:
    """Block scale factors 1/sigma_block by iterated feasible weighted least squares.

    The first pass is unweighted; its residuals overstate the noise of a
    quiet block (they contain the misfit forced by the noisy block), so the
    block sigmas are re-estimated from the weighted fit until they change by
    less than 1 % (at most 8 passes). Everything is done on the blocks' R
    factors of ``[X_b | y_b]``: the weighted regression is the stacked
    ``w_b R_b`` and a block's residual sum of squares is
    ``||R_b [theta; -1]||^2``.
    """
    labs = list(Rs)
    w = {lab: 1.0 for lab in labs}
    sig_old: dict[Any, float] | None = None
    for _ in range(8):
        M = np.vstack([w[lab] * Rs[lab] for lab in labs])
        theta = _lstsq_svd(M[:, :p], M[:, p], rcond)
        if theta is None:
            return {lab: 1.0 for lab in labs}
        sig = {}
        for lab in labs:
            R = Rs[lab]
            r = R[:, :p] @ theta - R[:, p]
            nb = counts[lab]
            dof_b = nb - p * nb / n
            sig[lab] = float(np.sqrt(float(r @ r) / dof_b)) if dof_b > 0 else math.nan
        smax = max(sig.values())
        if not smax > 0:
            return {lab: 1.0 for lab in labs}
        for lab in labs:
            w[lab] = 1.0 / max(sig[lab], _WEIGHT_FLOOR * smax)
        if sig_old is not None and all(
            abs(sig[k] - sig_old[k]) <= 0.01 * max(sig_old[k], _WEIGHT_FLOOR * smax) for k in sig
        ):
            break
        sig_old = sig
    return w


def _block_sigmas(res: np.ndarray, block_rows: Mapping[Any, np.ndarray], p: int, n: int) -> dict[Any, float]:
    """Residual standard deviation per block, with a proportional dof share."""
    out = {}
    for lab, rows in block_rows.items():
        nb = _count(rows, n)
        dof_b = nb - p * nb / n
        out[lab] = float(np.sqrt(np.sum(res[rows] ** 2) / dof_b)) if dof_b > 0 else math.nan
    return out


# ---------------------------------------------------------------------------
# stacking
# ---------------------------------------------------------------------------
def stack_rows(
    *equations: Sequence[Any],
    labels: Sequence[Any] | None = None,
    names: Sequence[str] | None = None,
) -> LinearSystem:
    """Stack per-equation blocks into one regression, as (10)-(11) do.

    Parameters
    ----------
    *equations : tuple
        One tuple per equation block: ``(columns, target)`` or
        ``(columns, target, sample_index)``.  ``columns`` is either a
        mapping ``{parameter name: regressor column}`` (columns may be
        arrays of the target's length or scalars; parameters a block does
        not mention get 0, like the zeros of (11)) or a 2-D array whose
        columns are in the same order in every block.  ``target`` is the
        1-D target of the block.  ``sample_index`` defaults to
        ``0, 1, ..., n_block - 1``, so the k-th rows of all blocks belong to
        the same sample.
    labels : sequence, optional
        Label of each block (int or str), default ``0, 1, ...``.
    names : sequence of str, optional
        Parameter order.  Default: order of first appearance in the
        mappings; required for the array form if you want to call
        :meth:`LinearSystem.solve` without names.

    Returns
    -------
    LinearSystem
        ``Phi``, ``phi``, ``names``, ``blocks``, ``sample_index``; call
        ``.solve(...)`` to identify.

    Examples
    --------
    The full set-up (10)-(12)::

        s1, c1 = np.sin(q1), np.abs(np.cos(q1))
        common = {"p1": -s1, "sa1": -c1 * q3, "sv1": -q3, "sb1": -q3**3}
        sys = stack_rows(
            ({**common, "p2": q4, "p3": -u}, dq3),
            ({k: -v for k, v in common.items()} | {"p2r": -q4, "p3r": u}, dq4),
            labels=("q3", "q4"),
        )
        result = sys.solve()
    """
    if not equations:
        raise InputError("stack_rows needs at least one equation block")
    labels = _equation_labels(labels, len(equations))
    parsed = [_parse_equation(eq, lab) for eq, lab in zip(equations, labels)]
    mapping_form = [isinstance(b.columns, Mapping) for b in parsed]
    if any(mapping_form) and not all(mapping_form):
        raise InputError("give the columns of every equation block in the same form: all mappings or all arrays")
    stacked = _mapping_regressors(parsed, names) if all(mapping_form) else _array_regressors(parsed, names)
    lab_arr = np.asarray(labels)
    blocks = np.concatenate([np.full(len(b.target), lab_arr[k], dtype=lab_arr.dtype) for k, b in enumerate(parsed)])
    sidx = np.concatenate(
        [b.sample_index if b.sample_index is not None else np.arange(len(b.target), dtype=np.int64) for b in parsed]
    )
    return LinearSystem(Phi=np.concatenate(stacked.matrices, axis=0), phi=np.concatenate([b.target for b in parsed]),
                        names=stacked.names, blocks=blocks, sample_index=sidx)


@dataclass(frozen=True, eq=False)
class _Equation:
    """One equation block of :func:`stack_rows`: its columns as given, its target and sample numbers."""

    label: Any
    columns: Any
    target: np.ndarray
    sample_index: np.ndarray | None


@dataclass(frozen=True, eq=False)
class _Stacked:
    """The regressor of every block in a common column order, and that order's names (None if unnamed)."""

    matrices: list[np.ndarray]
    names: tuple[str, ...] | None


def _equation_labels(labels: Sequence[Any] | None, n: int) -> list[Any]:
    """The blocks' labels (default ``0, 1, ...``), one per block and unique."""
    if labels is None:
        labels = list(range(n))
    labels = list(labels)
    if len(labels) != n:
        raise InputError(f"labels has {len(labels)} entries for {n} equation blocks")
    if len(set(map(str, labels))) != len(labels):
        raise InputError("labels must be unique")
    return labels


def _parse_equation(eq: Any, label: Any) -> _Equation:
    """Check one ``(columns, target[, sample_index])`` tuple."""
    if not isinstance(eq, (tuple, list)) or len(eq) not in (2, 3):
        raise InputError(
            f"equation block {label!r} must be a tuple (columns, target) or (columns, target, sample_index)"
        )
    try:
        t = np.asarray(eq[1], dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"target of equation block {label!r} must be an array of numbers") from None
    if t.ndim != 1:
        raise InputError(f"target of equation block {label!r} must be 1-D, got shape {t.shape}")
    si = None
    if len(eq) == 3 and eq[2] is not None:
        si = _as_int_array(f"sample_index of block {label!r}", eq[2], len(t))
    return _Equation(label=label, columns=eq[0], target=t, sample_index=si)


def _mapping_regressors(parsed: list[_Equation], names: Sequence[str] | None) -> _Stacked:
    """Regressors of blocks given as ``{name: column}``: absent names are zero columns, as in (11)."""
    order: list[str] = list(names) if names is not None else []
    if names is None:
        for b in parsed:
            for nm in b.columns:
                if nm not in order:
                    order.append(nm)
    known = set(order)
    mats = []
    for b in parsed:
        extra = [nm for nm in b.columns if nm not in known]
        if extra:
            raise InputError(f"equation block {b.label!r} has columns not in names: {', '.join(map(str, extra))}")
        n = len(b.target)
        M = np.zeros((n, len(order)))
        for j, nm in enumerate(order):
            if nm in b.columns:
                try:
                    M[:, j] = np.broadcast_to(np.asarray(b.columns[nm], dtype=float), (n,))
                except (TypeError, ValueError):
                    raise InputError(
                        f"column {nm!r} of equation block {b.label!r} must be a scalar or an array of {n} numbers"
                    ) from None
        mats.append(M)
    return _Stacked(matrices=mats, names=tuple(order))


def _array_regressors(parsed: list[_Equation], names: Sequence[str] | None) -> _Stacked:
    """Regressors of blocks given as 2-D arrays with the same columns in every block."""
    mats = []
    width = None
    for b in parsed:
        M = np.asarray(b.columns, dtype=float)
        if M.ndim != 2 or M.shape[0] != len(b.target):
            raise InputError(
                f"regressor of equation block {b.label!r} must have shape ({len(b.target)}, n_params), got {M.shape}"
            )
        if width is None:
            width = M.shape[1]
        elif M.shape[1] != width:
            raise InputError(
                f"regressor of equation block {b.label!r} has {M.shape[1]} columns, the first block has {width}"
            )
        mats.append(M)
    out_names = tuple(names) if names is not None else None
    if out_names is not None and len(out_names) != width:
        raise InputError(f"names has {len(out_names)} entries but the regressors have {width} columns")
    return _Stacked(matrices=mats, names=out_names)

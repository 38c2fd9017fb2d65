"""The covariance of a nonlinear least-squares fit from its Jacobian, and what it says about the data.

At the optimum of a fit, the covariance of the unknowns is ``(J_w^T J_w)^-1``
with ``J_w`` the Jacobian of the residuals divided by each residual block's
standard deviation (estimated from the residuals). It is computed from the
singular value decomposition of the column-scaled ``J_w`` (never by inverting
``J^T J``); directions the data do not determine (a rank-deficient Jacobian)
get an infinite (NaN) variance and are named; pairs of parameters whose
correlation exceeds :data:`CORR_WARN` are named too, with the combination the
data do determine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import stats

from ..errors import InputError

__all__ = ["CORR_WARN", "RCOND", "BANDWIDTH_RULES", "AUTO_FACTOR", "block_sigmas", "covariance_from_jacobian",
           "correlation_messages", "null_space_message", "bartlett_long_run_covariance", "hac_bandwidth",
           "fixed_b_critical_value", "Covariance", "hac_sandwich", "white_covariance", "loss_weights",
           "cluster_covariance", "ClusterDesign", "Reliability", "reliability", "SPREAD_WARN",
           "across_and_within", "Agreement", "experiments_agree", "AGREEMENT_LEVEL", "MIN_HAC_BLOCKS"]

#: |correlation| above which two free parameters are reported as not told apart.
CORR_WARN = 0.95
#: Relative singular value below which a direction counts as not determined.
RCOND = 1e-8
#: The automatic bandwidth rules of :func:`hac_bandwidth`.
BANDWIDTH_RULES = ("auto", "andrews", "nw94", "rule")
#: ``bandwidth="auto"`` = this factor times the Andrews (1991) AR(1) plug-in
AUTO_FACTOR = 2.0


def null_space_message(Vt_null: np.ndarray, names: Sequence[str]) -> str:
    """The combinations of unknowns along the (near) null directions ``Vt_null`` (rows), in words.

    Parameters
    ----------
    Vt_null : ndarray, shape (k, p)
        Right singular vectors of the null directions of the unit-norm-column Jacobian, one per row.
    names : sequence of str
        Names of the ``p`` unknowns.

    Returns
    -------
    str
        One clause per direction, joined by ``"; "``: an unexcited column or a collinear combination.
    """
    parts = []
    for v in Vt_null:
        v = v / np.abs(v).max()
        v = v * np.sign(v[np.argmax(np.abs(v))])
        idx = [j for j in np.argsort(-np.abs(v)) if abs(v[j]) >= 0.05]
        terms = " ".join(
            f"{'+' if v[j] >= 0 else '-'} "
            + (names[j] if abs(abs(v[j]) - 1.0) < 5e-4 else f"{abs(v[j]):.3g}*{names[j]}")
            for j in idx
        )
        cols = ", ".join(names[j] for j in idx)
        if len(idx) == 1:
            parts.append(f"column {cols} is (numerically) zero: {cols} is not excited")
        else:
            parts.append(
                f"columns {cols} are (nearly) collinear: {terms.lstrip('+ ')} = 0 (columns scaled to unit norm)"
            )
    return "; ".join(parts)


def block_sigmas(r: np.ndarray, blocks: np.ndarray, used: np.ndarray, n_unknowns: int) -> np.ndarray:
    """Residual standard deviation of each block (``blocks`` are 0..B-1), with the degrees-of-freedom correction.

    ``sigma_b^2 = (sum of r^2 in b / used rows of b) * n_used / (n_used - n_unknowns)``.

    Parameters
    ----------
    r : ndarray, shape (n,)
        Residuals (unused rows 0) [units of each block's signal].
    blocks : ndarray of int, shape (n,)
        Block of each row, ``0 .. B-1``.
    used : ndarray of bool, shape (n,)
        Rows that count (not left out).
    n_unknowns : int
        Number of estimated unknowns (degrees of freedom removed).

    Returns
    -------
    ndarray, shape (B,)
        Standard deviation per block [units of its signal].
    """
    nb = int(blocks.max()) + 1 if blocks.size else 0
    ssr = np.bincount(blocks, weights=r * r, minlength=nb)
    cnt = np.bincount(blocks, weights=used.astype(float), minlength=nb)
    n_used = float(cnt.sum())
    dof = max(n_used - n_unknowns, 1.0)
    return np.sqrt(ssr / np.maximum(cnt, 1.0) * n_used / dof)


def covariance_from_jacobian(Jw: np.ndarray, names: Sequence[str]) -> tuple[np.ndarray, list[str]]:
    """``(Jw^T Jw)^+`` from the SVD of the column-scaled Jacobian, and messages on rank deficiency.

    Unknowns involved in a direction the data do not determine get NaN rows
    and columns.

    Parameters
    ----------
    Jw : ndarray, shape (n, p)
        Weighted Jacobian of the residuals with respect to the unknowns.
    names : sequence of str
        Names of the ``p`` unknowns, for the messages.

    Returns
    -------
    cov : ndarray, shape (p, p)
        The pseudo-inverse, in the unknowns' units squared over the residuals' (NaN rows and columns for
        undetermined unknowns).
    messages : list of str
        Rank deficiency (naming the collinear columns) or a condition number above 1e6.
    """
    nz = Jw.shape[1]
    if nz == 0:
        return np.zeros((0, 0)), []
    cn = np.linalg.norm(Jw, axis=0)
    msgs = []
    zero = cn == 0
    cn_safe = np.where(zero, 1.0, cn)
    _U, s, Vt = np.linalg.svd(Jw / cn_safe, full_matrices=False)
    tol = RCOND * (s[0] if s.size else 0.0)
    keep = s > tol
    if not np.all(keep) or np.any(zero):
        msgs.append("the Jacobian is rank deficient, the data do not determine every unknown: "
                    + null_space_message(Vt[~keep], names))
    else:
        cond = s[0] / s[-1]
        if cond > 1e6:
            msgs.append(f"the Jacobian is ill conditioned (condition number {cond:.2g} with unit-norm columns): "
                        "some combination of unknowns is poorly determined")
    inv = np.where(keep, 1.0 / np.where(keep, s, 1.0) ** 2, 0.0)
    cov = (Vt.T * inv) @ Vt
    if not np.all(keep):
        bad = np.any(np.abs(Vt[~keep]) > 1e-3, axis=0)
        cov[bad, :] = np.nan
        cov[:, bad] = np.nan
    return cov / np.outer(cn_safe, cn_safe), msgs


def correlation_messages(free: Sequence[str], values: np.ndarray, cov: np.ndarray, units: Sequence[str],
                         Jp: np.ndarray) -> list[str]:
    """Warnings for pairs of free parameters with ``|correlation| > CORR_WARN``.

    A poorly determined direction of the Jacobian correlates every parameter
    that has a component along it, even one that is determined to 1 %. The
    pairs of which neither member is determined to within 5 % are named as
    "cannot be told apart" (most collinear Jacobian columns ``Jp`` first), with
    their sum or difference when it is determined (to 5 %, and its variance,
    which cancels the pair's, above their rounding) and the units agree; when
    there is none, the most collinear pair is named as strongly correlated;
    the other correlated pairs are listed in one line.

    Parameters
    ----------
    free : sequence of str
        Names of the ``p`` free parameters.
    values : ndarray, shape (p,)
        Their estimates [their units].
    cov : ndarray, shape (p, p)
        Their covariance.
    units : sequence of str
        Their units (a sum or difference is given only for equal units).
    Jp : ndarray, shape (n, p)
        Jacobian columns of the free parameters (ranks the pairs by collinearity).

    Returns
    -------
    list of str
        The warnings, empty when no pair is correlated above :data:`CORR_WARN`.
    """
    npar = len(free)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    cand = [(i, j) for i in range(npar) for j in range(i + 1, npar)
            if math.isfinite(corr[i, j]) and abs(corr[i, j]) > CORR_WARN]
    if not cand:
        return []
    cn = np.linalg.norm(Jp, axis=0)
    cn[cn == 0] = 1.0
    Q = (Jp / cn).T @ (Jp / cn)
    # the relative rounding of a covariance computed from these columns: eps times their condition number squared
    sv = np.linalg.svd(Jp / cn, compute_uv=False)
    rounding = np.finfo(float).eps * (sv[0] / sv[-1]) ** 2 if sv.size and sv[-1] > 0 else math.inf
    msgs, others = [], []
    rel = sd / np.maximum(np.abs(values), 1e-300)
    ranked = sorted(cand, key=lambda p: -abs(Q[p[0], p[1]]))
    main = [p for p in ranked if rel[p[0]] > 0.05 and rel[p[1]] > 0.05]
    main_done = set()
    if not main:  # all determined to 5 %: name the most collinear pair, without alarm
        i, j = ranked[0]
        msgs.append(f"{free[i]} and {free[j]} are strongly correlated (correlation {corr[i, j]:+.3f}; stderr "
                    f"{free[i]} {sd[i]:.2g}, {free[j]} {sd[j]:.2g}): their errors move together")
        main_done = {ranked[0]}
    for (i, j) in ranked:
        c = corr[i, j]
        a, b = free[i], free[j]
        if (i, j) in main_done:
            continue
        if (i, j) in main:
            text = (f"{a} and {b} cannot be told apart by these data (correlation {c:+.3f}; "
                    f"stderr {a} {sd[i]:.2g}, {b} {sd[j]:.2g})")
            if units[i] == units[j]:
                sign = 1.0 if c < 0 else -1.0
                val = values[i] + sign * values[j]
                var = cov[i, i] + cov[j, j] + 2 * sign * cov[i, j]
                # the variance of the sum cancels the pair's; below their rounding (relative cond^2 eps of the
                # covariance) it is not known, and then neither is whether the sum is determined
                if var > rounding * (cov[i, i] + cov[j, j] + 2 * abs(cov[i, j])) and math.sqrt(var) <= 0.05 * abs(val):
                    text += f"; {a} {'+' if sign > 0 else '-'} {b} = {val:.4g} +- {math.sqrt(var):.2g} is determined"
            text += "; excite larger amplitudes or fix one of them"
            msgs.append(text)
        else:
            others.append(f"{a}/{b} {c:+.3f}")
    if others:
        msgs.append("also strongly correlated (|correlation| > 0.95): " + ", ".join(others))
    return msgs


def bartlett_long_run_covariance(H: np.ndarray, L: int) -> np.ndarray:
    """Bartlett-kernel long-run covariance sum_l (1 - |l|/(L+1)) Gamma_l (unnormalised).

    Uses the identity with overlapping window sums of length L+1 over the
    zero-padded series, which is exact and costs O(T p^2) for any L.

    Parameters
    ----------
    H : ndarray, shape (T, r)
        Series of scores, one sample per row.
    L : int
        Bandwidth: lags included (0: ``H^T H``).

    Returns
    -------
    ndarray, shape (r, r)
        The long-run covariance, not divided by ``T``.
    """
    T, r = H.shape
    if L == 0:
        return H.T @ H
    Hp = np.concatenate([np.zeros((L, r)), H, np.zeros((L, r))])
    C = np.concatenate([np.zeros((1, r)), np.cumsum(Hp, axis=0)])
    W = C[L + 1 :] - C[: -(L + 1)]
    return W.T @ W / (L + 1)


def hac_bandwidth(H: np.ndarray, rule: str = "auto") -> int:
    """Automatic Bartlett bandwidth [samples] for the scores ``H`` (T x r).

    Parameters
    ----------
    H : ndarray, shape (T, r)
        Score series (regressor times residual, summed per sample), one row
        per sample, in time order.
    rule : {"auto", "andrews", "nw94", "rule"}
        ``"auto"`` (default of :func:`iwp.ident.lsq.solve_least_squares`): twice the
        Andrews value, see there for why.  ``"andrews"``: Andrews (1991)
        AR(1) plug-in,
        ``L = 1.1447 (alpha(1) T)^(1/3)`` with ``alpha(1)`` from an AR(1)
        fit to each score column; adapts to strongly autocorrelated
        residuals.  ``"nw94"``: Newey-West (1994) nonparametric plug-in
        with pilot lag ``4 (T/100)^(2/9)``.  ``"rule"``: the fixed rule
        ``floor(4 (T/100)^(2/9))``.

    Returns
    -------
    int
        Number of lags, at most ``T // 4``. A score column whose squares overflow or that holds a non-finite
        value is left out of the plug-in (0 when none is left; ``T // 4`` when the plug-in itself overflows).
    """
    T = H.shape[0]
    cap = max(0, T // 4)
    if rule == "rule":
        return int(min(cap, math.floor(4.0 * (T / 100.0) ** (2.0 / 9.0))))
    if rule in ("andrews", "auto"):
        factor = AUTO_FACTOR if rule == "auto" else 1.0
        Ht = np.ascontiguousarray(H.T)  # one contiguous row per score column (fast reductions)
        x0, x1 = Ht[:, :-1], Ht[:, 1:]
        den = np.einsum("ji,ji->j", x0, x0)
        ok = np.isfinite(den) & (den > 0) & np.all(np.isfinite(Ht), axis=1)  # a column with a non-finite score
        if not np.any(ok):
            return 0
        if not np.all(ok):
            x0, x1, den = x0[ok], x1[ok], den[ok]
        rho = np.einsum("ji,ji->j", x0, x1) / den
        rho = np.clip(rho, -0.97, 0.97)
        e = x1 - x0 * rho[:, None]
        s2 = np.einsum("ji,ji->j", e, e) / max(1, T - 1)
        num = np.sum(4.0 * rho**2 * s2**2 / ((1 - rho) ** 6 * (1 + rho) ** 2))
        dnm = np.sum(s2**2 / (1 - rho) ** 4)
        alpha = num / dnm if dnm > 0 else 0.0
        L = factor * 1.1447 * (alpha * T) ** (1.0 / 3.0)
        return int(min(cap, math.ceil(L))) if math.isfinite(L) else cap
    if rule == "nw94":
        n = int(math.floor(4.0 * (T / 100.0) ** (2.0 / 9.0)))
        h = H.sum(axis=1)
        h = h - h.mean()
        gam = np.array([h[j:] @ h[: T - j] / T for j in range(n + 1)])
        s0 = gam[0] + 2.0 * gam[1:].sum()
        s1 = 2.0 * np.sum(np.arange(1, n + 1) * gam[1:])
        if s0 <= 0:
            return 0
        L = 1.1447 * ((s1 / s0) ** 2 * T) ** (1.0 / 3.0)
        return int(min(cap, math.floor(L)))
    raise InputError(f"bandwidth rule must be one of {', '.join(map(repr, BANDWIDTH_RULES))}, got {rule!r}")


def fixed_b_critical_value(b: float) -> float:
    """Two-sided 95 % fixed-b critical value of the Bartlett HAC t statistic.

    Kiefer & Vogelsang (2005), polynomial fit for the Bartlett kernel,
    ``b = bandwidth / T``; 1.96 at b = 0.

    Parameters
    ----------
    b : float
        Bandwidth over the number of samples, clipped to ``[0, 1]``.

    Returns
    -------
    float
        The critical value.
    """
    b = min(max(b, 0.0), 1.0)
    return 1.96 + 2.9694 * b + 0.4160 * b**2 - 0.5324 * b**3


@dataclass(frozen=True, eq=False)
class Covariance:
    """The covariance of a fit's unknowns (the optimiser's coordinates) and how it was formed.

    Attributes
    ----------
    matrix : ndarray, shape (p, p)
        NaN rows and columns for unknowns the data do not determine.
    method : str
        ``"white"``: ``(J_w^T J_w)^-1``, valid for residuals that are white
        within each block; ``"hac"``: the sandwich ``A^-1 M A^-1`` with
        ``A = J_w^T J_w`` and ``M`` the Bartlett (Newey-West) long-run
        covariance of the scores ``J_w^T r_w`` summed per sample, over lags
        within each experiment (experiments independent).
    critical : float
        Multiplier of the standard errors for 95 % intervals (Student t for
        ``"white"``, the fixed-b value of Kiefer and Vogelsang for ``"hac"``).
    bandwidth : int or None
        Bartlett lags [samples] of ``"hac"``.
    inflation : ndarray, shape (p,)
        Variance of each unknown over what white residuals would give
        (1: white; N: the residuals' correlation is worth N times fewer samples).
    messages : list of str
        Rank deficiency, ill conditioning.
    """

    matrix: np.ndarray
    method: str
    critical: float
    bandwidth: int | None
    inflation: np.ndarray
    messages: list[str]
    clusters: "ClusterDesign | None" = None

    def critical_of(self, contrast: np.ndarray) -> float:
        """The multiplier of the standard error of ``contrast @ z`` for its 95 % interval: :attr:`critical`, or
        over experiments Student's t with the contrast's Bell-McCaffrey degrees of freedom
        (:meth:`ClusterDesign.dof`)."""
        if self.clusters is None:
            return self.critical
        k = self.clusters.dof(np.asarray(contrast, dtype=float))
        return float(stats.t.ppf(0.975, k)) if math.isfinite(k) and k > 0 else self.critical


@dataclass(frozen=True)
class ClusterDesign:
    """What the degrees of freedom of the spread across experiments depend on (Bell and McCaffrey, 2002).

    The cluster-robust variance of a contrast ``l @ z`` is a sum of ``G``
    squared adjusted scores, one per experiment. When the experiments inform
    ``l`` unequally (a stuck-wheel swing says nothing of the input gain
    ``p3``), fewer than ``G - 1`` of them carry its variance, and Student's
    t with ``G - 1`` degrees of freedom gives too short an interval. Under
    the working model of independent residuals of equal variance, the
    variance estimate is a weighted sum of chi-squares with weights the
    eigenvalues of ``M = W^T (I - H) W`` (``W``: each experiment's rows of
    ``A_s J_s A l``, with ``A_s = (I - H_ss)^-1/2`` and ``H`` the hat
    matrix); Satterthwaite's degrees of freedom are ``tr(M)^2 / tr(M^2)``:
    at most ``G - 1``, and ``G - 1`` when every experiment informs ``l``
    alike.

    Attributes
    ----------
    bread : ndarray, shape (p, p)
        ``A = (J_w^T J_w)^-1`` (0 where undetermined).
    scores : ndarray, shape (G, p, p)
        Each experiment's ``J_s^T A_s J_s``.
    squares : ndarray, shape (G, p, p)
        Each experiment's ``J_s^T A_s^2 J_s``.
    """

    bread: np.ndarray
    scores: np.ndarray
    squares: np.ndarray

    def dof(self, contrast: np.ndarray) -> float:
        """Satterthwaite's degrees of freedom of the variance of ``contrast @ z`` (NaN for a zero contrast)."""
        a = self.bread @ contrast
        C = self.scores @ a  # J^T w_s, w_s = experiment s's rows of A_s J_s a
        M = np.diag(self.squares @ a @ a) - C @ self.bread @ C.T
        tr, tr2 = float(np.trace(M)), float(np.sum(M * M))
        if not (tr > 0 and tr2 > 0):
            return math.nan
        return min(tr * tr / tr2, float(self.scores.shape[0] - 1))


def _leverage_adjustment(Js: np.ndarray, bread: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One experiment's ``(I - H_ss)^-1/2 = I + U diag(f) U^T`` and ``(I - H_ss)^-1 = I + U diag(g) U^T`` with
    ``H_ss = J_s A J_s^T`` (rank at most p: from a thin QR of ``J_s``); returns ``(U, f, g)``. Directions that
    the experiment alone determines (leverage 1: its initial state) are left as they are: its residuals are
    orthogonal to them."""
    Q, R = np.linalg.qr(Js)
    lam, V = np.linalg.eigh(R @ bread @ R.T)
    lev = np.clip(lam, 0.0, None)
    keep = lev < 1.0 - 1e-9
    left = np.where(keep, 1.0 - lev, 1.0)
    return Q @ V, np.where(keep, 1.0 / np.sqrt(left) - 1.0, 0.0), np.where(keep, 1.0 / left - 1.0, 0.0)


def hac_sandwich(Jw: np.ndarray, rw: np.ndarray, groups: np.ndarray, times: np.ndarray, names: Sequence[str],
                 dof: int, bandwidth: float | None = None) -> Covariance:
    """The heteroscedasticity-and-autocorrelation-consistent sandwich covariance of a nonlinear least-squares fit.

    Parameters
    ----------
    Jw, rw : ndarray
        Jacobian (rows: residuals; columns: unknowns) and residuals of the
        criterion the estimator minimised, with its own weights (the bread
        ``J^T J`` is its curvature, the meat the long-run covariance of its
        scores).
    groups : ndarray of int
        The experiment of each row: lags never cross experiments.
    times : ndarray of int
        The sample of each row within its experiment: rows of one sample
        (several outputs) form one score.
    names : sequence of str
        The unknowns (for the messages).
    dof : int
        Residual degrees of freedom (the small-sample factor ``n / dof``).

    Notes
    -----
    Under model-structure error the residuals are correlated over long
    times (a phase or amplitude error of the simulation); the sandwich is
    then the covariance of the estimate around the best value in the model
    family (the pseudo-true value), not around the truth, whose difference
    (the bias) no standard error shows.
    """
    white, msgs = covariance_from_jacobian(Jw, names)
    p = Jw.shape[1]
    if p == 0:
        return Covariance(white, "hac", math.nan, None, np.zeros(0), msgs)
    H_groups = _sample_scores(Jw, rw, groups, times)
    T = min(H.shape[0] for H in H_groups)
    L = hac_lags(H_groups, bandwidth)
    M = sum(bartlett_long_run_covariance(H, L) for H in H_groups)
    n = Jw.shape[0]
    A = np.nan_to_num(white)
    cov = A @ M @ A * (n / max(dof, 1))
    cov = 0.5 * (cov + cov.T)  # symmetric to rounding
    bad = np.isnan(np.diag(white))
    cov[bad, :] = np.nan
    cov[:, bad] = np.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        inflation = np.diag(cov) / np.diag(white) / max(float(rw @ rw) / max(dof, 1), 1e-300)
    return Covariance(cov, "hac", fixed_b_critical_value(L / max(T, 1)), int(L), inflation, msgs)


def _sample_scores(Jw: np.ndarray, rw: np.ndarray, groups: np.ndarray, times: np.ndarray) -> list[np.ndarray]:
    """Per experiment (in the order of ``np.unique(groups)``), the scores ``J^T r`` summed per sample (T_g x p)."""
    scores = Jw * rw[:, None]
    out = []
    for g in np.unique(groups):
        rows = groups == g
        t = times[rows]
        H = np.zeros((int(t.max() - t.min()) + 1, Jw.shape[1]))
        np.add.at(H, t - t.min(), scores[rows])
        out.append(H)
    return out


def hac_lags(H_groups: Sequence[np.ndarray], bandwidth: float | None = None) -> int:
    """The Bartlett lags of :func:`hac_sandwich` for the experiments' sample scores: the largest automatic bandwidth
    (:func:`hac_bandwidth`) of any experiment, at most half the shortest; or a fraction ``bandwidth`` of it."""
    T = min(H.shape[0] for H in H_groups)
    if bandwidth is None:
        return int(min(max(hac_bandwidth(H, "auto") for H in H_groups), max(T // 2, 0)))
    return int(min(max(round(bandwidth * T), 0), T - 1))  # a fraction b of the shortest experiment (fixed-b)


#: the experiments of a fit disagree beyond their noise when :func:`experiments_agree`'s p-value is below this
AGREEMENT_LEVEL = 0.01


@dataclass(frozen=True)
class Agreement:
    """Whether the experiments of a fit agree on the model's parameters within their noise (:func:`experiments_agree`).

    Attributes
    ----------
    statistic : float
        The heterogeneity statistic ``Q``.
    dof : int
        Its degrees of freedom: the directions the experiments determine, less those the joint fit determines.
    p_value : float
        ``P(chi2(dof) > Q)``: small when the experiments' own best parameters differ beyond their noise.
    """

    statistic: float
    dof: int
    p_value: float

    @property
    def agree(self) -> bool:
        return not self.p_value < AGREEMENT_LEVEL

    def describe(self) -> str:
        return f"Q = {self.statistic:.3g} on {self.dof} dof, p = {self.p_value:.2g}"

    def to_dict(self) -> dict:
        return {"statistic": self.statistic, "dof": self.dof, "p_value": self.p_value}


def _whitener(M: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
    """``W`` with ``W M W^T = I`` on the range of the symmetric ``M`` (rows: its well-determined directions)."""
    lam, V = np.linalg.eigh(0.5 * (M + M.T))
    keep = lam > rtol * max(float(lam.max()), 0.0) if lam.size else np.zeros(0, dtype=bool)
    return (V[:, keep] / np.sqrt(lam[keep])).T


def experiments_agree(Jw: np.ndarray, rw: np.ndarray, groups: np.ndarray, times: np.ndarray,
                      shared: Sequence[int], lags: int, dof: int) -> Agreement | None:
    """Do the experiments of a fit agree on its shared parameters within the noise each one's residuals show?

    Each experiment ``g``'s best shared parameters differ from the joint fit's, to first order, by
    ``A_g^-1 s_g``, with ``s_g`` its score ``J_g^T r_g`` and ``A_g = J_g^T J_g``, its own unknowns (initial
    state, sensor offsets) profiled out; the noise of ``s_g`` is ``M_g``, the Bartlett long-run covariance of its
    sample scores with the fit's HAC lags (the residuals' own correlation, whatever its spectrum). The statistic

        Q = min over d of sum_g (s_g - A_g d)^T M_g^+ (s_g - A_g d)

    (a Hansen-Sargan test of one parameter vector for all experiments) is chi-square with
    ``sum_g rank M_g - rank(sum_g A_g M_g^+ A_g)`` degrees of freedom when the model is right (the experiments'
    differences are their noise), and large when the model misses something that the experiments excite
    differently. Unlike the ratio of the spread across experiments to the noise within them (three experiments
    give that spread two degrees of freedom: it exceeded 6 on 3 of 10 correct fits, issue 50), its level holds.

    Parameters
    ----------
    Jw, rw : ndarray
        Weighted Jacobian (rows: residuals; columns: the unknowns) and residuals at the optimum.
    groups, times : ndarray of int
        The experiment of each row and its sample within the experiment.
    shared : sequence of int
        The columns of the unknowns common to all experiments (the model's parameters).
    lags : int
        Bartlett lags of the noise of each experiment's score.
    dof : int
        Residual degrees of freedom of the fit (the small-sample factor ``n / dof`` of :func:`hac_sandwich`).

    Returns
    -------
    Agreement or None
        None with fewer than two experiments or no shared unknown.
    """
    shared = list(shared)
    labels = np.unique(groups)
    if labels.size < 2 or not shared or Jw.size == 0:
        return None
    factor = Jw.shape[0] / max(dof, 1)
    H_groups = _sample_scores(Jw, rw, groups, times)
    terms = []
    ranks = 0
    for g, H in zip(labels, H_groups):
        rows = groups == g
        Jg = Jw[rows]
        own = [j for j in range(Jw.shape[1]) if j not in shared and np.any(Jg[:, j] != 0.0)]
        idx = shared + own
        A = Jg[:, idx].T @ Jg[:, idx]
        s = Jg[:, idx].T @ rw[rows]
        M = bartlett_long_run_covariance(H[:, idx], lags) * factor
        k = len(shared)
        if own:  # profile out the experiment's own unknowns: their score is zero at the optimum
            K = A[:k, k:] @ np.linalg.pinv(A[k:, k:])
            P = np.hstack([np.eye(k), -K])
            s, A, M = P @ s, A[:k, :k] - K @ A[k:, :k], P @ M @ P.T
        W = _whitener(M)
        ranks += W.shape[0]
        terms.append((W @ s, W @ A))
    B = sum(Wa.T @ Wa for _, Wa in terms)
    c = sum(Wa.T @ ws for ws, Wa in terms)
    lam, V = np.linalg.eigh(0.5 * (B + B.T))
    keep = lam > 1e-9 * max(float(lam.max()), 0.0)
    d = V[:, keep] @ ((V[:, keep].T @ c) / lam[keep])
    Q = float(sum(float(np.sum((ws - Wa @ d) ** 2)) for ws, Wa in terms))
    k_dof = ranks - int(np.count_nonzero(keep))
    if k_dof <= 0:
        return None
    return Agreement(Q, k_dof, float(stats.chi2.sf(Q, k_dof)))


def white_covariance(J: np.ndarray, row_sigma: np.ndarray, names: Sequence[str], dof: int) -> Covariance:
    """The covariance for residuals white within each block: ``A^-1 J^T diag(s^2) J A^-1``, ``A = J^T J``.

    ``J`` is the Jacobian of the residuals the estimator minimised (their own
    weights) and ``row_sigma`` each row's residual standard deviation (its
    block's, :func:`block_sigmas`); with rows weighted by their noise
    (``row_sigma`` 1) it is the textbook ``(J^T J)^-1``.

    Parameters
    ----------
    J : ndarray, shape (n, p)
        Jacobian of the minimised residuals.
    row_sigma : ndarray, shape (n,)
        Standard deviation of each row's residual.
    names : sequence of str
        Names of the ``p`` unknowns, for the messages.
    dof : int
        Degrees of freedom of the Student t quantile (at least 1 is used).

    Returns
    -------
    Covariance
        Method ``"white"``, critical value the 97.5 % Student t quantile.
    """
    A, msgs = covariance_from_jacobian(J, names)
    Js = J * row_sigma[:, None]
    An = np.nan_to_num(A)
    cov = An @ (Js.T @ Js) @ An
    cov = 0.5 * (cov + cov.T)
    bad = np.isnan(np.diag(A))
    cov[bad, :] = np.nan
    cov[:, bad] = np.nan
    return Covariance(cov, "white", float(stats.t.ppf(0.975, max(dof, 1))), None, np.ones(J.shape[1]), msgs)


#: derivatives rho'(z) of the robust losses of scipy's least_squares, ``z = (r / f_scale)^2``
_LOSS_DERIVATIVES = {
    "linear": lambda z: np.ones_like(z),
    "soft_l1": lambda z: 1.0 / np.sqrt(1.0 + z),
    "huber": lambda z: np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1.0))),
    "cauchy": lambda z: 1.0 / (1.0 + z),
    "arctan": lambda z: 1.0 / (1.0 + z * z),
}


def loss_weights(loss: str, r: np.ndarray, f_scale: float) -> np.ndarray:
    """Iteratively-reweighted least-squares weights ``rho'((r/f)^2)`` of a robust loss at its optimum (1: linear).

    Parameters
    ----------
    loss : {"linear", "soft_l1", "huber", "cauchy", "arctan"}
        Loss of :func:`scipy.optimize.least_squares`.
    r : ndarray
        Residuals at the optimum.
    f_scale : float
        Soft margin of the loss, in the residuals' unit.

    Returns
    -------
    ndarray
        The weights, of ``r``'s shape, in ``(0, 1]``.
    """
    return _LOSS_DERIVATIVES[loss]((r / f_scale) ** 2)


def cluster_covariance(Jw: np.ndarray, rw: np.ndarray, groups: np.ndarray, names: Sequence[str]) -> Covariance:
    """The cluster-robust sandwich over experiments: each experiment's summed score is one independent draw.

    Valid whatever the correlation of the residuals within an experiment (a
    simulation's error under model-structure error lasts as long as the
    pendulum's damping time). Bell and McCaffrey's bias-reduced form (CR2):
    each experiment's residuals are scaled by ``(I - H_ss)^-1/2`` before
    they enter its score, which undoes what the fit drew them towards (an
    experiment that holds most of a parameter's information has small
    residuals along it; the plain sandwich then under-covers), and is
    unbiased when the residuals are independent with equal variance. Its
    95 % intervals use Student's t with each parameter's own degrees of
    freedom (:class:`ClusterDesign`, at most ``G - 1`` for ``G``
    experiments), so that few experiments, or few that inform a parameter,
    give wide intervals. Needs ``G >= 2``.

    Parameters
    ----------
    Jw : ndarray, shape (n, p)
        Weighted Jacobian of the residuals.
    rw : ndarray, shape (n,)
        Weighted residuals.
    groups : ndarray, shape (n,)
        Experiment of each row.
    names : sequence of str
        Names of the ``p`` unknowns, for the messages.

    Returns
    -------
    Covariance
        Method ``"experiments"``, :attr:`~Covariance.critical` the t quantile
        with ``G - 1`` dof and :meth:`~Covariance.critical_of` each
        contrast's; all NaN when there are fewer than 2 experiments or no
        unknowns.
    """
    white, msgs = covariance_from_jacobian(Jw, names)
    p = Jw.shape[1]
    labels = np.unique(groups)
    G = labels.size
    if p == 0 or G < 2:
        return Covariance(np.full((p, p), np.nan), "experiments", math.nan, None, np.full(p, np.nan), msgs)
    A = np.nan_to_num(white)
    g, P, S = np.zeros((G, p)), np.zeros((G, p, p)), np.zeros((G, p, p))
    for k, lab in enumerate(labels):
        Js, rs = Jw[groups == lab], rw[groups == lab]
        U, f, h = _leverage_adjustment(Js, A)
        JU, JtJ = Js.T @ U, Js.T @ Js
        g[k] = Js.T @ rs + JU @ (f * (U.T @ rs))  # J_s^T A_s r_s
        P[k] = JtJ + (JU * f) @ JU.T
        S[k] = JtJ + (JU * h) @ JU.T
    cov = A @ (g.T @ g) @ A
    cov = 0.5 * (cov + cov.T)
    bad = np.isnan(np.diag(white))
    cov[bad, :] = np.nan
    cov[:, bad] = np.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        inflation = np.diag(cov) / np.diag(white)
    return Covariance(cov, "experiments", float(stats.t.ppf(0.975, G - 1)), None, inflation, msgs,
                      ClusterDesign(A, P, S))


#: With experiments too short for :func:`experiments_agree` (fewer than :data:`MIN_HAC_BLOCKS` blocks of the HAC
#: lags each), they disagree beyond their noise when the spread across them is this many times (in variance) what
#: the correlation within each explains (with long experiments this ratio exceeded 6 on 3 of 10 correct fits, for
#: the bias-reduced spread over three experiments has two degrees of freedom: the test decides there).
SPREAD_WARN = 6.0
#: the fewest blocks of the HAC lags each experiment must hold for the noise within the experiments to set a fit's
#: intervals and its agreement test (else the spread across them does, Student t with at most G - 1 dof). Measured
#: on three experiments with AR(1) noise, coverage of the 95 % intervals from the noise within them: 82-84 % with 13
#: blocks (8 s at 10 ms, 62 lags), 87.5 % with 19, 92 % with 31 (tests/test_uncertainty.py's set-up at 16 and 30 s),
#: 92.5 % with 136 (benchmarks/independent_study.py): the HAC estimate of a short experiment's noise is too low
MIN_HAC_BLOCKS = 25


@dataclass(frozen=True)
class Reliability:
    """How far a fit's intervals can be trusted, said beside them.

    Attributes
    ----------
    method : str
        The covariance used (:class:`Covariance`).
    experiments : int
        Independent experiments in the fit.
    spread : float or None
        With several experiments: the largest ratio over the model's
        parameters of the variance across experiments to the variance that the
        residuals' correlation within each explains (1: the logs agree within
        their noise). None with one experiment.
    structure_error : bool
        The data show model-structure error (the experiments disagree beyond their noise).
    reliable : bool
        The intervals can be read as they are.
    notes : list of str
        Why, in words (one line each).
    """

    method: str
    experiments: int
    spread: float | None
    structure_error: bool
    reliable: bool
    notes: list[str]

    def describe(self) -> str:
        """One line for a summary: the method, and what the intervals hold for."""
        return f"intervals: {self.method}" + ("" if not self.notes else "; " + "; ".join(self.notes))

    def to_dict(self) -> dict:
        return {"method": self.method, "experiments": self.experiments, "spread": self.spread,
                "structure_error": self.structure_error, "reliable": self.reliable, "notes": list(self.notes)}


def reliability(chosen: Covariance, experiments: int, model_columns: Sequence[int], length: int, *,
                within: Covariance | None = None, across: Covariance | None = None,
                agreement: Agreement | None = None, blocks: int | None = None) -> Reliability:
    """The verdict on a fit's intervals from the covariance used and, with several experiments, their agreement.

    Parameters
    ----------
    chosen : Covariance
        The covariance the intervals use.
    experiments : int
        Independent experiments in the fit.
    model_columns : sequence of int
        Indices of the unknowns that are model parameters.
    length : int
        Samples of the shortest experiment.
    within, across : Covariance, optional
        The sandwich within experiments and the spread across them (their ratio is reported as ``spread``).
    agreement : Agreement, optional
        :func:`experiments_agree`: the experiments disagree beyond their noise (model-structure error) when its
        p-value is below :data:`AGREEMENT_LEVEL`.
    blocks : int, optional
        Blocks of the HAC lags in the shortest experiment (said when the spread across experiments is used for
        want of them).

    Returns
    -------
    Reliability
        Method, spread, structure error, whether the intervals are reliable, and notes.
    """
    notes: list[str] = []
    cols = list(model_columns)
    agreed = "" if agreement is None else f" ({agreement.describe()})"
    if chosen.method == "experiments":
        method = (f"the spread across {experiments} experiments (bias-reduced; Student t with each parameter's "
                  f"Bell-McCaffrey dof, at most {experiments - 1})")
    elif chosen.method == "hac" and experiments > 1:
        method = (f"HAC sandwich within {experiments} experiments (Bartlett, {chosen.bandwidth} lags), which "
                  f"agree within their noise{agreed}")
    elif chosen.method == "hac":
        method = f"HAC sandwich (Bartlett, {chosen.bandwidth} lags)"
    elif chosen.method == "white":
        method = "white residuals"
    else:
        return Reliability("none", experiments, None, False, False, ["no uncertainty estimated"])
    spread = None
    if within is not None and across is not None and cols:
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.diag(across.matrix)[cols] / np.diag(within.matrix)[cols]
        ratio = ratio[np.isfinite(ratio)]
        spread = float(np.max(ratio)) if ratio.size else None
    structure = agreement is not None and not agreement.agree
    few = blocks is not None and blocks < MIN_HAC_BLOCKS
    if not structure and few and spread is not None and spread > SPREAD_WARN:
        # too few blocks for the test's noise within the experiments: the spread across them, many times that
        # noise, says it (with the test's own noise, a missing Coulomb friction of the pendulum went unseen at
        # p = 0.028 with 10 blocks an experiment, spread 20)
        structure = True
        agreed = f" (the spread across them {math.sqrt(spread):.1f} times the noise within them)"
    if structure:
        notes.append(f"model-structure error: the experiments disagree beyond their noise{agreed}, so the intervals "
                     "hold for the best model of this family on such experiments, not for the physical values (the "
                     f"model's bias is not in them); they are the spread across the {experiments} experiments, "
                     f"Student t with at most {experiments - 1} dof")
    reliable = not structure
    if experiments < 2:
        if chosen.method == "hac" and chosen.bandwidth is not None and chosen.bandwidth > length // 10:
            reliable = False
            notes.append(f"unreliable: the residuals are correlated over {chosen.bandwidth} of {length} samples, so "
                         "the one experiment holds few independent samples; fit several experiments")
        else:
            notes.append("one experiment: the model's structure cannot be checked; if the model misses something, "
                         "its error outlasts the log and these intervals are too narrow (fit several experiments)")
            reliable = False
    elif chosen.method == "experiments" and experiments < 4 and not structure:
        short = ("" if blocks is None or within is None else
                 f"; each holds only {blocks} blocks of the residuals' correlation ({within.bandwidth} lags), too few "
                 "to estimate the noise within it")
        notes.append(f"only {experiments} experiments: wide intervals (Student t with at most {experiments - 1} dof)"
                     + short)
    return Reliability(method, experiments, spread, structure, reliable, notes)


def across_and_within(across: Covariance, within: Covariance) -> Covariance:
    """The covariance of a fit over several experiments: per unknown the larger variance of the two, with the
    correlations of the one within experiments.

    The spread across ``G`` experiments (:func:`cluster_covariance`) holds
    whatever the residuals' correlation within each, but it has rank at most
    ``G - 1``: with fewer experiments than unknowns it determines no joint
    distribution (a draw of the parameters would move along ``G - 1``
    directions only). The sandwich within experiments (:func:`hac_sandwich`)
    has full rank but misses what lasts longer than an experiment and, in
    short experiments, what lasts longer than its bandwidth. This one takes
    the variances of the first and the correlations of the second:
    ``C = D C_within D`` with ``D_jj = sqrt(C_across,jj / C_within,jj)``, and
    the Student t quantiles of the spread across experiments -- the
    t-interval of ``G`` independent estimates, whose coverage does not depend
    on how the residuals are correlated within an experiment (measured: 97.5 %
    with three 8 s experiments where the sandwich within them gave 81 %,
    tests/test_uncertainty.py; 95 % with the plain sandwich and ``G - 1`` dof,
    which under-covers parameters that the experiments inform unequally).

    Parameters
    ----------
    across : Covariance
        The spread across experiments (:func:`cluster_covariance`).
    within : Covariance
        The sandwich within experiments, of the same unknowns.

    Returns
    -------
    Covariance
        Method ``"experiments"``, ``across``'s critical value, ``within``'s bandwidth and messages.
    """
    a, w = np.diag(across.matrix), np.diag(within.matrix)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.sqrt(np.where(np.isfinite(a / w) & (w > 0), a / w, 1.0))
    cov = within.matrix * np.outer(d, d)
    return Covariance(cov, "experiments", across.critical, within.bandwidth, within.inflation * d * d,
                      within.messages, across.clusters)

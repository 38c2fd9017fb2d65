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
from typing import Sequence

import numpy as np

__all__ = ["CORR_WARN", "RCOND", "block_sigmas", "covariance_from_jacobian", "correlation_messages",
           "null_space_message"]

#: |correlation| above which two free parameters are reported as not told apart.
CORR_WARN = 0.95
#: Relative singular value below which a direction counts as not determined.
RCOND = 1e-8


def null_space_message(Vt_null: np.ndarray, names: Sequence[str]) -> str:
    """The combinations of unknowns along the (near) null directions ``Vt_null`` (rows), in words."""
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
    their sum or difference when it is determined and the units agree; when
    there is none, the most collinear pair is named as strongly correlated;
    the other correlated pairs are listed in one line.
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
                s_comb = math.sqrt(max(cov[i, i] + cov[j, j] + 2 * sign * cov[i, j], 0.0))
                text += f"; {a} {'+' if sign > 0 else '-'} {b} = {val:.4g} +- {s_comb:.2g} is determined"
            text += "; excite larger amplitudes or fix one of them"
            msgs.append(text)
        else:
            others.append(f"{a}/{b} {c:+.3f}")
    if others:
        msgs.append("also strongly correlated (|correlation| > 0.95): " + ", ".join(others))
    return msgs

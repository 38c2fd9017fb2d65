"""Covariance of the estimates from the measurement noise, propagated through the differentiator.

The residuals of differentiated, filtered encoder data are the encoder noise
(quantisation and sensor noise) passed through known linear maps; see
:func:`noise_covariance`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.linalg import solve_triangular

from ..jit import jit
from .differentiate import Differentiator
from .lsq import LeastSquaresResult, tsqr_augmented
from .setups import Regression, Setup
from .signals import Signals, acceleration_noise_gain, apply_K

__all__ = ["NoiseCovariance", "noise_covariance", "block_weights", "row_weights", "TERMS"]

# ---------------------------------------------------------------------------
# covariance from the measurement noise, propagated through the differentiator
# ---------------------------------------------------------------------------
# Terms of the model (9) as functions of the measured signals (see prepare_signals):
# T1 = sin q1, T2 = |cos q1| q3, T3 = q3^3, T4 = q3 (channel q1) and T5 = q4 (channel q2).
# beta[row][Ti]: coefficient of Ti in the row's model  dq/dt = sum beta_i T_i + (input terms)
TERMS = ("T1", "T2", "T3", "T4", "T5")
#: rows per block of the tall matrix products in the noise covariance
_MATMUL_CHUNK = 512


@jit(exact=True)
def _noise_adjoints(filtered_q, p, chans, beta, terms, Ts):  # pragma: no cover - compiled
    """The adjoint maps ``A_1``, ``A_2`` of one file (see :func:`noise_covariance`), shape ``(2, p, n)``.

    ``filtered_q``: ``K`` applied to the weighted ``Q`` columns of each block, one
    row per column (blocks one after the other, ``p`` rows each). ``terms``:
    rows ``cos q1``, ``c2 = -sgn(cos q1) sin(q1) q3``, ``|cos q1|`` and
    ``3 q3^2`` of the file's samples. For each block ``b`` with noise channel
    ``chans[b]`` and term coefficients ``beta[b]`` (T1..T5), ``sv = S K Q_b``
    (triangle average) and ``acc = D2 K Q_b / Ts^2`` (``Ts`` [s]); then
    ``A_1 = [target] acc - (beta1 cos q1 + beta2 c2) sv - (P D1)^T g``,
    ``g = (beta2 |cos q1| + beta3 3 q3^2 + beta4) sv`` and
    ``A_2 = [target] acc - (P D1)^T (beta5 sv)``, with
    ``(P D1)^T y = -D1 P y`` (stencils with zeros outside the file).
    """
    n = filtered_q.shape[1]
    nb = chans.shape[0]
    inv_ts2 = 1.0 / (Ts * Ts)
    A = np.zeros((2, p, n))
    A1 = A[0]
    A2 = A[1]
    cos1 = terms[0]
    c2 = terms[1]
    abscos = terms[2]
    v3 = terms[3]
    g = np.zeros((p, n + 4))  # padded by 2 zeros at both ends for the stencils
    h = np.zeros((p, n + 4))
    for b in range(nb):
        tgt1 = chans[b] == 1
        b0, b1, b2, b3, b4 = beta[b, 0], beta[b, 1], beta[b, 2], beta[b, 3], beta[b, 4]
        for j in range(p):
            row = filtered_q[b * p + j]
            for t in range(n):
                x0 = row[t]
                xm = row[t - 1] if t > 0 else 0.0
                xp = row[t + 1] if t < n - 1 else 0.0
                d2 = xp - 2.0 * x0 + xm
                sv = x0 + d2 / 12.0
                acc = d2 * inv_ts2
                if tgt1:
                    A1[j, t] += acc - (b0 * cos1[t] + b1 * c2[t]) * sv
                else:
                    A2[j, t] += acc
                    A1[j, t] -= (b0 * cos1[t] + b1 * c2[t]) * sv
                g[j, t + 2] += (b1 * abscos[t] + b2 * v3[t] + b3) * sv
                h[j, t + 2] += b4 * sv
    half = 0.5 / Ts
    for j in range(p):
        gj = g[j]
        hj = h[j]
        for t in range(n):
            # (P D1)^T y at t = -(z[t+1] - z[t-1]) / (2 Ts), z = y - (second difference of y) / 6
            i = t + 2
            zgm = gj[i - 1] - (gj[i] - 2.0 * gj[i - 1] + gj[i - 2]) / 6.0
            zgp = gj[i + 1] - (gj[i + 2] - 2.0 * gj[i + 1] + gj[i]) / 6.0
            zhm = hj[i - 1] - (hj[i] - 2.0 * hj[i - 1] + hj[i - 2]) / 6.0
            zhp = hj[i + 1] - (hj[i + 2] - 2.0 * hj[i + 1] + hj[i]) / 6.0
            A1[j, t] -= (zgm - zgp) * half
            A2[j, t] -= (zhm - zhp) * half
    return A


@jit(exact=True)
def _noise_gram(A, s1, s2):  # pragma: no cover - compiled
    """``s1 A_1^T A_1 + s2 A_2^T A_2`` (``A`` from :func:`_noise_adjoints`; ``s1``, ``s2`` the encoders' noise
    variances [rad^2])."""
    p = A.shape[1]
    n = A.shape[2]
    A1 = A[0]
    A2 = A[1]
    M = np.zeros((p, p))
    for i in range(p):
        for j in range(i, p):
            acc1 = 0.0
            acc2 = 0.0
            ai = A1[i]
            aj = A1[j]
            ci = A2[i]
            cj = A2[j]
            for t in range(n):
                acc1 += ai[t] * aj[t]
                acc2 += ci[t] * cj[t]
            M[i, j] = s1 * acc1 + s2 * acc2
            M[j, i] = M[i, j]
    return M


@dataclass(frozen=True, eq=False)
class NoiseCovariance:
    """Covariance of the estimates from the encoder noise (:func:`noise_covariance`).

    Attributes
    ----------
    covariance : ndarray, shape (p, p)
        Covariance of the estimates, in the units of the parameters squared.
    noise_std : dict
        White-equivalent position noise per encoder, ``"q1"``, ``"q2"`` [rad]
        (from the fourth difference of the positions), and
        ``"from_residuals"``: ``{"q1": ..., "q2": ...}`` [rad], the level the
        residuals of each row would need if they were measurement noise only.
    """

    covariance: np.ndarray
    noise_std: dict[str, Any]


@dataclass(frozen=True, eq=False)
class _WeightedFactor:
    """The column-scaled triangular factor of the weighted regressor: ``(W^(1/2) Phi) / D = Q R``.

    ``Rinv = R^-1``, ``Dn`` the column norms, ``G[label]`` the map of a
    block's rows of ``Phi`` to their rows of ``W^(1/2) Q``, and
    ``block_rows[label]`` the block's rows.
    """

    Rinv: np.ndarray
    Dn: np.ndarray
    G: dict[str, np.ndarray]
    block_rows: dict[str, slice]


@dataclass(frozen=True, eq=False)
class _RowNoise:
    """The rows' noise model: encoder channel (1 or 2) and term coefficients ``beta`` (T1..T5) per block."""

    labels: list[str]
    chans: np.ndarray
    beta: np.ndarray


def noise_covariance(setup: Setup, sig: Signals, d: Differentiator, reg: Regression, res: LeastSquaresResult,
                     pend: Mapping[str, float] | None) -> NoiseCovariance | None:
    """Covariance of the estimates caused by white measurement noise on q1 and q2.

    The residual of each row is, to first order in the position noise
    ``w_c`` (quantisation and sensor noise of encoder ``c``), ``r = J_c w_c``
    with ``J_c`` the known linear map of the differentiator and the model:
    the target's ``K D2 / Ts^2`` minus the noise that reaches the
    regressor terms (e.g. ``p1 K S cos(q1) w_1``; it partly cancels the
    target's, which is why plain formulas overstate the spread of ``p1``).
    With ``Xs = Q R`` the weighted, column-scaled regressor, the estimate
    moves by ``R^-1 Q^T W^(1/2) J w``; its covariance is
    ``R^-1 (sum_c sigma_c^2 A_c^T A_c) R^-T`` with ``A_c = J_c^T W^(1/2) Q``,
    computed with the adjoint (time-reversed) filters. ``sigma_c^2`` is
    estimated from the residuals of the row that measures encoder ``c``:
    ``||r||^2 / ((n - p) ||f||^2)``.

    Returns None when it does not apply (rank deficiency, method
    ``"savgol_direct"``, nonlinear mode ``"filtered-states"``).

    Parameters
    ----------
    setup : Setup
        The identification set-up (its rows' noise coefficients, ``row_betas``).
    sig : Signals
        Stacked, filtered signals of the set-up's files.
    d : Differentiator
        The filter the signals were differentiated with.
    reg : Regression
        The set-up's least-squares problem (13): regressor ``Phi`` (one
        block of ``sig.n`` rows per label), ``blocks``, ``labels``, and in
        ``details["p2_known"]`` a known ``p2`` [1/s] (0 if none).
    res : LeastSquaresResult
        The least-squares solution (its values are the estimates the rows' noise coefficients use).
    pend : mapping of str to float or None
        Known pendulum parameters (two-step set-up), else None.

    Returns
    -------
    NoiseCovariance or None
        The covariance, shape ``(p, p)``, and the noise levels; None where it does not apply.
    """
    if not res.success or d.method == "savgol_direct" or any(f["v1"] is None for f in sig.files):
        return None
    factor = _weighted_factor(reg, res, sig.n)
    if factor is None:
        return None
    vals = {**reg.details.get("held", {}), **{nm: float(res.values[j]) for j, nm in enumerate(res.names)}}
    p2_known = float(reg.details.get("p2_known", {}).get("value", 0.0))
    betas = setup.row_betas(vals, pend, p2_known)
    rows = _RowNoise(labels=list(betas), chans=np.array([betas[lab][0] for lab in betas], dtype=np.int64),
                     beta=np.array([[betas[lab][1].get(t, 0.0) for t in TERMS] for lab in betas]))
    sig2 = _position_noise(sig)
    p = reg.Phi.shape[1]
    M = np.zeros((p, p))
    for k, f in enumerate(sig.files):
        M += _file_moments(f, sig.file_rows(k), d, reg.Phi, factor, rows, sig2)
    cov = (factor.Rinv @ M @ factor.Rinv.T) / np.outer(factor.Dn, factor.Dn)
    resid_sd = _residual_noise(d, sig, res, factor.block_rows, betas)
    return NoiseCovariance(covariance=cov, noise_std={"q1": math.sqrt(sig2[1]), "q2": math.sqrt(sig2[2]),
                                                      "from_residuals": {f"q{c}": v for c, v in resid_sd.items()}})


def _weighted_factor(reg: Regression, res: LeastSquaresResult, n: int) -> _WeightedFactor | None:
    """R of the weighted regressor from the blocks' R factors (tall-skinny QR), then column scaling.

    ``(W^(1/2) Phi) / D = Q (R_w / D)``; the big weighted matrices are never
    formed. None when a column is zero or ``R`` is numerically singular.
    """
    Phi, p = reg.Phi, reg.Phi.shape[1]
    block_rows = {lab: slice(i * n, (i + 1) * n) for i, lab in enumerate(reg.labels)}
    wb = block_weights(reg.blocks, res, reg.labels)
    Rb = [wb[lab] * tsqr_augmented(Phi[rows, :-1], Phi[rows, -1], slice(None), None)
          for lab, rows in block_rows.items()]
    Rw = np.linalg.qr(np.vstack(Rb), mode="r")[:p, :p] if len(Rb) > 1 else Rb[0][:p, :p]
    Dn = np.sqrt(np.einsum("ij,ij->j", Rw, Rw))
    if np.any(Dn == 0):
        return None
    R = Rw / Dn
    if np.any(np.abs(np.diag(R)) <= 1e-12 * np.abs(R).max()):
        return None
    Rinv = solve_triangular(R, np.eye(p))
    # W^(1/2) Q of each block: w_b^2 Phi_b D^-1 R^-1 (one factor w_b from Xs, one from W^(1/2))
    G = {lab: (wb[lab] ** 2) * (Rinv / Dn[:, None]) for lab in block_rows}
    return _WeightedFactor(Rinv=Rinv, Dn=Dn, G=G, block_rows=block_rows)


def _position_noise(sig: Signals) -> dict[int, float]:
    """Variance of the position noise per encoder (1, 2) [rad^2], from the fourth difference, pooled over files."""
    nsamp = np.array([f["n_full"] for f in sig.files], dtype=float)
    return {c + 1: float(np.sum(nsamp * np.array([f["noise"][c] ** 2 for f in sig.files])) / nsamp.sum())
            for c in (0, 1)}


def _residual_noise(d: Differentiator, sig: Signals, res: LeastSquaresResult, block_rows: Mapping[str, slice],
                    betas: Mapping[str, Any]) -> dict[int, float]:
    """The position noise [rad] per encoder the residuals of the row that measures it would imply."""
    n_rows, p = res.residuals.shape[0], len(res.names)
    nf = acceleration_noise_gain(d, sig.files[0]["Ts"])
    out: dict[int, float] = {}
    for lab, (chan, _) in betas.items():
        r = res.residuals[block_rows[lab]]
        dof = max(r.size - p * r.size / n_rows, 1.0)
        out[chan] = math.sqrt(float(np.einsum("i,i->", r, r)) / dof / nf)
    return out


def _file_moments(f: Mapping[str, Any], span: slice, d: Differentiator, Phi: np.ndarray, factor: _WeightedFactor,
                  rows: _RowNoise, sig2: Mapping[int, float]) -> np.ndarray:
    """``sum_c sigma_c^2 A_c^T A_c`` of one file (its rows ``span`` of the stacked signals,
    :meth:`Signals.file_rows`): its rows of ``W^(1/2) Q`` through ``K`` and the adjoint maps."""
    Ts, n_full, kk = f["Ts"], f["n_full"], f["kk"]
    start, nk = span.start, span.stop - span.start
    p = Phi.shape[1]
    q1, v1 = f["q1"], f["v1"]
    Qf = np.zeros((n_full, len(rows.labels) * p))
    for i, lab in enumerate(rows.labels):
        r0 = factor.block_rows[lab].start + start
        for c0 in range(0, nk, _MATMUL_CHUNK):  # small products: no threaded BLAS (it can stall)
            c1 = min(nk, c0 + _MATMUL_CHUNK)
            np.matmul(Phi[r0 + c0: r0 + c1], factor.G[lab], out=Qf[kk + c0: kk + c1, i * p: (i + 1) * p])
    filtered_q = np.ascontiguousarray(apply_K(d, Ts, Qf).T)  # K^T = K (zero-phase): one call for all blocks
    cos1 = np.cos(q1)
    terms = np.ascontiguousarray(np.vstack([cos1, -np.sign(cos1) * np.sin(q1) * v1, np.abs(cos1), 3.0 * v1 * v1]))
    adj = _noise_adjoints(filtered_q, p, rows.chans, rows.beta, terms, Ts)
    return _noise_gram(adj, sig2[1], sig2[2])


def row_weights(blocks: np.ndarray | None, res: LeastSquaresResult, n_rows: int) -> np.ndarray:
    """Row weight (1 / block sigma) of every row, as the block-weighted least squares used them.

    Parameters
    ----------
    blocks : ndarray or None
        Block label of each row; None: one block.
    res : LeastSquaresResult
        The solution, whose ``block_sigma`` holds each block's residual standard deviation.
    n_rows : int
        Number of rows.

    Returns
    -------
    ndarray, shape (n_rows,)
        The weights; all 1 with fewer than two blocks. A non-finite sigma counts as the largest finite one.
    """
    if blocks is None or len(res.block_sigma) < 2:
        return np.ones(n_rows)
    sig = res.block_sigma
    labels = list(sig)
    smax = max(v for v in sig.values() if math.isfinite(v))
    w = np.ones(n_rows)
    for lab in labels:
        s = sig[lab]
        w[blocks == lab] = 1.0 / max(s if math.isfinite(s) else smax, 1e-8 * smax)
    return w


def block_weights(blocks: np.ndarray | None, res: LeastSquaresResult, labels: Sequence[str]) -> dict[str, float]:
    """Row weight (1 / block sigma) per block label, as the block-weighted least squares used them.

    Parameters
    ----------
    blocks : ndarray or None
        Block label of each row; None: one block.
    res : LeastSquaresResult
        The solution, whose ``block_sigma`` holds each block's residual standard deviation.
    labels : sequence of str
        The block labels.

    Returns
    -------
    dict of str to float
        Weight per label; all 1 with fewer than two blocks. A non-finite sigma counts as the largest finite one.
    """
    if blocks is None or len(res.block_sigma) < 2:
        return {lab: 1.0 for lab in labels}
    sig = list(res.block_sigma.values())
    smax = max(v for v in sig if math.isfinite(v))
    return {lab: 1.0 / max(v if math.isfinite(v) else smax, 1e-8 * smax) for lab, v in zip(labels, sig)}


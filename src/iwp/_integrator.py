"""Compiled adaptive integrator (internal).

Dormand-Prince 8(5,3) -- the DOP853 method of Hairer, Norsett & Wanner,
with scipy's coefficient tables and its 7th-order dense output -- written
with numba so that a 300 s simulation runs in milliseconds. Error control,
step-size selection and dense output follow ``scipy.integrate.DOP853``; the
tests check agreement with it.

Inputs are evaluated inside the kernel: continuous signals (sine, chirp,
step, the Hopf feedback law) at every stage, and held (zero-order hold)
values for sampled arrays and sampled controllers, where the integration
restarts at every sample instant so that no step straddles a jump of the
input.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

#: LLVM fast-math flags: contraction and reassociation, but NaN and inf keep
#: their IEEE meaning so that divergence is still detected.
_FM = {"contract", "reassoc", "nsz", "arcp"}
from scipy.integrate._ivp import dop853_coefficients as _dc

from .models import E_SR, M_BELT, M_EL, M_MD, M_MD_RAW, SA, _ff, _rhs

# Butcher tableau and dense-output coefficients (scipy's DOP853 tables)
_NS = _dc.N_STAGES  # 12
_A = np.ascontiguousarray(_dc.A, dtype=np.float64)  # (16, 16), rows 13.. are the dense-output stages
_B = np.ascontiguousarray(_dc.B, dtype=np.float64)
_C = np.ascontiguousarray(_dc.C, dtype=np.float64)
_E3 = np.ascontiguousarray(_dc.E3, dtype=np.float64)
_E5 = np.ascontiguousarray(_dc.E5, dtype=np.float64)
_D = np.ascontiguousarray(_dc.D, dtype=np.float64)  # (4, 16)

SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
#: PI step-size control (Gustafsson; Hairer & Wanner II.4): the accepted-step
#: factor is ``SAFETY err^-(1/8 - 0.75 BETA) err_prev^BETA``; it damps the
#: oscillating step sizes that otherwise waste many rejected steps.
BETA = 0.04

# input kinds
I_ZERO = 0
I_CONST = 1
I_SINE = 2
I_CHIRP = 3
I_STEP = 4
I_SAMPLES = 5
I_HOPF = 6
I_EXTERNAL = 7  # held values supplied one segment at a time by Python

# segment modes
SEG_CONT = 0
SEG_SAMPLES = 1
SEG_CONTROLLER = 2

# status codes
ST_OK = 0
ST_DIVERGED = 1
ST_STEP_TOO_SMALL = 2
ST_MAX_STEPS = 3

# command parameter layout
C_FF, C_FFPOS, C_FFNEG, C_SATLO, C_SATHI = range(5)


@njit(cache=True, fastmath=_FM, inline="always")
def _signal(kind, ipar, t, x):
    """The ideal input ``u(t, x)`` of a continuous input kind."""
    if kind == I_CONST:
        return ipar[0]
    if kind == I_SINE:
        return ipar[0] * math.sin(ipar[1] * t + ipar[2]) + ipar[3]
    if kind == I_CHIRP:
        return ipar[0] * math.sin((ipar[1] + t / ipar[2]) * t) + ipar[3]
    if kind == I_STEP:
        if t < ipar[0]:
            return ipar[2]
        return ipar[2] + ipar[1]
    if kind == I_HOPF:
        q3 = x[2]
        return ipar[0] * q3 + ipar[1] * q3 * q3 * q3
    return 0.0


@njit(cache=True, fastmath=_FM, inline="always")
def _command(u, cpar):
    """Command sent to the model: feedforward (7)-(8) if enabled, then saturation."""
    w = u
    if cpar[C_FF] != 0.0:
        w = _ff(u, cpar[C_FFPOS], cpar[C_FFNEG])
    if w > cpar[C_SATHI]:
        w = cpar[C_SATHI]
    elif w < cpar[C_SATLO]:
        w = cpar[C_SATLO]
    return w


@njit(cache=True, fastmath=_FM)
def _eval(model, P, t, y, dx, held, hval, kind, ipar, cpar):
    if held:
        w = hval
    else:
        w = _command(_signal(kind, ipar, t, y), cpar)
    _rhs(model, y, w, P, dx)


@njit(cache=True, fastmath=_FM)
def _switch(model, P, y):
    """Switching function of the right-hand side's kinks (its sign changes there).

    The rolling friction ``sigma_a1 |cos q1| q3`` of section 3.1 has a kink
    where ``cos q1 = 0``; a Runge-Kutta step across it loses its order and its
    error estimate. Returns ``cos q1`` for models with that term, else 1.
    """
    if model == M_EL:
        if P[E_SR] == 0.0:
            return 1.0
    elif model == M_MD or model == M_MD_RAW or model == M_BELT:
        return 1.0
    elif P[SA] == 0.0:
        return 1.0
    return math.cos(y[0])


@njit(cache=True, fastmath=_FM)
def _norm_err(K, h, y, y_new, rtol, atol, n):
    e5 = 0.0
    e3 = 0.0
    for i in range(n):
        sc = atol + max(abs(y[i]), abs(y_new[i])) * rtol
        s5 = 0.0
        s3 = 0.0
        for s in range(_NS + 1):
            s5 += K[s, i] * _E5[s]
            s3 += K[s, i] * _E3[s]
        s5 /= sc
        s3 /= sc
        e5 += s5 * s5
        e3 += s3 * s3
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    den = e5 + 0.01 * e3
    return abs(h) * e5 / math.sqrt(den * n)


@njit(cache=True, fastmath=_FM)
def _step(model, P, t, y, f, h, K, ytmp, y_new, f_new, n, held, hval, kind, ipar, cpar):
    """One DOP853 step of size h from (t, y); stages in K[0:13]."""
    for i in range(n):
        K[0, i] = f[i]
    for s in range(1, _NS):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += _A[s, j] * K[j, i]
            ytmp[i] = y[i] + h * acc
        _eval(model, P, t + _C[s] * h, ytmp, K[s], held, hval, kind, ipar, cpar)
    for i in range(n):
        acc = 0.0
        for j in range(_NS):
            acc += _B[j] * K[j, i]
        y_new[i] = y[i] + h * acc
    _eval(model, P, t + h, y_new, f_new, held, hval, kind, ipar, cpar)
    for i in range(n):
        K[_NS, i] = f_new[i]


@njit(cache=True, fastmath=_FM)
def _dense_prepare(model, P, t, y, y_new, f, f_new, h, K, F, ytmp, n, held, hval, kind, ipar, cpar):
    """Compute the extra stages and the interpolation coefficients F (7, n)."""
    for s in range(_NS + 1, 16):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += _A[s, j] * K[j, i]
            ytmp[i] = y[i] + h * acc
        _eval(model, P, t + _C[s] * h, ytmp, K[s], held, hval, kind, ipar, cpar)
    for i in range(n):
        dy = y_new[i] - y[i]
        F[0, i] = dy
        F[1, i] = h * f[i] - dy
        F[2, i] = 2.0 * dy - h * (f_new[i] + f[i])
        for r in range(4):
            acc = 0.0
            for j in range(16):
                acc += _D[r, j] * K[j, i]
            F[3 + r, i] = h * acc


@njit(cache=True, fastmath=_FM, inline="always")
def _dense_eval(F, y, theta, out, n):
    for i in range(n):
        acc = 0.0
        for r in range(6, -1, -1):
            acc += F[r, i]
            if (6 - r) % 2 == 0:
                acc *= theta
            else:
                acc *= 1.0 - theta
        out[i] = acc + y[i]


@njit(cache=True, fastmath=_FM)
def _initial_step(model, P, t, y, f, n, rtol, atol, held, hval, kind, ipar, cpar, ytmp, ftmp, h_max):
    d0 = 0.0
    d1 = 0.0
    for i in range(n):
        sc = atol + abs(y[i]) * rtol
        d0 += (y[i] / sc) ** 2
        d1 += (f[i] / sc) ** 2
    d0 = math.sqrt(d0 / n)
    d1 = math.sqrt(d1 / n)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, h_max)
    for i in range(n):
        ytmp[i] = y[i] + h0 * f[i]
    _eval(model, P, t + h0, ytmp, ftmp, held, hval, kind, ipar, cpar)
    d2 = 0.0
    for i in range(n):
        sc = atol + abs(y[i]) * rtol
        d2 += ((ftmp[i] - f[i]) / sc) ** 2
    d2 = math.sqrt(d2 / n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, h_max)


@njit(cache=True, fastmath=_FM, inline="always")
def _put(j, tj, yv, X, U, W, n, held, uval, hval, kind, ipar, cpar):
    """Write output sample j: the state, the ideal input u and the command."""
    for i in range(n):
        X[j, i] = yv[i]
    if held:
        U[j] = uval
        W[j] = hval
    else:
        u_ = _signal(kind, ipar, tj, yv)
        U[j] = u_
        W[j] = _command(u_, cpar)


@njit(cache=True, fastmath=_FM)
def run(model, P, x0, t0, t_end, t_out, kind, ipar, usamp, seg_mode, seg_T, seg_t0, cpar,
        rtol, atol, h_max, max_steps, xmax, X, U, W, ext_hval, h0):
    """Integrate one simulation; fill X (n_out, n), U and W (n_out,).

    ``h0 > 0`` is the step size to start with (the one a previous call
    returned, when a caller integrates segment by segment); otherwise it is
    estimated.

    Returns ``(status, nfev, n_accepted, n_rejected, t_reached, h_next)``.
    """
    n = x0.size
    n_out = t_out.size
    y = x0.copy()
    f = np.empty(n)
    f_new = np.empty(n)
    y_new = np.empty(n)
    ytmp = np.empty(n)
    ftmp = np.empty(n)
    K = np.empty((16, n))
    F = np.empty((7, n))
    yo = np.empty(n)
    tol_t = 1e-9 * max(1.0, abs(t_end))
    t = t0
    j = 0
    nfev = 0
    nacc = 0
    nrej = 0
    status = ST_OK
    h_nat = h0
    # a step input is held per segment (the segment ends at the step time),
    # so no stage of a step ever samples the jump
    held = seg_mode != SEG_CONT or kind == I_STEP
    hval = 0.0
    uval = 0.0
    # segment grid
    kseg = 0
    if seg_mode != SEG_CONT:
        kseg = int(math.floor((t0 - seg_t0) / seg_T + 1e-9))
    while t < t_end - tol_t:
        # ---- segment [t, t_b]
        if seg_mode == SEG_CONT:
            t_b = t_end
            if kind == I_STEP:
                if ipar[0] > t + tol_t and ipar[0] < t_end - tol_t:
                    t_b = ipar[0]
                uval = _signal(kind, ipar, t + tol_t, y)
                hval = _command(uval, cpar)
        else:
            t_b = seg_t0 + (kseg + 1) * seg_T
            if t_b > t_end:
                t_b = t_end
            # held value for this segment
            if seg_mode == SEG_SAMPLES:
                idx = kseg
                if idx < 0:
                    idx = 0
                if idx > usamp.size - 1:
                    idx = usamp.size - 1
                uval = usamp[idx]
            elif kind == I_EXTERNAL:
                uval = ext_hval
            else:
                uval = _signal(kind, ipar, t, y)
            hval = _command(uval, cpar)
        _eval(model, P, t, y, f, held, hval, kind, ipar, cpar)
        nfev += 1
        # outputs at the segment start
        while j < n_out and t_out[j] <= t + tol_t:
            _put(j, t_out[j], y, X, U, W, n, held, uval, hval, kind, ipar, cpar)
            j += 1
        if h_nat <= 0.0:
            h_nat = _initial_step(model, P, t, y, f, n, rtol, atol, held, hval, kind, ipar, cpar, ytmp, ftmp, h_max)
            nfev += 1
        rejected = False
        h_force = -1.0
        err_prev = 1e-4
        while t < t_b - tol_t:
            min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
            h = min(h_nat, h_max)
            forced = False
            if h_force > 0.0:
                h = h_force
                h_force = -1.0
                forced = True
            clipped = False
            if t + h > t_b:
                # clip to the segment end; a step is never stretched, so a
                # rejected clipped step is retried with a shorter one
                h = t_b - t
                clipped = True
            if h < min_step:
                status = ST_STEP_TOO_SMALL
                break
            _step(model, P, t, y, f, h, K, ytmp, y_new, f_new, n, held, hval, kind, ipar, cpar)
            nfev += _NS
            err = _norm_err(K, h, y, y_new, rtol, atol, n)
            if not (err < 1.0):
                nrej += 1
                if err != err:  # NaN
                    factor = MIN_FACTOR
                else:
                    factor = max(MIN_FACTOR, SAFETY * err ** (-1.0 / 8.0))
                h_nat = h * factor
                rejected = True
                if h_nat < min_step:
                    status = ST_STEP_TOO_SMALL
                    break
                continue
            # a kink of the right-hand side inside the step: redo the step so
            # that it ends just past the kink (located on the dense output)
            if not forced:
                g0 = _switch(model, P, y)
                g1 = _switch(model, P, y_new)
                if g0 * g1 < 0.0:
                    _dense_prepare(model, P, t, y, y_new, f, f_new, h, K, F, ytmp, n, held, hval, kind, ipar, cpar)
                    nfev += 3
                    a = 0.0
                    b = 1.0
                    for _it in range(60):
                        mid = 0.5 * (a + b)
                        _dense_eval(F, y, mid, yo, n)
                        gm = _switch(model, P, yo)
                        if gm * g0 > 0.0:
                            a = mid
                        else:
                            b = mid
                        if (b - a) * abs(h) < 1e-13 * max(1.0, abs(t)):
                            break
                    h_force = b * h + 2e-13 * max(1.0, abs(t))
                    if h_force < h:
                        nrej += 1
                        continue
                    h_force = -1.0
            # accepted
            if err == 0.0:
                factor = MAX_FACTOR
            else:
                factor = min(MAX_FACTOR, SAFETY * err ** (-(1.0 / 8.0 - 0.75 * BETA)) * err_prev ** BETA)
            err_prev = max(err, 1e-4)
            if rejected:
                factor = min(1.0, factor)
            rejected = False
            if not clipped and not forced:
                h_nat = h * factor
            elif factor < 1.0:
                # a step clipped to the segment end keeps the natural step
                # size unless its own error asks for a smaller one
                h_nat = min(h_nat, h * factor)
            nacc += 1
            t_new = t + h
            if clipped:
                t_new = t_b
            # dense output strictly inside (t, t_new)
            if j < n_out and t_out[j] < t_new - tol_t:
                _dense_prepare(model, P, t, y, y_new, f, f_new, h, K, F, ytmp, n, held, hval, kind, ipar, cpar)
                nfev += 3
                while j < n_out and t_out[j] < t_new - tol_t:
                    theta = (t_out[j] - t) / h
                    _dense_eval(F, y, theta, yo, n)
                    _put(j, t_out[j], yo, X, U, W, n, held, uval, hval, kind, ipar, cpar)
                    j += 1
            bad = False
            for i in range(n):
                y[i] = y_new[i]
                f[i] = f_new[i]
                if not (abs(y_new[i]) < xmax):
                    bad = True
            t = t_new
            if bad:
                status = ST_DIVERGED
                break
            if nacc + nrej >= max_steps:
                status = ST_MAX_STEPS
                break
            # outputs exactly at an interior step end
            if t < t_b - tol_t:
                while j < n_out and t_out[j] <= t + tol_t:
                    _put(j, t_out[j], y, X, U, W, n, held, uval, hval, kind, ipar, cpar)
                    j += 1
        if status != ST_OK:
            break
        kseg += 1
        if kind == I_EXTERNAL:
            break  # Python supplies the next held value
    if status == ST_OK and t >= t_end - tol_t:
        # outputs at the end time
        if held:
            if seg_mode == SEG_SAMPLES:
                idx = kseg
                if idx > usamp.size - 1:
                    idx = usamp.size - 1
                uval = usamp[idx]
            elif kind != I_EXTERNAL:
                uval = _signal(kind, ipar, t, y)
            hval = _command(uval, cpar)
        while j < n_out and t_out[j] <= t_end + tol_t:
            _put(j, t_out[j], y, X, U, W, n, held, uval, hval, kind, ipar, cpar)
            j += 1
    # final state kept in x0's place for segment-wise callers
    for i in range(n):
        x0[i] = y[i]
    return status, nfev, nacc, nrej, t, h_nat


@njit(cache=True, parallel=True, fastmath=_FM)
def run_batch(model, Pm, X0m, t0, t_end, t_out, kind, Ipm, usamp, seg_mode, seg_T, seg_t0, cpar,
              rtol, atol, h_max, max_steps, xmax, X, U, W, status, nfev):
    """Run ``Pm.shape[0]`` simulations in parallel (one per row of Pm, X0m, Ipm)."""
    nrun = Pm.shape[0]
    for r in prange(nrun):
        x0 = X0m[r].copy()
        res = run(model, Pm[r], x0, t0, t_end, t_out, kind, Ipm[r], usamp, seg_mode, seg_T, seg_t0, cpar,
                  rtol, atol, h_max, max_steps, xmax, X[r], U[r], W[r], 0.0, -1.0)
        status[r] = res[0]
        nfev[r] = res[1]

"""Many simulations side by side: the batch kernel (internal).

:func:`iwp.sim.simulate.simulate_batch` runs thousands of simulations of one
model that differ in their gains, input parameters or initial states. One
simulation alone is latency-bound: every Runge-Kutta stage waits for the
previous one through the right-hand side. This kernel advances ``LANES``
simulations in lock step instead, each with its own step size, error
control, kink handling and outputs. Their states are the columns of
``(n, LANES)`` arrays, the stages and the right-hand side are evaluated for
all lanes in one loop that the compiler vectorises, and everything that
differs between lanes -- accepting or rejecting a step, the next step size,
dense output, the kinks of ``|cos q1|`` -- is done lane by lane with the
same code paths as :func:`iwp.sim.engine.integrate`. A lane whose simulation
ends takes the next one of its thread's share. The right-hand side is that
of :mod:`iwp.models`, reached through lane views (:mod:`iwp.sim.views`).

The method is the same DOP853 with the same error control, so a simulation
gives the same result here as alone, up to rounding (the compiler may order
sums differently in vector code).

Used for continuous inputs (signals and the continuous Hopf law) and
parameters shared by all runs; held inputs, sampled controllers and
per-run parameters go through :func:`iwp.sim.engine.batch_kernel`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange
from numba.np.unsafe.ndarray import to_fixed_tuple

from ..jit import jit
from ..models.actuator import command
from ..models.equations import optional_terms_off, rhs_of
from ..models.layout import M_PLAIN, N_COMMAND, N_PACK
from .dop853 import N_STAGES as _NS
from .dop853 import dense_coefficients, dense_eval, error_norm_lanes, stage_input_lanes
from .engine import (
    BRIDGE_FRAC,
    KINK_MARGIN,
    KINK_OVERSHOOT,
    NODES,
    ST_DIVERGED,
    ST_MAX_STEPS,
    ST_OK,
    ST_STEP_TOO_SMALL,
    accept_factor,
    first_step,
    has_kink,
    hermite,
    input_samples,
    kink_ahead,
    kink_step,
    plant_rate,
    reject_factor,
    rk4_bridge,
    stages,
    switch,
)
from .inputs import I_HOPF, input_value
from .views import lane, slab_lane

#: simulations per thread advanced together (two 8-wide vectors)
LANES = 16


@jit(inline=True)
def _lane_input_params(input_params_lanes, l):
    """The input parameters of lane ``l`` as the tuple the input functions take."""
    return (input_params_lanes[0, l], input_params_lanes[1, l], input_params_lanes[2, l], input_params_lanes[3, l])


@jit(inline=True)
def _plain_stages(P, command_params, T, Y, H, K, YT, input_params_lanes, n, L):
    """Stages 1-12 of a DOP853 step of every lane, model (9) without optional terms and the Hopf law.

    Everything is inlined and free of library calls: the loops over lanes
    are vectorised.
    """
    for s in range(1, _NS + 1):
        stage_input_lanes(s, Y, H, K, YT, n, L)
        cs = NODES[s]
        for l in range(L):
            x = lane(YT, l)
            input_params = _lane_input_params(input_params_lanes, l)
            w = command(input_value(I_HOPF, input_params, T[l] + cs * H[l], x), command_params)
            rhs_of(M_PLAIN, x, w, P, slab_lane(K, s, l))


@jit(inline=True)
def _general_stages(model, P, kind, command_params, T, Y, H, K, YT, input_params_lanes, n, L):
    """Stages 1-12 of a DOP853 step of every lane, any model and input: one call per lane and stage."""
    for s in range(1, _NS + 1):
        stage_input_lanes(s, Y, H, K, YT, n, L)
        cs = NODES[s]
        for l in range(L):
            input_params = _lane_input_params(input_params_lanes, l)
            plant_rate(
                model,
                P,
                T[l] + cs * H[l],
                lane(YT, l),
                slab_lane(K, s, l),
                False,
                0.0,
                kind,
                input_params,
                command_params,
            )


@jit(inline=True)
def _vector_step(model, P, kind, command_params, T, Y, F, H, K, YT, input_params_lanes, n, L):
    for l in range(L):
        for i in range(n):
            K[0, i, l] = F[i, l]
    if optional_terms_off(model, P) and kind == I_HOPF:
        _plain_stages(P, command_params, T, Y, H, K, YT, input_params_lanes, n, L)
    else:
        _general_stages(model, P, kind, command_params, T, Y, H, K, YT, input_params_lanes, n, L)


@jit
def run_lanes(
    model,
    n,
    P_arr,
    X0m,
    r0,
    r1,
    t0,
    t_end,
    t_out,
    kind,
    input_params_runs,
    command_params_arr,
    tol,
    X,
    U,
    W,
    status,
    nfev,
):
    """Simulations ``r0 .. r1-1`` of a batch, ``LANES`` at a time; fills X, U, W, status and nfev of each."""
    L = LANES
    P = to_fixed_tuple(P_arr, N_PACK)
    command_params = to_fixed_tuple(command_params_arr, N_COMMAND)
    rtol = tol.rtol
    atol = tol.atol
    h_max = tol.h_max
    max_steps = tol.max_steps
    xmax = tol.xmax
    n_out = t_out.size
    kinked = has_kink(model, P)
    tol_t = 1e-9 * max(1.0, abs(t_end))
    # lane arrays: column l is the simulation in lane l
    Y = np.zeros((n, L))
    F = np.zeros((n, L))
    YT = np.zeros((n, L))
    K = np.zeros((16, n, L))
    input_params_lanes = np.zeros((4, L))
    for l in range(L):  # idle lanes evaluate a real run's input (zeros are a chirp of no sweep time: 1/0)
        for i in range(4):
            input_params_lanes[i, l] = input_params_runs[r0, i]
    H = np.zeros(L)
    ERR = np.zeros(L)
    T = np.full(L, t0)
    HN = np.zeros(L)  # natural step size
    HF = np.full(L, -1.0)  # forced step size (a kink landed on)
    LERRP = np.zeros(L)  # log of the previous error (PI control)
    HLAST = np.zeros(L)
    ALAST = np.zeros(L)
    GCUR = np.ones(L)
    RUN = np.full(L, -1)
    J = np.zeros(L, dtype=np.int64)
    NFEV = np.zeros(L, dtype=np.int64)
    NSTEP = np.zeros(L, dtype=np.int64)
    STAT = np.zeros(L, dtype=np.int64)
    REJ = np.zeros(L, dtype=np.bool_)
    FORCED = np.zeros(L, dtype=np.bool_)
    CLIPPED = np.zeros(L, dtype=np.bool_)
    SHORT = np.zeros(L, dtype=np.bool_)
    BRIDGED = np.zeros(L, dtype=np.bool_)
    # one lane's data, for the lane-by-lane work
    ys = np.empty(n)
    yn = np.empty(n)
    fs = np.empty(n)
    dx = np.empty(n)
    ytmp = np.empty(n)
    ftmp = np.empty(n)
    Ks = np.empty((16, n))
    Fd = np.empty((7, n))
    yo = np.empty(n)
    nxt = r0
    n_active = 0
    while True:
        # ---- lane by lane: finish and start simulations, choose the next step
        for l in range(L):
            while True:
                r = RUN[l]
                if r >= 0 and (STAT[l] != ST_OK or T[l] >= t_end - tol_t):
                    # ---- the simulation in this lane is done
                    j = J[l]
                    if STAT[l] == ST_OK:
                        # samples within the time tolerance of the end: first-order correction
                        while j < n_out and t_out[j] <= t_end + tol_t:
                            for i in range(n):
                                X[r, j, i] = Y[i, l] + F[i, l] * (t_out[j] - T[l])
                            j += 1
                    input_samples(
                        kind,
                        _lane_input_params(input_params_lanes, l),
                        command_params,
                        t_out[:j],
                        X[r, :j],
                        U[r, :j],
                        W[r, :j],
                    )
                    # samples never reached (a failed run) are NaN
                    X[r, j:] = np.nan
                    U[r, j:] = np.nan
                    W[r, j:] = np.nan
                    status[r] = STAT[l]
                    nfev[r] = NFEV[l]
                    RUN[l] = -1
                    n_active -= 1
                    r = -1
                if r < 0:
                    if nxt >= r1:
                        H[l] = 0.0
                        break
                    # ---- start the next simulation in this lane
                    r = nxt
                    nxt += 1
                    RUN[l] = r
                    n_active += 1
                    for i in range(4):
                        input_params_lanes[i, l] = input_params_runs[r, i]
                    input_params = _lane_input_params(input_params_lanes, l)
                    for i in range(n):
                        ys[i] = X0m[r, i]
                        Y[i, l] = ys[i]
                    T[l] = t0
                    plant_rate(model, P, t0, ys, fs, False, 0.0, kind, input_params, command_params)
                    for i in range(n):
                        F[i, l] = fs[i]
                    j = 0
                    while j < n_out and t_out[j] <= t0 + tol_t:
                        for i in range(n):
                            X[r, j, i] = ys[i]
                        j += 1
                    J[l] = j
                    HN[l] = first_step(
                        model,
                        P,
                        t0,
                        ys,
                        fs,
                        n,
                        n,
                        rtol,
                        atol,
                        h_max,
                        False,
                        0.0,
                        kind,
                        input_params,
                        command_params,
                        None,
                        ytmp,
                        ftmp,
                    )
                    NFEV[l] = 2
                    NSTEP[l] = 0
                    STAT[l] = ST_OK
                    HF[l] = -1.0
                    LERRP[l] = math.log(1e-4)
                    HLAST[l] = -1.0
                    ALAST[l] = 0.0
                    REJ[l] = False
                    BRIDGED[l] = False
                    GCUR[l] = switch(model, P, ys)
                    continue
                # ---- the next step of this lane (as in _integrator.run)
                t = T[l]
                min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
                h = min(HN[l], h_max)
                forced = False
                if HF[l] > 0.0:
                    h = HF[l]
                    HF[l] = -1.0
                    forced = True
                clipped = False
                if t + h > t_end:
                    h = t_end - t
                    clipped = True
                shortened = False
                if kinked and not forced and not BRIDGED[l]:
                    jk = 0.0
                    if HLAST[l] > 0.0:
                        jk = (F[2, l] - ALAST[l]) / HLAST[l]
                    s_k = kink_ahead(Y[0, l], F[0, l], F[2, l], jk, h)
                    if s_k > 0.0 and s_k <= BRIDGE_FRAC * HN[l]:
                        hb = s_k * (1.0 + KINK_OVERSHOOT) + 1e-12 * max(1.0, abs(t))
                        if t + hb < t_end - tol_t:
                            # RK4 bridge across the kink, on this lane's copy
                            input_params = _lane_input_params(input_params_lanes, l)
                            for i in range(n):
                                ys[i] = Y[i, l]
                                fs[i] = F[i, l]
                            eb = rk4_bridge(
                                model,
                                P,
                                t,
                                ys,
                                fs,
                                hb,
                                Ks,
                                ytmp,
                                yn,
                                dx,
                                n,
                                n,
                                rtol,
                                atol,
                                False,
                                0.0,
                                kind,
                                input_params,
                                command_params,
                                None,
                            )
                            NFEV[l] += 4
                            if eb < 1.0:
                                j = J[l]
                                while j < n_out and t_out[j] < t + hb - tol_t:
                                    hermite(ys, yn, fs, dx, hb, (t_out[j] - t) / hb, yo, n)
                                    for i in range(n):
                                        X[r, j, i] = yo[i]
                                    j += 1
                                ALAST[l] = fs[2]
                                HLAST[l] = hb
                                bad = False
                                for i in range(n):
                                    F[i, l] = dx[i]
                                    Y[i, l] = yn[i]
                                    if not (abs(yn[i]) < xmax):
                                        bad = True
                                t = t + hb
                                T[l] = t
                                GCUR[l] = switch(model, P, yn)
                                NSTEP[l] += 1
                                BRIDGED[l] = True
                                if bad:
                                    STAT[l] = ST_DIVERGED
                                while j < n_out and t_out[j] <= t + tol_t:
                                    for i in range(n):
                                        X[r, j, i] = yn[i] + dx[i] * (t_out[j] - t)
                                    j += 1
                                J[l] = j
                                continue
                    elif s_k > 0.0 and s_k * (1.0 - KINK_MARGIN) < h:
                        h = s_k * (1.0 - KINK_MARGIN)
                        shortened = True
                        clipped = False
                BRIDGED[l] = False
                if h < min_step:
                    STAT[l] = ST_STEP_TOO_SMALL
                    continue
                H[l] = h
                FORCED[l] = forced
                CLIPPED[l] = clipped
                SHORT[l] = shortened
                break
        if n_active == 0:
            break
        # ---- all lanes at once: the stages and the error estimates
        _vector_step(model, P, kind, command_params, T, Y, F, H, K, YT, input_params_lanes, n, L)
        error_norm_lanes(K, H, Y, YT, rtol, atol, n, L, ERR)
        # ---- lane by lane: accept or reject (as in _integrator.run)
        for l in range(L):
            r = RUN[l]
            if r < 0:
                continue
            NFEV[l] += _NS
            t = T[l]
            h = H[l]
            err = ERR[l]
            forced = FORCED[l]
            clipped = CLIPPED[l]
            min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
            crossing = False
            dense = False
            g_new = 1.0
            j = J[l]
            if err < 1.0:
                g_new = switch(model, P, lane(YT, l))
                if not forced:
                    crossing = GCUR[l] * g_new < 0.0
                t_e = t_end if clipped else t + h
                dense = crossing or (j < n_out and t_out[j] < t_e - tol_t)
            if not (err < 1.0):
                NSTEP[l] += 1
                HN[l] = h * reject_factor(err)
                REJ[l] = True
                if HN[l] < min_step:
                    STAT[l] = ST_STEP_TOO_SMALL
                if NSTEP[l] >= max_steps:
                    STAT[l] = ST_MAX_STEPS
                continue
            if dense:
                # this lane's step, with its three extra stages, on a copy
                input_params = _lane_input_params(input_params_lanes, l)
                for i in range(n):
                    ys[i] = Y[i, l]
                    yn[i] = YT[i, l]
                    for s in range(_NS + 1):
                        Ks[s, i] = K[s, i, l]
                stages(
                    model,
                    P,
                    t,
                    ys,
                    h,
                    Ks,
                    ytmp,
                    dx,
                    n,
                    _NS + 1,
                    16,
                    False,
                    0.0,
                    kind,
                    input_params,
                    command_params,
                    None,
                )
                NFEV[l] += 3
                dense_coefficients(Ks, h, ys, yn, Fd, n)
            if crossing:
                h_force = kink_step(model, P, Fd, ys, h, t, GCUR[l], g_new, yo, n)
                if h_force < h:
                    NSTEP[l] += 1
                    HF[l] = h_force
                    if NSTEP[l] >= max_steps:
                        STAT[l] = ST_MAX_STEPS
                    continue
            # accepted
            factor = accept_factor(err, LERRP[l])
            LERRP[l] = math.log(max(err, 1e-4))
            if REJ[l]:
                factor = min(1.0, factor)
            REJ[l] = False
            if not clipped and not forced and not SHORT[l]:
                HN[l] = h * factor
            elif factor < 1.0:
                HN[l] = min(HN[l], h * factor)
            NSTEP[l] += 1
            t_new = t_end if clipped else t + h
            while j < n_out and t_out[j] < t_new - tol_t:
                dense_eval(Fd, ys, (t_out[j] - t) / h, yo, n)
                for i in range(n):
                    X[r, j, i] = yo[i]
                j += 1
            ALAST[l] = F[2, l]
            HLAST[l] = t_new - t
            bad = False
            for i in range(n):
                F[i, l] = K[_NS, i, l]
                Y[i, l] = YT[i, l]
                if not (abs(YT[i, l]) < xmax):
                    bad = True
            GCUR[l] = g_new
            T[l] = t_new
            if bad:
                STAT[l] = ST_DIVERGED
            elif NSTEP[l] >= max_steps:
                STAT[l] = ST_MAX_STEPS
            elif t_new < t_end - tol_t:
                while j < n_out and t_out[j] <= t_new + tol_t:
                    for i in range(n):
                        X[r, j, i] = Y[i, l] + F[i, l] * (t_out[j] - t_new)
                    j += 1
            J[l] = j


def _make_kernel(n: int):
    """The batch of runs side by side for ``n`` states (a compile-time constant inside it)."""

    def lanes_(
        model, P, X0m, kind, input_params_runs, command_params, tol, t0, t_end, t_out, X, U, W, status, nfev, nb
    ):
        nrun = X0m.shape[0]
        for b in prange(nb):
            run_lanes(
                model,
                n,
                P,
                X0m,
                b * nrun // nb,
                (b + 1) * nrun // nb,
                t0,
                t_end,
                t_out,
                kind,
                input_params_runs,
                command_params,
                tol,
                X,
                U,
                W,
                status,
                nfev,
            )

    lanes_.__name__ = lanes_.__qualname__ = f"run_lanes_{n}"
    return jit(lanes_, parallel=True)


_KERNELS: dict = {}


def kernel(n_states: int):
    """The lane kernel for ``n_states`` states (compiled on first use, then cached on disk).

    Called as ``kernel(n)(model, P, X0m, kind, input_params_runs, command_params, tol, t0, t_end, t_out, X, U, W,
    status, nfev, nb)``; ``nb`` is the number of blocks of runs (one per thread).
    """
    k = _KERNELS.get(int(n_states))
    if k is None:
        k = _KERNELS[int(n_states)] = _make_kernel(int(n_states))
    return k

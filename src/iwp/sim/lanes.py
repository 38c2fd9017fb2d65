"""Many simulations side by side: the batch kernel (internal).

:func:`iwp.sim.simulate.simulate_batch` runs thousands of simulations of one
model that differ in their plant parameters, gains or initial states. One
simulation alone is latency-bound: every Runge-Kutta stage waits for the
previous one through the right-hand side. For model (9) without optional
terms under a constant, a sine, a chirp or the Hopf law (:func:`vectorised`:
the sweeps of closed loops, the draws of a prediction band),
this kernel advances ``LANES`` simulations in lock step instead, each with
its own step size, error control, kinks and outputs, their right-hand sides
evaluated as one vector (:func:`plain_stages`). Their states are the columns
of ``(n, LANES)`` arrays. Any other batch runs as single runs on all cores
(a lane whose right-hand side does not vectorise costs more than a run alone).

Each step of a block has four parts:

1. lane by lane, the lanes that need it: start and finish runs, conclude a
   step that was not ordinary (clipped to the run's end, landed on or
   crossing a kink, or rejected with a step that may fall below the
   smallest), cross a kink with the RK4 bridge (its rate a
   :class:`~iwp.sim.engine.PlainField`'s), plan what part 4 left;
2. all lanes at once: the DOP853 stages and error norms (vectorised);
3. all lanes at once: accept the ordinary steps (the new state,
   branch-free, vectorised; the controller's factor lane by lane) or reject
   them (the factor, libm's ``pow`` as a single run has it, on the rejected
   lanes). A step
   with output times inside it needs the dense output: for model (9) without
   optional terms, a vectorised input and store="samples", the step is put in a slot
   (:class:`DenseSlots`) and its three extra stages are computed with those of
   ``N_SLOTS`` such steps at once (:func:`flush_dense`, also before a run ends);
   otherwise lane by lane (:func:`~iwp.sim.engine.dense_step`);
4. all lanes at once: plan the next steps, those near a kink of ``|cos q1|``
   included (:func:`~iwp.models.guards.kink_ahead`'s iterations side by side,
   :func:`~iwp.sim.engine.kink_plan`: a step ends short of the kink, or an
   RK4 bridge of the planned size crosses it in part 1); a lane at the
   run's end or due an output is left to part 1. Its loops each write few
   arrays: the compiler vectorises a loop only when it can check at run time
   that the arrays it writes overlap none of the others.

Of 1,794 visits lane by lane a run (2,000 Hopf loops of 300 s, table 1:
580 rejections, 660 steps ended short of a kink, 554 bridges), 557 are
left (the bridges).

The inputs are continuous (:func:`vectorised` refuses held ones), so a run
is one segment from ``t0`` to ``t_end``: none of the engine's held-segment
bookkeeping is needed here.

Parts 1, 3 and 4 are made of the pieces :func:`iwp.sim.engine.integrate`
uses -- the step-size controller (:mod:`iwp.sim.step_size`), :func:`~iwp.sim.engine.plan_step`
and :func:`~iwp.sim.engine.kink_plan`, the bridge and the output writers of :mod:`iwp.sim.engine`
-- so a simulation takes the same steps here as alone and gives the same
result up to rounding (the compiler may order sums differently in vector
code). The right-hand side is that of :mod:`iwp.models`, reached through
lane views (:mod:`iwp.sim.views`); for model (9) without optional terms and
an input of :data:`VECTOR_KINDS` it is the branch-free one that vectorises (the sine of a
sine or chirp is :func:`iwp.models.mathfn.sincos`, not libm's).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import prange

from ..jit import jit
from ..models.actuator import command
from ..models.equations import optional_terms_off, rhs_of
from ..models.guards import (
    KINK_ITERATIONS,
    KINK_TINY,
    KINKS,
    has_kink,
    kink_newton,
    kink_possible,
    kink_start,
    may_cross,
    switch_of,
)
from ..models.layout import M_PLAIN, N_COMMAND, N_PACK
from ..threads import once_per_argument
from .dop853 import (
    N_STAGES,
    dense_coefficients_lanes,
    dense_eval_row,
    error_norm_lanes,
    interpolant,
    stage_input_lanes,
)
from .engine import (
    BRIDGE,
    CLIPPED,
    FORCED,
    NODES,
    SHORT,
    ST_DIVERGED,
    ST_MAX_STEPS,
    ST_OK,
    ST_STEP_TOO_SMALL,
    STORE_SAMPLES,
    Field,
    Output,
    PlainField,
    Segments,
    Tolerances,
    beyond,
    bridge_work,
    dense_step,
    first_step,
    hermite,
    input_samples,
    is_held,
    kink_plan,
    kink_step,
    min_step,
    min_step_bound,
    new_work,
    plan_step,
    put_dense,
    put_near,
    put_sample,
    put_unreached,
    rate,
    rk4_bridge,
)
from .inputs import I_CHIRP, I_CONST, I_HOPF, I_SINE, I_ZERO, N_INPUT_PARAMS, input_value
from .step_size import LERR_FLOOR, MIN_FACTOR, accept_step, next_step_size, reject_factor
from .views import lane, slab_lane, tuple_of, vec

#: simulations per thread advanced together (two 8-wide vectors)
LANES = 16
#: deferred dense outputs computed together by :func:`flush_dense`: a call hands it 14 arrays, each
#: counted twice (atomically) by numba, so the fewer calls the better (16 slots: 1.75 counts per sample)
N_SLOTS = 4 * LANES
#: the inputs whose value vectorises across lanes: constant, sine, chirp and the Hopf law
VECTOR_KINDS = (I_ZERO, I_CONST, I_SINE, I_CHIRP, I_HOPF)

#: A batch of runs of one model: the model code, plant parameters per run
#: (n_runs, N_PACK), initial states (n_runs, n), the input kind, input
#: parameters per run (n_runs, N_INPUT_PARAMS), the command vector, how the
#: input is held (:class:`~iwp.sim.engine.Segments` whose ``values`` has one
#: row of held samples per run) and the interval [s].
Batch = namedtuple("Batch", ["model", "P", "X0", "kind", "input_params", "command_params", "seg", "t0", "t_end"])
#: What a batch keeps: output times, store mode (``engine.STORE_*``), states
#: (n_runs, n_out, n), ideal input and command (n_runs, n_out), summaries
#: (n_runs, N_SUMMARY, n), final states (n_runs, n) and per run the status,
#: evaluations, accepted and rejected steps; ``halt``, one int64 that stops every lane at its next step when set
#: non-zero (from another thread: an interrupt, :func:`iwp.sim.simulate.simulate_batch`).
BatchOutput = namedtuple(
    "BatchOutput", ["t", "store", "X", "U", "W", "S", "x_final", "status", "nfev", "n_steps", "n_rejected", "halt"]
)

#: Deferred dense outputs of accepted ordinary steps (model (9) plain, store="samples"),
#: one step per slot, computed ``N_SLOTS`` (S) at a time by :func:`flush_dense`: per slot the
#: step's start time T, state Y (n, S), size H, stages K (16, n, S) with 0-12 given, scratch
#: YT (n, S), end state YN (n, S), input and plant parameters IPL, PL, its run R, its
#: output samples ``J0 .. J1-1`` and its interpolant's coefficients F (7, n, S).
DenseSlots = namedtuple("DenseSlots", ["T", "Y", "H", "K", "YT", "YN", "IPL", "PL", "R", "J0", "J1", "F"])

# what a lane waits for before its next vector step
M_READY = 0  #: its next step is planned
M_DECIDE = 1  #: its last step was not an ordinary one: concluded lane by lane
M_POST = 2  #: its last step was accepted: outputs at the step end, divergence
M_PLAN = 3  #: its next step is planned lane by lane (kink, segment end, run end)
M_IDLE = 4  #: no run left for it
M_BRIDGE = 5  #: its next step is an RK4 bridge across a kink (of size H), planned side by side


@jit(inline=True)
def run_output(out, r):
    """The :class:`~iwp.sim.engine.Output` of run ``r`` of a batch.

    A continuous input is not recorded sample by sample: its columns are
    computed from the states when the run ends (:func:`~iwp.sim.engine.input_samples`).
    """
    return Output(out.t, out.X[r], out.U[r], out.W[r], False, out.store, out.S[r])


@jit(inline=True)
def run_field(bt, r):
    """The :class:`~iwp.sim.engine.Field` of run ``r`` of a batch (its input is never held: see :func:`vectorised`)."""
    return Field(bt.model, tuple_of(bt.P[r], N_PACK), bt.kind, tuple_of(bt.input_params[r], N_INPUT_PARAMS),
                 tuple_of(bt.command_params, N_COMMAND), False, 0.0, 0.0, None)


@jit(inline=True)
def lane_step_into(K, YT, l, wK, wy, n):
    """Copy lane ``l``'s stages 0-12 and end state into one run's work arrays ``wK`` (16, n) and ``wy`` (n,).

    Then :func:`~iwp.sim.engine.dense_step` adds stages 13-15 and the dense
    coefficients, as for a single run. (The work arrays are passed, not the
    :class:`~iwp.sim.engine.Work` record: numba lost writes made through a
    record inside an inlined function.)
    """
    for i in range(n):
        wy[i] = YT[i, l]
        for s in range(N_STAGES + 1):
            wK[s, i] = K[s, i, l]


@jit(inline=True)
def lane_outputs(out, r, j, step, ys, fld, wk):
    """Outputs of run r from sample j inside an accepted step ``step = (t, h, t_stop)``; returns the next sample.

    The samples before ``t_stop`` [s] are interpolated on the dense output
    ``wk.F`` from the state ``ys`` at ``t``; states only (a continuous input
    with store="samples") go straight into their rows, as
    :func:`~iwp.sim.engine.integrate` writes them, others through
    :func:`~iwp.sim.engine.put_dense`.
    """
    t, h, t_stop = step
    t_out = out.t
    n = ys.size
    if out.store == STORE_SAMPLES and not fld.held:
        Xr = out.X[r]
        rh = 1.0 / h
        while j < t_out.size and t_out[j] < t_stop:
            dense_eval_row(wk.F, ys, (t_out[j] - t) * rh, Xr, j, n)
            j += 1
    while j < t_out.size and t_out[j] < t_stop:
        put_dense(run_output(out, r), j, t_out[j], t, h, ys, n, fld, wk)
        j += 1
    return j


@jit(inline=True)
def plain_stages(kind, cps, TYH, K, YT, IPL, PL, n, span):
    """DOP853 stages of every lane, model (9) without optional terms and an input of ``kind`` (vectorised).

    Parameters
    ----------
    kind : int
        The input's kind, one of :data:`VECTOR_KINDS`.
    cps : tuple
        The command vector.
    TYH : tuple
        ``(T, Y, H)``: per lane the step's start time (L,), state (n, L) and size (L,); read only.
    K : ndarray
        Stages (16, n, L): ``K[0 .. s0-1]`` given, ``K[s0 .. s1-1]`` filled.
    YT : ndarray
        Scratch (n, L): the last stage's input on return (the new state after stage 12).
    IPL, PL : ndarray
        Input parameters (N_INPUT_PARAMS, L) and packed plant parameters (N_PACK, L) per lane.
    n : int
        Number of states.
    span : tuple
        ``(s0, s1, L)``: stages ``s0 .. s1-1`` of lanes ``0 .. L-1`` (1-12 for a step, 13-15 for its dense output).
    """
    T, Y, H = TYH
    s0, s1, L = span
    for s in range(s0, s1):
        stage_input_lanes(s, Y, H, K, YT, n, L)
        cs = NODES[s]
        # one loop per kind, each with its kind a constant: a branch on the kind inside the loop over the lanes
        # would keep the compiler from vectorising it (I_ZERO is a constant input of 0). The loops are written
        # out here, not in a function: numba counts the references of every array handed to an inlined function,
        # atomically, at every stage (126 counts per step of 16 lanes, a quarter of the step's time)
        if kind == I_HOPF:
            for l in range(L):
                x = lane(YT, l)
                w = command(input_value(I_HOPF, (IPL[0, l], IPL[1, l], IPL[2, l], IPL[3, l]), T[l] + cs * H[l], x),
                            cps)
                rhs_of(M_PLAIN, x, w, lane(PL, l), slab_lane(K, s, l))
        elif kind == I_CHIRP:
            for l in range(L):
                x = lane(YT, l)
                w = command(input_value(I_CHIRP, (IPL[0, l], IPL[1, l], IPL[2, l], IPL[3, l]), T[l] + cs * H[l], x),
                            cps)
                rhs_of(M_PLAIN, x, w, lane(PL, l), slab_lane(K, s, l))
        elif kind == I_SINE:
            for l in range(L):
                x = lane(YT, l)
                w = command(input_value(I_SINE, (IPL[0, l], IPL[1, l], IPL[2, l], IPL[3, l]), T[l] + cs * H[l], x),
                            cps)
                rhs_of(M_PLAIN, x, w, lane(PL, l), slab_lane(K, s, l))
        else:
            for l in range(L):
                x = lane(YT, l)
                w = command(input_value(I_CONST, (IPL[0, l], IPL[1, l], IPL[2, l], IPL[3, l]), T[l] + cs * H[l], x),
                            cps)
                rhs_of(M_PLAIN, x, w, lane(PL, l), slab_lane(K, s, l))


@jit(vector=True)
def flush_dense(kind, cps, ds, nd, X, t_out, n):
    """The dense outputs of the first ``nd`` slots of ``ds``, side by side, into their rows of ``X``.

    Stages 13-15 (:func:`plain_stages`) and the interpolants' coefficients
    (:func:`~iwp.sim.dop853.dense_coefficients_lanes`, into ``ds.F``) of all
    slots at once, then per slot its samples (:func:`~iwp.sim.dop853.interpolant`):
    the interpolant :func:`~iwp.sim.engine.dense_step` and :func:`lane_outputs`
    compute for one lane. No array is handed to a function per slot or per
    sample: each such call cost numba two atomic reference counts per array
    (six per sample, a sixth of a sweep's time at 50 ms outputs), and a call
    of this function hands it 14, so it runs once per ``N_SLOTS`` steps.
    The coefficients are computed without reassociation: with it, the
    vectorised sums rounded differently when numba compiled them than when
    it loaded them from its cache, so that a sweep's numbers depended on
    where it ran.

    Parameters
    ----------
    kind : int
        The input's kind, one of :data:`VECTOR_KINDS`.
    cps : tuple
        The command vector.
    ds : DenseSlots
        The deferred steps.
    nd : int
        Number of slots filled (at most ``N_SLOTS``).
    X : ndarray
        States of the batch (n_runs, n_out, n).
    t_out : ndarray
        Output times (n_out,).
    n : int
        Number of states.
    """
    if nd == 0:
        return
    # every slot, the stale ones too (finite: earlier steps, or zeros): a fixed count, so no remainder of slots is
    # left to scalar code; the configuration checked to round the same compiled and loaded from the cache
    plain_stages(kind, cps, (ds.T, ds.Y, ds.H), ds.K, ds.YT, ds.IPL, ds.PL, n, (N_STAGES + 1, 16, N_SLOTS))
    F = ds.F
    Y = ds.Y
    dense_coefficients_lanes(ds.K, ds.H, Y, ds.YN, F, n, N_SLOTS)
    for k in range(nd):
        r = ds.R[k]
        t = ds.T[k]
        rh = 1.0 / ds.H[k]
        for j in range(ds.J0[k], ds.J1[k]):
            th = (t_out[j] - t) * rh
            for i in range(n):
                c = (F[0, i, k], F[1, i, k], F[2, i, k], F[3, i, k], F[4, i, k], F[5, i, k], F[6, i, k])
                X[r, j, i] = interpolant(c, Y[i, k], th)


@jit
def new_slots(n):
    """Empty :class:`DenseSlots` of ``N_SLOTS`` slots for ``n`` states."""
    L = N_SLOTS
    return DenseSlots(np.zeros(L), np.zeros((n, L)), np.ones(L), np.zeros((16, n, L)), np.zeros((n, L)),
                      np.zeros((n, L)), np.zeros((N_INPUT_PARAMS, L)), np.zeros((N_PACK, L)),
                      np.zeros(L, dtype=np.int64), np.zeros(L, dtype=np.int64), np.zeros(L, dtype=np.int64),
                      np.zeros((7, n, L)))


@jit
def vectorised(model, kind, seg_mode, P, r0, r1):
    """True if runs ``r0 .. r1-1`` take the vectorised path: model (9) without optional terms
    (:func:`~iwp.models.equations.optional_terms_off`) under an input of :data:`VECTOR_KINDS`.

    Parameters
    ----------
    model, kind, seg_mode : int
        The model's code, the input's kind and the segments' mode of the batch.
    P : ndarray, shape (n_runs, N_PACK)
        The packed parameters per run.
    r0, r1 : int
        The runs ``r0 .. r1-1``.

    Returns
    -------
    bool
    """
    if kind not in VECTOR_KINDS or is_held(kind, seg_mode):
        return False
    for r in range(r0, r1):
        if not optional_terms_off(model, P[r]):
            return False
    return True


@jit(vector=True)
def run_lanes(n, bt, tol, out, r0, r1):
    """Simulations ``r0 .. r1-1`` of a :class:`Batch`, ``LANES`` at a time, into the :class:`BatchOutput`.

    The runs are those :func:`vectorised` accepts (model (9) without optional
    terms under an input of :data:`VECTOR_KINDS`): their stages are :func:`plain_stages`.
    :func:`iwp.sim.simulate.simulate_batch` runs any other batch as single runs.
    """
    L = LANES
    model = bt.model
    t0 = bt.t0
    t_end = bt.t_end
    t_out = out.t
    n_out = t_out.size
    cps = tuple_of(bt.command_params, N_COMMAND)
    h_max = tol.h_max
    xmax = tol.xmax
    tol_t = 1e-9 * max(1.0, abs(t_end))
    # lane arrays: column l is the simulation in lane l; idle lanes hold a
    # copy of the first run, so that their (unused) stages stay finite
    Y = np.empty((n, L))
    F = np.zeros((n, L))
    YT = np.empty((n, L))
    K = np.zeros((16, n, L))
    PL = np.empty((N_PACK, L))
    IPL = np.empty((N_INPUT_PARAMS, L))
    for l in range(L):
        for i in range(n):
            Y[i, l] = bt.X0[r0, i]
        for k in range(N_PACK):
            PL[k, l] = bt.P[r0, k]
        for k in range(N_INPUT_PARAMS):
            IPL[k, l] = bt.input_params[r0, k]
    H = np.zeros(L)
    ERR = np.zeros(L)
    T = np.full(L, t0)
    TNEXT = np.full(L, np.inf)  # next output time
    HN = np.zeros(L)  # natural step size
    HF = np.full(L, -1.0)  # forced step size (a kink landed on)
    LERRP = np.zeros(L)  # log of the previous error (PI control)
    HLAST = np.full(L, -1.0)
    ALAST = np.zeros(L)
    RUN = np.full(L, r0)
    ACTIVE = np.zeros(L, dtype=np.bool_)
    MODE = np.full(L, M_PLAN)
    PLAN = np.zeros(L, dtype=np.int64)
    J = np.zeros(L, dtype=np.int64)
    NFEV = np.zeros(L, dtype=np.int64)
    NACC = np.zeros(L, dtype=np.int64)
    NREJ = np.zeros(L, dtype=np.int64)
    STAT = np.zeros(L, dtype=np.int64)
    REJ = np.zeros(L, dtype=np.bool_)
    BRIDGED = np.zeros(L, dtype=np.bool_)
    KINKED = np.zeros(L, dtype=np.bool_)
    DONE = np.zeros(L, dtype=np.bool_)
    REJD = np.zeros(L, dtype=np.bool_)  # its ordinary step was rejected side by side
    # the kink ahead of the lanes near one, searched side by side (kink_ahead's iterations)
    NEAR = np.zeros(L, dtype=np.bool_)
    LIVE = np.zeros(L, dtype=np.bool_)
    CLIP = np.zeros(L, dtype=np.bool_)
    POST = np.zeros(L, dtype=np.bool_)
    USUAL = np.zeros(L, dtype=np.bool_)
    JK = np.zeros(L)
    KH = np.zeros(L)
    KQ = np.zeros(L)
    KS = np.zeros(L)
    KLO = np.zeros(L)
    KHI = np.zeros(L)
    KPLO = np.zeros(L)
    # one lane's state, for the lane-by-lane work
    ys = np.empty(n)
    fs = np.empty(n)
    wk = new_work(n)
    bw = bridge_work(wk, tol)
    # dense outputs of ordinary steps, deferred and computed N_SLOTS at a time
    defer = out.store == STORE_SAMPLES
    # (filled through these names: numba lost writes made through the record's fields here)
    ds = new_slots(n)
    DT, DY, DH, DK, _, DYN, DIPL, DPL, DR, DJ0, DJ1, _ = ds
    nd = 0
    nxt = r0
    n_active = 0
    halt = out.halt
    while True:
        if halt[0] != 0:  # asked to stop (an interrupt: the caller discards the batch)
            return 1
        # ---- 1. lane by lane, where needed
        for l in range(L):
            mode = MODE[l]
            if mode == M_READY or mode == M_IDLE:
                continue
            r = RUN[l]
            for i in range(n):
                ys[i] = Y[i, l]
                fs[i] = F[i, l]
            if mode == M_DECIDE:
                # conclude a step that was not an ordinary one (as integrate does)
                t = T[l]
                h = H[l]
                err = ERR[l]
                NFEV[l] += N_STAGES
                mode = M_PLAN
                if not (err < 1.0):
                    NREJ[l] += 1
                    HN[l] = h * reject_factor(err)
                    REJ[l] = True
                    if HN[l] < min_step(t):
                        STAT[l] = ST_STEP_TOO_SMALL
                else:
                    g_cur = switch_of(KINKED[l], ys[0])
                    g_new = switch_of(KINKED[l], YT[0, l])
                    crossing = PLAN[l] & FORCED == 0 and g_cur * g_new < 0.0
                    t_new = t_end if PLAN[l] & CLIPPED != 0 else t + h
                    dense = crossing or TNEXT[l] < t_new - tol_t
                    h_force = -1.0
                    if dense:
                        fld = run_field(bt, r)
                        lane_step_into(K, YT, l, wk.K, wk.y_new, n)
                        dense_step(fld, t, ys, h, wk, n)
                        NFEV[l] += 3
                        if crossing:
                            h_force = kink_step(fld, wk.F, ys, h, t, g_cur, g_new, wk.yo, wk.dx, n, KINKS)
                    if h_force > 0.0 and h_force < h:
                        NREJ[l] += 1
                        HF[l] = h_force
                    else:
                        factor, LERRP[l] = accept_step(err, LERRP[l])
                        if REJ[l]:
                            factor = min(1.0, factor)
                        REJ[l] = False
                        HN[l] = next_step_size(h, HN[l], factor, PLAN[l] == 0)
                        NACC[l] += 1
                        if dense:
                            J[l] = lane_outputs(out, r, J[l], (t, h, t_new - tol_t), ys, fld, wk)
                        ALAST[l] = F[2, l]
                        HLAST[l] = t_new - t
                        for i in range(n):
                            fs[i] = K[N_STAGES, i, l]
                            ys[i] = YT[i, l]
                            F[i, l] = fs[i]
                            Y[i, l] = ys[i]
                        T[l] = t_new
                        mode = M_POST
            if mode == M_POST:
                # after an accepted step: divergence, outputs exactly at an interior step end
                mode = M_PLAN
                if beyond(ys, n, xmax):
                    STAT[l] = ST_DIVERGED
                elif T[l] < t_end - tol_t and J[l] < n_out and t_out[J[l]] <= T[l] + tol_t:
                    o = run_output(out, r)
                    fld = run_field(bt, r)
                    j = J[l]
                    while j < n_out and t_out[j] <= T[l] + tol_t:
                        put_near(o, j, t_out[j], ys, fs, T[l], n, fld, wk.yo)
                        j += 1
                    J[l] = j
            # ---- plan the next step (several when it bridges a kink); finish and start runs
            while mode == M_PLAN or mode == M_BRIDGE:
                bridge_now = mode == M_BRIDGE
                mode = M_PLAN
                if ACTIVE[l] and (STAT[l] != ST_OK or T[l] >= t_end - tol_t):
                    # ---- the run in this lane is done
                    o = run_output(out, r)
                    fld = run_field(bt, r)
                    j = J[l]
                    if STAT[l] == ST_OK:
                        while j < n_out and t_out[j] <= t_end + tol_t:
                            put_near(o, j, t_out[j], ys, fs, T[l], n, fld, wk.yo)
                            j += 1
                    if nd > 0:
                        # the run's deferred samples first (its input columns follow from them)
                        flush_dense(bt.kind, cps, ds, nd, out.X, t_out, n)
                        nd = 0
                    if out.store == STORE_SAMPLES and o.U.size == t_out.size:
                        input_samples(bt.kind, fld.input_params, fld.command_params, t_out[:j], o.X[:j], o.U[:j],
                                      o.W[:j])
                    put_unreached(o, j, n)
                    for i in range(n):
                        out.x_final[r, i] = ys[i]
                    out.status[r] = STAT[l]
                    out.nfev[r] = NFEV[l]
                    out.n_steps[r] = NACC[l]
                    out.n_rejected[r] = NREJ[l]
                    ACTIVE[l] = False
                    n_active -= 1
                if not ACTIVE[l]:
                    if nxt >= r1:
                        mode = M_IDLE
                        H[l] = 0.0
                        break
                    # ---- start the next run in this lane
                    r = nxt
                    nxt += 1
                    RUN[l] = r
                    ACTIVE[l] = True
                    n_active += 1
                    for k in range(N_PACK):
                        PL[k, l] = bt.P[r, k]
                    for k in range(N_INPUT_PARAMS):
                        IPL[k, l] = bt.input_params[r, k]
                    for i in range(n):
                        ys[i] = bt.X0[r, i]
                        Y[i, l] = ys[i]
                    KINKED[l] = has_kink(model, tuple_of(bt.P[r], N_PACK))
                    T[l] = t0
                    HN[l] = -1.0
                    STAT[l] = ST_OK
                    J[l] = 0
                    NFEV[l] = 0
                    NACC[l] = 0
                    NREJ[l] = 0
                    if beyond(ys, n, xmax):
                        STAT[l] = ST_DIVERGED
                        continue
                    # the run's first rate, its outputs at t0 and its first step (the input is not held: one
                    # segment to t_end)
                    o = run_output(out, r)
                    fld = run_field(bt, r)
                    rate(fld, T[l], ys, fs)
                    NFEV[l] += 1
                    for i in range(n):
                        F[i, l] = fs[i]
                    j = J[l]
                    while j < n_out and t_out[j] <= T[l] + tol_t:
                        put_near(o, j, t_out[j], ys, fs, T[l], n, fld, wk.yo)
                        j += 1
                    J[l] = j
                    HN[l] = first_step(fld, T[l], ys, fs, wk, n, tol)
                    NFEV[l] += 1
                    REJ[l] = False
                    HF[l] = -1.0
                    LERRP[l] = LERR_FLOOR
                    HLAST[l] = -1.0
                    ALAST[l] = 0.0
                    BRIDGED[l] = False
                if NACC[l] + NREJ[l] >= tol.max_steps:
                    STAT[l] = ST_MAX_STEPS
                    continue
                t = T[l]
                jk = (fs[2] - ALAST[l]) / HLAST[l] if HLAST[l] > 0.0 else 0.0
                taylor = (ys[0], fs[0], fs[2], jk)
                if bridge_now:
                    p_flags = BRIDGE
                    p_h = H[l]
                else:
                    plan = plan_step(t, t_end, HN[l], h_max, HF[l], KINKED[l] and not BRIDGED[l], taylor, tol_t)
                    p_flags = plan.flags
                    p_h = plan.h
                HF[l] = -1.0
                BRIDGED[l] = False
                if p_flags == BRIDGE:
                    # ---- an RK4 step across a kink close ahead (its rate a PlainField's: no dispatch on the model)
                    hb = p_h
                    pf = PlainField(bt.kind, (IPL[0, l], IPL[1, l], IPL[2, l], IPL[3, l]), cps, lane(PL, l))
                    eb = rk4_bridge(pf, t, vec(ys), vec(fs), hb, bw, n)
                    NFEV[l] += 4
                    if eb < 1.0:
                        j = J[l]
                        if j < n_out and t_out[j] < t + hb - tol_t:
                            # (the output record only for samples: building it costs reference counting)
                            o = run_output(out, r)
                            fld = run_field(bt, r)
                            while j < n_out and t_out[j] < t + hb - tol_t:
                                hermite(ys, wk.y_new, fs, wk.dx, hb, (t_out[j] - t) / hb, wk.yo, n)
                                put_sample(o, j, t_out[j], wk.yo, n, fld)
                                j += 1
                        ALAST[l] = fs[2]
                        HLAST[l] = hb
                        for i in range(n):
                            fs[i] = wk.dx[i]
                            ys[i] = wk.y_new[i]
                            F[i, l] = fs[i]
                            Y[i, l] = ys[i]
                        t = t + hb
                        T[l] = t
                        NACC[l] += 1
                        BRIDGED[l] = True
                        if beyond(ys, n, xmax):
                            STAT[l] = ST_DIVERGED
                        elif j < n_out and t_out[j] <= t + tol_t:
                            o = run_output(out, r)
                            fld = run_field(bt, r)
                            while j < n_out and t_out[j] <= t + tol_t:
                                put_near(o, j, t_out[j], ys, fs, t, n, fld, wk.yo)
                                j += 1
                        J[l] = j
                        continue
                    plan = plan_step(t, t_end, HN[l], h_max, -1.0, False, taylor, tol_t)
                    p_flags = plan.flags
                    p_h = plan.h
                if p_h < min_step(t):
                    STAT[l] = ST_STEP_TOO_SMALL
                    continue
                H[l] = p_h
                PLAN[l] = p_flags
                mode = M_READY
            MODE[l] = mode
            TNEXT[l] = t_out[J[l]] if J[l] < n_out else np.inf
        if n_active == 0:
            break
        # ---- 2. all lanes: the stages and the error norms
        for i in range(n):
            for l in range(L):
                K[0, i, l] = F[i, l]
        plain_stages(bt.kind, cps, (T, Y, H), K, YT, IPL, PL, n, (1, N_STAGES + 1, L))
        error_norm_lanes(K, H, Y, YT, tol.rtol, tol.atol, n, L, ERR)
        # ---- 3. all lanes: accept the ordinary steps, reject those too large (branch-free but for the
        # controller's factor); a step that may cross a kink is concluded lane by lane (with the cosine)
        for l in range(L):
            crossless = (not KINKED[l]) | (PLAN[l] & FORCED != 0) | (not may_cross(Y[0, l], YT[0, l]))
            ready = MODE[l] == M_READY
            ok = ready & (ERR[l] < 1.0) & (PLAN[l] & (FORCED | CLIPPED) == 0) & crossless
            # a rejection here (as M_DECIDE has it) unless the next step may fall below min_step (the factor is
            # at least MIN_FACTOR)
            rejd = ready & (not (ERR[l] < 1.0)) & (MIN_FACTOR * H[l] > min_step_bound(T[l]))
            DONE[l] = ok
            REJD[l] = rejd
            MODE[l] = M_DECIDE if ready and not ok and not rejd else MODE[l]
            NREJ[l] += 1 if rejd else 0
            NFEV[l] += N_STAGES if rejd else 0
        for l in range(L):
            # (libm's pow, as a single run has it, for the few rejected lanes)
            if REJD[l]:
                HN[l] = H[l] * reject_factor(ERR[l])
        for l in range(L):
            # outputs inside an accepted ordinary step: its dense output, lane by lane
            if defer and DONE[l] and TNEXT[l] < T[l] + H[l] - tol_t:
                # into a slot: stages 13-15 and the samples when N_SLOTS slots are full
                t_stop = T[l] + H[l] - tol_t
                j = J[l]
                DJ0[nd] = j
                while j < n_out and t_out[j] < t_stop:
                    j += 1
                DJ1[nd] = j
                DR[nd] = RUN[l]
                DT[nd] = T[l]
                DH[nd] = H[l]
                for i in range(n):
                    DY[i, nd] = Y[i, l]
                    DYN[i, nd] = YT[i, l]
                    for s in range(N_STAGES + 1):
                        DK[s, i, nd] = K[s, i, l]
                for k in range(N_PACK):
                    DPL[k, nd] = PL[k, l]
                for k in range(N_INPUT_PARAMS):
                    DIPL[k, nd] = IPL[k, l]
                nd += 1
                if nd == N_SLOTS:
                    flush_dense(bt.kind, cps, ds, nd, out.X, t_out, n)
                    nd = 0
                NFEV[l] += 3
                J[l] = j
                TNEXT[l] = t_out[j] if j < n_out else np.inf
            elif DONE[l] and TNEXT[l] < T[l] + H[l] - tol_t:
                for i in range(n):
                    ys[i] = Y[i, l]
                fld = run_field(bt, RUN[l])
                lane_step_into(K, YT, l, wk.K, wk.y_new, n)
                dense_step(fld, T[l], ys, H[l], wk, n)
                NFEV[l] += 3
                J[l] = lane_outputs(out, RUN[l], J[l], (T[l], H[l], T[l] + H[l] - tol_t), ys, fld, wk)
                TNEXT[l] = t_out[J[l]] if J[l] < n_out else np.inf
        for l in range(L):
            ok = DONE[l]
            h = H[l]
            ALAST[l] = F[2, l] if ok else ALAST[l]
            # t_new - t, as integrate has it (not h: they differ by rounding)
            HLAST[l] = (T[l] + h) - T[l] if ok else HLAST[l]
            T[l] = T[l] + h if ok else T[l]
            NACC[l] += 1 if ok else 0
            NFEV[l] += N_STAGES if ok else 0
        for l in range(L):
            # the controller, all lanes at once (branch-free; the lanes of other steps keep theirs)
            ok = DONE[l]
            factor, lerr = accept_step(ERR[l], LERRP[l])
            factor = min(1.0, factor) if REJ[l] else factor
            hn = next_step_size(H[l], HN[l], factor, PLAN[l] == 0)
            LERRP[l] = lerr if ok else LERRP[l]
            HN[l] = hn if ok else HN[l]
            REJ[l] = (REJ[l] and not ok) or REJD[l]
        for i in range(n):
            for l in range(L):
                Y[i, l] = YT[i, l] if DONE[l] else Y[i, l]
                F[i, l] = K[N_STAGES, i, l] if DONE[l] else F[i, l]
        # ---- 4. all lanes: plan the next steps after an accepted or rejected ordinary step, those that end
        # short of a kink ahead too (as plan_step has them); the others lane by lane
        # (in loops that write few arrays each: the compiler vectorises a loop only when it can check at run
        # time that the arrays it writes overlap none of the others, and gives up beyond a few)
        for l in range(L):
            h = min(HN[l], h_max)
            clip = T[l] + h > t_end
            KH[l] = t_end - T[l] if clip else h
            CLIP[l] = clip
        for l in range(L):
            JK[l] = (F[2, l] - ALAST[l]) / HLAST[l] if HLAST[l] > 0.0 else 0.0
        for l in range(L):
            bad = False
            for i in range(n):
                bad = bad | (not (abs(Y[i, l]) < xmax))
            POST[l] = DONE[l] & (bad | (TNEXT[l] <= T[l] + tol_t))
        for l in range(L):
            slow = (KH[l] < min_step_bound(T[l])) | (NACC[l] + NREJ[l] >= tol.max_steps)
            USUAL[l] = (DONE[l] | REJD[l]) & (not POST[l]) & (not slow) & (not CLIP[l])
        n_near = 0
        for l in range(L):
            near = USUAL[l] & KINKED[l] & (not BRIDGED[l]) & kink_possible(Y[0, l], F[0, l], F[2, l], JK[l], KH[l])
            NEAR[l] = near
            n_near += 1 if near else 0
        for l in range(L):
            plan_here = USUAL[l] & (not NEAR[l])
            cand = DONE[l] | REJD[l]
            H[l] = KH[l] if plan_here else H[l]
            PLAN[l] = 0 if plan_here else PLAN[l]
            BRIDGED[l] = BRIDGED[l] and not plan_here
            mode = M_READY if plan_here else (M_POST if POST[l] else M_PLAN)
            MODE[l] = mode if cand else MODE[l]
        if n_near > 0:
            # the kink ahead (kink_ahead, the same iterations side by side); a step ends short of it unless it is
            # close enough for an RK4 bridge, which plan_step decides lane by lane
            # (a lane near a kink is one where kink_start finds it possible; three loops that write few arrays)
            for l in range(L):
                k_q, k_s, _, _, _, _ = kink_start(Y[0, l], F[0, l], F[2, l], JK[l], KH[l])
                KQ[l] = k_q
                KS[l] = k_s
            for l in range(L):
                _, _, k_lo, k_hi, k_plo, _ = kink_start(Y[0, l], F[0, l], F[2, l], JK[l], KH[l])
                KLO[l] = k_lo
                KHI[l] = k_hi
                KPLO[l] = k_plo
            for l in range(L):
                LIVE[l] = NEAR[l]
            for _it in range(KINK_ITERATIONS):
                n_left = 0
                for l in range(L):
                    k_s, k_lo, k_hi, k_plo, done = kink_newton(Y[0, l], KQ[l], F[0, l], F[2, l], JK[l], KH[l], KS[l],
                                                       KLO[l], KHI[l], KPLO[l])
                    live = LIVE[l]
                    KS[l] = k_s if live else KS[l]
                    KLO[l] = k_lo if live else KLO[l]
                    KPLO[l] = k_plo if live else KPLO[l]
                    KHI[l] = k_hi if live else KHI[l]
                    LIVE[l] = live & (not done)
                    n_left += 1 if live & (not done) else 0
                if n_left == 0:
                    break
            for l in range(L):
                s_k = KS[l] if KS[l] > 0.0 else KINK_TINY
                k_flags, k_h = kink_plan(T[l], t_end, KH[l], HN[l], s_k, tol_t)
                short = NEAR[l] & (k_flags == SHORT) & (k_h >= min_step_bound(T[l]))
                bridge = NEAR[l] & (k_flags == BRIDGE)
                H[l] = k_h if short | bridge else H[l]
                PLAN[l] = SHORT if short else PLAN[l]
                MODE[l] = M_READY if short else (M_BRIDGE if bridge else MODE[l])
    flush_dense(bt.kind, cps, ds, nd, out.X, t_out, n)
    return 0


@once_per_argument
def _make_kernel(n: int):
    """The batch of runs side by side for ``n`` states (a compile-time constant inside it)."""

    def lanes_(bt, tol, out, nb):
        # numba's parallel loop takes arrays and scalars, not records of arrays:
        # the records are taken apart here and put together in each thread
        model, P, X0, kind, ips, cps, seg, t0, t_end = bt
        mode, period, start, values, external = seg
        rtol, atol, h_max, max_steps, xmax, n_err = tol
        t, store, X, U, W, S, x_final, status, nfev, n_steps, n_rejected, halt = out
        nrun = X0.shape[0]
        for b in prange(nb):
            run_lanes(
                n,
                Batch(model, P, X0, kind, ips, cps, Segments(mode, period, start, values, external), t0, t_end),
                Tolerances(rtol, atol, h_max, max_steps, xmax, n_err),
                BatchOutput(t, store, X, U, W, S, x_final, status, nfev, n_steps, n_rejected, halt),
                b * nrun // nb,
                (b + 1) * nrun // nb,
            )

    lanes_.__name__ = lanes_.__qualname__ = f"run_lanes_{n}"
    return jit(lanes_, parallel=True)


def kernel(n_states: int):
    """The lane kernel for ``n_states`` states (compiled on first use, then cached on disk).

    Called as ``kernel(n)(batch, tol, out, nb)`` with a :class:`Batch`, the
    engine's :class:`~iwp.sim.engine.Tolerances` and a :class:`BatchOutput`;
    ``nb`` is the number of blocks of runs (one per thread, at least one run each).

    Parameters
    ----------
    n_states : int
        Number of states of the model (4, or 6 with the belt (15)).

    Returns
    -------
    numba dispatcher
        The lanes' run for that state size (the same object on every call).
    """
    return _make_kernel(int(n_states))


__all__ = ["Batch", "BatchOutput", "LANES", "VECTOR_KINDS", "kernel", "run_lanes", "vectorised"]

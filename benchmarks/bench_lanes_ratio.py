"""The batch engine's in-run ratio (issues 18 and 20): ns per lane-RHS over the RHS alone.

2,000 closed loops of model (9) with the Hopf law (k1 from -12 to -6,
k2 = 0.1), 300 s each, rtol 1e-9, atol 1e-7, outputs every 0.5 s, through
:func:`iwp.sim.simulate_batch`. The figure is the CPU time of all threads
over the right-hand-side evaluations the runs counted (so per core), divided
by the vectorised right-hand side alone on 16 lanes measured in the same
process, each repeat in turn; on cores shared with other work the best of
the repeats over the best is the steadier figure. That ratio is what bench_simulate's batch section reports; this
script measures only it, so that a version of iwp before and after a change
can be compared in one session (``PYTHONPATH=<worktree>/src``). Versions
without ``store=`` report the samples only; versions before
:class:`~iwp.sim.BatchOptions` get the options as keywords.

Run: python benchmarks/bench_lanes_ratio.py [--runs N] [--repeat R]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from numba import njit
from numba.np.unsafe.ndarray import to_fixed_tuple

from iwp.jit import FASTMATH
from iwp.models import Plant, table1
from iwp.models.actuator import command
from iwp.models.equations import rhs_of
from iwp.models.layout import M_PLAIN, N_COMMAND, N_PACK
from iwp.sim import HopfController, simulate_batch

try:
    from iwp.sim import BatchOptions, Tolerances
except ImportError:  # a version of iwp before the options objects: the options as keywords
    BatchOptions = Tolerances = None
from iwp.sim.dop853 import N_STAGES
from iwp.sim.inputs import I_HOPF, input_value
from iwp.sim.simulate import command_of
from iwp.sim.views import lane, slab_lane

#: lanes of the RHS-alone baseline (those of iwp.sim.lanes)
LANES = 16


# not cached: compiled against whichever iwp is on the path
@njit(cache=False, fastmath=FASTMATH)
def rhs_alone(P_arr, command_arr, k1s, reps):
    """The vectorised right-hand side of model (9) with the Hopf law on LANES lanes, ``reps`` x 12 times."""
    L = LANES
    P = np.empty((N_PACK, L))
    IP = np.zeros((4, L))
    for l in range(L):
        P[:, l] = P_arr
        IP[0, l] = k1s[l]
        IP[1, l] = 0.1
    cps = to_fixed_tuple(command_arr, N_COMMAND)
    Y = np.zeros((4, L))
    K = np.zeros((16, 4, L))
    for l in range(L):
        Y[0, l] = 0.1 + 1e-3 * l
    acc = 0.0
    for _ in range(reps):
        for s in range(1, N_STAGES + 1):
            for l in range(L):
                x = lane(Y, l)
                w = command(input_value(I_HOPF, (IP[0, l], IP[1, l], IP[2, l], IP[3, l]), 0.0, x), cps)
                rhs_of(M_PLAIN, x, w, lane(P, l), slab_lane(K, s, l))
            for l in range(L):
                Y[2, l] += 1e-9 * K[s, 3, l]
        acc += K[5, 2, 0]
    return acc


def cpu_of(fn):
    """CPU seconds over all threads of one call, and its result."""
    c0 = time.process_time()
    out = fn()
    return time.process_time() - c0, out


def ns_rhs_alone(p, reps=200_000):
    """ns per lane-RHS of :func:`rhs_alone` (CPU time)."""
    P = np.array(Plant(p).packed())
    cvec = np.ascontiguousarray(command_of(Plant(p)))
    k1l = np.linspace(-12.0, -6.0, LANES)
    rhs_alone(P, cvec, k1l, 10)
    c, _ = cpu_of(lambda: rhs_alone(P, cvec, k1l, reps))
    return 1e9 * c / (reps * N_STAGES * LANES)


def options(store=None) -> dict:
    """The batch's keywords of its tolerances (rtol 1e-9, atol 1e-7) and ``store``, for this version of iwp."""
    if BatchOptions is None:
        return {"rtol": 1e-9, "atol": 1e-7, **({} if store is None else {"store": store})}
    tol = Tolerances(rtol=1e-9, atol=1e-7)
    return {"options": BatchOptions(tolerances=tol) if store is None else BatchOptions(tolerances=tol, store=store)}


def ns_batch(p, ctrls, kw, store):
    """ns per lane-RHS of one batch (CPU time over the evaluations the runs counted)."""
    c, bb = cpu_of(lambda: simulate_batch(p, input=ctrls, **kw, **options(store)))
    return 1e9 * c / bb.nfev.sum()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=2000, help="closed loops per batch (default 2000)")
    ap.add_argument("--repeat", type=int, default=3, help="measurements of each figure (default 3)")
    args = ap.parse_args()
    p = table1()
    ctrls = [HopfController(float(k), 0.1) for k in np.linspace(-12.0, -6.0, args.runs)]
    kw = dict(x0=[0.1, 0.0, 0.0, 0.0], t_end=300.0, t_eval=np.arange(0.0, 300.0 + 1e-9, 0.5))
    try:
        simulate_batch(p, input=ctrls[:4], **kw, **options("final"))
        stores = ("samples", "final")
    except TypeError:
        stores = (None,)
    simulate_batch(p, input=ctrls[:4], **kw, **options())
    rows = {s: [] for s in stores}
    rhs = []
    for _ in range(args.repeat):
        rhs.append(ns_rhs_alone(p))
        for s in stores:
            rows[s].append(ns_batch(p, ctrls, kw, s))
    print(f"RHS alone on {LANES} lanes [ns per lane-RHS]: " + ", ".join(f"{v:.2f}" for v in rhs))
    for s in stores:
        name = "samples" if s is None else s
        print(f"batch store={name} [ns per lane-RHS]: " + ", ".join(f"{v:.2f}" for v in rows[s]))
        print("  / RHS alone, each repeat: " + ", ".join(f"{v / r:.2f}" for v, r in zip(rows[s], rhs))
              + f"; best over best: {min(rows[s]) / min(rhs):.2f}")


if __name__ == "__main__":
    main()

"""One chunk of a sweep: its lanes through the batch engine, and their metrics (:func:`run_chunk`).

This is the unit of work that runs locally or on a Dask worker; it depends
only on the spec and the chunk's index, so that it gives the same numbers
wherever it runs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numba
import numpy as np

from ..control import lqr_balance
from ..models.parameters import PARAMETER_INFO
from ..sim import BatchResult, CallableController, HopfController, simulate, simulate_batch
from ..sim.options import BatchOptions, SimOptions, Tolerances
from ..sim.simulate import output_times
from .metrics import closed_loop_metrics
from .spec import LaneSet, SweepSpec, lanes_of_chunk

__all__ = ["ChunkResult", "run_chunk", "STATUS_UNPHYSICAL", "METRIC_COLUMNS", "SLICE_BYTES", "column_names", "slices"]

#: Status of a lane whose drawn or gridded parameters leave the physical range (not simulated).
STATUS_UNPHYSICAL = -1


@dataclass(frozen=True, eq=False)
class ChunkResult:
    """The rows of one chunk.

    Attributes
    ----------
    index : int
        The chunk's index.
    columns : dict of str to ndarray
        ``lane``, the varied values, then the metrics (:data:`~iwp.sweep.metrics.METRICS`), one row per lane.
    seconds : float
        Wall time of the chunk where it ran [s].
    cpu_seconds : float
        CPU time of the process that ran it, over the chunk (all its threads) [s]: the chunk's own
        CPU time where one chunk runs per process at a time (locally; a Dask worker of one thread).
    """

    index: int
    columns: dict
    seconds: float
    cpu_seconds: float = float("nan")

    @property
    def n_rows(self) -> int:
        return int(self.columns["lane"].size)


def _hopf(spec: SweepSpec, ls: LaneSet, sel: np.ndarray) -> BatchResult:
    shared = not any(n in ls.values for n in PARAMETER_INFO)
    plant = spec.plant(spec.params) if shared else [spec.plant(ls.params[i], ls.belts[i]) for i in sel]
    inputs = [HopfController(float(ls.k1[i]), float(ls.k2[i]), spec.controller_Ts) for i in sel]
    x0 = [ls.x0[i].tolist() for i in sel]
    return simulate_batch(plant, x0=x0, input=inputs, t_end=spec.t_end, Ts=spec.sample_time,
                          options=BatchOptions(tolerances=Tolerances(rtol=spec.rtol, atol=spec.atol)))


def _lqr(spec: SweepSpec, ls: LaneSet, sel: np.ndarray) -> BatchResult:
    # designed on the nominal parameters, run on every lane's plant (a controller designed on a fit); a Python
    # law sampled every lqr_Ts, so one lane at a time (the batch engine runs compiled laws only)
    law = lqr_balance(spec.params, Q=spec.lqr_Q, R=spec.lqr_R, u_max=spec.lqr_u_max, Ts=spec.lqr_Ts)
    ctrl = CallableController(lambda t, x: law(x), Ts=spec.lqr_Ts)
    t = output_times(0.0, spec.t_end, spec.sample_time)
    x = np.full((sel.size, t.size, 4), np.nan)
    u = np.full((sel.size, t.size), np.nan)
    w = np.full((sel.size, t.size), np.nan)
    status = np.zeros(sel.size, dtype=np.int64)
    nfev = np.zeros(sel.size, dtype=np.int64)
    for k, i in enumerate(sel):
        r = simulate(spec.plant(ls.params[i], ls.belts[i]), x0=ls.x0[i], t_end=spec.t_end, Ts=spec.sample_time,
                     input=ctrl, options=SimOptions(tolerances=Tolerances(rtol=spec.rtol, atol=spec.atol), check=False))
        n = r.t.size
        x[k, :n], u[k, :n], w[k, :n] = r.x[:, :4], r.u, r.command
        status[k], nfev[k] = r.status, r.nfev
    return BatchResult(t=t, x=x, u=u, command=w, status=status, nfev=nfev)


def run_chunk(spec: SweepSpec, index: int, *, threads: int | None = None) -> ChunkResult:
    """Run the lanes of chunk ``index`` and measure them.

    Parameters
    ----------
    spec : SweepSpec
    index : int
        The chunk (``0 .. spec.n_chunks - 1``).
    threads : int, optional
        Threads of the batch engine in this process (a Dask worker with one
        thread per worker: 1); None: all (numba's default).

    Returns
    -------
    ChunkResult
    """
    start = time.perf_counter()
    cpu = time.process_time()
    before = numba.get_num_threads()
    if threads is not None:
        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    try:
        columns = _columns(spec, index)
    finally:
        numba.set_num_threads(before)  # the caller's engine keeps its threads
    return ChunkResult(index=index, columns=columns, seconds=time.perf_counter() - start,
                       cpu_seconds=time.process_time() - cpu)


#: The metric columns of a chunk's table, after ``lane``, the varied values and ``status``; ``nfev`` last.
METRIC_COLUMNS = ("q1_end", "q2_end", "q3_end", "q4_end", "max_abs_q1", "amplitude", "amplitude_change", "period",
                  "rotating", "captured")


def column_names(spec: SweepSpec) -> list[str]:
    """The header of every chunk's table of ``spec``: ``lane``, the varied values, ``status``, the metrics, ``nfev``.

    Parameters
    ----------
    spec : SweepSpec

    Returns
    -------
    list of str
    """
    return ["lane", *lanes_of_chunk(spec, 0).values, "status", *METRIC_COLUMNS, "nfev"]


#: Largest outputs of one batch of a chunk [bytes]: a chunk's lanes run in slices whose states, input and
#: command stay within it. A chunk of 1,000 lanes of 300 s at 50 ms held 288 MB at once, which the system
#: zeroed page by page at every chunk (a third of the engine's time); 2,000 lanes cost 1.23-1.38 ms of CPU a
#: loop in batches of 1,000, 1.07-1.16 ms in batches of 128-512 (BENCHMARKS.md, "A sweep's outputs"). Each
#: lane is independent of the others in its batch: same numbers.
SLICE_BYTES = 64 * 2**20


def slices(spec: SweepSpec, sel: np.ndarray) -> list[np.ndarray]:
    """The lanes ``sel`` of a chunk in the slices that run as one batch (each within :data:`SLICE_BYTES`).

    Parameters
    ----------
    spec : SweepSpec
    sel : ndarray of int
        The chunk's lanes to simulate.

    Returns
    -------
    list of ndarray of int
    """
    per_lane = (spec.t_end / spec.sample_time + 1) * 6 * 8  # states, input and command at every output
    size = max(1, int(SLICE_BYTES // per_lane))
    return [sel[a:a + size] for a in range(0, sel.size, size)]


def _columns(spec: SweepSpec, index: int) -> dict:
    ls = lanes_of_chunk(spec, index)
    m = ls.lanes.size
    sel = np.flatnonzero(ls.physical)
    status = np.full(m, STATUS_UNPHYSICAL, dtype=np.int64)
    nfev = np.zeros(m, dtype=np.int64)
    # NaN for lanes not simulated; the flags (0/1) 0
    metrics = {k: np.zeros(m, dtype=np.int64) if k in ("rotating", "captured") else np.full(m, np.nan)
               for k in METRIC_COLUMNS}
    for part in slices(spec, sel):
        res = (_hopf if spec.law == "hopf" else _lqr)(spec, ls, part)
        status[part] = res.status
        nfev[part] = res.nfev
        got = closed_loop_metrics(res.t, res.x, np.asarray(res.status), law=spec.law, window=spec.window)
        del res  # before the next slice's outputs are allocated
        for k, v in got.items():
            metrics[k][part] = v
    columns = {"lane": ls.lanes.astype(np.int64), **{k: np.asarray(v, dtype=float) for k, v in ls.values.items()},
               "status": status}
    for k in METRIC_COLUMNS:
        columns[k] = metrics[k]
    columns["nfev"] = nfev
    return columns

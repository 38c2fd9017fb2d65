"""Run a sweep into its folder: :func:`run_sweep` and what it returns, :class:`SweepResult`."""

from __future__ import annotations

import datetime
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..control.robust import spread_of
from ..errors import InputError
from .executors import DaskExecutor, LocalExecutor, make_executor
from .spec import SweepSpec
from .store import RESULT_FORMATS, SweepStore

__all__ = ["run_sweep", "SweepResult", "SweepProgress", "MANIFEST_EVERY"]

#: The manifest's list of chunks done is brought up to date at most this often during a run [s] (and at its
#: end, also when interrupted); the chunk files on disk are what a resumed run goes by.
MANIFEST_EVERY = 5.0


@dataclass(frozen=True)
class SweepProgress:
    """Where a running sweep stands (given to the ``progress`` callback after every chunk).

    Attributes
    ----------
    chunk : int
        The chunk just written.
    done, total : int
        Chunks on disk, chunks of the sweep.
    computed : int
        Chunks computed by this run so far.
    lanes_done : int
        Lanes on disk.
    seconds : float
        Wall time of this run so far [s].
    """

    chunk: int
    done: int
    total: int
    computed: int
    lanes_done: int
    seconds: float


@dataclass(frozen=True, eq=False)
class SweepResult:
    """A finished (or resumed and finished) sweep.

    Attributes
    ----------
    spec : SweepSpec
    out : Path
        The folder.
    results : Path
        The results table (``results.csv`` or ``results.parquet``).
    table : dict of str to ndarray
        Its columns (:mod:`iwp.sweep.metrics`), one row per lane in lane order.
    computed : list of int
        Chunks computed by this run (the others were on disk already).
    seconds : float
        Wall time of this run [s].
    executor : str
        Where the chunks ran.
    cores : int
        Engine threads (local) or worker threads (Dask) used.
    cpu_seconds : float
        CPU time of the chunks computed by this run, where they ran
        (:attr:`~iwp.sweep.chunk.ChunkResult.cpu_seconds`) [s].
    """

    spec: SweepSpec
    out: Path
    results: Path
    table: dict = field(repr=False)
    computed: list
    seconds: float
    executor: str
    cores: int
    cpu_seconds: float = float("nan")
    #: what the run changed of what was asked (a thread or worker count capped by the cores and memory), one line each
    notes: list = field(default_factory=list)

    @property
    def resumed(self) -> list[int]:
        """Chunks found on disk (from an earlier run)."""
        return [i for i in range(self.spec.n_chunks) if i not in set(self.computed)]

    @property
    def throughput_per_cpu_second(self) -> float:
        """Closed loops of ``t_end`` per CPU-second of the processes that ran them (robust to other load)."""
        lanes = sum(len(self.spec.chunk_range(i)) for i in self.computed)
        if not lanes or not self.cpu_seconds > 0:
            return math.nan
        return lanes / self.cpu_seconds

    @property
    def throughput_per_core(self) -> float:
        """Closed loops of ``t_end`` per second and per core in this run."""
        lanes = sum(len(self.spec.chunk_range(i)) for i in self.computed)
        if not lanes or self.seconds <= 0:
            return math.nan
        return lanes / self.seconds / max(self.cores, 1)

    def summary(self) -> str:
        """A few lines: what ran, where, how long, and the outcome's distribution."""
        s = self.spec
        tab = self.table
        n = tab["lane"].size
        status = tab["status"]
        failed = int(np.count_nonzero(status > 0))
        unphys = int(np.count_nonzero(status < 0))
        chunks = f"{s.n_chunks} chunk{'s' if s.n_chunks != 1 else ''}"
        head = f"{self.results}: {n} closed loops ({s.law}, {s.t_end:g} s each) in {chunks}; "
        if self.computed:
            head = (f"wrote {head}{len(self.computed)} computed in {self.seconds:.1f} s on {self.executor}"
                    + (f", {len(self.resumed)} resumed from disk" if self.resumed else ""))
        else:
            head += "all were done already (nothing computed)"
        lines = [head, *self.notes]
        if self.computed:
            lines.append(f"throughput: {self.throughput_per_core:.3g} closed loops per second per core")
        if s.uncertainty is not None:
            lines.append(f"parameters drawn from the fit's covariance ({', '.join(s.uncertainty.free)}"
                         + ("" if s.uncertainty.reliable else "; its intervals are marked UNRELIABLE") + ")")
        ok = status == 0
        what = "on a steady orbit" if s.law == "hopf" else "balanced at the end"
        lines.append(f"captured ({what}): {int(np.sum(tab['captured'][ok]))} of {n} "
                     f"({100 * np.mean(tab['captured'] == 1):.1f} %); failed runs: {failed}; "
                     f"unphysical parameter draws (not run): {unphys}")
        amp = spread_of(tab["amplitude"])
        if amp.count:
            label = "orbit amplitude" if s.law == "hopf" else "final |q1 - pi|"
            where = (f"95 % of lanes in [{amp.low:.4g}, {amp.high:.4g}] rad" if amp.is_interval
                     else f"all {amp.count} lanes in [{amp.low:.4g}, {amp.high:.4g}] rad")
            lines.append(f"{label}: median {amp.median:.4g} rad, {where}")
        mq = tab["max_abs_q1"][np.isfinite(tab["max_abs_q1"])]
        if mq.size:
            lines.append(f"max |q1|: median {np.median(mq):.4g} rad, largest {np.max(mq):.4g} rad")
        return "\n".join(lines)


def run_sweep(
    spec: SweepSpec,
    out,
    *,
    force: bool = False,
    scheduler: str | None = None,
    workers: int | None = None,
    threads: int | None = None,
    format: str = "csv",
    progress: Callable[[SweepProgress], None] | None = None,
    executor: LocalExecutor | DaskExecutor | None = None,
) -> SweepResult:
    """Run a sweep into the folder ``out``, resuming it if it holds the same sweep.

    Parameters
    ----------
    spec : SweepSpec
    out : str or Path
        The output folder (:class:`~iwp.sweep.store.SweepStore`): new or empty; a
        folder with the same spec's chunks resumes (only the missing chunks run).
    force : bool
        Start afresh: replace the sweep in ``out`` (this one, not resumed, or another), or write into a
        folder holding other files.
    scheduler : str, optional
        Run on this Dask scheduler's workers (``tcp://host:8786``).
    workers : int, optional
        Run on a Dask ``LocalCluster`` of this many worker processes.
    threads : int, optional
        Engine threads of a local run (default: all cores).
    format : {"csv", "parquet"}
        Of the results table.
    progress : callable, optional
        Called with a :class:`SweepProgress` after each chunk is written.
    executor : LocalExecutor or DaskExecutor, optional
        An executor already entered (a Dask client kept across sweeps); replaces
        ``scheduler``, ``workers`` and ``threads``.

    Returns
    -------
    SweepResult
    """
    if not isinstance(spec, SweepSpec):
        raise InputError(f"spec must be a SweepSpec, got {type(spec).__name__}", argument="spec")
    if format not in RESULT_FORMATS:
        raise InputError(f"format must be one of {', '.join(RESULT_FORMATS)}, got {format!r}", argument="format")
    if executor is not None and (scheduler is not None or workers is not None or threads is not None):
        raise InputError("give executor or scheduler/workers/threads, not both", argument="executor")
    if spec.uncertainty is not None and not spec.uncertainty.reliable:
        notes = "; ".join(spec.uncertainty.notes) or "no reason given"
        warnings.warn(f"the fit's intervals are marked unreliable ({notes}): the parameter draws may understate "
                      "the spread of the real rig", UserWarning, stacklevel=2)
    own = executor is None
    ex = make_executor(scheduler=scheduler, workers=workers, threads=threads) if own else executor
    store = SweepStore(out, spec, force=force)  # checks only: nothing written yet
    start = time.perf_counter()
    started = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    missing = store.missing()
    computed: list[int] = []
    cpu_seconds = 0.0
    describe, cores = "nothing to compute", 0
    if missing and own:
        ex.__enter__()  # a scheduler that cannot be reached fails here, before the folder is touched
    try:
        store.open()
        store.write_manifest()
        completed = False
        try:
            if missing:
                describe, cores = ex.describe(), ex.cores
                on_disk = store.done()
                lanes_done = sum(len(spec.chunk_range(i)) for i in on_disk)
                noted = time.perf_counter()
                for res in ex.map(spec, missing):
                    store.write_chunk(res)
                    computed.append(res.index)
                    cpu_seconds += res.cpu_seconds
                    if time.perf_counter() - noted > MANIFEST_EVERY:
                        store.write_manifest()
                        noted = time.perf_counter()
                    lanes_done += res.n_rows
                    if progress is not None:
                        progress(SweepProgress(chunk=res.index, done=len(on_disk) + len(computed), total=spec.n_chunks,
                                               computed=len(computed), lanes_done=lanes_done,
                                               seconds=time.perf_counter() - start))
            completed = True
        finally:
            if not completed and not computed and not store.resumable:
                store.discard()  # a fresh start that failed or was stopped before its first chunk: nothing to keep
            else:
                # the record of what this run did, even when it was interrupted
                run = {"started": started, "executor": describe, "cores": cores, "computed": len(computed),
                       "seconds": round(time.perf_counter() - start, 3), "cpu_seconds": round(cpu_seconds, 3)}
                store.write_manifest(run=run)
    finally:
        if missing and own:
            ex.__exit__(None, None, None)
    seconds = time.perf_counter() - start
    results = store.path / f"results.{format}"
    # a finished sweep run again keeps its table, unless it is not every lane's (cut, edited)
    problem = None if computed else store.results_problem(format)
    if computed or problem is not None:
        if problem is not None and results.is_file():
            warnings.warn(f"out {store.path}: {results.name} is not the sweep's table ({problem}); it is written "
                          "again from the chunks", UserWarning, stacklevel=2)
        store.write_results(format)
    store.write_manifest(results=results.name)
    return SweepResult(spec=spec, out=Path(out), results=results, table=store.read_results(format), computed=computed,
                       seconds=seconds, executor=describe, cores=cores, cpu_seconds=cpu_seconds,
                       notes=[ex.note] if getattr(ex, "note", "") else [])

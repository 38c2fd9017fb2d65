"""Where a sweep's chunks run: this process on all cores (:class:`LocalExecutor`) or Dask (:class:`DaskExecutor`).

Both call :func:`~iwp.sweep.chunk.run_chunk` with the same spec and chunk
index, so they give the same numbers for the same seed. Locally one chunk
at a time runs on all cores (the batch engine's threads); on Dask every
worker thread runs one chunk at a time with one engine thread.
"""

from __future__ import annotations

import importlib.util
import logging
import math
import threading
from collections.abc import Iterator, Sequence

import numba

from ..errors import InputError
from ..models.parameters import table1
from ..threads import usable_cores, usable_memory
from .chunk import ChunkResult, run_chunk
from .spec import Grid, SweepSpec

__all__ = ["LocalExecutor", "DaskExecutor", "make_executor", "warm_up_worker", "CONNECT_SECONDS"]

#: A scheduler that has not answered within this long [s] is not one (Dask's own timeout does not cover a
#: service that accepts the connection and never speaks Dask's protocol: the client then waits for ever)
CONNECT_SECONDS = 20.0


def warm_up_worker() -> None:
    """One short closed loop in this process (loads the compiled engine from numba's cache)."""
    spec = SweepSpec(params=table1(), t_end=1.0, window=0.5, sample_time=0.05, chunk_size=2,
                     vary=(Grid("k1", (-10.0, -9.0)),))
    run_chunk(spec, 0, threads=1)


#: the memory a Dask worker process of a sweep takes beside its chunk [bytes] (numba, the compiled kernels, Dask)
WORKER_MEMORY = 400e6


class LocalExecutor:
    """The chunks one after another in this process, each on all cores (or ``threads``, at most the cores this
    process may use: :func:`iwp.threads.usable_cores`; :attr:`note` says when it was capped)."""

    def __init__(self, threads: int | None = None):
        cores = usable_cores()
        self.note = ""
        if threads is not None and threads > cores:
            self.note = (f"threads {threads}: capped at the {cores} core{'s' if cores != 1 else ''} this process "
                         "may use (its CPU affinity and cgroup quota)")
            threads = cores
        self.threads = threads

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None

    @property
    def cores(self) -> int:
        return self.threads or numba.get_num_threads()

    def describe(self) -> str:
        return f"local, {self.cores} thread{'s' if self.cores != 1 else ''}"

    def map(self, spec: SweepSpec, indices: Sequence[int]) -> Iterator[ChunkResult]:
        """Run the chunks ``indices`` and yield their results as they finish."""
        for i in indices:
            yield run_chunk(spec, i, threads=self.threads)


class DaskExecutor:
    """The chunks on a Dask distributed cluster: an existing scheduler, or a ``LocalCluster`` started here.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running scheduler (``tcp://host:8786``); its workers need iwp installed.
    workers : int, optional
        Without ``scheduler``: start a ``LocalCluster`` of this many worker
        processes, one thread each (default: one per core).
    """

    def __init__(self, scheduler: str | None = None, workers: int | None = None):
        if scheduler is not None and workers is not None:
            raise InputError("give scheduler (an existing cluster) or workers (a local one), not both",
                             argument=("scheduler", "workers"))
        if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
            raise InputError(f"workers must be a positive integer, got {workers!r}", argument="workers")
        if scheduler is not None and (not isinstance(scheduler, str) or not scheduler.strip()):
            raise InputError(f"scheduler must be an address such as tcp://host:8786, got {scheduler!r}",
                             argument="scheduler")
        self.note = ""
        if scheduler is None and workers is not None:
            # a local cluster of more processes than cores or memory allow only waits (1,000 workers on 2 cores
            # gave no answer in 60 s): capped, and said
            cores, memory = usable_cores(), usable_memory()
            by_memory = max(1, int(memory // WORKER_MEMORY)) if math.isfinite(memory) else workers
            cap = min(cores, by_memory)
            if workers > cap:
                self.note = (f"workers {workers}: capped at {cap}, the {cores} core{'s' if cores != 1 else ''} and "
                             f"{memory / 1e9:.3g} GB this process may use (a worker takes about "
                             f"{WORKER_MEMORY / 1e6:.0f} MB)")
                workers = cap
        self.scheduler = scheduler
        self.workers = workers
        self.client = None
        self.cluster = None

    def __enter__(self):
        try:
            from distributed import Client, LocalCluster  # optional dependency
        except ImportError:
            raise InputError("a Dask run needs dask distributed: pip install 'iwp[dask]'",
                             argument="scheduler" if self.scheduler else "workers") from None
        if self.scheduler is not None:
            self.client = _connect(Client, self.scheduler)
        else:
            n = self.workers or min(numba.config.NUMBA_NUM_THREADS, usable_cores())
            # the workers leave an interrupt to this process, which stops them (iwp.sweep.dask_worker); their
            # logs below errors (a cancelled task's warning when interrupted) are not the user's business
            # no dashboard, and its HTTP server (started all the same) on a free local port, not on 8787
            self.cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                        scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
                                        preload=["iwp.sweep.dask_worker"], silence_logs=logging.ERROR)
            self.client = Client(self.cluster)
        _TORNADO_LOG.addFilter(_INTERRUPT_RACE)
        return self

    def __exit__(self, *exc) -> None:
        try:
            if self.client is not None:
                self.client.close()
            if self.cluster is not None:
                self.cluster.close()
        finally:
            self.client = self.cluster = None
            _TORNADO_LOG.removeFilter(_INTERRUPT_RACE)

    def warm_up(self) -> None:
        """Import iwp and load the compiled engine on every worker (the first chunk then runs at full speed)."""
        if self.client is None:
            raise RuntimeError("DaskExecutor.warm_up outside its 'with' block")
        self.client.run(warm_up_worker)

    @property
    def cores(self) -> int:
        """Worker threads of the cluster."""
        return sum(self.client.nthreads().values()) if self.client is not None else 0

    def describe(self) -> str:
        where = self.scheduler or "LocalCluster"
        n = len(self.client.nthreads()) if self.client is not None else 0
        return f"dask {where}, {n} workers, {self.cores} threads"

    def map(self, spec: SweepSpec, indices: Sequence[int]) -> Iterator[ChunkResult]:
        """Submit the chunks ``indices`` and yield their results as they finish (any order)."""
        from distributed import as_completed  # optional dependency, imported in __enter__ already

        if self.client is None:
            raise RuntimeError("DaskExecutor.map outside its 'with' block")
        futures = [self.client.submit(run_chunk, spec, i, threads=1, pure=False)
                   for i in indices]
        try:
            for fut in as_completed(futures):
                yield fut.result()
                fut.release()
        finally:
            for fut in futures:
                fut.cancel()


class _InterruptRace(logging.Filter):
    """Drops the traceback Dask's event loop logs when Ctrl-C lands before a blocking call has started.

    ``distributed.utils.sync`` answers a ``KeyboardInterrupt`` by scheduling
    a ``cancel`` of the call's future on the loop; when the interrupt came
    before that future was made, ``cancel`` raises ``NameError`` (a free
    variable not yet bound), which tornado logs as "Exception in callback"
    with a traceback. The interrupt itself is reported by the command; only
    this one record is dropped.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        if not isinstance(exc, NameError):
            return True
        tb = exc.__traceback__
        while tb is not None and tb.tb_next is not None:
            tb = tb.tb_next
        code = tb.tb_frame.f_code if tb is not None else None
        return not (code is not None and code.co_name == "cancel"
                    and code.co_filename.replace("\\", "/").endswith("distributed/utils.py"))


_TORNADO_LOG = logging.getLogger("tornado.application")
_INTERRUPT_RACE = _InterruptRace()


def _connect(client_class, address: str):
    """A Dask client of the scheduler at ``address``, or an :class:`~iwp.errors.InputError` naming it.

    The client is made in a daemon thread given :data:`CONNECT_SECONDS`: one
    that has not connected by then is abandoned (the process can still
    exit). Whatever the client raises (an unreachable host, a refused port,
    a service that is not Dask's, even a ``MemoryError`` from a reply that
    is not Dask's) is the address's error.
    """
    box: dict = {}

    def connect() -> None:
        try:
            box["client"] = client_class(address, timeout=f"{CONNECT_SECONDS / 2:g}s")
        except BaseException as exc:  # noqa: BLE001 - reported to the caller as the address's error
            box["error"] = exc

    th = threading.Thread(target=connect, name="iwp-dask-connect", daemon=True)
    th.start()
    th.join(CONNECT_SECONDS)
    if "client" in box:
        return box["client"]
    if th.is_alive():
        raise InputError(f"scheduler {address}: no Dask scheduler answered within {CONNECT_SECONDS:g} s (is it a "
                         "Dask scheduler's address, tcp://host:8786?)", argument="scheduler")
    exc = box.get("error")
    raise InputError(f"scheduler {address}: cannot connect ({type(exc).__name__}: {exc})", argument="scheduler")


def make_executor(*, scheduler: str | None = None, workers: int | None = None, threads: int | None = None):
    """:class:`DaskExecutor` when ``scheduler`` or ``workers`` is given, else :class:`LocalExecutor`.

    Parameters
    ----------
    scheduler : str, optional
        Address of a Dask scheduler (``"tcp://host:8786"``).
    workers : int, optional
        Number of workers of a local Dask cluster.
    threads : int, optional
        Engine threads of a local run (default: all cores); not with ``scheduler`` or ``workers``.

    Returns
    -------
    DaskExecutor or LocalExecutor
        The executor.

    Raises
    ------
    InputError
        ``threads`` with a Dask run or not a positive integer, or a Dask run without ``distributed``
        installed.
    """
    if scheduler is not None or workers is not None:
        if threads is not None:
            raise InputError("threads is for a local run; a Dask worker runs one engine thread per worker thread",
                             argument="threads")
        if importlib.util.find_spec("distributed") is None:
            raise InputError("a Dask run needs dask distributed: pip install 'iwp[dask]'",
                             argument="scheduler" if scheduler is not None else "workers")
        return DaskExecutor(scheduler=scheduler, workers=workers)
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
        raise InputError(f"threads must be a positive integer, got {threads!r}", argument="threads")
    return LocalExecutor(threads)

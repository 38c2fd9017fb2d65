"""iwp's threads: the simulations of a fit side by side, and the linear algebra under it on one thread.

Simulations side by side
    A simulation-error fit simulates each of its logs (with forward
    sensitivities) at every evaluation; the logs are independent. The
    compiled kernels release the GIL (``nogil``), so :func:`thread_map`
    runs them on :func:`fit_threads` threads (numba's thread count: all
    cores, or ``NUMBA_NUM_THREADS``). Each task's result is the same as
    one after another; only the wall time differs.

BLAS on one thread
    The linear algebra of a fit works on tall, narrow Jacobians (thousands
    of rows, tens of columns), where OpenBLAS's threads gain nothing and,
    on a machine whose cores are busy, spin: one singular value
    decomposition of a 4806 x 24 Jacobian took 0.77 s with OpenBLAS's
    default threads on a loaded 2-core machine and 0.0037 s with one.
    :func:`one_blas_thread` limits the BLAS and LAPACK libraries to one
    thread for the duration of a fit (:mod:`threadpoolctl`, whichever
    library numpy and scipy load); the ``iwp`` command runs under it
    throughout, and :func:`thread_map` enters it before its calls run side
    by side. The limit is process-wide and counted: it is restored when the
    last call inside it leaves, whichever thread that is. Set from a pool
    thread it may not hold: OpenBLAS 0.3.31 (pthreads) ignored a limit set
    from another thread once the main thread had set one (the 2 threads it
    had stayed), so the caller's entry is the one that sets it.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import signal
import threading
from collections.abc import Callable, Hashable, Iterable
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import wait as futures_wait
from typing import TypeVar

import numba
from threadpoolctl import threadpool_limits

__all__ = ["one_blas_thread", "fit_threads", "thread_map", "once_per_argument", "usable_cores", "usable_memory"]

T = TypeVar("T")
R = TypeVar("R")

_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()
_LOCAL = threading.local()


def once_per_argument(make: Callable[[Hashable], R]) -> Callable[[Hashable], R]:
    """``make`` called once per argument, the result kept, also when threads ask for it at once.

    For the factories of compiled kernels: two threads of :func:`thread_map`
    asking for a kernel first at the same moment would otherwise build two
    dispatchers of it, and compile it twice.

    Parameters
    ----------
    make : callable
        Of one hashable argument.

    Returns
    -------
    callable
        ``make`` with its results kept per argument (under a lock).
    """
    made: dict = {}
    lock = threading.Lock()

    @functools.wraps(make)
    def get(key):
        with lock:
            if key not in made:
                made[key] = make(key)
            return made[key]

    return get


_BLAS_LOCK = threading.Lock()
#: the calls inside :func:`one_blas_thread` now, and the limiter the first of them set (restored by the last)
_BLAS = {"users": 0, "limiter": None}


@contextlib.contextmanager
def one_blas_thread():
    """A context manager limiting BLAS/LAPACK to one thread; the previous limits restored when the last call inside
    it, in any thread, leaves.

    Counted across threads: fits side by side each enter it, and leave in any order. With one
    :func:`threadpoolctl.threadpool_limits` per call, the first to leave restored the library's own threads while
    the other fits still ran, and their linear algebra then depended on which finished first (``fit_logs`` with
    the belt gave rigid fits 1e-7 apart from run to run, and belt fits ending at costs of 0.151 or 0.223).
    """
    with _BLAS_LOCK:
        if _BLAS["users"] == 0:
            _BLAS["limiter"] = threadpool_limits(limits=1, user_api="blas")
        _BLAS["users"] += 1
    try:
        yield
    finally:
        with _BLAS_LOCK:
            _BLAS["users"] -= 1
            if _BLAS["users"] == 0:
                _BLAS["limiter"].restore_original_limits()
                _BLAS["limiter"] = None


def fit_threads() -> int:
    """The threads :func:`thread_map` uses: numba's thread count for the calling thread (all cores,
    ``NUMBA_NUM_THREADS``, or what :func:`numba.set_num_threads` set, e.g. a sweep's ``--threads``)."""
    return max(1, int(numba.get_num_threads()))


#: the signals whose Python handlers :func:`thread_map` defers while it submits (Ctrl-C and the CLI's SIGTERM)
_DEFERRED = (signal.SIGINT, signal.SIGTERM)


@contextlib.contextmanager
def _interrupts_deferred():
    """SIGINT and SIGTERM recorded, not handled, for the block (main thread, where a Python handler is in place);
    yields the signals recorded, in order.

    A call already submitted may interrupt (a test's ``os.kill``, a user's Ctrl-C) while the pool takes the next
    one: a KeyboardInterrupt inside ``ThreadPoolExecutor.submit`` left its threads so that the interpreter hung
    at exit, and the call running was not waited for.
    """
    got: list[int] = []
    main = threading.current_thread() is threading.main_thread()
    old = {s: h for s in _DEFERRED if main and callable(h := signal.getsignal(s))}  # not ignored, not the default
    for s in old:
        signal.signal(s, lambda signum, frame: got.append(signum))
    try:
        yield got
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _pool() -> ThreadPoolExecutor:
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(max_workers=max(1, int(numba.config.NUMBA_NUM_THREADS)),
                                       thread_name_prefix="iwp-sim", initializer=_mark_worker)
        return _POOL


def _mark_worker() -> None:
    _LOCAL.worker = True


#: seconds between the wake-ups of a caller waiting on the pool, to run the signal handlers (Ctrl-C)
WAKE = 0.05


def _wait(f: Future) -> None:
    """Until ``f`` is done, woken every :data:`WAKE` seconds: a Ctrl-C the kernel delivers to a worker thread
    leaves the main thread asleep in an untimed wait (the signal handler runs in the main thread, between its
    bytecodes), so the interrupt would wait for the whole map (the Ctrl-C test saw all 30 calls run)."""
    while not f.done():
        futures_wait([f], timeout=WAKE)


def thread_map(func: Callable[[T], R], items: Iterable[T]) -> list[R]:
    """``[func(x) for x in items]``, the calls on iwp's shared thread pool.

    For calls that spend their time in compiled code that releases the GIL
    (a simulation). Inline (one after another) for one item, one thread, or
    when called from the pool itself (no task waits on the pool it runs on).
    The first exception raised by a call is raised here, after the calls
    not yet started are cancelled and the running ones have finished; so is
    an interrupt (Ctrl-C) received while waiting.

    Parameters
    ----------
    func : callable
        Called once per item.
    items : iterable
        The arguments, in order.

    Returns
    -------
    list
        The results, in the order of ``items``.
    """
    items = list(items)
    k = min(len(items), fit_threads())
    if k <= 1 or getattr(_LOCAL, "worker", False):
        return [func(x) for x in items]
    with one_blas_thread():  # entered by the caller: the calls' own entries (each fit's) then only count
        return _on_pool(func, items, k)


def _on_pool(func: Callable[[T], R], items: list[T], k: int) -> list[R]:
    """:func:`thread_map`'s calls on ``k`` threads of the pool."""
    results: list = [None] * len(items)
    order = iter(range(len(items)))
    lock, stop = threading.Lock(), threading.Event()

    def loop() -> None:  # k of these take the items in turn: at most k calls at once, the fast ones take more
        while not stop.is_set():
            with lock:
                i = next(order, None)
            if i is None:
                return
            try:
                results[i] = func(items[i])
            except BaseException:
                stop.set()
                raise

    pool = _pool()
    futures: list[Future] = []
    try:  # an interrupt from here on waits for the calls submitted
        with _interrupts_deferred() as deferred:  # an interrupt inside submit() would leave the pool broken
            for _ in range(k):
                futures.append(pool.submit(loop))
        for signum in deferred:  # delivered now, to the handlers in place (Ctrl-C: KeyboardInterrupt, handled below)
            signal.raise_signal(signum)
        for f in futures:
            _wait(f)
            f.result()
        return results
    except BaseException:
        stop.set()  # no call starts after a failure or an interrupt
        try:
            for f in futures:  # the running calls finish before the caller's clean-up (they share its buffers)
                _wait(f)
        except BaseException:  # noqa: BLE001, S110 - a second interrupt while waiting: stop waiting
            pass
        raise


def _cgroup_file(name: str) -> str | None:
    """The text of this process's cgroup v2 file ``name`` (``cpu.max``, ``memory.max``), or None."""
    with contextlib.suppress(OSError, ValueError, IndexError):
        with open("/proc/self/cgroup") as fh:
            rel = next(line.split(":", 2)[2].strip() for line in fh if line.startswith("0::"))
        with open(os.path.join("/sys/fs/cgroup", rel.lstrip("/"), name)) as fh:
            return fh.read().strip()
    return None


def usable_cores() -> int:
    """The cores this process may use: its CPU affinity, within its cgroup's CPU quota (``cpu.max``), at least 1.

    Returns
    -------
    int
        The number of cores.
    """
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    quota = _cgroup_file("cpu.max")
    if quota:
        parts = quota.split()
        if parts[0] != "max" and len(parts) == 2:
            with contextlib.suppress(ValueError, ZeroDivisionError):
                n = min(n, max(1, math.ceil(int(parts[0]) / int(parts[1]))))
    return max(1, n)


def usable_memory() -> float:
    """The memory this process may use [bytes]: the machine's, within its cgroup's limit (``memory.max``).

    Returns
    -------
    float
        Bytes (``inf`` where neither is known).
    """
    total = math.inf
    with contextlib.suppress(ValueError, OSError, AttributeError):
        total = float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    limit = _cgroup_file("memory.max")
    if limit and limit != "max":
        with contextlib.suppress(ValueError):
            total = min(total, float(limit))
    return total

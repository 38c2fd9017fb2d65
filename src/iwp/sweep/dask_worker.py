"""Preloaded into the worker processes of the ``LocalCluster`` a sweep starts (``--workers N``).

A Ctrl-C in a terminal (or ``timeout -s INT``) reaches the whole process
group, the cluster's workers with the command. The command stops its
cluster itself when it is interrupted; a worker that took the interrupt as
its own would print a traceback of its event loop. So the workers ignore
SIGINT (Dask's ``dask_setup`` hook of a preload module, run in each worker
process as it starts, also when a worker is restarted).
"""

from __future__ import annotations

import signal
import threading

__all__ = ["dask_setup"]


def dask_setup(worker) -> None:
    """Ignore SIGINT in this worker process (its cluster's owner stops it)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)

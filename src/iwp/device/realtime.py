"""Real-time scheduling of a loop's thread where the system allows it.

A loop at 200 Hz on a busy computer waits behind other processes for
milliseconds; Linux's ``SCHED_FIFO`` policy runs it as soon as it wakes.
:func:`realtime_priority` asks for it (root, ``CAP_SYS_NICE``, or an
``rtprio`` limit allow it), for the calling thread only, and gives the old
policy back at the end; where it is refused, the loop runs as before and
says so (the logs' ``timing`` metadata, ``scheduling``). The loops that use
it block in ``select``/``read`` between periods, so they never hold a core.
"""

from __future__ import annotations

import contextlib
import os

__all__ = ["realtime_priority", "FIFO_PRIORITY"]

#: The priority asked for (1-99; the kernel's own threads run at 50).
FIFO_PRIORITY = 20


@contextlib.contextmanager
def realtime_priority(enabled: bool = True):
    """Within the block the calling thread runs ``SCHED_FIFO``; yields ``"SCHED_FIFO 20"`` or ``"normal"``.

    Parameters
    ----------
    enabled : bool, default True
        False: leave the scheduling as it is (yields ``"normal"``).

    Yields
    ------
    str
        The policy the thread runs under: ``"SCHED_FIFO 20"``, or ``"normal"`` when it is off or the system
        refuses (no permission, no ``sched_setscheduler``). The old policy is restored after the block.
    """
    if not enabled or not hasattr(os, "sched_setscheduler"):
        yield "normal"
        return
    try:
        old_policy = os.sched_getscheduler(0)
        old_param = os.sched_getparam(0)
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(FIFO_PRIORITY))
    except (OSError, AttributeError):
        yield "normal"
        return
    try:
        yield f"SCHED_FIFO {FIFO_PRIORITY}"
    finally:
        try:
            os.sched_setscheduler(0, old_policy, old_param)
        except OSError:
            pass

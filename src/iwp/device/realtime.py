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

__all__ = ["realtime_priority", "realtime_allowed", "starving_note", "FIFO_PRIORITY", "STALL_SEEN_MS"]

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


def realtime_allowed() -> bool:
    """Whether this process may run a thread at ``SCHED_FIFO`` (tried on the calling thread, then put back)."""
    with realtime_priority() as policy:
        return policy != "normal"


#: The longest a loop without real-time scheduling was held off by a browser starting beside it [ms] (Chromium
#: started three times on the page of a 40 s run on the emulator, 2-core machine, 2026-12-07; with SCHED_FIFO the
#: longest was 42 ms and the run went to its end).
STALL_SEEN_MS = 148.0


def starving_note(port: str | None, watchdog_ms: float | None, fast: bool = False) -> str:
    """What to say before a real-time run with a live view whose loop cannot get real-time scheduling: a browser
    starting beside it can hold the loop off past the device's watchdog. Empty when there is nothing to say
    (real-time scheduling allowed, a run by the host's clock, the twin in this process, or a watchdog given
    longer than twice :data:`STALL_SEEN_MS`).
    """
    if fast or port == "twin" or (watchdog_ms is not None and watchdog_ms > 2 * STALL_SEEN_MS):
        return ""
    if realtime_allowed():
        return ""
    return (f"this process may not use real-time scheduling, so a program starting during the run (a browser "
            f"opening this page: {STALL_SEEN_MS:.0f} ms seen on a 2-core machine) can hold its loop off past the "
            "device's watchdog, which then stops the run; open the page before the run starts, give --watchdog-ms "
            "500, or allow real-time scheduling (docs/live.md)")

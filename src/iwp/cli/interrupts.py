"""Ctrl-C and ``kill``: one exception at a point where Python can take it, never a signal death.

SIGINT raises :class:`KeyboardInterrupt` and SIGTERM :class:`~iwp.interruption.Terminated`
(a ``KeyboardInterrupt``), so that every staged output is removed on the way
out and the CLI exits 130 with one line. Python runs a signal's handler at
the next bytecode it executes; while a compiled (numba) kernel returns, numba
runs Python code of its own (``numba.core.serialize``, unpickling the class
of the result it boxes) and does not check it for an exception: an interrupt
raised there crashes the process (a segmentation fault, issue 23). So do
llvmlite's callbacks from LLVM while numba compiles (ctypes prints and drops
the exception, and the compilation goes on broken). An interrupt that
arrives there is therefore raised a moment later, when the caller runs
again (at the next function call or return outside those callbacks).
Elsewhere Python may still drop it (a weakref or garbage-collection
callback): the dropped exception is remembered (:mod:`iwp.interruption`),
no output is committed after it, and it prints nothing.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading

from ..interruption import delivered, dropped, forget, interrupt

#: Python code run by compiled code that must not raise (path fragments of its files): numba's boxing, and
#: llvmlite's callbacks from LLVM while numba compiles (an exception there is printed and dropped by ctypes, and
#: the compilation goes on broken: "no compiled object yet for <Library ...>", exit 1 instead of 130)
_NO_RAISE = (os.sep.join(("numba", "core", "serialize.py")), os.sep.join(("llvmlite", "binding", "")))
#: The signal that arrived inside numba's boxing, to be raised when it returns.
_PENDING: list[int] = []


def _inside_compiled_return(frame) -> bool:
    while frame is not None:
        if any(part in frame.f_code.co_filename for part in _NO_RAISE):
            return True
        frame = frame.f_back
    return False


def _on_signal(signum, frame):
    if _inside_compiled_return(frame):
        # raised at the next Python event outside numba's callback (a profile hook: a signal sent again could
        # land there again and again when the caller does little else than call the kernel)
        _PENDING[:] = [signum]
        sys.setprofile(_raise_when_safe)
        return
    delivered(signum)
    raise interrupt(signum)


def _raise_when_safe(frame, event, arg):
    if not _PENDING or _inside_compiled_return(frame):
        return
    sys.setprofile(None)
    signum = _PENDING.pop()
    delivered(signum)
    raise interrupt(signum)


@contextlib.contextmanager
def interrupts_as_exceptions():
    """While the block runs, SIGINT and SIGTERM raise where safe (:func:`iwp.interruption.interrupt`).

    Outside the main thread (where Python delivers no signal) it does nothing; an ignored signal stays ignored.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    # a signal the process was started to ignore (nohup, a background job) stays ignored
    old = {s: signal.signal(s, _on_signal) for s in (signal.SIGINT, signal.SIGTERM)
           if signal.getsignal(s) is not signal.SIG_IGN}
    hook = sys.unraisablehook

    def unraisable(u):
        # an interrupt dropped by a callback is remembered and raised where outputs are committed: no traceback
        if isinstance(u.exc_value, KeyboardInterrupt):
            dropped(u.exc_value)
        else:
            hook(u)

    sys.unraisablehook = unraisable
    try:
        yield
    finally:
        sys.unraisablehook = hook
        for s, h in old.items():
            signal.signal(s, h)
        forget()
        if _PENDING:
            _PENDING.clear()
            sys.setprofile(None)


@contextlib.contextmanager
def interrupts_ignored():
    """While the block runs, SIGINT and SIGTERM do nothing: a command that is stopping already (a rig run
    interrupted) writes what it recorded whatever further Ctrl-C or ``timeout``'s second signal arrives.

    Outside the main thread it does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)

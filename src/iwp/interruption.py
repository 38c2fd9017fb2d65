"""An interrupt whose exception Python dropped: remembered, so that no output is committed after it.

Python runs a signal's handler at the next bytecode, wherever that is; where
Python itself calls code whose exceptions it cannot pass on (a weakref or
garbage-collection callback, a ``__del__``, a ctypes callback), the
handler's exception goes to :data:`sys.unraisablehook` ("Exception ignored
in ...") and is dropped, and the command would run on to its end as if
nothing had happened. The CLI's hook (:mod:`iwp.cli.interrupts`) records
such an interrupt here, and every output is committed only after
:func:`raise_pending` (:mod:`iwp.files`). An interrupt delivered as an
exception is not recorded: whoever catches it decides (a rig run keeps its
log of the run so far).
"""

from __future__ import annotations

import signal

__all__ = ["Terminated", "interrupt", "dropped", "raise_pending", "forget", "delivered", "deliveries",
           "raise_if_replaced"]

#: The signal of the interrupt dropped and not yet forgotten (at most one).
_DROPPED: list[int] = []
#: How many interrupts were delivered as exceptions, and the last one's signal.
_DELIVERED: list[int] = [0, signal.SIGINT]


class Terminated(KeyboardInterrupt):
    """SIGTERM received: unwinds like Ctrl-C, so that every staged output is removed."""


def interrupt(signum: int) -> KeyboardInterrupt:
    """The exception a signal raises: :class:`Terminated` for SIGTERM, else :class:`KeyboardInterrupt`.

    Parameters
    ----------
    signum : int
        The signal's number.

    Returns
    -------
    KeyboardInterrupt
    """
    return Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def dropped(exc: KeyboardInterrupt) -> None:
    """Remember an interrupt whose exception ``exc`` Python dropped.

    Parameters
    ----------
    exc : KeyboardInterrupt
        The dropped exception (:class:`Terminated` for SIGTERM).
    """
    _DROPPED[:] = [signal.SIGTERM if isinstance(exc, Terminated) else signal.SIGINT]


def delivered(signum: int) -> None:
    """Count an interrupt about to be raised as an exception (the CLI's signal handler calls this).

    Parameters
    ----------
    signum : int
        The signal's number.
    """
    _DELIVERED[:] = [_DELIVERED[0] + 1, signum]


def deliveries() -> int:
    """How many interrupts were delivered as exceptions so far (compare before and after a block)."""
    return _DELIVERED[0]


def raise_if_replaced(since: int, exc: BaseException) -> None:
    """Raise the interrupt that ``exc`` replaced, if one was delivered after :func:`deliveries` returned ``since``.

    Compiled code that Python calls back into (matplotlib's C code converting
    a bounding box) may catch the interrupt's exception and raise its own
    instead ("ValueError: Invalid bounding box"): a block that was
    interrupted then fails with an error that is not the interrupt's. A
    caller that records a failure and goes on calls this first, so that the
    interrupt ends the command as an interrupt.

    Parameters
    ----------
    since : int
        :func:`deliveries` when the block began.
    exc : BaseException
        The exception the block raised.

    Raises
    ------
    KeyboardInterrupt
        An interrupt was delivered while the block ran (:func:`interrupt` of its signal, from ``exc``).
    """
    if _DELIVERED[0] > since:
        raise interrupt(_DELIVERED[1]) from exc


def raise_pending() -> None:
    """Raise the interrupt whose exception was dropped, if any (:func:`interrupt` of its signal).

    Raises
    ------
    KeyboardInterrupt
        An interrupt's exception was dropped by a callback.
    """
    if _DROPPED:
        raise interrupt(_DROPPED[0])


def forget() -> None:
    """Forget the dropped interrupt (the command that got it has ended)."""
    _DROPPED.clear()

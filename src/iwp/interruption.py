"""An interrupt received: remembered until it is delivered, so that no output is committed after it.

Python runs a signal's handler at the next bytecode, wherever that is; where
Python itself calls code whose exceptions it cannot pass on (a weakref or
garbage-collection callback, a ``__del__``, a ctypes callback), the
handler's exception is printed ("Exception ignored in ...") and dropped, and
the command would run on to its end as if nothing had happened. The handler
(:mod:`iwp.cli.interrupts`) therefore also records the signal here, and every
output is committed only after :func:`raise_pending` (:mod:`iwp.files`).
"""

from __future__ import annotations

import signal

__all__ = ["Terminated", "interrupt", "received", "received_signal", "raise_pending", "forget"]

#: The signal received and not yet forgotten (at most one).
_RECEIVED: list[int] = []


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


def received(signum: int) -> None:
    """Remember that ``signum`` (SIGINT or SIGTERM) arrived.

    Parameters
    ----------
    signum : int
        The signal's number.
    """
    _RECEIVED[:] = [int(signum)]


def received_signal() -> int | None:
    """The signal received and not yet forgotten, or None.

    Returns
    -------
    int or None
        The signal's number.
    """
    return _RECEIVED[0] if _RECEIVED else None


def raise_pending() -> None:
    """Raise the interrupt received, if any: :class:`Terminated` for SIGTERM, else :class:`KeyboardInterrupt`.

    Raises
    ------
    KeyboardInterrupt
        A signal was received (also when its first exception was dropped by a callback).
    """
    if _RECEIVED:
        raise interrupt(_RECEIVED[0])


def forget() -> None:
    """Forget the interrupt received (the command that got it has ended)."""
    _RECEIVED.clear()

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

__all__ = ["Terminated", "interrupt", "dropped", "raise_pending", "forget"]

#: The signal of the interrupt dropped and not yet forgotten (at most one).
_DROPPED: list[int] = []


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

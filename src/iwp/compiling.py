"""Which compiled kernels iwp has, how long each takes to compile, and the notice when one compiles.

numba compiles each kernel the first time it runs (then loads it from its
on-disk cache, :mod:`iwp.jit`). :func:`compile_notices` makes a command say
so in one line before it waits; :mod:`iwp.warmup` compiles them all ahead.
This module imports nothing of iwp, so that a command can register the
notice before it imports the numerical code.
"""

from __future__ import annotations

from typing import Callable

from numba.core import event

__all__ = ["KERNELS", "DISPATCHERS", "compile_notices"]

#: kernel name -> (what it serves, about how long it compiles [s]); see :mod:`iwp.warmup`
KERNELS: dict[str, tuple[str, float]] = {
    "simulation": ("the simulation kernel of the 4-state models", 9.0),
    "belt": ("the simulation kernel of the belt models", 11.0),
    "sensitivity": ("the sensitivity kernel of fits and shooting", 11.0),
    "batch": ("the kernel of runs side by side", 30.0),
    "identification": ("the kernel of the least-squares uncertainty", 1.0),
}
#: compiled function name -> kernel name (what the notice says)
DISPATCHERS = {
    "integrate_4": "simulation",
    "integrate_6": "belt",
    "integrate_sens": "sensitivity",
    "run_lanes_4": "batch",
    "_noise_adjoints": "identification",
    "_noise_gram": "identification",
}


def compile_notices(say: Callable[[str], None]) -> None:
    """Call ``say(line)`` once per kernel when it starts to compile (not when it loads from the cache).

    Parameters
    ----------
    say : callable
        Called as ``say(line)`` with a one-line notice (``str``) naming the kernel and its rough compile time [s].

    Notes
    -----
    Registers a listener for numba's ``"numba:compile"`` event for the rest of the process; returns None.
    """
    class _Notice(event.Listener):
        def __init__(self):
            self.seen: set[str] = set()

        def on_start(self, ev):
            name = DISPATCHERS.get(ev.data["dispatcher"].py_func.__name__)
            if name is None or name in self.seen:
                return
            self.seen.add(name)
            what, seconds = KERNELS[name]
            say(f"compiling {what} (first run only, about {seconds:.0f} s; `iwp warmup` compiles every kernel ahead)")

        def on_end(self, ev):
            return None

    event.register("numba:compile", _Notice())

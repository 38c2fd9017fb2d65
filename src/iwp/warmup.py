"""Compile iwp's kernels ahead of their first use: ``iwp warmup``.

numba compiles each kernel the first time it runs and keeps it in its
on-disk cache (see :mod:`iwp.jit`). A kernel takes 1-12 s to compile, so the
first run of a command is slower than the next ones. :func:`warmup` compiles
them ahead, in parallel processes (one kernel a process); ``pip install``
runs it while it builds the package, so that an installed iwp starts warm
(see ``setup.py``). :func:`iwp.compiling.compile_notices` prints one line
when a command is about to wait for a compilation.

======================  ===============================================  =========
kernel                  used by                                          about [s]
======================  ===============================================  =========
``simulation``          every 4-state model: simulate, validate, reports  9
``belt``                the belt models (15): the virtual rig             11
``sensitivity``         refinement, shooting of periodic orbits           11
``batch``               ``simulate_batch`` (runs side by side)            25
``identification``      the noise covariance of the least squares          1
======================  ===============================================  =========
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from typing import Callable

import numpy as np

from .compiling import KERNELS
from .data import ExperimentData
from .errors import InputError
from .ident import identify
from .models import Plant, paper_belt, table1
from .sim import Feedforward, HopfController, Sampled, SimOptions, Sine, simulate, simulate_batch
from .sim.sensitivity import simulate_sensitivities
from .sim.simulate import output_times


def _warm_simulation() -> None:
    p = table1()
    simulate(Plant(p), x0=[0.1, 0.0, 0.0, 0.0], t_end=0.05, input=HopfController(-10.0, 0.1))
    r = simulate(Plant(p, model="raw"), t_end=0.05, input=Sine(40.0),
                 options=SimOptions(feedforward=Feedforward.of_plant(p)))
    _ = r.u  # continuous inputs are evaluated afterwards
    simulate(Plant(p), t_end=0.05, input=Sampled(np.zeros(11), 0.005))


def _warm_belt() -> None:
    plant = Plant(table1(), model="belt-full", belt=paper_belt(), dead_zone=True)
    opts = SimOptions(feedforward=Feedforward.of_plant(plant), saturation=100.0)
    simulate(plant, t_end=0.05, input=Sine(40.0), options=opts)
    simulate(plant, t_end=0.05, input=Sampled(np.zeros(11), 0.005), options=opts)


def _warm_sensitivity() -> None:
    p = table1()
    t = output_times(0.0, 0.05, 0.005)
    simulate_sensitivities(Plant(p, model="free"), t_eval=t, x0=[1.0, 0.0, 0.0, 0.0], wrt=("p1",), wrt_x0=(0, 2))
    simulate_sensitivities(Plant(p), t_eval=t, input=Sampled(np.zeros(11), 0.005), wrt=("p2",), wrt_x0=(0,))
    simulate_sensitivities(Plant(p), t_eval=t, x0=[1.0, 0.0, 0.0, 0.0], input=HopfController(-10.0, 0.1),
                           wrt=("k1",), wrt_x0=(0, 2, 3))


def _warm_batch() -> None:
    p = table1()
    simulate_batch(p, input=[HopfController(-10.0, 0.1), HopfController(-9.0, 0.1)], x0=[0.1, 0.0, 0.0, 0.0],
                   t_end=0.05)
    simulate_batch([p, p.replace(p1=25.0)], input=HopfController(-10.0, 0.1, Ts=0.005), x0=[0.1, 0.0, 0.0, 0.0],
                   t_end=0.05)


def _warm_identification() -> None:
    t = np.arange(2001) * 0.005
    q1 = np.round(0.5 * np.exp(-0.05 * t) * np.cos(5.1 * t) / 3.14e-3) * 3.14e-3
    identify(ExperimentData(t=t, q1=q1, q2=np.zeros(t.size), source="warmup"), "free")


_TASKS: dict[str, Callable[[], None]] = {
    "simulation": _warm_simulation,
    "belt": _warm_belt,
    "sensitivity": _warm_sensitivity,
    "batch": _warm_batch,
    "identification": _warm_identification,
}


def _run_task(name: str) -> tuple[str, float]:
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _TASKS[name]()
    return name, time.perf_counter() - t0


def warmup(kernels=None, *, processes: int | None = None,
           progress: Callable[[str, float], None] | None = None) -> dict[str, float]:
    """Compile (or load) iwp's kernels, in parallel processes.

    Parameters
    ----------
    kernels : sequence of str, optional
        Names among :data:`KERNELS` (default: all).
    processes : int, optional
        Worker processes (default: the number of cores, at most one per
        kernel); 0 runs them in this process, one after the other.
    progress : callable, optional
        Called with ``(name, seconds)`` as each kernel is ready.

    Returns
    -------
    dict
        Seconds per kernel (load or compile).
    """
    names = list(KERNELS) if kernels is None else list(kernels)
    unknown = [n for n in names if n not in KERNELS]
    if unknown:
        raise InputError(f"unknown kernel {unknown[0]!r}; choose among {', '.join(KERNELS)}")
    # the slowest first, so that parallel workers finish together
    names.sort(key=lambda n: -KERNELS[n][1])
    n_proc = (os.cpu_count() or 1) if processes is None else int(processes)
    out: dict[str, float] = {}
    if n_proc <= 0 or len(names) == 1:
        for n in names:
            _, s = _run_task(n)
            out[n] = s
            if progress is not None:
                progress(n, s)
        return out
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(n_proc, len(names)), mp_context=ctx) as pool:
        for name, seconds in pool.map(_run_task, names):
            out[name] = seconds
            if progress is not None:
                progress(name, seconds)
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m iwp.warmup``: compile every kernel (used by the build, see setup.py)."""
    ap = argparse.ArgumentParser(prog="python -m iwp.warmup", description="Compile iwp's kernels ahead of use.")
    ap.add_argument("kernels", nargs="*", help=f"kernels (default all): {', '.join(KERNELS)}")
    ap.add_argument("--processes", type=int, default=None, help="worker processes (default: cores)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    done = warmup(args.kernels or None, processes=args.processes,
                  progress=lambda n, s: print(f"iwp warmup: {n} ready in {s:.1f} s", flush=True))
    print(f"iwp warmup: {len(done)} kernel(s) in {time.perf_counter() - t0:.1f} s", flush=True)
    return 0


if __name__ == "__main__":  # pragma: no cover - the build runs it
    sys.exit(main())

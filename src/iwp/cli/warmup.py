"""``iwp warmup``: compile iwp's numba kernels ahead of their first use (see :mod:`iwp.warmup`)."""

from __future__ import annotations

import argparse


def register(sub) -> None:
    p = sub.add_parser(
        "warmup", help="compile the numerical kernels now (first use of a command is then fast)",
        description="Compile iwp's numba kernels ahead of use, in parallel processes. pip install runs this "
                    "while it builds iwp; run it after changing numba or the CPU, or in a fresh NUMBA_CACHE_DIR.",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("kernels", nargs="*", metavar="KERNEL",
                   help="kernels to compile (default all): simulation, belt, sensitivity, batch, identification")
    p.add_argument("--processes", type=int, default=None, metavar="N",
                   help="worker processes (default: one per core; 0: in this process)")
    p.set_defaults(func=run)


def run(args) -> int:
    import time

    from ..compiling import KERNELS
    from ..errors import InputError
    from ..warmup import warmup

    unknown = [k for k in args.kernels if k not in KERNELS]
    if unknown:
        raise InputError(f"KERNEL {unknown[0]!r} is not a kernel; choose among {', '.join(KERNELS)}")
    if args.processes is not None and args.processes < 0:
        raise InputError(f"--processes must be >= 0, got {args.processes}")
    t0 = time.perf_counter()
    done = warmup(args.kernels or None, processes=args.processes,
                  progress=lambda name, s: print(f"{name}: ready in {s:.1f} s", flush=True))
    print(f"{len(done)} kernel(s) ready in {time.perf_counter() - t0:.1f} s")
    return 0

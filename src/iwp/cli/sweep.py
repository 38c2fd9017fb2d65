"""``iwp sweep``: a sweep or Monte Carlo study of closed loops, on all local cores or on a Dask cluster."""

from __future__ import annotations

import argparse
import sys
import time

from ._common import add_force_arg

_DESCRIPTION = """\
Run many closed loops of model (9) (the Hopf law u = k1 q3 + k2 q3^3, or the
LQR balance at the upright) over grids and distributions of plant
parameters, gains and initial states, as described in a JSON spec
(docs/sweeps.md). The folder --out gets one file per chunk, a manifest and,
at the end, the table results.csv (or .parquet): one row per closed loop
with its final state, max |q1|, orbit amplitude and period, and whether it
was captured. A run that was interrupted resumes when started again with
the same spec and folder: only the missing chunks are computed. The same
seed gives the same numbers locally and on Dask.
Examples:
  iwp sweep spec.json --out sweep1                 # all local cores
  iwp sweep spec.json --out sweep1 --workers 2     # a Dask LocalCluster of 2 processes
  iwp sweep spec.json --out sweep1 --scheduler tcp://10.0.0.5:8786
A spec:
  {"law": "hopf", "params": "table1", "t_end": 300,
   "vary": {"k1": {"linspace": [-12, -6, 7]}, "x0.q1": {"normal": [0.1, 0.05]}},
   "samples": 100, "seed": 1, "chunk_size": 100}
"""


def register(sub) -> None:
    p = sub.add_parser("sweep", help="sweeps and Monte Carlo studies of closed loops (local cores or Dask)",
                       description=_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("spec", metavar="SPEC.json", help="the sweep: law, parameters, varied names, samples, seed")
    p.add_argument("--out", "-o", required=True, metavar="DIR",
                   help="output folder: new, empty, or this sweep's (then it resumes; --force starts afresh)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=None, metavar="N",
                       help="run on a Dask LocalCluster of N worker processes (one thread each)")
    where.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="run on an existing Dask scheduler (tcp://host:8786); its workers need iwp")
    where.add_argument("--threads", type=int, default=None, metavar="N",
                       help="engine threads of a local run (default: all cores)")
    p.add_argument("--format", choices=("csv", "parquet"), default="csv", help="results table (default csv)")
    p.add_argument("--chunk-size", type=int, default=None, metavar="N", help="lanes per chunk (overrides the spec)")
    p.add_argument("--samples", type=int, default=None, metavar="N", help="draws per grid point (overrides the spec)")
    p.add_argument("--seed", type=int, default=None, metavar="N", help="root seed (overrides the spec)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress lines")
    add_force_arg(p)
    p.set_defaults(func=run)


class _Progress:
    """One line on stderr per chunk, at most one a second (and the last)."""

    def __init__(self):
        self.last = -1.0

    def __call__(self, pr) -> None:
        now = time.perf_counter()
        if pr.done < pr.total and now - self.last < 1.0:
            return
        self.last = now
        rate = pr.computed / pr.seconds if pr.seconds > 0 else 0.0
        # from the second chunk on (the first one's time holds the start-up: loading the engine, a cluster's)
        eta = (f", about {(pr.total - pr.done) / rate:.0f} s left" if rate > 0 and pr.computed >= 2
               and pr.done < pr.total else "")
        print(f"iwp: sweep: {pr.done}/{pr.total} chunks ({pr.lanes_done} lanes), {pr.seconds:.1f} s{eta}",
              file=sys.stderr, flush=True)


def run(args) -> int:
    from ..errors import InputError
    from ..sweep import load_spec, run_sweep

    for flag, value, low in (("--chunk-size", args.chunk_size, 1), ("--samples", args.samples, 1),
                             ("--seed", args.seed, 0), ("--workers", args.workers, 1), ("--threads", args.threads, 1)):
        if value is not None and value < low:
            raise InputError(f"{flag} must be an integer >= {low}, got {value}")
    spec = load_spec(args.spec, argument="spec", chunk_size=args.chunk_size, samples=args.samples, seed=args.seed)
    res = run_sweep(spec, args.out, force=args.force, scheduler=args.scheduler, workers=args.workers,
                    threads=args.threads, format=args.format, progress=None if args.quiet else _Progress())
    print(res.summary())
    return 0

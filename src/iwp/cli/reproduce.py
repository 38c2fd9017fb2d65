"""``iwp reproduce --out DIR``: run the paper end to end on the virtual rig and write the report.

Runs every experiment of the paper's section 5 on the virtual rig, identifies
and compares the models as the paper does, refines the parameters, and
writes ``DIR/report.html`` (self-contained), ``DIR/figures/*.svg``,
``DIR/parameters.json`` and ``DIR/results.json``; the page names the command
that writes each experiment's log. Progress is printed while it runs.

Exit status: 0 when every step completed; 1 when a step failed (each failed
step is named on stderr; the completed parts and the report are kept);
2 on bad input (e.g. DIR exists and is not empty without --force).
"""

from __future__ import annotations

import argparse
import sys

from ._common import add_force_arg, plain


def register(sub) -> None:
    p = sub.add_parser("reproduce", help="run the paper end to end on the virtual rig and write a report",
                       description=plain(__doc__), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", "-o", required=True, metavar="DIR", help="output folder")
    p.add_argument("--quick", action="store_true", help="shorter experiments and refinement (a reduced run)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the rig's measurement noise (default 0; the default rig is noise-free)")
    p.add_argument("--stop-on-error", action="store_true",
                   help="stop at the first failed step (the report is still written)")
    p.add_argument("--quiet", "-q", action="store_true", help="print only the summary")
    add_force_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..reproduce import reproduce

    quiet = args.quiet

    def progress(ev) -> None:
        if quiet and ev.kind != "failed":
            return
        head = f"[{ev.index:2d}/{ev.total}] {ev.step}"
        if ev.kind == "start":
            print(f"{head}: {ev.title} ...", flush=True)
        elif ev.kind == "done":
            print(f"{'':8}done in {ev.seconds:.1f} s: {ev.message}", flush=True)
        elif ev.kind == "failed":
            print(f"{'':8}FAILED after {ev.seconds:.1f} s: {ev.message}", flush=True)
        elif ev.kind == "skipped":
            print(f"{head}: skipped ({ev.message})", flush=True)
        elif ev.kind == "info":
            print(f"{'':8}{ev.message}", flush=True)

    res = reproduce(args.out, force=args.force, quick=args.quick, seed=args.seed, progress=progress,
                    keep_going=not args.stop_on_error)
    st = res.statements
    n_pass = sum(s.passed is True for s in st)
    n_fail = sum(s.passed is False for s in st)
    n_nc = sum(s.passed is None for s in st)
    if res.report_path.exists():
        print(f"wrote {res.report_path} in {res.elapsed:.1f} s: statements {n_pass} pass, {n_fail} fail, "
              f"{n_nc} not checked")
    for s in res.failed_steps:
        print(f"iwp: error: step '{s.name}' failed: {s.message}", file=sys.stderr)
    return 1 if res.failed_steps else 0

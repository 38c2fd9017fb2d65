"""``iwp fit TRAIN... --rig RIG.json --validate HELDOUT... --out DIR``: logs to a validated model.

Reads the logs with the rig description (docs/rig-description.md), finds and
reports glitches, starts from least squares, fits model (9) (or (6) with
--dead-zone) by simulation error on all training logs jointly, with initial
states and the pendulum angle's zero offset estimated per log, then
simulates each held-out log from its measured initial state without
re-fitting. Writes DIR/fit.json, DIR/parameters.json (for --params),
DIR/report.html and DIR/figures/. See docs/fit.md.
"""

from __future__ import annotations

import argparse
import json
import sys

from ._common import add_force_arg, plain


def register(sub) -> None:
    p = sub.add_parser("fit", help="fit a model to a rig's logs and validate it on held-out logs",
                       description=plain(__doc__), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("train", nargs="+", metavar="TRAIN", help="training logs (CSV or .mat), fitted jointly")
    p.add_argument("--rig", metavar="RIG.json", help="rig description: columns, units, input, drive, sample period")
    p.add_argument("--validate", nargs="+", default=[], metavar="HELDOUT",
                   help="held-out logs, simulated from their measured initial state (not fitted)")
    p.add_argument("--out", "-o", required=True, metavar="DIR", help="output folder (new or empty)")
    add_force_arg(p)
    p.add_argument("--dead-zone", action="store_true", help="model (6) with the dead zone (5) (raw input v)")
    p.add_argument("--coulomb", action="store_true", help="fit Coulomb friction of the wheel (sigma_c2)")
    p.add_argument("--pendulum-coulomb", action="store_true",
                   help="fit Coulomb friction of the pendulum joint (sigma_c1)")
    p.add_argument("--input-offset", action="store_true", help="fit an offset of the input (u_offset)")
    p.add_argument("--loss", default="linear", choices=["linear", "soft_l1", "huber", "cauchy", "arctan"],
                   help="loss of the simulation-error fit (default linear)")
    p.add_argument("--t-start", type=float, metavar="S", help="window start of every training log [s]")
    p.add_argument("--t-end", type=float, metavar="S", help="window end of every training log [s]")
    p.add_argument("--json", action="store_true", help="print fit.json's content instead of the summary")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..files import check_output_dir, jsonable
    from ..ident.logfit import LogFitOptions, fit_logs
    from ..report.fit_page import write_fit_report

    check_output_dir(args.out, force=args.force)  # refuse before the work, not after
    options = LogFitOptions(dead_zone=args.dead_zone, coulomb=args.coulomb, pendulum_coulomb=args.pendulum_coulomb,
                            input_offset=args.input_offset, loss=args.loss, window=(args.t_start, args.t_end))
    res = fit_logs(args.train, rig=args.rig, validate=args.validate, options=options)
    files = write_fit_report(res, args.out, force=args.force)
    if args.json:
        print(json.dumps(jsonable(res.to_dict()), indent=2))
    else:
        print(res.summary(warnings=False))  # the warnings went to stderr
        print(f"wrote {files['report']}, {files['json']}, {files['parameters']}", file=sys.stdout)
    return 0

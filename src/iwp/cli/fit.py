"""``iwp fit TRAIN... --rig RIG.json --validate HELDOUT... --out DIR``: logs to a validated model.

Reads the logs with the rig description (docs/rig-description.md), finds and
reports glitches, starts from least squares, fits a ladder of model
structures (model (9), + wheel Coulomb, + pendulum Coulomb, + their widths,
+ input offset or dead zone or, for a belt drive, the belt (15)) by simulation error on all training logs
jointly, ranks them on the held-out logs (or by leaving one training log out)
and keeps the simplest within noise of the best (--model, or the term flags,
fit one structure), with initial
states and the pendulum angle's zero offset estimated per log, then
simulates each held-out log from its measured initial state without
re-fitting. Writes DIR/fit.json, DIR/parameters.json (for --params),
DIR/report.html and DIR/figures/. See docs/fit.md.
"""

from __future__ import annotations

import argparse
import json
import sys

from ..models.terms import TERMS, rung_names
from ._common import (
    add_accept_poor_arg,
    add_controller_args,
    add_force_arg,
    add_input_hold_arg,
    controller_of,
    plain,
    poor_status,
)


def register(sub) -> None:
    p = sub.add_parser("fit", help="fit a model to a rig's logs and validate it on held-out logs",
                       description=plain(__doc__), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("train", nargs="+", metavar="TRAIN", help="training logs (CSV or .mat), fitted jointly, each as the "
                   "set-up the rig description's experiments give its file name; one not given there whose "
                   "pendulum stays still while the wheel turns joins as --clamped, one whose wheel stays still "
                   "while the pendulum swings as --wheel-locked")
    p.add_argument("--rig", metavar="RIG.json", help="rig description: columns, units, input, drive, sample period")
    p.add_argument("--validate", nargs="+", default=[], metavar="HELDOUT",
                   help="held-out logs, simulated from their measured initial state (not fitted)")
    p.add_argument("--clamped", nargs="+", default=[], metavar="LOG",
                   help="logs with the pendulum clamped and the wheel driven (section 5.1), joining the training")
    p.add_argument("--wheel-locked", nargs="+", default=[], metavar="LOG",
                   help="logs of free swings with the wheel locked to the arm, joining the training")
    p.add_argument("--closed-loop", nargs="+", default=[], metavar="LOG",
                   help="logs of the closed loop of --controller, joining the training: simulated with the law "
                        "instead of replaying their logged input")
    add_controller_args(p, "the feedback law of the --closed-loop logs: u = k1 q3 + k2 q3^3, in the logs' input "
                           "units")
    p.add_argument("--out", "-o", required=True, metavar="DIR", help="output folder (new or empty)")
    add_force_arg(p)
    add_accept_poor_arg(p)
    # --model: the former name; a structure of the ladder (a set of terms), not an equation of iwp simulate --model
    p.add_argument("--structure", "--model", dest="structure", metavar="STRUCTURE", choices=rung_names(),
                   help="fit this structure of the ladder only: %(choices)s (default: fit them all and keep the "
                   "simplest within noise of the best on held-out data; see docs/fit.md; --model is its former "
                   "name)")
    for t in TERMS.values():  # a flag for each optional term of the models (iwp.models.terms)
        p.add_argument(t.flag, action="store_true", help=f"fit {t.description}")
    p.add_argument("--terms", metavar="TERM[,TERM...]",
                   help="fit the structure with these optional terms (and those they need): "
                        + ", ".join(t.replace("_", "-") for t in TERMS) + " (the same as their flags)")
    p.add_argument("--try", dest="try_terms", metavar="TERM[,TERM...]",
                   help="also try these terms off the default ladder on it: "
                        + ", ".join(t.replace("_", "-") for t, v in TERMS.items() if not v.rung.default))
    p.add_argument("--fix", action="append", default=[], metavar="NAME=VALUE",
                   help="hold a parameter at this value in every structure fitted (repeat for more), e.g. "
                        "--fix rho=247.2: known from elsewhere, or not identified by these logs")
    p.add_argument("--loss", default="linear", choices=["linear", "soft_l1", "huber", "cauchy", "arctan"],
                   help="loss of the simulation-error fit (default linear)")
    add_input_hold_arg(p)
    p.add_argument("--t-start", type=float, metavar="S", help="window start of every training log [s]")
    p.add_argument("--t-end", type=float, metavar="S", help="window end of every training log [s]")
    p.add_argument("--json", action="store_true", help="print fit.json's content instead of the summary")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..errors import InputError
    from ..files import check_output_dir, jsonable
    from ..ident.logfit import LogFitOptions, fit_logs
    from ..ident.structure import RUNGS
    from ..models.terms import TERMS, parse_terms
    from ..report.fit_page import write_fit_report

    check_output_dir(args.out, force=args.force)  # refuse before the work, not after
    given = {t.name for t in TERMS.values() if getattr(args, t.name)}
    if args.terms is not None:
        given |= parse_terms(args.terms, argument="--terms")
    if args.structure is not None and given:
        raise InputError(f"--structure {args.structure} and {TERMS[sorted(given)[0]].flag} both set the structure; "
                         "give one of them", argument="--structure")
    if args.try_terms is not None and (args.structure is not None or given):
        raise InputError("--try adds rungs to the ladder, which --structure and the term flags replace; give one of "
                         "them", argument="--try")
    terms = RUNGS[args.structure].terms if args.structure is not None else given
    fixed = {}
    for item in args.fix:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise InputError(f"--fix {item}: give NAME=VALUE, e.g. --fix rho=247.2", argument="--fix")
        fixed[name.strip()] = value.strip()
    options = LogFitOptions(terms=terms, select=args.structure is None and not given,
                            try_terms=parse_terms(args.try_terms, argument="--try") if args.try_terms else (),
                            fixed=fixed, loss=args.loss, window=(args.t_start, args.t_end),
                            input_hold=args.input_hold)
    kinds = {k: v for k, v in (("clamped", args.clamped), ("wheel-locked", args.wheel_locked),
                                ("closed-loop", args.closed_loop)) if v}
    res = fit_logs(args.train, rig=args.rig, validate=args.validate, kinds=kinds, controller=controller_of(args),
                   options=options)
    files = write_fit_report(res, args.out, force=args.force)
    if args.json:
        print(json.dumps(jsonable(res.to_dict()), indent=2))
    else:
        print(res.summary(warnings=False))  # the warnings went to stderr
        print(f"wrote {files['report']}, {files['json']}, {files['parameters']}", file=sys.stdout)
    return poor_status(res.poor_prediction(), args.accept_poor)

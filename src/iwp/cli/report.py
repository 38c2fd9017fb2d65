"""``iwp report FILES... --params P.json --out DIR``: compare your own logs with a model.

Each log (CSV, Parquet, MAT; see docs/data-format.md) is simulated with the
compensated model (9) and the parameter set, from the log's first measured
state: logged inputs are replayed (compared on q1 and the wheel's q2, or its
speed q4 when only that is logged), logs whose metadata give k1 and k2 are run
in closed loop with the Hopf law, logs without input are a free pendulum,
logs marked ``# pendulum: locked`` are compared on the disk velocity. With
the parameters.json of ``iwp fit``, a log converted with the rig
description gets the fit's pendulum offset and its raw command v is read as
u, as the fit did. Static
curves (``v,q4`` or ``u,q4``) are drawn against the model's static line.
Writes ``DIR/report.html`` (self-contained), ``DIR/figures/*`` and
``DIR/comparison.json``.
"""

from __future__ import annotations

import argparse

from ._common import add_force_arg, add_params_arg, load_lumped, plain


def register(sub) -> None:
    p = sub.add_parser("report", help="compare your own logs with a model in a self-contained HTML page",
                       description=plain(__doc__), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("files", nargs="+", metavar="FILE", help="experiment logs or static curves")
    add_params_arg(p)
    p.add_argument("--out", "-o", required=True, metavar="DIR", help="output folder")
    add_force_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..models.parameters import stored_q1_offset, stored_reads_v_as_u
    from ..report.logs import report_logs

    params = load_lumped(args.params)
    res = report_logs(args.files, params, args.out, force=args.force, progress=lambda m: print(m, flush=True),
                      params_name=str(args.params), held_out_offset=stored_q1_offset(args.params),
                      reads_v_as_u=stored_reads_v_as_u(args.params))
    print(f"wrote {res['report']} ({len(res['comparisons'])} log(s))")
    return 0

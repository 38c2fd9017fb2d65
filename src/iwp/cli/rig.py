"""``iwp rig``: the virtual rig -- list the paper's experiments, run one, write the default truth.

``iwp rig list`` names the experiments; ``iwp rig run NAME --out FILE``
runs one with the paper's settings (options override them) and writes the
log (CSV, Parquet or MAT by extension; static curves as CSV);
``iwp rig truth --out TRUTH.json`` writes the default truth plant for
editing (``--truth`` reads it back, field by field);
``iwp rig calibrate --out TRUTH.json`` calibrates the truth so that the
paper's procedures return the paper's published numbers (indirect
inference; ``--targets`` for other numbers) and writes it with its record.
"""

from __future__ import annotations

import argparse
import sys

from ..errors import InputError
from ._common import add_force_arg


def _x0(text: str) -> list[float]:
    try:
        vals = [float(s) for s in text.split(",") if s.strip() != ""]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected q1 or q1,q2,q3,q4, got {text!r}") from None
    if len(vals) not in (1, 4):
        raise argparse.ArgumentTypeError(f"expected q1 or q1,q2,q3,q4, got {len(vals)} numbers")
    return vals


def _v_dz(text: str):
    if text.strip().lower() == "none":
        return "none"
    try:
        vals = [float(s) for s in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected V, VPOS,VNEG or none, got {text!r}") from None
    if len(vals) not in (1, 2):
        raise argparse.ArgumentTypeError(f"expected V, VPOS,VNEG or none, got {text!r}")
    return vals[0] if len(vals) == 1 else tuple(vals)


def register(sub) -> None:
    p = sub.add_parser("rig", help="the virtual rig: run the paper's experiments on a truth plant",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    rs = p.add_subparsers(dest="rig_command", metavar="{list,run,truth,calibrate}", parser_class=type(p))
    rs.required = True

    pl = rs.add_parser("list", help="name the paper's experiments with their settings")
    pl.set_defaults(func=run_list)

    pr = rs.add_parser("run", help="run one experiment and write its log",
                       description="Run one of the paper's experiments on the virtual rig; write its log "
                                   "(.csv/.txt, .parquet/.pq, .mat; static curves .csv).")
    pr.add_argument("name", metavar="NAME", help="experiment (see: iwp rig list)")
    pr.add_argument("--out", "-o", required=True, metavar="FILE", help="output file")
    pr.add_argument("--amplitude", type=float, help="input amplitude [input units] (static curves: largest |input|)")
    pr.add_argument("--step", type=float, help="static curves: spacing of the inputs [input units]")
    pr.add_argument("--duration", type=float, metavar="S",
                    help="log length [s] (static curves: hold time per point)")
    pr.add_argument("--seed", type=int, help="noise seed (default 0)")
    pr.add_argument("--noise", type=float, metavar="STD", help="position noise standard deviation [rad]")
    pr.add_argument("--truth", metavar="TRUTH.json", help="truth plant overrides (see: iwp rig truth)")
    pr.add_argument("--k1", type=float, help="closed-loop gain k1 (default -10)")
    pr.add_argument("--k2", type=float, help="closed-loop gain k2 (default 0.1)")
    pr.add_argument("--x0", type=_x0, metavar="Q1[,Q2,Q3,Q4]", help="initial state [rad, rad/s]")
    pr.add_argument("--v-dz", type=_v_dz, metavar="V|VPOS,VNEG|none",
                    help="thresholds of the rig's dead-zone compensation (default 31; none: off)")
    add_force_arg(pr)
    pr.set_defaults(func=run_run)

    pt = rs.add_parser("truth", help="write the default truth plant as JSON (for editing)")
    pt.add_argument("--out", "-o", required=True, metavar="TRUTH.json", help="output file")
    pt.add_argument("--truth", metavar="BASE.json", help="start from these overrides of the default")
    add_force_arg(pt)
    pt.set_defaults(func=run_truth)

    pc = rs.add_parser("calibrate", help="calibrate the truth so that the paper's procedures return its numbers",
                       description="Calibrate the virtual rig's truth by indirect inference: run the paper's "
                                   "experiments on the twin, apply the paper's procedures as iwp identify does with "
                                   "its defaults, and fit the twin's structural parameters so that the numbers "
                                   "match the targets within their tolerances. Writes the calibrated truth with "
                                   "where each value came from and the residual table (a --truth file). Takes "
                                   "minutes: every iteration runs every experiment.")
    pc.add_argument("--targets", metavar="TARGETS.json",
                    help="the numbers to reproduce (default: the paper's, shipped with iwp)")
    pc.add_argument("--out", "-o", required=True, metavar="TRUTH.json", help="output file")
    pc.add_argument("--truth", metavar="START.json", help="start from this truth (default: the default truth)")
    pc.add_argument("--max-nfev", type=int, default=40, metavar="N",
                    help="most iterations of the optimiser (default 40)")
    pc.add_argument("--quiet", "-q", action="store_true", help="print only the result")
    add_force_arg(pc)
    pc.set_defaults(func=run_calibrate)


def run_list(args) -> int:
    from ..rig import list_experiments

    specs = list_experiments()
    w = max(len(s.name) for s in specs)
    print(f"{'NAME':<{w}}  DESCRIPTION")
    for s in specs:
        print(f"{s.name:<{w}}  {s.description}")
        print(f"{'':<{w}}    paper: {s.reference}; settings: {s.settings_text()}")
    return 0


def _truth(path):
    from ..rig import RigTruth, default_truth

    return default_truth() if path is None else RigTruth.from_json(path)


def run_run(args) -> int:
    from ..rig import VirtualRig, check_output_path, write_result

    overrides = {}
    for opt, key in (("amplitude", "amplitude"), ("step", "step"), ("duration", "duration"), ("seed", "seed"),
                     ("noise", "noise_std"), ("k1", "k1"), ("k2", "k2"), ("x0", "x0"), ("v_dz", "v_dz")):
        val = getattr(args, opt)
        if val is not None:
            overrides[key] = None if (key == "v_dz" and val == "none") else val
    truth = _truth(args.truth)
    rig = VirtualRig(truth)
    spec_opts = {s.name: s.options for s in rig.list_experiments()}
    if args.name in spec_opts:
        flags = {"noise_std": "--noise", "v_dz": "--v-dz"}
        bad = [k for k in overrides if k not in spec_opts[args.name]]
        if bad:
            raise InputError(f"experiment {args.name!r} does not take {flags.get(bad[0], '--' + bad[0])}; it takes: "
                             + ", ".join(flags.get(k, "--" + k.replace('_', '-')) for k in spec_opts[args.name]))
    out = check_output_path(args.name, args.out, force=args.force)
    result = rig.run(args.name, **overrides)
    write_result(result, out, force=True)
    if hasattr(result, "n_samples"):
        what = f"{result.n_samples} samples, t = {result.t[0]:g}..{result.t[-1]:g} s"
    else:
        what = f"{result.n_points} points"
    print(f"wrote {out} ({args.name}, {what}, seed {result.metadata.get('seed')})")
    return 0


def run_truth(args) -> int:
    truth = _truth(args.truth)
    p = truth.to_json(args.out, force=args.force)
    print(f"wrote {p}")
    return 0


def run_calibrate(args) -> int:
    from ..calibration import calibrate, load_targets
    from ..files import check_output_file
    from ..ident.problem import SolverOptions

    if args.max_nfev < 1:
        raise InputError(f"--max-nfev must be a positive integer, got {args.max_nfev}")
    check_output_file(args.out, force=args.force)
    targets = load_targets(args.targets)
    start = _truth(args.truth)
    progress = None if args.quiet else (lambda msg: print(msg, flush=True))
    res = calibrate(targets, start=start, options=SolverOptions(tol=1e-3, max_nfev=args.max_nfev), progress=progress,
                    warn=False)
    p = res.write(args.out, force=args.force)
    print(res.summary())
    print(f"wrote {p}")
    if not res.success:
        print(f"iwp: calibration incomplete: {res.message} (the truth reached is written; --truth {p} continues "
              "from it)", file=sys.stderr)
        return 1
    return 0

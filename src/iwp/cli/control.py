"""``iwp control``: swing-up and balance (figure, animation, CSV); the balance LQR."""

from __future__ import annotations

import argparse
import json

from ..errors import InputError
from ._common import add_force_arg, add_params_arg, float_list, load_lumped

_SWINGUP_DESCRIPTION = """\
Swing the pendulum up from rest at the bottom by pumping energy with the
wheel, switch to an LQR near the top and balance it. By default on the
rig's conditions: raw model (6) with the dead zone v+ = 33, v- = 29
compensated with v = 31, encoders of 2000 counts/rev, observer, controller
every 5 ms, |u| <= 100. Writes OUT/swingup.csv, swingup.png, swingup.gif
and swingup.json.
Examples:
  iwp control swingup --out runs/swingup
  iwp control swingup --out runs/ideal --ideal --x0 0.5,0,0,0 --t-end 15
"""


def register(sub) -> None:
    p = sub.add_parser("control", help="swing-up and balance; the upright LQR",
                       description="Control beyond the paper: swing-up and balance.")
    csub = p.add_subparsers(dest="control_command", metavar="WHAT", parser_class=type(p))
    csub.required = True

    s = csub.add_parser("swingup", help="swing up and balance; write CSV, figure and GIF",
                        description=_SWINGUP_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_params_arg(s)
    s.add_argument("--out", required=True, metavar="DIR", help="output folder")
    s.add_argument("--x0", type=float_list, default=[0.0, 0.0, 0.0, 0.0], help="initial state q1,q2,q3,q4")
    s.add_argument("--t-end", type=float, default=20.0, help="simulated time [s] (default 20)")
    s.add_argument("--ideal", action="store_true",
                   help="compensated model (9), true state, no quantisation (default: rig conditions)")
    s.add_argument("--u-max", type=float, default=100.0, help="saturation of u (default 100)")
    s.add_argument("--frames", type=int, default=100, help="frames of the GIF (default 100)")
    s.add_argument("--no-animation", action="store_true", help="skip the GIF")
    s.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_force_arg(s)
    s.set_defaults(func=run_swingup)

    q = csub.add_parser("lqr", help="the balance LQR at the upright (gains, poles, capture bound)")
    add_params_arg(q)
    q.add_argument("--ts", type=float, default=0.005, help="sample period of the discrete design [s]; 0: continuous")
    q.add_argument("--u-max", type=float, default=100.0, help="saturation of u (default 100)")
    q.add_argument("--json", action="store_true", help="print as JSON")
    q.set_defaults(func=run_lqr)


def run_swingup(args) -> int:
    from ..checks import check_positive
    from ..control import RigConditions, swing_up
    from ..files import check_output_dir, staged_dir
    from ..plotting import savefig

    params = load_lumped(args.params)
    if len(args.x0) != 4:
        raise InputError(f"--x0 must have 4 values q1,q2,q3,q4, got {len(args.x0)}")
    check_positive("t_end", args.t_end)
    check_positive("u_max", args.u_max)
    if not 2 <= args.frames <= 2000:
        raise InputError(f"--frames must be from 2 to 2000, got {args.frames}")
    out = check_output_dir(args.out, force=args.force, argument="out")
    names = {k: f"swingup.{k}" for k in ("csv", "png", "json")}
    if not args.no_animation:
        names["gif"] = "swingup.gif"
    rig = None if args.ideal else RigConditions(u_max=args.u_max)
    res = swing_up(params, x0=args.x0, t_end=args.t_end, rig=rig, u_max=args.u_max) if rig is None else \
        swing_up(params, x0=args.x0, t_end=args.t_end, rig=rig)
    summary = res.summary()
    summary["x0"] = list(args.x0)
    summary["files"] = {k: str(out / v) for k, v in names.items()}
    with staged_dir(out, force=args.force, argument="out") as tmp:
        res.result.to_csv(tmp / names["csv"], force=True)
        savefig(res.plot()["figure"], tmp / names["png"])
        if "gif" in names:
            res.animate(tmp / names["gif"], frames=args.frames, force=True)
        (tmp / names["json"]).write_text(json.dumps(summary, indent=2))
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        state = "balanced" if res.success else "NOT balanced"
        print(f"swing-up ({res.conditions}): {state}; catch at t = {res.t_catch:.3f} s, within "
              f"{res.tolerance:g} rad from t = {res.t_balanced:.3f} s; max |u| = {res.u_max:.4g}, "
              f"max |q4| = {res.q4_max:.4g} rad/s")
        print("wrote " + ", ".join(summary["files"].values()))
    return 0 if res.success else 1


def run_lqr(args) -> int:
    from ..control import lqr_balance

    params = load_lumped(args.params)
    L = lqr_balance(params, u_max=args.u_max, Ts=args.ts if args.ts > 0 else None)
    d = {"K": L.K.tolist(), "poles": [[float(p.real), float(p.imag)] for p in L.poles], "Ts": L.Ts,
         "u_max": L.u_max, "unstable_eigenvalue": L.unstable_eigenvalue,
         "unstable_direction": L.unstable_direction.tolist(), "capture_bound": L.capture_bound,
         "backend": L.backend}
    if args.json:
        print(json.dumps(d, indent=2))
        return 0
    print(f"LQR at the upright on (q1 - pi, q3, q4) ({'discrete, Ts = %g s' % L.Ts if L.Ts else 'continuous'}, "
          f"{L.backend}):")
    print("  K = [" + ", ".join(f"{k:.5g}" for k in L.K) + "]")
    print("  closed-loop poles: " + ", ".join(f"{p:.4g}" for p in L.poles))
    print(f"  open-loop unstable eigenvalue {L.unstable_eigenvalue:.4g} 1/s; capture bound |w.x| < "
          f"{L.capture_bound:.4g} rad with |u| <= {L.u_max:g}")
    return 0

"""``iwp control``: swing-up and balance (figure, animation, CSV); the balance LQR; controllers on a rig."""

from __future__ import annotations

import argparse
import sys

from ..errors import InputError
from ._common import (
    add_draws_args,
    add_force_arg,
    add_params_arg,
    add_x0_arg,
    draws_uncertainty,
    float_list,
    json_text,
    load_lumped,
    load_uncertainty_arg,
    write_robust,
)
from .portargs import (
    add_live_args,
    add_port_args,
    live_params,
    live_session,
    open_port_rig,
    port_clearing,
    port_operator,
    port_progress,
)

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
With --draws N and --params FILE (the parameters.json of iwp fit, with its
covariance) the controller, built on the fit's estimates, also swings up N
plants drawn from the fit's uncertainty: the probability of success (Wilson
interval) and the time to capture, in OUT/robust.json and OUT/robust.png:
  iwp control swingup --out runs/robust --params fit/parameters.json --draws 50
"""

_LQR_DESCRIPTION = """\
The balance LQR at the upright on (q1 - pi, q3, q4): gains, poles, capture
bound. With --draws N and --params FILE (the parameters.json of iwp fit, with
its covariance) the LQR, designed on the fit's estimates, is simulated on N
parameter draws from its uncertainty, from rest at each of --angles from the
upright: the probability of capture (Wilson interval) per angle and overall,
and the settling time's distribution, in OUT/robust.json and OUT/robust.png:
  iwp control lqr --params fit/parameters.json --draws 200 --out runs/lqr
  iwp control lqr --params fit/parameters.json --draws 200 --angles 0.02,0.05 --out runs/lqr
"""


def register(sub) -> None:
    p = sub.add_parser("control", help="swing-up and balance; the upright LQR",
                       description="Control beyond the paper: swing-up and balance, the upright LQR, and iwp's "
                                   "controllers on a rig in the loop.")
    csub = p.add_subparsers(dest="control_command", metavar="WHAT", parser_class=type(p))
    csub.required = True

    s = csub.add_parser("swingup", help="swing up and balance; write CSV, figure and GIF",
                        description=_SWINGUP_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_params_arg(s)
    s.add_argument("--out", "-o", required=True, metavar="DIR", help="output folder")
    add_x0_arg(s, default=[0.0, 0.0, 0.0, 0.0], help="initial state [rad, rad/s] (default 0,0,0,0)")
    s.add_argument("--t-end", type=float, default=20.0, help="simulated time [s] (default 20)")
    s.add_argument("--ideal", action="store_true",
                   help="compensated model (9), true state, no quantisation (default: rig conditions)")
    s.add_argument("--u-max", type=float, default=100.0, help="saturation of u (default 100)")
    s.add_argument("--frames", type=int, default=100, help="frames of the GIF (default 100)")
    s.add_argument("--no-animation", action="store_true", help="skip the GIF")
    s.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_draws_args(s, "the probability of success")
    add_force_arg(s)
    s.set_defaults(func=run_swingup)

    q = csub.add_parser("lqr", help="the balance LQR at the upright (gains, poles, capture bound)",
                        description=_LQR_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_params_arg(q)
    q.add_argument("--ts", type=float, default=0.005, help="sample period of the discrete design [s]; 0: continuous")
    q.add_argument("--u-max", type=float, default=100.0, help="saturation of u (default 100)")
    q.add_argument("--json", action="store_true", help="print as JSON")
    add_draws_args(q, "the probability of capture")
    q.add_argument("--angles", type=float_list, default=None, metavar="A1,A2,...",
                   help="initial angles from the upright, at rest [rad] (--draws; default 0.25 to 1.25 times "
                        "the capture bound)")
    q.add_argument("--t-end", type=float, default=5.0, help="simulated time of each closed loop [s] (default 5)")
    q.add_argument("--out", "-o", default=None, metavar="DIR", help="output folder of --draws")
    add_force_arg(q)
    q.set_defaults(func=run_lqr)

    r = csub.add_parser("run", help="run a controller on a rig in the loop (--port) and write its log",
                        description="Run iwp's controllers on a rig in the loop: the Hopf law of section 5.3 "
                                    "(on the device or from the host), the upright LQR (device or host), swing-up "
                                    "and balance (host). Writes the log; Ctrl-C, a limit, a lost link or an "
                                    "error stops the motor and writes the log so far, marked interrupted. Exit "
                                    "status 1 when a balance or swing-up does not end balanced.")
    r.add_argument("what", choices=["hopf", "balance", "swingup"], help="the controller")
    r.add_argument("--where", choices=["device", "host"], help="where it runs (default: device; swingup: host)")
    r.add_argument("--out", "-o", required=True, metavar="FILE", help="output log (.csv/.txt, .parquet/.pq, .mat)")
    r.add_argument("--duration", type=float, metavar="S", help="length [s] (default: hopf 60, balance 10, swingup 20)")
    r.add_argument("--k1", type=float, default=-10.0, help="hopf: k1 (default -10)")
    r.add_argument("--k2", type=float, default=0.1, help="hopf: k2 (default 0.1)")
    add_x0_arg(r, help="where the pendulum is released [rad] (by hand: at rest, so Q2,Q3,Q4 are 0; default 0.3)")
    add_params_arg(r)
    add_port_args(r)
    add_live_args(r, params=False)
    add_force_arg(r)
    r.set_defaults(func=run_on_port)


def run_swingup(args) -> int:
    from ..checks import check_positive
    from ..control import RigConditions, swing_up
    from ..files import check_output_dir, staged_dir
    from ..plotting import savefig

    if args.draws is not None:
        from ..control.robust import check_draws

        check_draws(args.draws)
        uncertainty = load_uncertainty_arg(args.params)
        params = uncertainty.params
    else:
        params = load_lumped(args.params)
    check_positive("t_end", args.t_end)
    check_positive("u_max", args.u_max)
    if not 2 <= args.frames <= 2000:
        raise InputError(f"--frames must be from 2 to 2000, got {args.frames}")
    out = check_output_dir(args.out, force=args.force, argument="out")
    names = {k: f"swingup.{k}" for k in ("csv", "png", "json")}
    if not args.no_animation:
        names["gif"] = "swingup.gif"
    rig = None if args.ideal else RigConditions(u_max=args.u_max)
    kw = {"u_max": args.u_max} if rig is None else {}
    res = swing_up(params, x0=args.x0, t_end=args.t_end, rig=rig, **kw)
    robust = None
    if args.draws is not None:
        from ..control.robust import robust_swingup

        robust = robust_swingup(uncertainty, draws=args.draws, seed=args.seed, x0=args.x0, t_end=args.t_end,
                                rig=rig, **kw)
        names.update({"robust_json": "robust.json", "robust_figure": "robust.png"})
    summary = res.summary()
    summary["x0"] = list(args.x0)
    summary["files"] = {k: str(out / v) for k, v in names.items()}
    if robust is not None:
        summary["robust"] = {k: v for k, v in robust.to_dict().items() if k != "runs"}
    with staged_dir(out, force=args.force, argument="out") as tmp:
        if robust is not None:
            (tmp / names["robust_json"]).write_text(json_text(robust.to_dict(), indent=2))
            savefig(robust.plot()["figure"], tmp / names["robust_figure"])
        res.result.to_csv(tmp / names["csv"], force=True)
        savefig(res.plot()["figure"], tmp / names["png"])
        if "gif" in names:
            res.animate(tmp / names["gif"], frames=args.frames, force=True)
        (tmp / names["json"]).write_text(json_text(summary, indent=2))
    if args.json:
        print(json_text(summary, indent=2))
    else:
        state = "balanced" if res.success else "NOT balanced"
        print(f"swing-up ({res.conditions}): {state}; catch at t = {res.t_catch:.3f} s, within "
              f"{res.tolerance:g} rad from t = {res.t_balanced:.3f} s; max |u| = {res.u_max:.4g}, "
              f"max |q4| = {res.q4_max:.4g} rad/s")
        if robust is not None:
            print(robust.summary())
        print("wrote " + ", ".join(summary["files"].values()))
    return 0 if res.success else 1


def run_lqr(args) -> int:
    from ..control import lqr_balance

    if not args.ts >= 0.0 or args.ts == float("inf"):  # NaN, negative, infinite
        raise InputError(f"--ts must be a sample period >= 0 [s] (0: a continuous design), got {args.ts:g}")
    robust = None
    if args.draws is not None:
        if args.angles is not None and len(args.angles) == 0:
            raise InputError("--angles: give at least one angle")
        uncertainty = draws_uncertainty(args)
        params = uncertainty.params
    elif args.out is not None or args.angles is not None:
        raise InputError("--out and --angles belong to --draws; give --draws N (or drop them)")
    else:
        params = load_lumped(args.params)
    L = lqr_balance(params, u_max=args.u_max, Ts=args.ts if args.ts > 0 else None)
    d = L.to_dict()
    if args.draws is not None:
        from ..control.robust import robust_balance

        robust = robust_balance(uncertainty, lqr=L, angles=args.angles, draws=args.draws, seed=args.seed,
                                t_end=args.t_end)
        d["robust"] = write_robust(robust, args)
    if args.json:
        print(json_text(d, indent=2))
        return 0
    print(f"LQR at the upright on (q1 - pi, q3, q4) ({'discrete, Ts = %g s' % L.Ts if L.Ts else 'continuous'}, "
          f"{L.backend}):")
    print("  K = [" + ", ".join(f"{k:.5g}" for k in L.K) + "]")
    print("  closed-loop poles: " + ", ".join(f"{p:.4g}" for p in L.poles))
    print(f"  open-loop unstable eigenvalue {L.unstable_eigenvalue:.4g} 1/s; capture bound |w.x| < "
          f"{L.capture_bound:.4g} rad with |u| <= {L.u_max:g}")
    if robust is not None:
        print(robust.summary())
        print("  wrote " + ", ".join(d["robust"]["files"].values()))
    return 0


def run_on_port(args) -> int:
    from ..device.control import ControlRun, control_conditions, run_control
    from ..device.prediction import predict_control_run
    from ..files import LOG_SUFFIXES, check_output_file
    from ..rig import write_result
    from .rig import finish_port_run

    if args.port is None:
        raise InputError("--port is required: a board with iwp's firmware, the port of iwp rig emulate, or twin")
    out = check_output_file(args.out, force=args.force, argument="out", suffixes=tuple(LOG_SUFFIXES))
    if args.x0 is not None and any(v != 0.0 for v in args.x0[1:]):
        raise InputError(f"--x0: a rig releases the pendulum at rest, so Q2,Q3,Q4 must be 0, got "
                         f"{','.join(f'{v:g}' for v in args.x0)}")
    params = load_lumped(args.params)
    model = live_params(args.params) if args.live else None
    where = args.where or ("host" if args.what == "swingup" else "device")
    spec = ControlRun(args.what, duration=args.duration, where=where, k1=args.k1, k2=args.k2,
                      x0=None if args.x0 is None else args.x0[0])
    duration = spec.duration
    clearing = port_clearing(args)  # checked before anything opens
    with live_session(args, f"control {args.what} ({where}) on {args.port}", duration) as view:
        with open_port_rig(args) as rig:
            if view is not None:
                view.attach(rig, lambda Ts: predict_control_run(spec, model, **control_conditions(rig, spec)))
            run = run_control(rig, spec, params=params, fast=args.fast, operator=port_operator(args),
                              progress=port_progress(args) if view is None else view.feed,
                              clearing=clearing)
        if view is not None:
            view.finish(run.reason, run=run)
    args.name = f"control {args.what}"
    status = finish_port_run(run, out, args, write_result)
    if status == 0 and args.what in ("balance", "swingup") and run.log is not None \
            and run.log.metadata.get("balanced") != "yes":
        print(f"iwp: {args.what}: not balanced at the end", file=sys.stderr)
        return 1
    return status

"""``iwp rig``: the virtual rig and rigs in the loop -- list the paper's experiments, run one, emulate a rig.

``iwp rig list`` names the experiments; ``iwp rig run NAME --out FILE``
runs one with the paper's settings (options override them) on the virtual
rig and writes the log (CSV, Parquet or MAT by extension; static curves as
CSV); with ``--port PORT`` it runs on a rig in the loop (a board with iwp's
firmware, the port of ``iwp rig emulate``, or ``twin`` for the twin in this
process), also user inputs (chirp, prbs, steps, sine, release);
``iwp rig emulate`` puts the twin behind a pseudo-terminal that speaks iwp's
protocol in real time and prints its port;
``iwp rig truth --out TRUTH.json`` writes the default truth plant for
editing (``--truth`` reads it back, field by field);
``iwp rig calibrate --out TRUTH.json`` calibrates the truth so that the
paper's procedures return the paper's published numbers (indirect
inference; ``--targets`` for other numbers) and writes it with its record.
"""

from __future__ import annotations

import argparse
import contextlib
import sys

from ..errors import InputError
from ._common import add_force_arg, add_x0_arg, float_list, plain
from .interrupts import interrupts_ignored
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
                       description=plain(__doc__), formatter_class=argparse.RawDescriptionHelpFormatter)
    rs = p.add_subparsers(dest="rig_command", metavar="{list,run,emulate,truth,calibrate}", parser_class=type(p))
    rs.required = True

    pl = rs.add_parser("list", help="name the paper's experiments with their settings",
                       description="Name the paper's experiments that iwp rig run NAME runs, one a line, with "
                                   "where the paper uses them and their settings.")
    pl.set_defaults(func=run_list, numerical=False)  # computes nothing: starts without numba

    pr = rs.add_parser("run", help="run one experiment and write its log",
                       description="Run one of the paper's experiments on the virtual rig, or with --port on a rig "
                                   "in the loop (also the inputs chirp, prbs, steps, sine, release); write its log "
                                   "(.csv/.txt, .parquet/.pq, .mat; static curves .csv). On a rig, Ctrl-C, a limit, "
                                   "a lost link or an error stops the motor and writes the log so far, marked "
                                   "interrupted.")
    pr.add_argument("name", metavar="NAME", help="experiment (see: iwp rig list), or with --port: chirp, prbs, "
                                                 "steps, sine, release")
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
    add_x0_arg(pr)
    pr.add_argument("--v-dz", type=_v_dz, metavar="V|VPOS,VNEG|none",
                    help="thresholds of the rig's dead-zone compensation (default 31; none: off)")
    add_port_args(pr)
    # --controller: the former name (elsewhere --controller names a feedback law, such as hopf)
    pr.add_argument("--where", "--controller", dest="where", choices=["device", "host"], default="device",
                    help="closed-loop: the Hopf law runs on the device (default) or on the host (as in iwp control "
                         "run; --controller is its former name)")
    pr.add_argument("--w0", type=float, help="chirp: start frequency [rad/s]")
    pr.add_argument("--tau", type=float, help="chirp: w(t) = w0 + t/tau [s]")
    pr.add_argument("--omega", type=float, help="sine: frequency [rad/s]")
    pr.add_argument("--hold-time", type=float, metavar="S", help="prbs: time each level is held [s]")
    pr.add_argument("--levels", type=float_list, metavar="U1,U2,...", help="steps: the levels [input units]")
    pr.add_argument("--step-time", type=float, metavar="S", help="steps: time on each level [s]")
    pr.add_argument("--locked", action="store_true", help="chirp, sine, prbs, steps: pendulum clamped at rest")
    add_live_args(pr)
    add_force_arg(pr)
    pr.set_defaults(func=run_run)

    pe = rs.add_parser("emulate", help="the twin behind a pseudo-terminal that speaks iwp's protocol",
                       description="Put the twin (the firmware's core with the twin as its plant) behind a "
                                   "pseudo-terminal that speaks iwp's protocol in real time, print its port, and "
                                   "serve until Ctrl-C. Then: iwp rig run NAME --port PORT --out FILE.")
    pe.add_argument("--truth", metavar="TRUTH.json", help="truth plant overrides (default: the calibrated twin)")
    pe.add_argument("--params", metavar="FILE.json",
                    help="another rig: its parameters (a rigid coupling; its dead zone if any)")
    pe.add_argument("--rig", metavar="RIG.json", help="another rig's description: its sample period and encoders")
    pe.add_argument("--session", choices=["auto", "5.1", "5.2"], default="auto",
                    help="the twin's motor session (default auto: clamped 5.1, free 5.2)")
    pe.add_argument("--seed", type=int, default=0, help="encoder noise seed")
    pe.add_argument("--link", metavar="PATH", help="also make the port reachable as PATH (a symbolic link)")
    pe.set_defaults(func=run_emulate)

    pt = rs.add_parser("truth", help="write the default truth plant as JSON (for editing)",
                       description="Write the virtual rig's default truth plant (the calibrated twin) as JSON, "
                                   "for editing; iwp rig run --truth FILE reads it back, field by field.")
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
    if args.port is not None:
        return run_port(args)
    from ..rig import VirtualRig, check_output_path, write_result

    port_only = [f for f in ("w0", "tau", "omega", "hold_time", "levels", "step_time", "params")
                 if getattr(args, f) is not None] + [f for f in ("live",) if getattr(args, f)]
    if args.fast or args.locked or port_only:
        flag = "--fast" if args.fast else "--locked" if args.locked else "--" + port_only[0].replace("_", "-")
        raise InputError(f"{flag} needs --port (a rig in the loop; --port twin for the twin)")
    overrides = {}
    for opt, key in (("amplitude", "amplitude"), ("step", "step"), ("duration", "duration"), ("seed", "seed"),
                     ("noise", "noise_std"), ("k1", "k1"), ("k2", "k2"), ("x0", "x0"), ("v_dz", "v_dz")):
        val = getattr(args, opt)
        if val is not None:
            overrides[key] = None if (key == "v_dz" and val == "none") else val
    truth = _truth(args.truth)
    rig = VirtualRig(truth)
    spec_opts = {s.name: s.options for s in rig.list_experiments()}
    if args.name not in spec_opts:
        from ..device.runs import USER_INPUTS

        if args.name in USER_INPUTS:
            raise InputError(f"{args.name!r} runs on a rig in the loop: add --port PORT (--port twin for the twin)")
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


def run_port(args) -> int:
    """``iwp rig run NAME --port PORT``: the experiment on a rig in the loop."""
    from ..device.prediction import predict_rig_run
    from ..device.runs import RUN_NAMES, run_kind, run_on_rig, run_settings
    from ..files import check_output_file
    from ..rig import write_result
    from ..rig.output import result_suffixes

    if args.name not in RUN_NAMES:
        raise InputError(f"unknown experiment or input {args.name!r}; valid: {', '.join(RUN_NAMES)}")
    out = check_output_file(args.out, force=args.force, argument="out", suffixes=result_suffixes(run_kind(args.name)))
    if args.truth is not None and args.port != "twin":
        raise InputError("--truth sets the twin's truth: use it with --port twin (or with iwp rig emulate)")
    options = {"amplitude": args.amplitude, "step": args.step, "duration": args.duration, "seed": args.seed,
               "noise_std": args.noise, "k1": args.k1, "k2": args.k2, "x0": args.x0,
               "v_dz": args.v_dz, "w0": args.w0, "tau": args.tau, "omega": args.omega,
               "hold_time": args.hold_time, "levels": args.levels, "step_time": args.step_time,
               "locked": True if args.locked else None,
               "where": args.where if run_kind(args.name).run.name == "CLOSED_LOOP" else None}
    if args.params is not None and not args.live:
        raise InputError("--params is the model of the live view's prediction: use it with --live")
    params = live_params(args.params) if args.live else None
    settings = run_settings(args.name, options)
    static = run_kind(args.name).run.name == "STATIC_CURVE"
    clearing = port_clearing(args)  # checked before anything opens
    with live_session(args, f"{args.name} on {args.port}", None if static else settings["duration"]) as view:
        with open_port_rig(args, _truth(args.truth) if args.truth else None) as rig:
            if view is not None:
                view.attach(rig, lambda Ts: predict_rig_run(args.name, params, Ts=Ts, **options))
            run = run_on_rig(rig, args.name, fast=args.fast, operator=port_operator(args),
                             progress=port_progress(args) if view is None else view.feed, clearing=clearing,
                             **options)
        if view is not None:
            view.finish(run.reason, run=run)
    return finish_port_run(run, out, args, write_result)


def finish_port_run(run, out, args, write) -> int:
    """Write what a run on a rig recorded (also when it stopped early) and say how it ended."""
    if not args.quiet and sys.stderr.isatty():
        print(file=sys.stderr)  # end the progress line
    if run.log is not None:
        if not getattr(args, "force", False) and out.exists():  # another program wrote --out meanwhile
            taken = out
            out = free_sibling(out)
            print(f"iwp: warning: {taken} appeared during the run (another program wrote it): not overwritten; "
                  f"the run's log is {out}", file=sys.stderr)
        # an interrupted run's log is written whatever interrupts follow (a second Ctrl-C, timeout's group signal)
        with interrupts_ignored() if run.interrupted else contextlib.nullcontext():
            write(run.log, out, force=True)
    what = "nothing recorded" if run.log is None else (
        f"{run.log.n_samples} samples, t = 0..{run.log.t[-1]:g} s" if hasattr(run.log, "n_samples")
        else f"{run.log.n_points} points")
    for kind, text in run.link_notes():
        print(f"iwp: {kind}: {text}", file=sys.stderr)
    if not run.interrupted:
        print(f"wrote {out} ({args.name} on {args.port}, {what})")
        return 0
    if run.log is not None:
        print(f"wrote {out} ({args.name} on {args.port}, {what}; interrupted: {run.reason})")
    if isinstance(run.error, KeyboardInterrupt):
        raise run.error
    from ..device.errors import DeviceError
    from ..device.loop import Terminated

    stopped = (f"the motor was stopped: {run.reason}" if run.stop_confirmed is not False else
               f"{run.reason}; the device did not answer the stop, so nothing confirms it: its watchdog stops the "
               f"motor within {watchdog_ms(run)} ms of the last command if it still runs (check the rig)")
    if isinstance(run.error, Terminated):
        print(f"iwp: {stopped}", file=sys.stderr)
        return 143
    if run.error is not None and not isinstance(run.error, DeviceError):
        raise run.error
    print(f"iwp: {stopped}", file=sys.stderr)
    return 1 if run.stop_confirmed is not False else UNCONFIRMED_STOP


#: exit status of a run whose device did not answer its stop (the watchdog's stop not confirmed)
UNCONFIRMED_STOP = 4


def watchdog_ms(run) -> str:
    """The device's watchdog [ms] as its log records it (``?`` where it does not)."""
    return "?" if run.watchdog_ms is None else f"{run.watchdog_ms:g}"


def free_sibling(path):
    """``path`` with ``.1``, ``.2``, ... before its extension: the first name not taken."""
    k = 1
    while True:
        p = path.with_name(f"{path.stem}.{k}{path.suffix}")
        if not p.exists():
            return p
        k += 1


def run_emulate(args) -> int:
    from ..data.rig_description import load_rig
    from ..device.emulator import TwinDevice, check_link, run_emulator
    from ..models.actuator import StartupFriction
    from ..rig import RigTruth
    from ..rig.stepper import TwinStepper
    from ._common import load_lumped

    if args.seed < 0:
        raise InputError(f"--seed must be >= 0, got {args.seed}")
    truth = _truth(args.truth)
    setup = {}
    what = "the calibrated twin of the paper's rig" if args.truth is None else f"the twin of {args.truth}"
    if args.params is not None:
        lumped = load_lumped(args.params)
        truth = RigTruth(lumped=lumped, belt=None, startup=StartupFriction())
        what = f"a rig with the parameters of {args.params}"
    if args.rig is not None:
        rig = load_rig(args.rig)
        if rig.sample_period is not None:
            setup["period_us"] = round(rig.sample_period * 1e6)
        cpr = getattr(rig.pendulum, "counts_per_rev", None)
        if cpr:
            setup["counts1"] = float(cpr)
            truth = truth.replace(counts_per_rev=int(cpr))
        wcpr = getattr(rig.wheel, "counts_per_rev", None)
        if wcpr:
            setup["counts2"] = float(wcpr)
        from ..device.protocol import PARAMS

        for name, value in setup.items():  # what the emulated board runs, or a clear refusal (never dropped)
            p = PARAMS[name]
            if not p.lo <= value <= p.hi:
                shown = (f"sample period {value * 1e-3:g} ms" if name == "period_us" else f"{value:g} counts a turn")
                raise InputError(f"--rig {args.rig}: its {shown} is beyond what the emulated board runs ({name} "
                                 f"{p.lo:g} .. {p.hi:g} {p.unit})")
        what += f", sampled as {args.rig} describes"
    if args.link is not None and check_link(args.link):
        print(f"iwp: removed --link {args.link}: a stale link to a port that no longer exists (an emulator "
              "killed without its clean-up)", file=sys.stderr)
    device = TwinDevice(TwinStepper(truth, session=args.session, seed=args.seed))

    def on_port(path: str) -> None:
        print(f"iwp: emulating {what} in real time; Ctrl-C stops", file=sys.stderr, flush=True)
        print(f"port: {path}", flush=True)
        if args.link:
            print(f"link: {args.link}", flush=True)

    def on_event(e: dict) -> None:
        what = e["state"] + (f" ({e['fault']})" if e["fault"] != "NONE" else "")
        after = "" if e["after_host"] != e["after_host"] else f", {e['after_host'] * 1e3:.1f} ms after the host's " \
                                                                "last bytes"
        if e["fault"] == "WATCHDOG" and e["own_pause"] > 2.0 * device.period:
            after += (f"; the emulator itself paused {e['own_pause'] * 1e3:.0f} ms meanwhile (its machine is "
                      "overloaded: no telemetry went out, so the host had nothing to answer)")
        print(f"iwp: device {what} at t = {e['t_device']:.3f} s (tick {e['tick']}){after}", file=sys.stderr,
              flush=True)

    timing = run_emulator(device, on_port=on_port, link=args.link, setup=setup, on_event=on_event)
    print(f"iwp: emulator stopped after {timing['ticks']} ticks; lateness of its ticks p50 "
          f"{timing['p50'] * 1e3:.3f} ms, p99 {timing['p99'] * 1e3:.3f} ms, max {timing['max'] * 1e3:.3f} ms "
          f"({timing['scheduling']}); "
          + (f"a host was driving the motor: stopped (device {timing['state']})"
             if timing["state_before"] == "ARMED" else f"device {timing['state_before']}"
             + (f" ({timing['fault_before']})" if timing["fault_before"] != "NONE" else "")),
          file=sys.stderr)
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

"""``iwp design``: gains of the Hopf anticontrol law for a wanted amplitude; the bifurcation branch."""

from __future__ import annotations

import argparse
import contextlib
import math
from pathlib import Path

from ..errors import InputError
from ._common import (
    add_draws_args,
    add_force_arg,
    add_params_arg,
    draws_uncertainty,
    json_text,
    load_lumped,
    write_robust,
)

_HOPF_DESCRIPTION = """\
Gains of u = k1 q3 + k2 q3^3 (section 5.3) that make the pendulum oscillate
with amplitude max q1 = A on the compensated model (9): numerical
continuation of the periodic orbit from the Hopf point, then Newton with the
amplitude fixed. With --k2 (default 0.1) it solves for k1; with --k1 it
solves for k2.
Examples:
  iwp design hopf --orbit-amplitude 2.58
  iwp design hopf --orbit-amplitude 1.5 --k2 0.2 --check --json
  iwp design hopf --orbit-amplitude 2.58 --k1 -10
  iwp design hopf --orbit-amplitude 2 --plot bifurcation.png
With --draws N and --params FILE (the parameters.json of iwp fit, which
carries the fit's covariance) the design, made on the fit's estimates, is
simulated on N parameter draws from its uncertainty: the amplitude's median
and 95 % interval and the share of draws with no stable orbit, written as
OUT/robust.json and OUT/robust.png (histogram and ECDF, the nominal marked):
  iwp design hopf --orbit-amplitude 1.5 --params fit/parameters.json --draws 200 --out robust-hopf
"""

_BRANCH_DESCRIPTION = """\
Continue the branch of periodic orbits from the Hopf point in k1 (fixed k2)
and write it as CSV (k1, amplitude, period, stable, max |u|, max |q4|,
|Floquet multipliers|); optionally the bifurcation diagram with long
simulations on it.
Example:
  iwp design branch --k2 0.1 --out branch.csv --plot branch.png --simulate 6
"""


def register(sub) -> None:
    p = sub.add_parser("design", help="controller design: Hopf amplitude (design hopf), bifurcation branch",
                       description="Controller design for the inertia wheel pendulum.")
    dsub = p.add_subparsers(dest="design_command", metavar="WHAT", parser_class=type(p))
    dsub.required = True

    h = dsub.add_parser("hopf", help="k1 (or k2) of u = k1 q3 + k2 q3^3 for an oscillation of amplitude A",
                        description=_HOPF_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    # --amplitude: the former name (elsewhere --amplitude is an input's amplitude [input units])
    h.add_argument("--orbit-amplitude", "--amplitude", dest="orbit_amplitude", type=float, required=True,
                   metavar="A", help="wanted amplitude of the oscillation, max q1 [rad] (--amplitude is its former "
                                     "name)")
    g = h.add_mutually_exclusive_group()
    g.add_argument("--k2", type=float, default=None, help="cubic gain, fixed (default 0.1); solve for k1")
    g.add_argument("--k1", type=float, default=None, help="linear gain, fixed; solve for k2")
    add_params_arg(h)
    h.add_argument("--json", action="store_true", help="print the result as JSON")
    h.add_argument("--check", action="store_true",
                   help="check by a long simulation (300 s) and report the simulated amplitude")
    h.add_argument("--allow-unstable", action="store_true", help="return an unstable orbit instead of an error")
    h.add_argument("--plot", default=None, metavar="FIG", help="write the bifurcation diagram with the design")
    add_draws_args(h, "the amplitude reached")
    h.add_argument("--t-end", type=float, default=60.0,
                   help="simulated time of each draw's closed loop [s] (default 60, at least 20: the amplitude is "
                        "measured over its last 20 s; --draws)")
    h.add_argument("--out", "-o", default=None, metavar="DIR", help="output folder of --draws")
    add_force_arg(h)
    h.set_defaults(func=run_hopf)

    b = dsub.add_parser("branch", help="the branch of periodic orbits from the Hopf point (CSV, figure)",
                        description=_BRANCH_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    b.add_argument("--k2", type=float, default=0.1, help="cubic gain (default 0.1)")
    add_params_arg(b)
    b.add_argument("--out", "-o", default=None, metavar="FILE.csv", help="write the branch as CSV")
    b.add_argument("--plot", default=None, metavar="FIG", help="write the bifurcation diagram")
    b.add_argument("--simulate", type=int, default=0, metavar="N",
                   help="add N long simulations (300 s) on the diagram and in the output")
    b.add_argument("--json", action="store_true", help="print the branch as JSON")
    add_force_arg(b)
    b.set_defaults(func=run_branch)


@contextlib.contextmanager
def _naming_params(args):
    """A design that fails on a parameter file names it: a file a fit wrote can hold a model whose orbit or
    simulation diverges (an x0 of 3.9e7 rad/s), and the message alone did not say which file."""
    from ..errors import GoalNotReached, SimulationError

    try:
        yield
    except (SimulationError, GoalNotReached) as exc:
        if args.params in (None, "table1"):
            raise
        raise type(exc)(f"--params {args.params}: the design on this file's parameters failed: {exc}") from None


def run_hopf(args) -> int:
    from ..checks import check_finite
    from ..control import design_hopf, simulated_amplitude
    from ..files import FIGURE_SUFFIXES, check_output_file, write_all

    robust = None
    if args.draws is not None:
        uncertainty = draws_uncertainty(args)
        params = uncertainty.params
    elif args.out is not None:
        raise InputError("--out is the folder of --draws; give --draws N (or drop --out)")
    else:
        params = load_lumped(args.params)
    for name in ("amplitude", "k1", "k2"):
        if getattr(args, name, None) is not None:
            check_finite(name, getattr(args, name))
    if args.plot is not None:
        check_output_file(args.plot, force=args.force, argument="plot", suffixes=FIGURE_SUFFIXES)
    with _naming_params(args):
        d = design_hopf(params, args.orbit_amplitude, k2=args.k2, k1=args.k1, require_stable=not args.allow_unstable)
    out = d.to_dict()
    if args.draws is not None:
        from ..control.robust import robust_hopf

        robust = robust_hopf(uncertainty, design=d, draws=args.draws, seed=args.seed, t_end=args.t_end)
        out["robust"] = write_robust(robust, args)
    sim = None
    if args.check:
        with _naming_params(args):
            sim = simulated_amplitude(params, d.k1, d.k2)
        out["check"] = {"simulated_amplitude": sim.amplitude, "relative_error": (sim.amplitude - d.amplitude)
                        / d.amplitude, "simulated_period": sim.period, "t_end": 300.0}
    if args.plot is not None:
        from ..control import continue_hopf
        from ..plotting import savefig

        branch = continue_hopf(params, d.k2)
        fig = branch.plot(design=d, simulations=[sim] if sim is not None else None)["figure"]
        write_all([(args.plot, lambda tmp: savefig(fig, tmp))])
        out["plot"] = str(args.plot)
    if args.json:
        print(json_text(out, indent=2))
        return 0
    fl = sorted(abs(m) for m in d.orbit.floquet)
    print(f"Hopf design on model (9): amplitude max q1 = {d.amplitude:g} rad")
    print(f"  k1 = {d.k1:.6g}{'  (solved)' if d.solved_for == 'k1' else ''}")
    print(f"  k2 = {d.k2:.6g}{'  (solved)' if d.solved_for == 'k2' else ''}")
    print(f"  period = {d.period:.5g} s (frequency {2 * math.pi / d.period:.5g} rad/s)")
    print(f"  orbit {'stable' if d.stable else 'UNSTABLE'}: Floquet |mu| = " + ", ".join(f"{m:.4g}" for m in fl))
    print(f"  on the orbit: max |u| = {d.orbit.u_max:.4g}, max |q4| = {d.orbit.q4_max:.4g} rad/s")
    print(f"  Hopf point k1* = {d.hopf.k1:.6g} ({d.hopf.criticality}, l1 = {d.hopf.l1:.4g})"
          + (f"; normal-form prediction k1 = {d.k1_normal_form:.4g}" if math.isfinite(d.k1_normal_form) else ""))
    if sim is not None:
        print(f"  check (300 s simulation): amplitude {sim.amplitude:.6g} rad "
              f"({100 * (sim.amplitude - d.amplitude) / d.amplitude:+.3f} %), period {sim.period:.5g} s")
    if args.plot is not None:
        print(f"  figure: {args.plot}")
    if robust is not None:
        print(robust.summary())
        print("  wrote " + ", ".join(out["robust"]["files"].values()))
    return 0


def run_branch(args) -> int:
    from ..checks import check_finite
    from ..control import continue_hopf, simulated_amplitude
    from ..files import FIGURE_SUFFIXES, check_output_file, write_all

    params = load_lumped(args.params)
    check_finite("k2", args.k2)
    if args.simulate < 0 or args.simulate > 100:
        raise InputError(f"--simulate must be from 0 to 100 simulations, got {args.simulate}")
    if args.out is not None:
        check_output_file(args.out, force=args.force, argument="out", suffixes=(".csv", ".txt"))
    if args.plot is not None:
        check_output_file(args.plot, force=args.force, argument="plot", suffixes=FIGURE_SUFFIXES)
    branch = continue_hopf(params, args.k2)
    sims = [simulated_amplitude(params, float(k), args.k2) for k in branch.stable_gains(args.simulate)] \
        if args.simulate > 0 else []
    writes = []
    if args.out is not None:
        writes.append((Path(args.out), branch.write_csv))
    if args.plot is not None:
        from ..plotting import savefig

        fig = branch.plot(simulations=sims or None)["figure"]
        writes.append((Path(args.plot), lambda tmp: savefig(fig, tmp)))
    write_all(writes)
    if args.json:
        d = branch.to_dict()
        d["simulations"] = [{"k1": s.k1, "amplitude": s.amplitude, "period": s.period} for s in sims]
        print(json_text(d, indent=2))
        return 0
    lo, hi = branch.amplitude_range
    print(f"Hopf branch (k2 = {args.k2:g}): k1* = {branch.hopf.k1:.6g} ({branch.hopf.criticality}), "
          f"{branch.k1.size} points, k1 down to {branch.k1[-1]:.5g}, amplitude up to {hi:.4g} rad "
          f"(stop: {branch.stop_reason})")
    for b in branch.bifurcations:
        print(f"  stability change ({b['kind']}) at k1 = {b['k1']:.5g}, amplitude {b['amplitude']:.4g} rad")
    for s in sims:
        print(f"  simulation k1 = {s.k1:.4g}: amplitude {s.amplitude:.5g} rad (branch {branch.amplitude_at(s.k1):.5g})")
    for path in (args.out, args.plot):
        if path is not None:
            print(f"  wrote {path}")
    return 0

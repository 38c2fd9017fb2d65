"""``iwp simulate``: simulate a model with an input or a controller, write CSV (and a plot)."""

from __future__ import annotations

from ._common import add_force_arg, add_params_arg, float_list, load_lumped


def register(sub) -> None:
    p = sub.add_parser("simulate", help="simulate the model with an input or a controller; write CSV",
                       description="Simulate the inertia wheel pendulum and write t,q1,q2,q3,q4,u as CSV.")
    add_params_arg(p)
    p.add_argument("--model", default="compensated",
                   choices=["compensated", "raw", "motor-disk", "motor-disk-raw"],
                   help="model: compensated (9, input u), raw (6, input v through the dead zone), "
                        "motor-disk (14)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--controller", help="state feedback: hopf (u = k1 q3 + k2 q3^3)")
    g.add_argument("--input", help="open-loop input: zero, constant, sine, chirp, step")
    p.add_argument("--k1", type=float, default=-10.0, help="Hopf gain k1 (default -10)")
    p.add_argument("--k2", type=float, default=0.1, help="Hopf gain k2 (default 0.1)")
    p.add_argument("--sampled", action="store_true",
                   help="evaluate the controller every --ts and hold it (as on the rig)")
    p.add_argument("--amplitude", type=float, default=60.0, help="input amplitude (default 60)")
    p.add_argument("--omega", type=float, default=5.0, help="sine frequency [rad/s] (default 5)")
    p.add_argument("--w0", type=float, default=3.0, help="chirp initial frequency [rad/s] (default 3)")
    p.add_argument("--tau", type=float, default=100.0, help="chirp rate: w(t) = w0 + t/tau (default 100)")
    p.add_argument("--t-step", type=float, default=0.0, help="step time [s]")
    p.add_argument("--x0", type=float_list, default=None, help="initial state q1,q2,q3,q4 (default 0,0,0,0)")
    p.add_argument("--t0", type=float, default=0.0, help="initial time [s] (restart, figure 9b)")
    p.add_argument("--t-end", type=float, required=True, help="final time [s]")
    p.add_argument("--ts", type=float, default=0.005, help="output sample time [s] (default 0.005)")
    p.add_argument("--feedforward", action="store_true", help="apply the dead-zone feedforward (7)-(8)")
    p.add_argument("--saturation", type=float, default=None, help="clip the command to +-VALUE")
    p.add_argument("--rtol", type=float, default=1e-10,
                   help="relative error tolerance of the DOP853 integrator (default 1e-10)")
    p.add_argument("--atol", type=float, default=1e-10,
                   help="absolute error tolerance of the integrator, per state [rad, rad/s] (default 1e-10)")
    p.add_argument("--band", choices=["linear", "monte-carlo"], default=None,
                   help="also write the 95 %% parameter and prediction bands (columns q1_lo, q1_hi, q1_plo, q1_phi, "
                        "...) from the covariance in --params (the parameters.json of iwp fit)")
    p.add_argument("--draws", type=int, default=None,
                   help="parameter draws of a monte-carlo band (default 1000; --band monte-carlo)")
    p.add_argument("--seed", type=int, default=None, help="seed of the parameter draws (default 0; --band monte-carlo)")
    p.add_argument("--out", required=True, help="output CSV file")
    p.add_argument("--plot", default=None, help="also save a figure (PNG/SVG/PDF)")
    add_force_arg(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..errors import InputError
    from ..models.plant import Plant
    from ..sim.inputs import make_input
    from ..sim.tasks import SimulationTask, write_simulation
    from ..sim.uncertainty import load_uncertainty

    if args.controller is not None:
        inp = make_input(args.controller, k1=args.k1, k2=args.k2, Ts=args.ts if args.sampled else None,
                         argument="controller")
    else:
        inp = make_input(args.input or "zero", amplitude=args.amplitude, omega=args.omega, w0=args.w0, tau=args.tau,
                         t_step=args.t_step)
    for flag, value in (("--draws", args.draws), ("--seed", args.seed)):
        if value is not None and args.band != "monte-carlo":
            raise InputError(f"{flag} is for the draws of --band monte-carlo; without it, it would do nothing")
    uncertainty = load_uncertainty(args.params) if args.band is not None else None
    params = uncertainty.params if uncertainty is not None else load_lumped(args.params)
    task = SimulationTask(Plant(params, model=args.model), inp, x0=args.x0, t0=args.t0, t_end=args.t_end, Ts=args.ts,
                          feedforward=args.feedforward, saturation=args.saturation, rtol=args.rtol, atol=args.atol,
                          uncertainty=uncertainty, band=args.band, draws=1000 if args.draws is None else args.draws,
                          seed=0 if args.seed is None else args.seed)
    print(write_simulation(task, args.out, plot=args.plot, force=args.force))
    return 0

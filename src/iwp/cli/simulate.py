"""``iwp simulate``: simulate a model with an input or a controller, write CSV (and a plot)."""

from __future__ import annotations

from ._common import add_force_arg, add_params_arg, add_x0_arg, load_lumped


def register(sub) -> None:
    p = sub.add_parser("simulate", help="simulate the model with an input or a controller; write CSV",
                       description="Simulate the inertia wheel pendulum and write t,q1,q2,q3,q4,u as CSV.")
    add_params_arg(p)
    p.add_argument("--model", default="compensated",
                   choices=["compensated", "raw", "motor-disk", "motor-disk-raw", "belt-full"],
                   help="model: compensated (9, input u), raw (6, input v through the dead zone), "
                        "motor-disk (14), belt-full ((4a) with the belt (15) of a fit with it: --params its "
                        "parameters.json)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--controller", help="state feedback: hopf (u = k1 q3 + k2 q3^3)")
    g.add_argument("--input", help="open-loop input: zero, constant, sine, chirp, step")
    p.add_argument("--k1", type=float, default=None, help="Hopf gain k1 (default -10; --controller hopf)")
    p.add_argument("--k2", type=float, default=None, help="Hopf gain k2 (default 0.1; --controller hopf)")
    p.add_argument("--sampled", action="store_true",
                   help="evaluate the controller every --ts and hold it (as on the rig)")
    p.add_argument("--amplitude", type=float, default=None,
                   help="input amplitude (default 60; --input constant, sine, chirp, step)")
    p.add_argument("--omega", type=float, default=None, help="sine frequency [rad/s] (default 5; --input sine)")
    p.add_argument("--w0", type=float, default=None, help="chirp initial frequency [rad/s] (default 3; --input chirp)")
    p.add_argument("--tau", type=float, default=None,
                   help="chirp rate: w(t) = w0 + t/tau (default 100; --input chirp)")
    p.add_argument("--t-step", type=float, default=None, help="step time [s] (default 0; --input step)")
    add_x0_arg(p, help="initial state [rad, rad/s] (default 0,0,0,0)")
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
    p.add_argument("--out", "-o", required=True, help="output CSV file")
    p.add_argument("--plot", default=None, help="also save a figure (PNG/SVG/PDF)")
    add_force_arg(p)
    p.set_defaults(func=run)


#: the settings of the inputs and their users; their defaults
_SETTINGS = {"k1": ("hopf",), "k2": ("hopf",), "sampled": ("hopf",), "amplitude": ("constant", "sine", "chirp", "step"),
             "omega": ("sine",), "w0": ("chirp",), "tau": ("chirp",), "t_step": ("step",)}
_DEFAULTS = {"k1": -10.0, "k2": 0.1, "amplitude": 60.0, "omega": 5.0, "w0": 3.0, "tau": 100.0, "t_step": 0.0}
_KIND = {"hopf": "--controller", "constant": "--input", "sine": "--input", "chirp": "--input", "step": "--input",
         "zero": "--input"}


def run(args) -> int:
    from ..errors import InputError
    from ..models.parameters import stored_belt
    from ..models.plant import MODELS, Plant
    from ..sim.inputs import make_input
    from ..sim.options import CommandChain, Feedforward, Tolerances
    from ..sim.tasks import SimulationTask, write_simulation
    from ..sim.uncertainty import BandOptions, load_uncertainty

    # a setting the chosen input does not take would be ignored: refused, as an unknown one is
    chosen = args.controller.lower() if args.controller is not None else (args.input or "zero").lower()
    for dest, users in _SETTINGS.items():
        value = getattr(args, dest)
        if value not in (None, False) and chosen not in users:
            flag = "--" + dest.replace("_", "-")
            raise InputError(f"{flag} is a setting of {' or '.join(f'{_KIND[u]} {u}' for u in users)}; "
                             f"{_KIND.get(chosen, '--input')} {chosen} takes none")

    def get(dest):
        return _DEFAULTS[dest] if getattr(args, dest) is None else getattr(args, dest)

    if args.controller is not None:
        inp = make_input(args.controller, k1=get("k1"), k2=get("k2"), Ts=args.ts if args.sampled else None,
                         argument="controller")
    else:
        inp = make_input(args.input or "zero", amplitude=get("amplitude"), omega=get("omega"), w0=get("w0"),
                         tau=get("tau"), t_step=get("t_step"))
    for flag, value in (("--draws", args.draws), ("--seed", args.seed)):
        if value is not None and args.band != "monte-carlo":
            raise InputError(f"{flag} is for the draws of --band monte-carlo; without it, it would do nothing")
    uncertainty = load_uncertainty(args.params) if args.band is not None else None
    params = uncertainty.params if uncertainty is not None else load_lumped(args.params)
    belt = None
    if MODELS[args.model].drive is not None:  # the belt of a fit with it, from its parameters.json
        belt = uncertainty.belt if uncertainty is not None else stored_belt(args.params)
        if belt is None:
            raise InputError(f"--params {args.params}: model {args.model!r} needs the belt's parameters (15), which "
                             "it does not hold; give the parameters.json of a fit with the belt")
    plant = Plant(params, model=args.model, belt=belt)
    chain = CommandChain(inp, Feedforward.of_plant(plant) if args.feedforward else None, args.saturation)
    task = SimulationTask(plant, chain, x0=args.x0, t0=args.t0, t_end=args.t_end, Ts=args.ts,
                          tolerances=Tolerances(rtol=args.rtol, atol=args.atol),
                          uncertainty=uncertainty, band=None if args.band is None else BandOptions(
                              args.band, draws=1000 if args.draws is None else args.draws,
                              seed=0 if args.seed is None else args.seed))
    print(write_simulation(task, args.out, plot=args.plot, force=args.force))
    return 0

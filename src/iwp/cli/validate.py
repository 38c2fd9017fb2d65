"""``iwp validate``: simulate a parameter set against a log; fit per signal, error, restarts (figure 9b)."""

from __future__ import annotations

import argparse
import math

from ._common import (
    add_accept_poor_arg,
    add_controller_args,
    add_force_arg,
    add_input_hold_arg,
    controller_of,
    float_list,
    json_text,
    poor_status,
)

_DESCRIPTION = """\
Simulate the model from the log's initial state with the logged input
replayed (or in closed loop with --controller hopf) and compare with the
measured signals: fit = 100 (1 - ||y - y_sim|| / ||y - mean(y)||) per signal,
the error signal, and restarts from the measured state (figure 9b).
Examples:
  iwp validate free.csv --params free.json --t-start 0.5 --json
  iwp validate chirp.csv --params table1 --restart 200 --plot fig9b.png
  iwp validate loop.csv --params table1 --controller hopf --k1 -10 --k2 0.1
  iwp validate swing.txt --format angle-log --params swing.json --t-start 0.5
"""

_MODELS = ("auto", "free", "free-nowheel", "compensated", "raw", "motor-disk", "motor-disk-raw")


def register(sub) -> None:
    p = sub.add_parser("validate", help="simulate a parameter set against a log: fit, error, restarts",
                       description=_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", metavar="FILE", help="experiment log (CSV, Parquet, MAT, or an angle log with --format)")
    p.add_argument("--params", required=True, metavar="P.json",
                   help="parameter set: a JSON file (e.g. from iwp identify --out) or a built-in name (table1)")
    p.add_argument("--format", default=None, choices=["csv", "mat", "parquet", "angle-log"],
                   help="format of FILE (default: from its extension)")
    p.add_argument("--model", default="auto", choices=_MODELS,
                   help="model simulated (default auto: the 'model' entry of P.json if any, else free for a log "
                        "without input (free-nowheel for an angle log), raw for a log of v, compensated otherwise)")
    p.add_argument("--estimate-x0", action="store_true",
                   help="estimate the initial state by a simulation-error fit instead of taking the measured one")
    add_input_hold_arg(p)
    p.add_argument("--t-start", type=float, default=None, help="start of the window [s]")
    p.add_argument("--t-end", type=float, default=None, help="end of the window [s]")
    p.add_argument("--restart", type=float_list, default=None, metavar="T1,T2",
                   help="restart the simulation from the measured state at these times [s] (figure 9b)")
    p.add_argument("--signals", default=None,
                   help="signals compared, and judged for the exit status (default q1, the wheel's q2 and q4, judged "
                        "on q1 and q4; q1 and q4 when the log holds only the wheel speed; q3, q4 differentiated when "
                        "not logged)")
    add_controller_args(p, "simulate in closed loop with u = k1 q3 + k2 q3^3 instead of replaying the logged u")
    p.add_argument("--band", action="store_true",
                   help="the fit's 95 %% parameter and prediction bands (linearised, from the covariance in P.json, "
                        "the parameters.json of iwp fit) and the share of the samples inside the prediction band")
    p.add_argument("--json", action="store_true", help='print {"fit": {"q1": ..., ...}, ...} as JSON')
    add_accept_poor_arg(p)
    p.add_argument("--plot", default=None, metavar="FIG", help="save the comparison figure (PNG/SVG/PDF)")
    add_force_arg(p)
    p.set_defaults(func=run)


def _looks_like_angle_log(path: str) -> bool:
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            first = fh.readline()
    except OSError:
        return False
    return "sample_rate" in first


def run(args) -> int:
    from ..data import read_experiment
    from ..errors import DataFormatError, InputError
    from ..files import FIGURE_SUFFIXES, check_output_file, write_all
    from ..ident.metrics import judged_fits, poor_fits
    from ..ident.output_error import angle_quantum
    from ..ident.validation import (
        ValidationOptions,
        choose_model,
        held_out_q1_offset,
        model_input,
        validate,
        validation_plant,
    )
    from ..models.parameters import stored_belt, stored_model, stored_q1_zero, stored_reads_v_as_u
    from ..models.plant import MODELS
    from ..plotting import savefig
    from ..sim.uncertainty import load_uncertainty
    from ._common import load_lumped

    if args.plot is not None:
        check_output_file(args.plot, force=args.force, argument="plot", suffixes=FIGURE_SUFFIXES)
    signals = None
    if args.signals is not None:
        signals = tuple(s.strip() for s in args.signals.split(",") if s.strip())
        if not signals:
            raise InputError("--signals: give at least one of q1,q2,q3,q4")
    params = load_uncertainty(args.params) if args.band else load_lumped(args.params)
    try:
        data = read_experiment(args.file, format=args.format)
    except DataFormatError as exc:
        if args.format is None and _looks_like_angle_log(args.file):
            raise DataFormatError(f"{exc}; this looks like an angle log: give --format angle-log") from None
        raise
    reads_v_as_u = stored_reads_v_as_u(args.params)
    model = choose_model(data, args.model, stored=stored_model(args.params), closed_loop=args.controller is not None,
                         source=args.params, log=args.file, reads_v_as_u=reads_v_as_u)
    if reads_v_as_u:  # as iwp fit read the logs
        data = model_input(data, model, args.file)
    if MODELS[model].drive is not None:  # a belt model: the belt comes from the file, as iwp fit --belt writes it
        if args.band:  # the uncertainty holds the file's belt: checked here, to name the file when it has none
            validation_plant(params.params, data, model, belt=params.belt, source=f"--params {args.params}")
        else:
            params = validation_plant(params, data, model, belt=stored_belt(args.params),
                                      source=f"--params {args.params}")
    zero = stored_q1_zero(args.params)
    offset = held_out_q1_offset(data, zero.value)
    # the log's own zero about the fit's mean, as iwp fit's held-out bands carry it
    zero_variance = zero.variance(angle_quantum(data.q1)) if offset else None
    controller = controller_of(args)
    # default: q1 and the wheel's own signal, and its speed where that is its angle (q1 and q4 are judged)
    shown = signals if signals is not None else (("q1", "q2", "q4") if data.q2 is not None else None)
    v = validate(data, params, model=model, controller=controller, signals=shown,
                 options=ValidationOptions(window=(args.t_start, args.t_end), restart_times=args.restart or (),
                                           estimate_x0=args.estimate_x0, q1_offset=offset,
                                           q1_zero_variance=zero_variance, input_hold=args.input_hold))
    if args.plot is not None:
        fig = v.plot()["figure"]
        write_all([(args.plot, lambda tmp: savefig(fig, tmp))])
    if args.json:
        print(json_text(v.to_dict(), indent=2))
    else:
        if offset:
            print(f"q1 less the pendulum zero offset {offset:+.4g} rad of {args.params} (the training logs' mean, "
                  "as iwp fit took it off its held-out logs)")
        print(v.summary())
        if args.plot is not None:
            print(f"wrote {args.plot}")
    bad = [k for k, f in v.fit.items() if not math.isfinite(f)]
    if bad and not args.json:
        print(f"note: the fit of {', '.join(bad)} is not defined (the measured signal is constant)")
    # the given signals, or q1 and the wheel's speed where they move (the wheel's angle is shown, not judged)
    judged = signals if signals is not None else tuple(judged_fits(v.fit, v.measured))
    poor = poor_fits([v.fit], [k for k in judged if math.isfinite(v.fit.get(k, math.nan))])
    return poor_status(f"the model predicts {args.file} poorly (fit {', '.join(poor)})" if poor else None,
                       args.accept_poor)

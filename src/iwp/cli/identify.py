"""``iwp identify``: least-squares identification of the paper's set-ups, with uncertainty.

``iwp identify FILE... --setup SETUP`` reads one or more logs of one set-up
(stacked), differentiates the encoder positions, solves the least squares
(13) and prints the parameters with standard errors, 95 % intervals and
diagnostics (``--json``: one JSON object). ``--out PARAMS.json`` writes a
parameter file for ``iwp simulate --params`` (parameters the set-up does not
identify come from ``--base``, default Table 1).

Set-ups (section 5): full (10)-(12), motor-disk (theta^a), motor-disk-coulomb
(theta^b), free (theta^c), two-step (theta^d; needs --pendulum, the free
result), dead-zone (v+, v- from a static curve).
"""

from __future__ import annotations

import argparse
import sys

from ..errors import InputError
from ._common import LazyChoices, add_force_arg, add_input_hold_arg, json_text, plain


def register(sub) -> None:
    p = sub.add_parser(
        "identify", help="identify parameters from logs (least squares of section 5, with uncertainty)",
        description=plain(__doc__), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="log(s) of one set-up (stacked); a static curve for dead-zone")
    p.add_argument("--setup", required=True, choices=LazyChoices("iwp.ident.setups", "SETUPS"), metavar="SETUP",
                   help="identification set-up (paper's numbering): %(choices)s")
    p.add_argument("--pendulum", metavar="FREE.json",
                   help="two-step: the free-pendulum result (--json output or --out file of --setup free) "
                        "or a parameter file")
    p.add_argument("--p2", metavar="VALUE|FILE.json",
                   help="free: known p2 [1/s] (a number, or a two-step result/parameter file) so that the disk "
                        "term p2 q4 of (9) is not neglected")
    p.add_argument("--t-start", type=float, metavar="S", help="start of the time window [s]")
    p.add_argument("--t-end", type=float, metavar="S", help="end of the time window [s]")
    p.add_argument("--method", choices=["central", "savgol", "savgol_direct", "butter"],
                   help="differentiation method (default: savgol over 0.5 s, cubic = 101 samples at 5 ms; "
                        "see docs/identification.md)")
    p.add_argument("--window", type=int, metavar="N",
                   help="savgol: window [samples] (default: the default method's, 0.5 s of the log)")
    p.add_argument("--polyorder", type=int, metavar="N", help="savgol: polynomial degree")
    p.add_argument("--cutoff", type=float, metavar="HZ", help="butter: cut-off frequency [Hz]")
    p.add_argument("--order", type=int, metavar="N", help="butter: filter order")
    p.add_argument("--covariance", choices=["noise", "hac", "ols"], default="noise",
                   help="uncertainty: encoder noise through the differentiator (default), HAC, or OLS")
    add_input_hold_arg(p)
    p.add_argument("--angle-zero", choices=["estimate", "logged"], default="estimate",
                   help="the pendulum angle's zero in each log: estimate its offset from the hanging position "
                        "(default; a column cos q1 per log) or take the logged zero as exact (the paper's (10))")
    p.add_argument("--base", metavar="PARAMS", default=None,
                   help="parameter set for the values the set-up does not identify (default table1)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--out", "-o", metavar="PARAMS.json",
                   help="write the identified parameter set (iwp simulate --params)")
    p.add_argument("--refine", action="store_true",
                   help="refine the least-squares result by simulation error (iwp.refine)")
    add_force_arg(p)
    p.set_defaults(func=run)


def _differentiator(args, Ts: float):
    from ..ident.differentiate import Differentiator
    from ..ident.identification import default_differentiator

    settings = {k: getattr(args, k) for k in ("window", "polyorder", "cutoff", "order") if getattr(args, k) is not None}
    if args.method is None and not settings:
        return None  # identify() picks the default for the log's sample time
    method = args.method
    if method is None:
        method = "butter" if {"cutoff", "order"} & set(settings) else "savgol"
    if method in ("savgol", "savgol_direct") and "window" not in settings:
        # the default's window for the log's sample time (naming the default method changes nothing)
        default = default_differentiator(Ts)
        settings.setdefault("polyorder", default.polyorder)
        settings["window"] = default.window
    try:
        return Differentiator(method, **settings)
    except InputError as exc:
        raise InputError(f"{exc} (--method {method})", argument=exc.argument) from None


def _load_series(path: str):
    """A time-series log; a static curve gets a clear message."""
    from ..data import read_experiment, read_static_curve
    from ..errors import DataFormatError

    try:
        return read_experiment(path)
    except DataFormatError as exc:
        try:
            read_static_curve(path)
        except Exception:
            raise exc from None
        raise InputError(f"{path}: is a static curve (input, q4); this set-up needs a time-series log "
                         "(t, q1, q2, ...); use --setup dead-zone for static curves") from None


def _load_curve(path: str):
    from ..data import read_experiment, read_static_curve
    from ..errors import DataFormatError

    try:
        return read_static_curve(path)
    except DataFormatError as exc:
        try:
            read_experiment(path)
        except Exception:
            raise exc from None
        raise InputError(f"{path}: is a time-series log; --setup dead-zone needs a static curve "
                         "(columns v,q4 or u,q4, one row per steady state)") from None


def _p2(spec: str | None):
    if spec is None:
        return None
    try:
        return float(spec)
    except ValueError:
        pass
    from ..ident.identification import load_pendulum

    obj = load_pendulum(spec)
    if hasattr(obj, "parameters") and "p2" not in obj.parameters:
        raise InputError(f"--p2 {spec}: the {obj.setup!r} result has no p2; give a two-step result")
    return obj


def run(args) -> int:
    from ..errors import IdentificationError
    from ..files import check_output_file, write_all
    from ..ident.identification import IdentifyOptions, identify, load_pendulum
    from ..ident.setups import get_setup
    from ..models.parameters import save_params
    from ._common import load_lumped

    spec = get_setup(args.setup)
    spec.check_options(args.pendulum, args.p2)  # the set-up's own rules, before any work
    base = load_lumped(args.base, flag="--base") if args.base is not None else None
    out_path = None
    if args.out is not None:
        out_path = check_output_file(args.out, force=args.force, argument="out", suffixes=(".json",))
    pendulum = load_pendulum(args.pendulum) if args.pendulum is not None else None
    p2 = _p2(args.p2)
    if spec.static:
        data = [_load_curve(f) for f in args.files]
        res = identify(data if len(data) > 1 else data[0], args.setup, t_start=args.t_start, t_end=args.t_end)
    else:
        data = [_load_series(f) for f in args.files]
        diff = _differentiator(args, data[0].Ts)
        res = identify(data if len(data) > 1 else data[0], args.setup, pendulum=pendulum, p2=p2, t_start=args.t_start,
                       t_end=args.t_end, base=base,
                       options=IdentifyOptions(differentiator=diff, covariance=args.covariance,
                                               input_hold=args.input_hold, angle_zero=args.angle_zero))
    files = ", ".join(args.files)
    if not res.success:
        raise IdentificationError(f"{files}: {res.message}; nothing written")

    if args.refine:
        from ..ident.refinement import refine_identification

        r = refine_identification(args.setup, data, res.to_params(base), window=(args.t_start, args.t_end))
        if not r.success:
            raise IdentificationError(f"{files}: refinement failed: {r.message}; nothing written")
        if out_path is not None:
            write_all([(out_path, lambda tmp: save_params(
                r.params, tmp, force=True, extra={"identification": res.to_dict(), "refinement": r.to_dict()}))])
        if args.json:
            print(json_text(r.to_dict()))
        else:
            print(res.summary())
            print()
            print(r.summary(warnings=False))  # its warnings went to stderr
            if out_path is not None:
                print(f"wrote {out_path}")
        return 0

    if out_path is not None:
        params = res.to_params(base)
        extra = {"note": spec.note, "identification": res.to_dict()}
        try:
            params.check_physical()
        except InputError as exc:
            # keep the fit as it is (the paper simulates its eq. (16) too), but say so in the file
            extra["unconstrained_fit"] = True
            print(f"iwp: warning: {out_path}: written as an unconstrained fit ({exc}); "
                  "iwp simulate will use it with a warning", file=sys.stderr)
        write_all([(out_path, lambda tmp: save_params(params, tmp, force=True, extra=extra))])
    if args.json:
        print(json_text(res.to_dict()))
    else:
        print(res.summary())
        if out_path is not None:
            print(f"wrote {out_path}")
    return 0

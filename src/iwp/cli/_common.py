"""Argument helpers shared by the subcommands (parsing only)."""

from __future__ import annotations

import argparse
import importlib
import json
import re
import sys
from collections.abc import Sequence

from ..errors import InputError


class LazyChoices(Sequence):
    """``choices=`` for argparse whose names live in a module that is slow to import.

    The module is imported the first time argparse checks a value or prints
    the option's help, so that building the parser (``iwp --help``) stays fast.
    """

    def __init__(self, module: str, attribute: str):
        self._module = module
        self._attribute = attribute
        self._names: list[str] | None = None

    def _load(self) -> list[str]:
        if self._names is None:
            self._names = list(getattr(importlib.import_module(self._module), self._attribute))
        return self._names

    def __getitem__(self, i):
        return self._load()[i]

    def __len__(self) -> int:
        return len(self._load())

    def __contains__(self, value) -> bool:
        return value in self._load()


def json_text(obj, **kw) -> str:
    """``obj`` as strict JSON (NaN and inf as null, numpy values as numbers): what ``--json`` prints and the
    commands' JSON files hold, readable by any parser (``jq``, a browser)."""
    from ..files import jsonable  # numpy: loaded with the command, not with the parser

    return json.dumps(jsonable(obj), allow_nan=False, **kw)


def plain(doc: str) -> str:
    """A module docstring as a parser's description: reST literals (````iwp rig````) become plain text."""
    return re.sub(r"``([^`]+)``", r"\1", doc)


def float_list(text: str) -> list[float]:
    """Parse ``"0.1,0,0,0"`` into floats (argparse type)."""
    try:
        return [float(s) for s in text.split(",") if s.strip() != ""]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None


def initial_state(text: str) -> list[float]:
    """Parse ``--x0``: ``Q1`` (released at rest: ``Q1,0,0,0``) or ``Q1,Q2,Q3,Q4`` [rad, rad/s] into 4 floats."""
    vals = float_list(text)
    if len(vals) not in (1, 4):
        raise argparse.ArgumentTypeError(f"expected Q1 or Q1,Q2,Q3,Q4, got {len(vals)} numbers")
    return vals + [0.0, 0.0, 0.0] if len(vals) == 1 else vals


#: metavar and help of ``--x0`` (:func:`add_x0_arg`)
X0_METAVAR = "Q1[,Q2,Q3,Q4]"


def add_x0_arg(p: argparse.ArgumentParser, help: str = "initial state [rad, rad/s]", **kw) -> None:
    """``--x0 Q1[,Q2,Q3,Q4]`` (:func:`initial_state`): the same syntax and meaning in every command."""
    p.add_argument("--x0", type=initial_state, metavar=X0_METAVAR,
                   help=f"{help}; Q1 alone: released at rest (Q1,0,0,0)", **kw)


def add_params_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--params", default="table1", metavar="FILE.json",
                   help="parameter set: a JSON file or a built-in name (default: table1)")


def add_controller_args(p: argparse.ArgumentParser, help: str) -> None:
    """``--controller hopf`` with its gains ``--k1``, ``--k2`` and ``--controller-ts`` (:func:`controller_of`)."""
    p.add_argument("--controller", choices=["hopf"], default=None, help=help)
    p.add_argument("--k1", type=float, default=-10.0, help="Hopf gain k1 (default -10)")
    p.add_argument("--k2", type=float, default=0.1, help="Hopf gain k2 (default 0.1)")
    p.add_argument("--controller-ts", type=float, default=None,
                   help="sample the controller every TS seconds and hold it (default: continuous)")


def controller_of(args: argparse.Namespace):
    """The controller of :func:`add_controller_args`' arguments, or None."""
    if args.controller is None:
        return None
    from ..sim.inputs import HopfController

    return HopfController(args.k1, args.k2, args.controller_ts)


def add_force_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--force", action="store_true", help="overwrite existing output files")


def add_input_hold_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--input-hold", choices=["auto", "zoh", "continuous"], default="auto",
                   help="how the logged input acted between samples: held until the next (zoh, a rig's "
                        "controller), continuous (a continuous simulation, an analog drive), or auto (default: the "
                        "log's metadata input_hold, else read from the log: both readings fitted to the wheel's "
                        "row, the one with the smaller residuals taken, held where the data cannot tell)")


def add_accept_poor_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--accept-poor", action="store_true",
                   help="exit with status 0 when the model predicts the held-out data poorly (a mean fit below "
                        "50 %% or a fit below 0 %%); without it such a run writes its results and exits with 1")


def poor_status(reason: str | None, accept: bool) -> int:
    """The exit status of a command whose prediction of held-out data may be poor: 1 with the reason on stderr
    (unless ``accept``), else 0."""
    if reason is None:
        return 0
    print(f"iwp: {reason}" + ("" if accept else " (exit status 1; --accept-poor to accept it)"), file=sys.stderr)
    return 0 if accept else 1


def load_lumped(spec: str, flag: str = "--params"):
    """The lumped parameter set of a ``--params`` argument (file or built-in name); errors name ``flag``."""
    from ..models.parameters import LumpedParameters, PhysicalParameters, load_params

    try:
        params = load_params(spec)
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(flag) else f"{flag} {msg}") from None
    if isinstance(params, PhysicalParameters):
        return params.to_lumped()
    if not isinstance(params, LumpedParameters):
        raise InputError(f"{flag} {spec}: expected a lumped or physical parameter set")
    return params


def add_draws_args(p: argparse.ArgumentParser, what: str) -> None:
    """``--draws N`` and ``--seed``: the outcome of ``what`` over the parameter uncertainty of ``--params``."""
    p.add_argument("--draws", type=int, default=None, metavar="N",
                   help=f"{what} over N parameter draws from the fit's uncertainty (--params: the parameters.json "
                        "of iwp fit, with its covariance); writes robust.json and robust.png into --out")
    p.add_argument("--seed", type=int, default=0, help="seed of the parameter draws (default 0)")


def load_uncertainty_arg(spec: str, flag: str = "--params"):
    """The fit's parameters and covariance of a ``--params`` file (for ``--draws``); errors name ``flag``."""
    from ..sim.uncertainty import load_uncertainty

    try:
        return load_uncertainty(spec)
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(flag) else f"{flag} {msg}") from None



def draws_uncertainty(args):
    """The fit's uncertainty for ``--draws N`` (``--params`` with its covariance), after checking ``--draws``,
    ``--out`` (the folder for robust.json and robust.png) and ``--t-end`` before any work."""
    from ..checks import check_positive
    from ..control.robust import check_draws
    from ..files import check_output_dir

    check_draws(args.draws)
    if args.out is None:
        raise InputError("--draws needs --out DIR, the folder for robust.json and robust.png")
    check_positive("t_end", args.t_end)
    uncertainty = load_uncertainty_arg(args.params)
    check_output_dir(args.out, force=args.force, argument="out")
    return uncertainty


def write_robust(robust, args) -> dict:
    """Write a robust design's robust.json and robust.png into ``--out`` (staged); its summary for the JSON
    output, without the runs, with the files written."""
    from pathlib import Path

    from ..files import staged_dir
    from ..plotting import savefig

    with staged_dir(args.out, force=args.force, argument="out") as tmp:
        (tmp / "robust.json").write_text(json_text(robust.to_dict(), indent=2))
        savefig(robust.plot()["figure"], tmp / "robust.png")
    summary = {k: v for k, v in robust.to_dict().items() if k != "runs"}
    summary["files"] = {"json": str(Path(args.out) / "robust.json"), "figure": str(Path(args.out) / "robust.png")}
    return summary

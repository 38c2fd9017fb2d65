"""Argument helpers shared by the subcommands (parsing only)."""

from __future__ import annotations

import argparse

from ..errors import InputError


def float_list(text: str) -> list[float]:
    """Parse ``"0.1,0,0,0"`` into floats (argparse type)."""
    try:
        return [float(s) for s in text.split(",") if s.strip() != ""]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None


def add_params_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--params", default="table1", metavar="FILE.json",
                   help="parameter set: a JSON file or a built-in name (default: table1)")


def add_force_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--force", action="store_true", help="overwrite existing output files")


def load_lumped(spec: str):
    from ..models.parameters import LumpedParameters, PhysicalParameters, load_params

    params = load_params(spec)
    if isinstance(params, PhysicalParameters):
        return params.to_lumped()
    if not isinstance(params, LumpedParameters):
        raise InputError(f"{spec}: expected a lumped or physical parameter set")
    return params

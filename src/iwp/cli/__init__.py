"""Command-line interface: ``iwp <command> ...``.

The CLI only parses arguments and calls the API. Every subcommand lives in its
own module with ``register(subparsers)``; errors derived from
:class:`iwp.errors.IwpError` become one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings

from ..errors import IwpError

# One module per subcommand, each defines ``register(subparsers)``.
_COMMANDS = [
    "simulate",
    "convert",
    "rig",
    "design",
    "control",
    "identify",
    "reproduce",
    "report",
    "validate",
]


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2, as argparse does, but with our prefix
        self.exit(2, f"iwp: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = _Parser(prog="iwp", description="Inertia wheel pendulum toolkit.")
    parser.add_argument("--version", action="version", version=f"iwp {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in _COMMANDS:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``iwp`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    # warnings are one line on stderr, like errors, without source lines
    warnings.showwarning = lambda message, category, filename, lineno, file=None, line=None: print(
        f"iwp: warning: {message}", file=sys.stderr)
    try:
        status = args.func(args)
    except IwpError as exc:
        print(f"iwp: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("iwp: interrupted", file=sys.stderr)
        return 130
    return int(status or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

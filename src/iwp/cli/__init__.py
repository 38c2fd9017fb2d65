"""Command-line interface: ``iwp <command> ...``.

The CLI only parses arguments and calls the API. Every subcommand lives in its
own module with ``register(subparsers)``; the API is imported when a command
runs, not when the parser is built, so that ``iwp --help`` is instant.

Exit status
    0 done; 1 the command ran but its result is not trustworthy and nothing was
    written; 2 bad input: one line ``iwp: error: ...`` naming the flag, file,
    line or column, nothing written; 3 an internal error (a bug: one line, please
    report it); 130 interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import difflib
import importlib
import os
import re
import sys
import warnings

from ..errors import GoalNotReached, IwpError
from ..interruption import Terminated, deliveries, raise_if_replaced
from .interrupts import interrupts_as_exceptions

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
    "warmup",
    "fit",
    "sweep",
]

#: API argument names that differ from the flag's name (``Ts`` is ``--ts`` by case alone).
_API_NAMES = {"input_name": "input", "noise_std": "noise", "from_format": "from", "to_format": "to"}
#: numpy's repr of a scalar (``np.float64(0.5)``, ``np.int64(3)``, ``np.True_``'s kin): shown as its value.
_NUMPY_REPR = re.compile(r"\bnp\.(?:float|int|uint|complex|bool)\w*\(([^()]*)\)")
#: An error line longer than this is cut (a message should never echo a whole file).
_MAX_LINE = 400


class _Parser(argparse.ArgumentParser):
    """argparse with iwp's error line, and negative numbers taken as values (``--x0 -0.1,0,0,0``)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # argparse takes "-0.1,0,0,0" for an option because it is not a plain number;
        # iwp has no option that starts with a digit, so anything "-<digit>..." is a value
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def error(self, message):  # one line, exit 2, as argparse does, but with our prefix and a suggestion
        self.exit(2, f"iwp: error: {_one_line(message + _suggestion(self, message))}\n")

    def parse_known_args(self, args=None, namespace=None):
        self.argv = list(sys.argv[1:] if args is None else args)  # what the user typed, for the suggestions
        return super().parse_known_args(args, namespace)


#: argparse's messages of an unknown flag and of a choice not among the valid ones
_UNKNOWN = re.compile(r"^unrecognized arguments: (.*)$")
_CHOICE = re.compile(r"invalid choice: '([^']*)' \(choose from (.*)\)$")


def _suggestion(parser: argparse.ArgumentParser, message: str) -> str:
    """`` (did you mean ...?)`` for a flag or a choice close to a valid one (:func:`difflib.get_close_matches`), or
    an empty string."""
    if m := _CHOICE.search(message):
        valid = [c.strip().strip("'") for c in m.group(2).split(",")]
        near = difflib.get_close_matches(m.group(1), valid, n=1, cutoff=0.6)
        return f" (did you mean {near[0]!r}?)" if near else ""
    if m := _UNKNOWN.match(message):
        flags = [s for a in _command_parser(parser)._actions for s in a.option_strings if s.startswith("--")]
        pairs = [(w, difflib.get_close_matches(w.split("=")[0], flags, n=1, cutoff=0.6))
                 for w in m.group(1).split() if w.startswith("--")]
        said = [f"{w.split('=')[0]}: did you mean {near[0]}?" for w, near in pairs if near]
        return f" ({'; '.join(said)})" if said else ""
    return ""


def _command_parser(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The (sub)subcommand's parser the user's words chose (argparse reports unknown flags from the top parser)."""
    words = getattr(parser, "argv", [])
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            chosen = next((w for w in words if w in action.choices), None)
            if chosen is not None:
                sub = action.choices[chosen]
                sub.argv = words[words.index(chosen) + 1:]
                return _command_parser(sub)
    return parser


def build_parser() -> argparse.ArgumentParser:
    """The ``iwp`` parser with every subcommand (imports no numerical code)."""
    from .. import __version__

    parser = _Parser(prog="iwp", description="Inertia wheel pendulum toolkit.")
    parser.add_argument("--version", action="version", version=f"iwp {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in _COMMANDS:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    _remember_parsers(parser)
    return parser


def _remember_parsers(parser: argparse.ArgumentParser) -> None:
    """Each (sub)parser puts itself in the namespace, so that errors can name its flags."""
    parser.set_defaults(cli_parser=parser)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for p in action.choices.values():
                _remember_parsers(p)


def _flags(parser: argparse.ArgumentParser) -> dict[str, str]:
    """dest -> the long flag the user typed (``t_end`` -> ``--t-end``; of a flag with a former name, the name
    typed), and each long name's own identifier -> the same (``amplitude`` -> ``--amplitude`` when that is what
    was typed for ``--orbit-amplitude``)."""
    typed = {w.split("=", 1)[0] for w in getattr(parser, "argv", []) if w.startswith("--")}
    out = {}
    for action in parser._actions:
        longs = [s for s in action.option_strings if s.startswith("--")]
        if longs:
            flag = next((s for s in longs if s in typed), longs[0])
            out[action.dest] = flag
            for s in longs:
                out.setdefault(s[2:].replace("-", "_"), flag)
    return out


def _one_line(text: str) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= _MAX_LINE else text[: _MAX_LINE - 3] + "..."


def user_message(exc: BaseException, parser: argparse.ArgumentParser | None) -> str:
    """The error's message with the API's argument names replaced by the command's flags, on one line.

    Parameters
    ----------
    exc : BaseException
        The error; its ``argument`` attribute (if any) names the API arguments it concerns.
    parser : argparse.ArgumentParser or None
        Parser of the command that ran, whose flags replace the argument names; None leaves the names.

    Returns
    -------
    str
        The message on one line (long messages shortened with ``"..."``), NumPy scalar reprs such as
        ``np.float64(0.5)`` written as ``0.5``.
    """
    text = _NUMPY_REPR.sub(r"\1", str(exc))  # np.float64(0.5) -> 0.5: a value as the user typed it
    if parser is not None:
        flags = _flags(parser)
        names = list(getattr(exc, "argument", ()) or ())
        if not names:
            m = re.match(r"([A-Za-z_][A-Za-z0-9_]*)(\[\d+\])?\b(?! *:)", text)
            if m:
                names = [m.group(1)]
        for name in names:
            dest = _API_NAMES.get(name, name)
            flag = flags.get(dest) or flags.get(dest.lower()) or flags.get(name)
            if flag is None:
                continue
            # never inside a file name: rig.json, truth.json, x0.csv stay as typed
            word = rf"(?<![\w\-./\\']){re.escape(name)}(?![\w/\\'*]|\.\w)"
            if not re.fullmatch(r"[a-z]+", name):
                text = re.sub(word, flag, text)  # t_end, Ts, x0: identifiers, never prose
            else:  # amplitude, model: replaced where they name the argument, not in prose
                text = re.sub(rf"^{re.escape(name)}\b(?!\.\w)|{word}(?= ?(?:must|=|:|\(|\[|-|$))", flag, text)
    return _one_line(text)


#: the arguments that set how much a command computes, and how a memory error names them (what to lower)
_SIZE_ARGUMENTS = (("draws", "--draws {}"), ("t_end", "--t-end {}"), ("duration", "--duration {}"),
                   ("spec", "the points or draws of {}"))


def _size_hint(args) -> str:
    """What to lower after a memory error: the size-setting arguments the command was given, with their values."""
    given = [text.format(getattr(args, dest)) for dest, text in _SIZE_ARGUMENTS
             if getattr(args, dest, None) is not None]
    if not given:
        return "shorten it or lengthen the sample time"
    return "lower " + " or ".join(given) + " (or lengthen the sample time)"


def _os_message(exc: OSError) -> str:
    what = exc.strerror or type(exc).__name__
    name = exc.filename
    if name is None:
        return what
    return f"{name}: {what.lower() if what[:1].isupper() and what[1:2].islower() else what}"


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``iwp`` console script; returns the exit status.

    Parameters
    ----------
    argv : list of str or None, optional
        Command-line arguments without the program name; None (default): ``sys.argv[1:]``.

    Returns
    -------
    int
        Exit status: 0 success (or the command's own status), 2 an error the user can fix (one line on stderr),
        3 an internal error, 130 interrupted or terminated. Set ``IWP_TRACEBACK=1`` to see the traceback of an
        internal error instead.
    """
    try:
        return _run(argv)
    except KeyboardInterrupt as exc:  # Ctrl-C while the parser or the numerical libraries load: nothing written yet
        return _interrupted(exc)


def _run(argv: list[str] | None) -> int:
    """:func:`main` itself: parse, run the command, turn its errors into one line and an exit status."""
    # the command line draws into files: matplotlib's file backend unless the user chose one (the library itself
    # never sets a backend, so that a notebook's stays as it is)
    os.environ.setdefault("MPLBACKEND", "Agg")
    parser = build_parser()
    args = parser.parse_args(argv)  # --help and usage errors end here, before any numerical library loads
    cli_parser = getattr(args, "cli_parser", None)
    # warnings are one line on stderr, like errors, without source lines
    warnings.showwarning = lambda message, category, filename, lineno, file=None, line=None: print(
        f"iwp: warning: {user_message(message, cli_parser)}", file=sys.stderr)
    numerical = getattr(args, "numerical", True)  # False: a command that computes nothing (iwp rig list)
    if getattr(args, "command", None) != "warmup" and numerical:
        from ..compiling import compile_notices

        compile_notices(lambda line: print(f"iwp: {line}", file=sys.stderr, flush=True))
    from ..files import output_lock

    signals = deliveries()
    try:
        with contextlib.ExitStack() as stack:
            stack.enter_context(interrupts_as_exceptions())
            if numerical:  # numba and BLAS (iwp.threads) load for commands that compute
                from ..threads import one_blas_thread

                stack.enter_context(one_blas_thread())  # iwp's parallel work is its own; BLAS threads only spin
            for dest in ("out", "plot"):  # a second run into the same output is refused, not mixed
                target = getattr(args, dest, None)
                if isinstance(target, str) and target.strip():
                    stack.enter_context(output_lock(target, argument=dest))
            status = args.func(args)
    except GoalNotReached as exc:  # ran, but did not reach its goal: the reason, and status 1
        print(f"iwp: {user_message(exc, cli_parser)}", file=sys.stderr)
        return 1
    except IwpError as exc:
        print(f"iwp: error: {user_message(exc, cli_parser)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (kill): the outputs were not moved into place
        return _interrupted(exc)
    except BrokenPipeError:  # the reader of the output stopped reading (iwp rig list | head): nothing is wrong
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # a file or folder the system refuses: name it
        print(f"iwp: error: {_one_line(_os_message(exc))}", file=sys.stderr)
        return 2
    except MemoryError:
        print(f"iwp: error: not enough memory for this run: {_size_hint(args)}", file=sys.stderr)
        return 2
    except RecursionError:
        print("iwp: error: the input is nested too deeply to read", file=sys.stderr)
        return 2
    except Exception as exc:  # a bug: still one line, no traceback (IWP_TRACEBACK=1 shows it)
        try:
            raise_if_replaced(signals, exc)  # an interrupt that compiled code turned into its own error
        except KeyboardInterrupt as intr:
            return _interrupted(intr)
        if os.environ.get("IWP_TRACEBACK"):
            raise
        print(f"iwp: internal error: {type(exc).__name__}: {_one_line(exc)} "
              "(please report it with the command line)", file=sys.stderr)
        return 3
    return int(status or 0)


def _interrupted(exc: KeyboardInterrupt) -> int:
    """Say that the command was interrupted (Ctrl-C) or terminated (SIGTERM); the exit status 130."""
    print(f"iwp: {'terminated' if isinstance(exc, Terminated) else 'interrupted'}", file=sys.stderr)
    return 130


__all__ = ["main", "build_parser", "user_message"]

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""Flags and helpers shared by the commands that drive a rig in the loop (``iwp rig run``, ``iwp control run``).

Parsing and printing only: the rig is :mod:`iwp.device`.
"""

from __future__ import annotations

import argparse
import contextlib
import sys

#: the highest baud rate iwp passes to a serial port (USB-serial adapters reach 12 Mbaud; the driver takes a C int)
MAX_BAUD = 12_000_000


def add_port_args(p: argparse.ArgumentParser) -> None:
    """``--port``, ``--baud``, ``--fast``, ``--yes``, ``--quiet``, ``--clear-fault``, ``--watchdog-ms``,
    ``--reset-params``."""
    p.add_argument("--port", metavar="PORT",
                   help="a rig in the loop: a serial device (/dev/ttyACM0), the port iwp rig emulate printed, or "
                        "'twin' for the twin in this process")
    p.add_argument("--baud", type=int, metavar="N", help="baud rate of a serial port (default 500000)")
    p.add_argument("--fast", action="store_true",
                   help="run by the host's clock, faster than real time (the emulator and the twin only)")
    p.add_argument("--yes", action="store_true",
                   help="a rig without emulated hands: do not ask before each set-up (it is arranged)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress line")
    p.add_argument("--clear-fault", action="store_true",
                   help="clear a fault or emergency stop left on the device by an earlier run or another client "
                        "(without it such a run is refused, exit status 2)")
    p.add_argument("--watchdog-ms", type=float, default=None, metavar="MS",
                   help="the device's watchdog for this run (10-2000 ms; default the device's, 100 ms), put back "
                        "after it: the motor stops when no command came for this long. A host without real-time "
                        "scheduling can be held off longer by a program starting (docs/live.md)")
    p.add_argument("--reset-params", action="store_true",
                   help="put the device's limits (watchdog_ms, v_max, q1_max, q4_max, sat_ms_max) back to their "
                        "defaults when another client changed them (without it such a run is refused, exit 2)")


def open_port_rig(args, truth=None):
    """The rig of ``--port`` (``twin``: the twin in this process)."""
    from ..device.twin import open_rig
    from ..errors import InputError

    if args.baud is not None and not 0 < args.baud <= MAX_BAUD:
        raise InputError(f"--baud must be a baud rate from 1 to {MAX_BAUD} (a serial port's), got {args.baud}")
    return open_rig(args.port, baudrate=args.baud, truth=truth, fast=args.fast)


def port_clearing(args):
    """``--clear-fault``, ``--reset-params`` and ``--watchdog-ms`` as :class:`~iwp.device.runs.Clearing`."""
    from ..device.runs import Clearing

    return Clearing(clear_fault=args.clear_fault, reset_params=args.reset_params, watchdog_ms=args.watchdog_ms)


def port_operator(args):
    """Ask the operator (stdin) to arrange the pendulum on a rig without emulated hands; ``--yes``: do not ask."""
    def ask(message: str) -> None:
        from ..device.errors import DeviceError

        if args.yes:
            print(f"iwp: {message} (--yes: taken as done)", file=sys.stderr)
            return
        if not sys.stdin.isatty():
            raise DeviceError(f"{message}, then run again with --yes")
        input(f"iwp: {message}; press Enter when done ")

    return ask


def port_progress(args):
    """The live progress line on stderr (a terminal only, not with ``--quiet``)."""
    if args.quiet or not sys.stderr.isatty():
        return None

    def show(p: dict) -> None:
        print(f"\r  t = {p['t']:7.2f} / {p['duration']:g} s   q1 = {p['q1']:+7.3f} rad   u = {p['u']:+7.2f}   "
              f"overruns {p['overruns']}   late {p['late']}   lost {p['lost']}  ", end="", file=sys.stderr,
              flush=True)

    return show


def add_live_args(p: argparse.ArgumentParser, params: bool = True) -> None:
    """``--live``, ``--live-port`` (and ``--params``, the model of the live view's prediction)."""
    p.add_argument("--live", action="store_true",
                   help="serve a live view of the run on 127.0.0.1 (its URL is printed): q1, q2, the command, the "
                        "flags, the model's prediction, a stop button (needs: pip install 'iwp[live]')")
    p.add_argument("--live-port", type=int, default=0, metavar="N",
                   help="port of the live view (default: a free one)")
    if params:
        p.add_argument("--params", metavar="FILE.json",
                       help="--live: the model's parameters for the prediction (default table1; the parameters.json "
                            "of iwp fit adds the 95 %% prediction band)")


def live_params(spec: str | None):
    """The model of the live view's prediction: ``--params`` (with its covariance when it has one) or Table 1."""
    from ..files import read_json
    from ._common import load_lumped, load_uncertainty_arg

    spec = "table1" if spec is None else spec
    params = load_lumped(spec)
    if spec != "table1":
        doc = read_json(spec, argument="params")
        if isinstance(doc, dict) and doc.get("covariance") is not None and doc.get("belt") is None:
            return load_uncertainty_arg(spec)
    return params


@contextlib.contextmanager
def live_session(args, title: str, duration: float | None):
    """The live view of ``--live`` (None without it), serving from before the rig opens until the block ends;
    its URL printed on stdout."""
    from ..errors import InputError

    if not args.live:
        if args.live_port != 0:
            raise InputError("--live-port needs --live")
        yield None
        return
    from ..device.live import LiveFeed, LiveView
    from ..device.realtime import starving_note

    with LiveView(LiveFeed(port_progress(args)), port=args.live_port, title=title, duration=duration) as view:
        print(f"live view: {view.url}", flush=True)
        note = starving_note(args.port, args.watchdog_ms, args.fast)
        if note:
            print(f"iwp: note: {note}", file=sys.stderr)
        yield view

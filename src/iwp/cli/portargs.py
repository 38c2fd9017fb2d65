"""Flags and helpers shared by the commands that drive a rig in the loop (``iwp rig run``, ``iwp control run``).

Parsing and printing only: the rig is :mod:`iwp.device`.
"""

from __future__ import annotations

import argparse
import sys


def add_port_args(p: argparse.ArgumentParser) -> None:
    """``--port``, ``--baud``, ``--fast``, ``--yes``, ``--quiet``, ``--clear-fault``, ``--reset-params``."""
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
    p.add_argument("--reset-params", action="store_true",
                   help="put the device's limits (watchdog_ms, v_max, q1_max, q4_max, sat_ms_max) back to their "
                        "defaults when another client changed them (without it such a run is refused, exit 2)")


def open_port_rig(args, truth=None):
    """The rig of ``--port`` (``twin``: the twin in this process)."""
    from ..device.twin import open_rig
    from ..errors import InputError

    if args.baud is not None and args.baud <= 0:
        raise InputError(f"--baud must be a positive integer, got {args.baud}")
    return open_rig(args.port, baudrate=args.baud, truth=truth, fast=args.fast)


def port_clearing(args):
    """``--clear-fault`` and ``--reset-params`` as :class:`~iwp.device.runs.Clearing`."""
    from ..device.runs import Clearing

    return Clearing(clear_fault=args.clear_fault, reset_params=args.reset_params)


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

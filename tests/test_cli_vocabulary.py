"""One CLI vocabulary: the same concept has the same flag name, syntax and meaning in every command.

The parsers are walked (as in tests/test_cli_help.py), so that a flag added
later is checked too. :data:`VOCABULARY` is the table of the flags that more
than one command uses: its meaning, and a check of how each command declares
it (type, choices, short form). A flag used by two or more commands must be in
the table. :data:`ALIASES` lists the former names that are still accepted:
every other flag has one long name. A concept has one name: a flag whose
choices are where a controller runs is ``--where``, whose choices are model
equations ``--model``, whose choices are the ladder's structures
``--structure``, whose type is an initial state ``--x0``.
"""

from __future__ import annotations

import argparse

import pytest

from iwp.cli import build_parser
from iwp.cli._common import X0_METAVAR, initial_state
from iwp.models import MODELS
from iwp.models.terms import rung_names


def _walk(parser: argparse.ArgumentParser, path: tuple[str, ...]):
    """(command, parser) for every leaf command (``"rig run"``)."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield " ".join(path), parser
    for action in subs:
        for name, sub in action.choices.items():
            yield from _walk(sub, (*path, name))


def _flags() -> list[tuple[str, str, argparse.Action]]:
    """(command, primary long flag, action) for every optional argument of every command."""
    out = []
    for command, parser in _walk(build_parser(), ()):
        for a in parser._actions:
            if a.option_strings and not isinstance(a, (argparse._HelpAction, argparse._VersionAction)):
                out.append((command, next(s for s in a.option_strings if s.startswith("--")), a))
    return out


def _store_true(a) -> str | None:
    return None if isinstance(a, argparse._StoreTrueAction) else "is not a switch (store_true)"


def _of_type(t):
    def check(a):
        return None if a.type is t else f"has type {a.type}, expected {t.__name__}"
    return check


def _short(letter: str, then=None):
    def check(a):
        if f"-{letter}" not in a.option_strings:
            return f"has no -{letter}"
        return then(a) if then else None
    return check


def _choices(valid: set[str], exact: bool = False):
    def check(a):
        got = set(a.choices or ())
        if not got or (got != valid if exact else not got <= valid):
            return f"takes {sorted(got)}, expected {'exactly' if exact else 'some of'} {sorted(valid)}"
        return None
    return check


def _x0(a) -> str | None:
    if a.type is not initial_state or a.metavar != X0_METAVAR:
        return f"is not declared by add_x0_arg (type {a.type}, metavar {a.metavar})"
    return None


def _value(a) -> str | None:
    return None if a.nargs is None and a.type is None else "does not take one plain value (a path)"


def _any(a) -> str | None:
    return None


_FLOAT, _INT = _of_type(float), _of_type(int)
WHERE = {"device", "host"}
EQUATIONS = set(MODELS) | {"auto"}

#: flag -> (meaning, check of each command's declaration: None when it conforms, else what is wrong)
VOCABULARY: dict[str, tuple[str, object]] = {
    "--out": ("where the command writes: a file or a folder (never overwritten without --force)",
              _short("o", _value)),
    "--force": ("overwrite existing output files", _store_true),
    "--quiet": ("no progress lines", _short("q", _store_true)),
    "--json": ("print the result as JSON", _store_true),
    "--plot": ("also save a figure (PNG/SVG/PDF)", _value),
    "--params": ("parameter set: a JSON file or a built-in name", _value),
    "--rig": ("a rig description (RIG.json): columns, units, input, drive, sample period", _value),
    "--truth": ("the virtual rig's truth plant overrides (TRUTH.json)", _value),
    "--model": ("the model equation simulated (iwp.models.MODELS: compensated (9), raw (6), ...)",
                _choices(EQUATIONS)),
    "--structure": ("a structure of the fit's ladder (a set of optional terms)", _choices(set(rung_names()), True)),
    "--controller": ("the feedback law: hopf, u = k1 q3 + k2 q3^3", _any),
    "--where": ("where a controller runs: on the device or on the host", _choices(WHERE, True)),
    "--k1": ("linear gain k1 of the Hopf law", _FLOAT),
    "--k2": ("cubic gain k2 of the Hopf law", _FLOAT),
    "--controller-ts": ("sample period of the controller [s]", _FLOAT),
    "--ts": ("sample period [s]", _FLOAT),
    "--x0": ("initial state Q1[,Q2,Q3,Q4] [rad, rad/s]; Q1 alone: released at rest", _x0),
    "--t-start": ("start time [s] (of a log's window)", _FLOAT),
    "--t-end": ("end time [s] (of a simulation or of a log's window)", _FLOAT),
    "--duration": ("length of a run on a rig [s]", _FLOAT),
    "--amplitude": ("amplitude of an open-loop input [input units]", _FLOAT),
    "--omega": ("sine frequency [rad/s]", _FLOAT),
    "--w0": ("chirp start frequency [rad/s]", _FLOAT),
    "--tau": ("chirp rate: w(t) = w0 + t/tau [s]", _FLOAT),
    "--u-max": ("saturation of u [input units]", _FLOAT),
    "--draws": ("number of parameter draws (from a fit's uncertainty, or of a band)", _INT),
    "--seed": ("seed of the random numbers", _INT),
    "--band": ("the fit's parameter and prediction bands", _any),
    "--format": ("a file's format (csv, parquet, mat, ...)", _choices({"csv", "mat", "parquet", "angle-log"})),
    "--port": ("a rig in the loop: serial device, emulator port or twin", _value),
    "--baud": ("baud rate of a serial port", _INT),
    "--fast": ("run by the host's clock, faster than real time (emulator and twin)", _store_true),
    "--yes": ("do not ask before each set-up", _store_true),
    "--accept-poor": ("exit 0 although the model predicts the held-out data poorly (else 1)", _store_true),
    "--clear-fault": ("clear a fault or ESTOP latched on the device before arming", _store_true),
    "--reset-params": ("restore the device's limits another client changed before arming", _store_true),
    "--watchdog-ms": ("the device's watchdog for this run [ms], put back after it", _FLOAT),
    "--live": ("serve a live view of the run beside the model's prediction", _store_true),
    "--live-port": ("the local port of the live view", _INT),
    "--input-hold": ("how a log's input acted between samples: zoh, continuous, or auto (its metadata, else read "
                     "from the log)", _choices({"auto", "zoh", "continuous"})),
}

#: (command, former name) -> the flag it names now; accepted, shown in --help as a second name
ALIASES = {
    ("rig run", "--controller"): "--where",
    ("fit", "--model"): "--structure",
    ("design hopf", "--amplitude"): "--orbit-amplitude",
}
#: short options and the one flag each stands for
SHORT = {"-o": "--out", "-q": "--quiet"}


def test_the_walk_reaches_every_command():
    commands = {c for c, _, _ in _flags()}
    assert {"simulate", "rig run", "control run", "control swingup", "design hopf", "fit", "sweep"} <= commands
    assert len(commands) >= 18


def test_every_flag_used_by_two_commands_is_in_the_vocabulary():
    users: dict[str, set[str]] = {}
    for command, flag, _ in _flags():
        users.setdefault(flag, set()).add(command)
    shared = {f: sorted(c) for f, c in users.items() if len(c) > 1 and f not in VOCABULARY}
    assert shared == {}, "flags of several commands missing from VOCABULARY (give them a meaning)"
    unused = [f for f in VOCABULARY if f not in users]
    assert unused == []


@pytest.mark.parametrize("flag", sorted(VOCABULARY))
def test_each_command_declares_the_flag_as_the_vocabulary_means_it(flag):
    _, check = VOCABULARY[flag]
    wrong = [f"{command}: {flag} {why}" for command, f, a in _flags() if f == flag and (why := check(a))]
    assert wrong == []


def test_one_long_name_per_flag_but_the_listed_former_names():
    extra = {}
    for command, flag, a in _flags():
        for s in a.option_strings:
            if s == flag:
                continue
            if s.startswith("--"):
                if ALIASES.get((command, s)) != flag:
                    extra[(command, s)] = flag
            elif SHORT.get(s) != flag:
                extra[(command, s)] = flag
    assert extra == {}
    # every listed former name is still accepted
    declared = {(c, s) for c, _, a in _flags() for s in a.option_strings}
    assert set(ALIASES) <= declared


def test_one_name_per_concept():
    structures = set(rung_names())
    wrong = []
    for command, flag, a in _flags():
        choices = set(a.choices or ())
        # a choice of model equations holds the paper's two (compensated (9), raw (6)); an identification set-up
        # (identify --setup) shares names such as motor-disk, but is an experiment, not an equation
        expected = ("--where" if choices == WHERE else "--structure" if choices and choices <= structures
                    else "--model" if {"compensated", "raw"} <= choices else None)
        if a.type is initial_state:
            expected = "--x0"
        if a.dest == "out" or (isinstance(a, argparse._StoreTrueAction) and "progress" in (a.help or "")):
            expected = "--out" if a.dest == "out" else "--quiet"
        if expected is not None and flag != expected:
            wrong.append(f"{command}: {flag} should be {expected}")
    assert wrong == []


def _parse(argv):
    return build_parser().parse_args(argv)


@pytest.mark.parametrize("argv", [
    ["simulate", "--t-end", "1", "--out", "a.csv"],
    ["rig", "run", "free-swing", "--out", "a.csv"],
    ["control", "swingup", "--out", "d"],
    ["control", "run", "hopf", "--out", "a.csv"],
])
def test_x0_means_the_same_state_in_every_command(argv):
    # one number is q1, released at rest; four are the whole state
    assert _parse(argv + ["--x0", "0.3"]).x0 == [0.3, 0.0, 0.0, 0.0]
    assert _parse(argv + ["--x0", "-0.3,0,0.5,-1"]).x0 == [-0.3, 0.0, 0.5, -1.0]
    with pytest.raises(SystemExit) as e:
        _parse(argv + ["--x0", "0.3,0"])
    assert e.value.code == 2


def test_former_names_parse_as_the_new_ones():
    assert _parse(["rig", "run", "closed-loop", "-o", "a.csv", "--controller", "host"]).where == "host"
    assert _parse(["rig", "run", "closed-loop", "-o", "a.csv", "--where", "host"]).where == "host"
    assert _parse(["rig", "run", "closed-loop", "-o", "a.csv"]).where == "device"
    assert _parse(["fit", "a.csv", "-o", "d", "--model", "coulomb"]).structure == "coulomb"
    assert _parse(["fit", "a.csv", "-o", "d", "--structure", "coulomb"]).structure == "coulomb"
    assert _parse(["design", "hopf", "--amplitude", "1.5"]).orbit_amplitude == 1.5
    assert _parse(["design", "hopf", "--orbit-amplitude", "2"]).orbit_amplitude == 2.0
    assert _parse(["sweep", "spec.toml", "-o", "d", "-q"]).quiet is True


def test_control_run_refuses_an_initial_velocity_a_rig_cannot_give(capsys):
    from iwp.cli import main

    assert main(["control", "run", "hopf", "-o", "never.csv", "--port", "twin", "--x0", "0.3,0,0.1,0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("iwp: error: --x0") and "at rest" in err and "\n" not in err

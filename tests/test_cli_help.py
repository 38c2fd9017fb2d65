"""Every subcommand of ``iwp`` says what it does and every flag has help text, in plain words.

The parsers are walked, not listed, so that a subcommand or flag added later
without help fails here.
"""

from __future__ import annotations

import argparse

from iwp.cli import build_parser


def _walk(parser: argparse.ArgumentParser, path: tuple[str, ...]):
    """(path, parser) for ``parser`` and every subparser below it."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _walk(sub, (*path, name))


def _parsers():
    return list(_walk(build_parser(), ("iwp",)))


def test_walk_reaches_every_subcommand():
    # the walk is what the other checks rely on: it must reach the nested subcommands
    paths = {" ".join(path) for path, _ in _parsers()}
    for expected in ("iwp simulate", "iwp rig list", "iwp rig truth", "iwp rig run", "iwp control lqr",
                     "iwp control swingup", "iwp design hopf", "iwp fit", "iwp warmup"):
        assert expected in paths
    assert len(paths) >= 20


def test_every_flag_has_help():
    missing = []
    for path, parser in _parsers():
        for action in parser._actions:
            if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
                continue
            if not (action.help or "").strip() or action.help == argparse.SUPPRESS:
                missing.append(f"{' '.join(path)} {'/'.join(action.option_strings) or action.dest}")
    assert missing == []


def test_every_subcommand_has_a_description():
    # a parser with subcommands or flags beyond --help says what it does in its own --help
    missing = [" ".join(path) for path, parser in _parsers() if not (parser.description or "").strip()]
    assert missing == []


def test_help_is_plain_text():
    # reST markup (``iwp rig``, :func:) belongs in the docs, not on a terminal
    marked = []
    for path, parser in _parsers():
        texts = [parser.description or "", parser.epilog or ""]
        texts += [a.help or "" for a in parser._actions]
        for sub in parser._actions:
            if isinstance(sub, argparse._SubParsersAction):
                texts += [c.help or "" for c in sub._choices_actions]
        marked += [f"{' '.join(path)}: {t[:60]!r}" for t in texts if "``" in t or ":func:" in t or ":class:" in t]
    assert marked == []


def test_outputs_say_file_or_folder_as_their_metavar():
    # --out DIR is a folder in its help, --out FILE a file (control swingup once said "CSV file" of a folder)
    wrong = []
    for path, parser in _parsers():
        for action in parser._actions:
            if "--out" not in action.option_strings:
                continue
            help_text = (action.help or "").lower()
            if action.metavar == "DIR" and "folder" not in help_text:
                wrong.append(" ".join(path))
            if action.metavar != "DIR" and "folder" in help_text:
                wrong.append(" ".join(path))
    assert wrong == []


def _usage_error(argv, capsys) -> str:
    """The one line argparse's usage error prints (it exits 2)."""
    from iwp.cli import main

    try:
        main(argv)
    except SystemExit as exc:
        assert exc.code == 2
    else:
        raise AssertionError(f"{argv} was accepted")
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err.strip()


def test_a_typo_gets_a_suggestion_on_its_one_error_line(capsys):
    assert _usage_error(["fit", "log.csv", "--out", "o", "--modle", "9"], capsys) == (
        "iwp: error: unrecognized arguments: --modle 9 (--modle: did you mean --model?)")
    assert _usage_error(["fit", "log.csv", "--out", "o", "--model", "coulomn"], capsys).endswith(
        "(did you mean 'coulomb'?)")
    assert _usage_error(["fitt", "log.csv"], capsys).endswith("(did you mean 'fit'?)")
    assert _usage_error(["rig", "run", "full-chirp", "--out", "x.csv", "--durration", "3"], capsys).endswith(
        "(--durration: did you mean --duration?)")
    # nothing is suggested where nothing is close
    assert _usage_error(["fit", "log.csv", "--out", "o", "--zzz"], capsys) == (
        "iwp: error: unrecognized arguments: --zzz")

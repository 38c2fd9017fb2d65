"""Sphinx extension: the ``iwp`` command's reference generated from its argparse parsers.

``.. iwp-cli::`` walks :func:`iwp.cli.build_parser` and writes one section
per command and subcommand: its usage line, its description (the text of
``iwp COMMAND --help``) and a table of its arguments with their help, so
that the reference cannot drift from the parsers.
"""

from __future__ import annotations

import argparse

from docutils import nodes
from docutils.parsers.rst import Directive
from docutils.statemachine import StringList
from sphinx.util.nodes import nested_parse_with_titles

from iwp.cli import build_parser

UNDERLINES = "=-~^\"'"


def _walk(parser: argparse.ArgumentParser, path: tuple[str, ...]):
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _walk(sub, (*path, name))


def _literal(text: str) -> str:
    return "``" + text.replace("`", "'") + "``" if text else ""


def _cell(text: str) -> str:
    """One line of a list-table cell: argparse's %% and %(default)s resolved, no reST specials."""
    return " ".join(text.split()).replace("*", r"\*").replace("|", r"\|").replace("_", r"\_")


def _action_rows(parser: argparse.ArgumentParser, action: argparse.Action) -> list[str]:
    if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
        return []
    if action.option_strings:
        metavar = ""
        if action.nargs != 0:
            metavar = " " + parser._get_formatter()._format_args(action, action.dest.upper())
        name = ", ".join(s + metavar for s in action.option_strings)
    else:
        name = parser._get_formatter()._format_args(action, action.dest)
    help_text = parser._get_formatter()._expand_help(action) if action.help else ""
    if action.choices is not None and not action.option_strings:
        help_text += f" (one of: {', '.join(map(str, action.choices))})"
    return [f"   * - {_literal(name)}", f"     - {_cell(help_text)}"]


def _section(path: tuple[str, ...], parser: argparse.ArgumentParser, level: int) -> list[str]:
    title = " ".join(path)
    lines = [f".. _cli-{'-'.join(path[1:]) or 'iwp'}:", "", title, UNDERLINES[level] * len(title), ""]
    usage = parser.format_usage().strip().removeprefix("usage: ")
    lines += ["::", ""] + ["   " + line for line in usage.splitlines()] + [""]
    if parser.description:
        lines += ["::", ""] + ["   " + line for line in parser.description.strip().splitlines()] + [""]
    rows = []
    for action in parser._actions:
        rows += _action_rows(parser, action)
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    for sub in subs:
        for choice in sub._choices_actions:
            rows += [f"   * - {_literal(choice.dest)}", f"     - {_cell(choice.help or '')}"]
    if rows:
        lines += [".. list-table::", "   :header-rows: 1", "   :widths: 35 65", "",
                  "   * - argument", "     - meaning"] + rows + [""]
    return lines


class IwpCli(Directive):
    """``.. iwp-cli::``: the whole ``iwp`` command, one section per (sub)command."""

    has_content = False

    def run(self):
        lines: list[str] = []
        for path, parser in _walk(build_parser(), ("iwp",)):
            lines += _section(path, parser, min(len(path) - 1, len(UNDERLINES) - 1) + 1)
        container = nodes.section()
        container.document = self.state.document
        nested_parse_with_titles(self.state, StringList(lines, source="iwp-cli"), container)
        return container.children


def setup(app):
    app.add_directive("iwp-cli", IwpCli)
    return {"parallel_read_safe": True, "parallel_write_safe": True, "version": "1"}

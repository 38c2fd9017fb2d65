"""The Python code blocks and the shell sessions of the README and the user guide run as written.

Each Markdown file's ``python`` blocks run in order in one namespace (a
later block may use an earlier one's names), in an empty temporary folder,
with matplotlib drawing off screen; a block that raises fails its file.
``console`` blocks are shell sessions: each ``$ iwp ...`` line (continued by
a trailing backslash) runs, in the same folder and in the file's order with
the python blocks, as the ``iwp`` command would (:func:`iwp.cli.main`) and
must exit with status 0; the other lines of a session are its output, shown,
not checked.
``.ci/run`` runs this after the test suite::

    python -m pytest -q -p no:cacheprovider docs/test_code_blocks.py
"""

from __future__ import annotations

import re
import shlex
import warnings
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
FILES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
#: a python block or a console session, in the file's order
ANY_BLOCK = re.compile(r"^```(python|console)\n(.*?)^```", re.S | re.M)


def python_blocks(path: Path) -> list[str]:
    return BLOCK.findall(path.read_text())


def session_commands(session: str) -> list[list[str]]:
    """The ``iwp`` commands of a console session: its ``$ `` lines, backslash continuations joined."""
    commands, current = [], None
    for line in session.splitlines():
        if current is None and line.startswith("$ "):
            current = line[2:]
        elif current is not None:
            current += " " + line.strip()
        else:
            continue
        if current.endswith("\\"):
            current = current[:-1]
            continue
        words = shlex.split(current, comments=True)
        assert words[0] == "iwp", f"a console block runs iwp commands only, not {current!r}"
        commands.append(words[1:])
        current = None
    return commands


def blocks(path: Path) -> list[tuple[str, str]]:
    return ANY_BLOCK.findall(path.read_text())


def test_blocks_are_found():
    blocks = {p.name: len(python_blocks(p)) for p in FILES}
    assert blocks["README.md"] >= 1 and blocks["getting-started.md"] >= 2
    assert sum(blocks.values()) >= 8
    assert python_blocks(Path(__file__)) == []  # this file's own fences are not Markdown blocks


def test_console_sessions_are_parsed():
    session = "$ iwp fit a.csv \\\n    --out fit/   # the fit\nwrote fit/report.html\n$ iwp --version\n"
    assert session_commands(session) == [["fit", "a.csv", "--out", "fit/"], ["--version"]]


@pytest.mark.parametrize("path", [p for p in FILES if blocks(p)], ids=lambda p: p.name)
def test_python_blocks_run(path, tmp_path, monkeypatch):
    from iwp.cli import main

    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": f"doc_{path.stem}"}
    for i, (kind, code) in enumerate(blocks(path)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the fits' notes; the blocks are checked for running, not silence
            if kind == "python":
                exec(compile(code, f"{path.name} (block {i + 1})", "exec"), namespace)
                continue
            for argv in session_commands(code):
                assert main(argv) == 0, f"{path.name} (block {i + 1}): iwp {shlex.join(argv)} failed"
    matplotlib.pyplot.close("all")

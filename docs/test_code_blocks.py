"""The Python code blocks of the README and the user guide run as written.

Each Markdown file's ``python`` blocks run in order in one namespace (a
later block may use an earlier one's names), in an empty temporary folder,
with matplotlib drawing off screen; a block that raises fails its file.
``.ci/run`` runs this after the test suite::

    python -m pytest -q -p no:cacheprovider docs/test_code_blocks.py
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
FILES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def python_blocks(path: Path) -> list[str]:
    return BLOCK.findall(path.read_text())


def test_blocks_are_found():
    blocks = {p.name: len(python_blocks(p)) for p in FILES}
    assert blocks["README.md"] >= 1 and blocks["getting-started.md"] >= 2
    assert sum(blocks.values()) >= 8
    assert python_blocks(Path(__file__)) == []  # this file's own fences are not Markdown blocks


@pytest.mark.parametrize("path", [p for p in FILES if python_blocks(p)], ids=lambda p: p.name)
def test_python_blocks_run(path, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": f"doc_{path.stem}"}
    for i, code in enumerate(python_blocks(path)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the fits' notes; the blocks are checked for running, not silence
            exec(compile(code, f"{path.name} (python block {i + 1})", "exec"), namespace)
    matplotlib.pyplot.close("all")

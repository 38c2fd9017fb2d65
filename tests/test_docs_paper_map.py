"""docs/models.md, "the paper in the code", names functions and tests that exist.

Every ``iwp.…`` name in its table imports, and every test it cites
(``tests/FILE.py::test_name``, or a bare ``test_name`` after one in the same
cell) is defined in that file, so that the map cannot drift from the code.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODELS_MD = ROOT / "docs" / "models.md"


def resolve(dotted: str):
    """The object a dotted name ``iwp.a.b.C.d`` names (module prefix imported, the rest attributes)."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for attr in parts[cut:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(dotted)


def table_rows(text: str) -> list[list[str]]:
    rows = [line.strip().strip("|").split(" | ") for line in text.splitlines() if line.startswith("| ")]
    return [r for r in rows if r[0] not in ("paper", "---")]


def test_the_table_is_read():
    rows = table_rows(MODELS_MD.read_text())
    assert len(rows) >= 20 and all(len(r) == 4 for r in rows)


def test_every_function_named_exists():
    missing = []
    for _, _, function, _ in table_rows(MODELS_MD.read_text()):
        names = re.findall(r"`(iwp(?:\.\w+)+)`", function)
        module = None
        for code in re.findall(r"`([^`]+)`", function):
            if code.startswith("iwp."):
                module = code
            elif re.fullmatch(r"[A-Za-z_]\w*", code) and module is not None:
                # a bare name after a dotted one: a sibling in the same module
                names.append(module.rsplit(".", 1)[0] + "." + code)
        for name in names:
            try:
                resolve(name)
            except (ImportError, AttributeError):
                missing.append(name)
    assert missing == []


def test_every_test_cited_exists():
    missing = []
    for *_, tests in table_rows(MODELS_MD.read_text()):
        current = None
        for code in re.findall(r"`([^`]+)`", tests):
            m = re.fullmatch(r"(tests/\w+\.py)(?:::(\w+))?", code)
            if m:
                current = ROOT / m.group(1)
                if not current.is_file():
                    missing.append(code)
                    continue
                name = m.group(2)
            elif re.fullmatch(r"test_\w+", code) and current is not None:
                name = code
            else:
                continue
            if name and not re.search(rf"^def {name}\(", current.read_text(), re.M):
                missing.append(f"{current.name}::{name}")
    assert missing == []


def test_every_dotted_name_in_the_guide_exists():
    # the README, the guide and the firmware's README name iwp's modules and functions as `iwp.a.b`
    missing = []
    for path in [ROOT / "README.md", ROOT / "firmware" / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for name in sorted(set(re.findall(r"`(iwp(?:\.\w+)+)", path.read_text()))):
            if name == "iwp.metadata":  # the Parquet schema key of data-format.md, not a module
                continue
            try:
                resolve(name)
            except (ImportError, AttributeError):
                missing.append(f"{path.name}: {name}")
    assert missing == []

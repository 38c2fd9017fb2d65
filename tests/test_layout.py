"""The package's layout keeps its rules: no private name across subpackages, no import circle, one API."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

import iwp

ROOT = Path(iwp.__file__).resolve().parent


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in ROOT.rglob("*.py")}


def _resolve(mod: str, path: Path, node: ast.ImportFrom) -> str:
    """Absolute module of ``from X import ...`` inside ``mod``."""
    if node.level == 0:
        return node.module or ""
    pkg = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
    base = pkg.split(".")
    if node.level > 1:
        base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _subpackage(mod: str) -> str:
    parts = mod.split(".")
    return ".".join(parts[:2]) if len(parts) > 1 else mod


def _imports(top_level_only: bool):
    """(importer, imported module, names, inside a function) of every ``from iwp... import`` (module level only,
    if asked)."""
    out = []
    for mod, path in _modules().items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        local = {id(n) for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
                 for n in ast.walk(f)}
        nodes = tree.body if top_level_only else list(ast.walk(tree))
        for node in nodes:
            if isinstance(node, ast.ImportFrom):
                target = _resolve(mod, path, node)
                if target == "iwp" or target.startswith("iwp."):
                    out.append((mod, target, [a.name for a in node.names], id(node) in local))
    return out


def _is_cli(mod: str) -> bool:
    """The command line imports the API when a command runs (``iwp --help`` stays instant)."""
    return mod == "iwp.cli" or mod.startswith("iwp.cli.")


def test_no_private_name_is_imported_from_another_subpackage():
    bad = []
    for mod, target, names, _local in _imports(top_level_only=False):
        for n in names:
            if n.startswith("_") and not n.startswith("__") and _subpackage(mod) != _subpackage(target):
                bad.append(f"{mod} imports {target}.{n}")
    assert bad == []


def test_no_import_inside_a_function():
    """No iwp module imports another inside a function (which would hide a circle or an arrow back up), but the CLI's
    commands, which import the API when they run, and the figures of results that draw when asked (``.plot()``):
    plotting (matplotlib) is imported only then, so that iwp.sim, iwp.ident and iwp.control import none of it."""
    local = sorted(f"{mod} imports {target} in a function" for mod, target, _n, inside in
                   _imports(top_level_only=False)
                   if inside and not _is_cli(mod) and not (target == "iwp.plotting" or
                                                          target.startswith("iwp.plotting.")))
    assert local == []


def test_no_import_circle():
    """Imports between iwp's modules -- at module level and inside functions, but the CLI's lazy ones -- form no
    cycle (Tarjan's strongly connected components): no module imports one that imports it back, directly or not."""
    modules = set(_modules())
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for mod, target, names, inside in _imports(top_level_only=False):
        if inside and _is_cli(mod):
            continue
        submodules = [f"{target}.{n}" for n in names if f"{target}.{n}" in modules]
        graph[mod].update(submodules)  # "from .pkg import module" imports the module
        if target in modules and len(submodules) < len(names):
            graph[mod].add(target)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    cycles = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert cycles == []


def test_the_package_exports_its_api():
    from iwp import Plant, identify, simulate, table1

    r = simulate(Plant(table1()), x0=[0.2, 0.0, 0.0, 0.0], t_end=0.5)
    assert r.success and callable(identify)
    for name in iwp.__all__:
        if name == "__version__":
            continue
        home = importlib.import_module(iwp._EXPORTS[name])
        # each name is the object its subpackage defines (not a stale or shadowed one)
        assert getattr(iwp, name) is getattr(home, name), name
        assert name in home.__all__, name
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        iwp.nope  # noqa: B018


@pytest.mark.parametrize("sub", ["models", "sim", "data", "ident", "control", "rig", "calibration", "device",
                                 "reproduce", "report", "plotting", "sweep"])
def test_every_subpackage_lists_what_it_exports(sub):
    m = importlib.import_module(f"iwp.{sub}")
    assert m.__doc__ and len(m.__all__) > 0
    for name in m.__all__:
        assert hasattr(m, name), f"iwp.{sub}.{name}"

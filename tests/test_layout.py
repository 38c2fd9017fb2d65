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


#: The subpackages whose signatures take at most :data:`MAX_PARAMETERS` parameters (issue 38: options objects instead).
NARROW = ("iwp.ident", "iwp.sim", "iwp.device")
MAX_PARAMETERS = 8
#: Compiled numba kernels of the engine whose scalars and arrays are passed apart (numba keeps them in registers;
#: bundling them would change the compiled code). Exempt by name, and only while they are compiled (``@jit``).
WIDE_KERNELS = {"iwp.sim.engine.kink_step", "iwp.sim.engine.put_near", "iwp.sim.engine.put_dense",
                "iwp.sim.lanes.plain_stages", "iwp.sim.dop853.error_norm_lanes"}
#: The subpackages whose functions are at most :data:`MAX_LINES` lines long.
SHORT = ("iwp.ident", "iwp.sim")
MAX_LINES = 120
#: The compiled kernels longer than that: the lanes' and the single run's integrators (their parts are named
#: functions; what is left is the step loop, which numba compiles as one). Splitting the single run's loop further
#: cost 6-18 % of its speed, measured: BENCHMARKS.md, issue 38.
LONG_KERNELS = {"iwp.sim.lanes.run_lanes", "iwp.sim.engine.integrate"}


def _functions(subpackages):
    """(qualified name, node, compiled) of every function and method defined in ``subpackages``."""
    out = []
    for mod, path in _modules().items():
        if _subpackage(mod) not in subpackages:
            continue

        def walk(node, prefix):
            for child in ast.iter_child_nodes(node):
                if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    compiled = any("jit" in ast.unparse(d) for d in child.decorator_list)
                    out.append((f"{prefix}.{child.name}", child, compiled))
                    walk(child, f"{prefix}.{child.name}")
                elif isinstance(child, ast.ClassDef):
                    walk(child, f"{prefix}.{child.name}")

        walk(ast.parse(path.read_text(encoding="utf-8")), mod)
    return out


def _parameters(f: ast.FunctionDef) -> int:
    """The parameters of ``f``'s signature (``*args`` and ``**kwargs`` count one each; a method's self or cls not)."""
    a = f.args
    names = [x.arg for x in a.posonlyargs + a.args]
    n = len(names) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)
    return n - 1 if names and names[0] in ("self", "cls") else n


def test_no_signature_takes_more_than_eight_parameters():
    """ident/, sim/ and device/ take options objects (iwp.sim.SimOptions, ...), not long lists of keywords; only the
    engine's compiled kernels of WIDE_KERNELS are exempt."""
    found = {name: _parameters(f) for name, f, compiled in _functions(NARROW)
             if _parameters(f) > MAX_PARAMETERS and not (compiled and name in WIDE_KERNELS)}
    assert found == {}
    # the exemption is for compiled kernels that exist and still need it
    wide = {name for name, f, compiled in _functions(NARROW) if compiled and _parameters(f) > MAX_PARAMETERS}
    assert wide == WIDE_KERNELS


def test_no_function_is_longer_than_120_lines():
    found = {name: f.end_lineno - f.lineno + 1 for name, f, compiled in _functions(SHORT)
             if f.end_lineno - f.lineno + 1 > MAX_LINES and not (compiled and name in LONG_KERNELS)}
    assert found == {}
    long = {name for name, f, compiled in _functions(SHORT) if compiled and f.end_lineno - f.lineno + 1 > MAX_LINES}
    assert long == LONG_KERNELS


def test_the_parameter_count_counts_what_a_caller_can_pass():
    tree = ast.parse("def f(a, /, b, *c, d, e=1, **g): pass\nclass C:\n    def m(self, a, *, b): pass\n")
    f, m = tree.body[0], tree.body[1].body[0]
    assert (_parameters(f), _parameters(m)) == (6, 2)


def test_the_integrators_know_the_models_switching_surfaces_from_guards_alone():
    """The engine and the lanes imported the kinks' predictor and seven of its internals from models/pendulum.py;
    the models' switching surfaces now have one home, models/guards.py."""
    engines = {"iwp.sim.engine", "iwp.sim.lanes"}
    seen = sorted({(mod, target) for mod, target, _n, _inside in _imports(top_level_only=False)
                   if mod in engines and target.startswith("iwp.models.")})
    assert seen and not any(t == "iwp.models.pendulum" for _m, t in seen), seen
    assert ("iwp.sim.engine", "iwp.models.guards") in seen and ("iwp.sim.lanes", "iwp.models.guards") in seen

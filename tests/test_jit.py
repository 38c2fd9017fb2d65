"""numba's on-disk cache follows every source a kernel compiles (no stale kernel after an edit)."""

from __future__ import annotations

from pathlib import Path

import iwp
from iwp import jit
from iwp.models import equations
from iwp.sim import engine

ROOT = Path(iwp.__file__).resolve().parent


def test_the_stamp_covers_the_compiled_sources():
    files = {p.relative_to(ROOT).as_posix() for p in jit.compiled_sources(ROOT)}
    # the kernel, and what it inlines from other modules
    assert {"sim/engine.py", "sim/dop853.py", "models/equations.py", "models/pendulum.py", "models/actuator.py",
            "models/friction.py", "models/mathfn.py", "sim/inputs.py", "models/laws.py"} <= files
    assert "data/csv_format.py" not in files  # no compiled code there


def test_the_stamp_changes_with_any_compiled_source(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "a.py").write_text("@jit\ndef f(x):\n    return x\n")
    (pkg / "b.py").write_text("@jit\ndef g(x):\n    return f(x) + 1\n")
    (pkg / "c.py").write_text("def h():\n    return 0\n")
    s0 = jit.source_tree_stamp(pkg)
    (pkg / "c.py").write_text("def h():\n    return 1\n")  # not compiled code: same stamp
    assert jit.source_tree_stamp(pkg) == s0
    (pkg / "a.py").write_text("@jit\ndef f(x):\n    return 2 * x\n")  # a function the other one calls
    s1 = jit.source_tree_stamp(pkg)
    assert s1 != s0
    (pkg / "a.py").write_text("@jit\ndef f(x):\n    return x\n")
    assert jit.source_tree_stamp(pkg) == s0


def test_iwp_kernels_are_cached_with_the_tree_stamp():
    for dispatcher in (engine.kernel(4), equations.rhs, engine.integrate):
        locator = dispatcher._cache._impl._locator
        assert isinstance(locator, (jit.SourceTreeLocator, jit.UserDirSourceTreeLocator))
        assert locator.get_source_stamp() == jit.source_tree_stamp(ROOT)


def test_the_stamp_follows_the_compile_options(tmp_path, monkeypatch):
    """numba's cache index holds a kernel's signature and bytecode, not its options (nogil, fastmath): an edit of
    the options in iwp.jit must recompile every kernel."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "a.py").write_text("@jit\ndef f(x):\n    return x\n")
    s0 = jit.source_tree_stamp(pkg)
    edited = tmp_path / "jit.py"
    edited.write_text(Path(jit.__file__).read_text().replace('"nogil": True', '"nogil": False'))
    monkeypatch.setattr(jit, "__file__", str(edited))
    assert jit.source_tree_stamp(pkg) != s0

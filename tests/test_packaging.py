"""The wheel: only the numba caches its own build compiled, and a build whose compilation fails, fails.

Each test builds a wheel of a copy of the source tree (the files git tracks,
so that nothing of this checkout's build folder leaks in) with pip, in an
isolated build environment (``[build-system] requires``: pip fetches them).
``IWP_NO_PRECOMPILE=1`` skips the compilation where it is not what is tested,
so each build takes tens of seconds, not minutes; the full build with its
compilation is measured by ``benchmarks/bench_startup.py --install``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.slow


def _copy_tree(dest: Path) -> Path:
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    for rel in files.decode().split("\0"):
        if rel and (ROOT / rel).is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / rel, dest / rel)
    return dest


def _build(src: Path, out: Path, **env) -> subprocess.CompletedProcess:
    e = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH", "IWP_NO_PRECOMPILE")}
    e.update(env)
    return subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(out), str(src)],
                          env=e, capture_output=True, text=True, timeout=1800)


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs the git checkout (the wheel is built from the files git tracks)")
    return _copy_tree(tmp_path_factory.mktemp("src") / "iwp")


def test_the_wheel_takes_no_numba_cache_of_the_source_tree(tree, tmp_path):
    # what a test run leaves beside the sources (before conftest.py moved them) must not reach the wheel
    stray = tree / "src" / "iwp" / "sim" / "__pycache__"
    stray.mkdir(parents=True)
    (stray / "engine.integrate-1.py311.nbi").write_bytes(b"x" * 1000)
    (stray / "engine.integrate-1.py311.1.nbc").write_bytes(b"x" * 100_000)
    r = _build(tree, tmp_path, IWP_NO_PRECOMPILE="1")
    assert r.returncode == 0, r.stderr[-3000:]
    (wheel,) = tmp_path.glob("iwp-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert [n for n in names if n.endswith((".nbi", ".nbc"))] == []
    # the package data it must carry: the twin, the paper's targets, the firmware's core
    for needed in ("iwp/rig/default_truth.json", "iwp/device/csrc/iwp_core.c", "iwp/device/csrc/iwp_core.h"):
        assert needed in names
    assert any(n.startswith("iwp/calibration/") and n.endswith(".json") for n in names)
    assert wheel.stat().st_size < 2_000_000  # sources and data only: about 0.7 MB


def test_a_failed_compilation_fails_the_build_and_says_why(tree, tmp_path):
    warm = tree / "src" / "iwp" / "warmup.py"
    original = warm.read_text()
    # the user's case: the warm-up imports a module the build environment lacks
    future = "from __future__ import annotations\n"
    assert future in original
    warm.write_text(original.replace(future, future + "import planted_missing_module  # noqa: F401\n", 1))
    try:
        r = _build(tree, tmp_path)
    finally:
        warm.write_text(original)
    assert r.returncode != 0
    said = r.stdout + r.stderr
    assert "failed to compile at build time" in said
    assert "planted_missing_module" in said  # the cause, not only the verdict
    assert "IWP_NO_PRECOMPILE=1" in said  # and the way out
    assert list(tmp_path.glob("*.whl")) == []

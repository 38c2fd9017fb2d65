"""Build hook: compile iwp's numba kernels while the package is built (``pip install .``).

numba caches compiled kernels on disk next to the sources. Compiling them
here, in the build folder, puts the cache into the installed package, so
that the first ``iwp simulate`` or ``iwp reproduce`` after ``pip install .``
does not wait for the compiler (about 60 s on 2 cores, paid once, here).
The cache is stamped with the numba version, the machine's CPU and the hash
of the sources (``iwp.jit``): where any of them differs, iwp compiles at
first use as usual.

Only the caches this build compiles go into the wheel: caches found in the
build folder before the compilation (an earlier build) are deleted first, and
``pyproject.toml``'s package data does not pick the source tree's
``__pycache__`` (where a test run or an editable install leaves its own).

A failed compilation fails the build, with the compiler's output: pip hides
a build's output unless it fails, and a silent failure costs every user a
cold first run. ``IWP_NO_PRECOMPILE=1`` skips the step on purpose.
"""

import os
import subprocess
import sys
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py


def _remove_caches(root: Path) -> int:
    """Delete numba's cache files (``*.nbi``, ``*.nbc``) under ``root``; return how many."""
    n = 0
    for pattern in ("*.nbi", "*.nbc"):
        for f in root.rglob(pattern):
            f.unlink()
            n += 1
    return n


class BuildPyWithKernels(build_py):
    def run(self):
        super().run()
        if os.environ.get("IWP_NO_PRECOMPILE", "").strip() not in ("", "0"):
            return
        # an editable install (pip install -e .) runs the sources in place: compile there
        editable = getattr(self, "editable_mode", False)
        root = os.path.abspath("src") if editable else os.path.abspath(self.build_lib)
        if not editable:
            _remove_caches(Path(root) / "iwp")
        env = dict(os.environ)
        env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
        env.pop("NUMBA_CACHE_DIR", None)  # the cache must land in the package
        env.setdefault("MPLBACKEND", "Agg")
        cmd = [sys.executable, "-m", "iwp.warmup"]
        try:
            r = subprocess.run(cmd, env=env, timeout=1800, cwd=root, capture_output=True, text=True)
        except (OSError, subprocess.SubprocessError) as exc:
            raise SystemExit(self._failure(f"{' '.join(cmd)} did not run: {exc}")) from None
        print(r.stdout, end="")
        if r.returncode != 0:
            raise SystemExit(self._failure(f"{' '.join(cmd)} exited with status {r.returncode}:\n"
                                           f"{r.stdout[-4000:]}{r.stderr[-8000:]}"))
        n = sum(1 for _ in Path(root, "iwp").rglob("*.nbi"))
        if n == 0:
            raise SystemExit(self._failure("the compilation wrote no cache file (*.nbi) into the package"))
        print(f"iwp: {n} compiled kernel index file(s) in the package")

    @staticmethod
    def _failure(what: str) -> str:
        return ("error: iwp's numba kernels failed to compile at build time, so the installed package would "
                f"compile them at first use (minutes).\n{what}\n"
                "Fix the cause (often a runtime dependency missing from [build-system] requires in "
                "pyproject.toml), or build without the precompilation: IWP_NO_PRECOMPILE=1 pip install .")


setup(cmdclass={"build_py": BuildPyWithKernels})

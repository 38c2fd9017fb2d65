"""Build hook: compile iwp's numba kernels while the package is built (``pip install .``).

numba caches compiled kernels on disk next to the sources. Compiling them
here, in the build folder, puts the cache into the installed package, so
that the first ``iwp simulate`` or ``iwp reproduce`` after ``pip install .``
does not wait for the compiler (about 30 s on 2 cores, paid once, here).
The cache is stamped with the numba version, the machine's CPU and the hash
of the sources (``iwp.jit``): where any of them differs, iwp compiles at
first use as usual. ``IWP_NO_PRECOMPILE=1`` skips this step; a failure here
only prints a warning.
"""

import os
import subprocess
import sys

from setuptools import setup
from setuptools.command.build_py import build_py


class BuildPyWithKernels(build_py):
    def run(self):
        super().run()
        if os.environ.get("IWP_NO_PRECOMPILE", "").strip() not in ("", "0"):
            return
        # an editable install (pip install -e .) runs the sources in place: compile there
        root = os.path.abspath("src") if getattr(self, "editable_mode", False) else os.path.abspath(self.build_lib)
        env = dict(os.environ)
        env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
        env.pop("NUMBA_CACHE_DIR", None)  # the cache must land in the package
        env.setdefault("MPLBACKEND", "Agg")
        try:
            subprocess.run([sys.executable, "-m", "iwp.warmup"], env=env, check=True, timeout=1800,
                           cwd=root)
        except (OSError, subprocess.SubprocessError) as exc:
            print(f"warning: iwp's kernels were not compiled at build time ({exc}); they compile at first use",
                  file=sys.stderr)


setup(cmdclass={"build_py": BuildPyWithKernels})

"""iwp never sets a matplotlib backend, imports plotting only to draw, and starts its compute-free commands without
the numerical libraries (issue 38: a notebook's backend is its user's; ``iwp rig list`` starts fast)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest


def _run(code: str, env_extra: dict | None = None) -> str:
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    env.update(env_extra or {})
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    return r.stdout.strip()


def test_iwp_leaves_the_users_backend_alone():
    code = ("import matplotlib; matplotlib.use('svg'); import iwp, iwp.sim, iwp.ident, iwp.control, iwp.plotting, "
            "iwp.report, iwp.reproduce; from iwp import simulate, table1; print(matplotlib.get_backend())")
    assert _run(code) == "svg"


@pytest.mark.parametrize("module", ["iwp.sim", "iwp.ident", "iwp.control", "iwp.models", "iwp.data", "iwp.device",
                                    "iwp.rig", "iwp.sweep", "iwp.calibration"])
def test_the_computing_packages_import_no_plotting(module):
    code = (f"import sys, importlib; importlib.import_module({module!r}); "
            "print([m for m in sys.modules if m.split('.')[0] == 'matplotlib' or m.startswith('iwp.plotting')])")
    assert _run(code) == "[]"


def test_a_result_draws_when_asked():
    code = ("import sys; from iwp import simulate, table1, Sine; r = simulate(table1(), t_end=1.0, input=Sine(1, 2)); "
            "assert 'matplotlib' not in sys.modules; out = r.plot(); print(type(out).__name__, 'matplotlib' in "
            "sys.modules)")
    assert _run(code, {"MPLBACKEND": "Agg"}) == "dict True"


@pytest.mark.parametrize("argv, absent", [(["--help"], ("numba", "matplotlib", "numpy", "scipy")),
                                          (["rig", "list"], ("numba", "matplotlib", "numpy", "scipy", "iwp.sim")),
                                          (["fit", "--model", "cubic"], ("numba", "matplotlib", "scipy"))])
def test_commands_that_compute_nothing_load_no_numerical_library(argv, absent):
    code = ("import sys, json\nfrom iwp.cli import main\ntry:\n    main(%r)\nexcept SystemExit:\n    pass\n"
            "print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in %r or m.startswith('iwp.sim'))),"
            " file=sys.stderr)" % (argv, tuple(a for a in absent if not a.startswith("iwp"))))
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    loaded = json.loads(r.stderr.strip().splitlines()[-1])
    assert [m for m in loaded if m.split(".")[0] in absent or any(m.startswith(a + ".") or m == a for a in absent)] \
        == [], loaded

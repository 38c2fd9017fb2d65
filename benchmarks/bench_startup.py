"""Benchmark of first use: ``iwp --help``, and the first ``iwp simulate``/``reproduce`` cold and warm.

Cold means an empty numba cache (a fresh ``NUMBA_CACHE_DIR``): every kernel a
command uses is compiled. Warm means the cache of the cold run. The build
(``pip install .``) compiles every kernel ahead (``setup.py``, ``iwp warmup``),
so an installed iwp starts warm; the cold rows are what a user pays without
it (a changed numba or CPU). Each command is a fresh process; the baseline
is the start of a bare Python interpreter in the same run.

Usage::

    python benchmarks/bench_startup.py
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def wall(cmd: list[str], env: dict, cwd: str) -> float:
    t0 = time.perf_counter()
    r = subprocess.run(cmd, env=env, cwd=cwd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed (exit {r.returncode}):\n{r.stderr[-2000:]}")
    return dt


def median_of(n: int, cmd: list[str], env: dict, cwd: str) -> float:
    return statistics.median(wall(cmd, env, cwd) for _ in range(n))


def main() -> int:
    py = sys.executable
    iwp = [py, "-m", "iwp"]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, MPLBACKEND="Agg")
        base = median_of(5, [py, "-c", "pass"], env, tmp)
        rows.append(("bare `python -c pass` (baseline)", base, 1.0))
        t = median_of(5, iwp + ["--help"], env, tmp)
        rows.append(("`iwp --help`", t, t / base))
        t = median_of(5, iwp + ["--version"], env, tmp)
        rows.append(("`iwp --version`", t, t / base))
        t = median_of(5, iwp + ["rig", "list"], env, tmp)
        rows.append(("`iwp rig list` (computes nothing: no numba, no matplotlib)", t, t / base))
        t = median_of(5, [py, "-c", "import iwp.sim"], env, tmp)
        rows.append(("`python -c 'import iwp.sim'` (numba, no matplotlib)", t, t / base))
        sim = iwp + ["simulate", "--t-end", "5", "--controller", "hopf", "--x0", "0.1,0,0,0", "--force", "--out"]
        cold_env = dict(env, NUMBA_CACHE_DIR=str(Path(tmp) / "cache1"))
        cold = wall(sim + ["a.csv"], cold_env, tmp)
        warm = median_of(3, sim + ["a.csv"], cold_env, tmp)
        rows.append(("first `iwp simulate`, cold cache (compiles the 4-state kernel)", cold, cold / base))
        rows.append(("`iwp simulate`, warm cache", warm, warm / base))
        w_env = dict(env, NUMBA_CACHE_DIR=str(Path(tmp) / "cache2"))
        cold_w = wall(iwp + ["warmup"], w_env, tmp)
        rows.append(("`iwp warmup`, cold cache (every kernel, 2 processes)", cold_w, cold_w / base))
        after = wall(sim + ["b.csv"], w_env, tmp)
        rows.append(("first `iwp simulate` after `iwp warmup`", after, after / base))
        rep_env = dict(env, NUMBA_CACHE_DIR=str(Path(tmp) / "cache3"))
        rep = iwp + ["reproduce", "--quiet", "--force", "--out"]
        cold_r = wall(rep + ["r1"], rep_env, tmp)
        warm_r = wall(rep + ["r2"], rep_env, tmp)
        rows.append(("first `iwp reproduce`, cold cache", cold_r, cold_r / base))
        rows.append(("`iwp reproduce`, warm cache", warm_r, warm_r / base))
        after_r = wall(rep + ["r3"], w_env, tmp)
        rows.append(("first `iwp reproduce` after `iwp warmup`", after_r, after_r / base))
    print(f"Fresh processes on {os.cpu_count()} cores; medians of 5 (help, version) and 3 (warm simulate).\n")
    print("| command | wall [s] | / baseline |")
    print("|---|---:|---:|")
    for name, t, r in rows:
        print(f"| {name} | {t:.2f} | {r:.1f} |")
    print("\nTargets (issue 15, 38): `iwp --help` and `iwp rig list` under 0.3 s warm; first `iwp simulate` of a "
          "fresh install under 10 s and "
          "first `iwp reproduce` under 30 s, compilation included (the install compiles: the rows 'after "
          "`iwp warmup`').")
    return 0


if __name__ == "__main__":
    sys.exit(main())

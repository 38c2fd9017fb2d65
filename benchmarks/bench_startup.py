"""Benchmark of first use: ``iwp --help``, and the first ``iwp simulate``/``reproduce`` cold and warm.

Cold means an empty numba cache (a fresh ``NUMBA_CACHE_DIR``): every kernel a
command uses is compiled. Warm means the cache of the cold run. The build
(``pip install .``) compiles every kernel ahead (``setup.py``, ``iwp warmup``),
so an installed iwp starts warm; the cold rows are what a user pays without
it (a changed numba or CPU). Each command is a fresh process; the baseline
is the start of a bare Python interpreter in the same run.

With ``--install`` (slow: a fresh venv, pip's installs and the build's
compilation, 5-15 min on 2 cores), the newcomer's first minutes: ``pip
install`` of this checkout (the files git tracks) into a new virtual
environment, the wheel's size and its compiled caches, then the first
``iwp reproduce`` after the install and a second one, with no
``NUMBA_CACHE_DIR`` (the install's caches; target: the first within 1.5
times the second).

Usage::

    python benchmarks/bench_startup.py [--install]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
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


def install_rows(tmp: str) -> list[tuple[str, float, float | str]]:
    """``pip install`` of this checkout into a fresh venv, then its first and second ``iwp reproduce``."""
    root = Path(__file__).resolve().parents[1]
    src = Path(tmp) / "src"
    files = subprocess.run(["git", "ls-files", "-z"], cwd=root, capture_output=True, check=True).stdout.decode()
    for rel in filter(None, files.split("\0")):
        if (root / rel).is_file():
            (src / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(root / rel, src / rel)
    venv = Path(tmp) / "venv"
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH", "IWP_NO_PRECOMPILE")}
    env["MPLBACKEND"] = "Agg"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = str(venv / "bin" / "python")
    wheels = Path(tmp) / "wheels"
    t_wheel = wall([py, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(src)], env, tmp)
    (wheel,) = wheels.glob("iwp-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    n_index = sum(n.endswith(".nbi") for n in names)
    t_inst = wall([py, "-m", "pip", "install", "-q", str(wheel)], env, tmp)
    iwp = [str(venv / "bin" / "iwp"), "reproduce", "--quiet", "--out"]
    first = wall(iwp + ["r1"], env, tmp)
    second = wall(iwp + ["r2"], env, tmp)
    return [("`pip wheel .` in a fresh venv (build requirements, the build's compilation)", t_wheel, ""),
            (f"the wheel: {wheel.stat().st_size / 1e6:.1f} MB, {n_index} compiled kernel index files", 0.0, ""),
            ("`pip install` of the wheel (its dependencies)", t_inst, ""),
            ("first `iwp reproduce` after the install", first, first / second),
            ("second `iwp reproduce`", second, 1.0)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--install", action="store_true", help="also measure a fresh venv's install (slow)")
    args = ap.parse_args()
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
        installed = install_rows(tmp) if args.install else []
    print(f"Fresh processes on {os.cpu_count()} cores; medians of 5 (help, version) and 3 (warm simulate).\n")
    print("| command | wall [s] | / baseline |")
    print("|---|---:|---:|")
    for name, t, r in rows:
        print(f"| {name} | {t:.2f} | {r:.1f} |")
    if installed:
        print("\nA fresh virtual environment (`--install`): `pip install .`, then the first `iwp reproduce` against "
              "the second.\n")
        print("| step | wall [s] | / second `iwp reproduce` |")
        print("|---|---:|---:|")
        for name, t, r in installed:
            print(f"| {name} | {t:.1f} | {r if isinstance(r, str) else f'{r:.2f}'} |" if t else f"| {name} | | |")
    print("\nTargets (issue 15, 38, 41): `iwp --help` and `iwp rig list` under 0.3 s warm; first `iwp simulate` of a "
          "fresh install under 10 s and "
          "first `iwp reproduce` under 30 s, compilation included (the install compiles: the rows 'after "
          "`iwp warmup`'); after a fresh install, the first `iwp reproduce` within 1.5 times the second.")
    return 0


if __name__ == "__main__":
    sys.exit(main())

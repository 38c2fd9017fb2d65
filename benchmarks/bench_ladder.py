"""Speed of ``iwp fit``'s ladder of structures (issue 21) and of two fits at once (issue 23).

The virtual direct-drive rig of ``benchmarks/ladder_study.py`` (50 ms, PWM duty, pendulum Coulomb
friction as the truth): three 40 s chirps to train and nineteen 40 s pseudo-random runs held out, as
the issue's user has. Timed as whole commands (a new process each):

(a) ``iwp fit`` with one structure (``--model pendulum-coulomb``): the baseline;
(b) ``iwp fit`` with the ladder (the default): six structures fitted and ranked on the held-out logs;
(b1) (b) on one thread (``NUMBA_NUM_THREADS=1``): the fits' logs, the structures that do not extend each other
     and the folds one after another, as before the fits used every core;
(c) two of (b) at once on the same machine (their thread pools must not fight: issue 23);
and, in this process, the writing of (b)'s report alone.

``--against SRC`` adds the same-run baseline the machine's speed needs: (b) with the iwp of another source tree
(``SRC``, the ``src`` folder of a checkout of an earlier commit: ``git worktree add /tmp/old <commit>``), run
alternately with this one, three times each after a run of each that compiles their kernels; the ratio of the
medians is what is compared across days.

Run: python benchmarks/bench_ladder.py [--against SRC]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

from iwp.ident.logfit import LogFitOptions, fit_logs
from iwp.report.fit_page import write_fit_report
from iwp.threads import one_blas_thread

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ladder_study import RIG, TRUTHS, logs  # noqa: E402


def fit(folder: Path, out: str, *extra: str, threads: int | None = None, src: str | None = None) -> subprocess.Popen:
    train = sorted(str(p) for p in folder.glob("chirp*.csv"))
    held = sorted(str(p) for p in folder.glob("prbs*.csv"))
    env = dict(os.environ, **({"NUMBA_NUM_THREADS": str(threads)} if threads else {}),
               **({"PYTHONPATH": src} if src else {}))
    return subprocess.Popen([sys.executable, "-m", "iwp", "fit", *train, "--rig", str(folder / "rig.json"),
                             "--validate", *held, "--out", str(folder / out), *extra],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)


def report_time(folder: Path) -> float:
    """The ladder fitted in this process, then its report written alone [s]."""
    train = sorted(str(p) for p in folder.glob("chirp*.csv"))
    held = sorted(str(p) for p in folder.glob("prbs*.csv"))
    with warnings.catch_warnings(), one_blas_thread():
        warnings.simplefilter("ignore")
        r = fit_logs(train, rig=folder / "rig.json", validate=held, warn=False, options=LogFitOptions(select=True))
    t0 = time.perf_counter()
    write_fit_report(r, folder / "report_alone")
    return time.perf_counter() - t0


def timed(*procs: subprocess.Popen) -> list[float]:
    t0 = time.perf_counter()
    out = [0.0] * len(procs)
    pending = set(range(len(procs)))
    while pending:
        for i in list(pending):
            if procs[i].poll() is not None:
                if procs[i].returncode != 0:
                    raise SystemExit(f"iwp fit failed (exit {procs[i].returncode})")
                out[i] = time.perf_counter() - t0
                pending.discard(i)
        time.sleep(0.02)
    return out


def against(folder: Path, src: str) -> None:
    """(b) with this iwp and with the one in ``src``, alternately: the medians and their ratio."""
    here = str(Path(__file__).resolve().parents[1] / "src")
    timed(fit(folder, "ab_here0", src=here))  # each tree's kernels compiled (their caches differ)
    timed(fit(folder, "ab_there0", src=src))
    t_here, t_there = [], []
    for k in range(1, 4):
        t_here += timed(fit(folder, f"ab_here{k}", src=here))
        t_there += timed(fit(folder, f"ab_there{k}", src=src))
    mh, mt = sorted(t_here)[1], sorted(t_there)[1]
    print(f"\n(b) against {src}, alternately in this run: this tree {', '.join(f'{t:.1f}' for t in t_here)} s, "
          f"that one {', '.join(f'{t:.1f}' for t in t_there)} s; medians {mh:.1f} s / {mt:.1f} s = {mh / mt:.2f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", metavar="SRC", help="the src folder of another checkout: (b) timed against it")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        logs(TRUTHS["pendulum-coulomb"], 5, folder, duration=40.0, n_train=3, n_held=19)
        (folder / "rig.json").write_text(json.dumps(RIG))
        if args.against:
            against(folder, args.against)
        timed(fit(folder, "warm", "--model", "9"))  # kernels compiled
        (one,) = timed(fit(folder, "one", "--model", "pendulum-coulomb"))
        (lad,) = timed(fit(folder, "ladder"))
        doc = json.loads((folder / "ladder" / "fit.json").read_text())
        (lad1,) = timed(fit(folder, "ladder1", threads=1))
        doc1 = json.loads((folder / "ladder1" / "fit.json").read_text())
        a, b = timed(fit(folder, "twin_a"), fit(folder, "twin_b"))
        rep = report_time(folder)
    print("## `iwp fit`'s ladder of structures (issue 21) and two fits at once (issue 23)\n")
    print("Three chirps of 40 s to train, 19 pseudo-random runs of 40 s held out (50 ms), the virtual direct-drive "
          "rig with pendulum Coulomb friction; whole commands, kernels compiled.\n")
    print("| command | wall time | / one structure |")
    print("|---|---:|---:|")
    print(f"| (a) `iwp fit --model pendulum-coulomb` | {one:.1f} s | 1 |")
    print(f"| (b) `iwp fit` (the ladder: 6 structures) | {lad:.1f} s | {lad / one:.2f} |")
    print(f"| (b1) (b) on one thread | {lad1:.1f} s | {lad1 / one:.2f} |")
    print(f"| (c) two of (b) at once | {a:.1f} s and {b:.1f} s | {max(a, b) / one:.2f} |")
    print(f"\n(b): the fit itself {doc['elapsed_s']:.1f} s (on one thread, (b1): {doc1['elapsed_s']:.1f} s); chosen "
          f"{doc['structures']['chosen']}; writing its report alone {rep:.1f} s ({100 * rep / lad:.0f} % of (b)). "
          "Issue 21's targets: 30 s or less on 2 cores, the report under a quarter of that.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

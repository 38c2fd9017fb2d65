"""Speed of the identification set-ups (issue 4): each on 60,000 samples, target well under 100 ms.

Virtual-rig logs of 300 s at Ts = 5 ms (60,001 samples, as the paper's
section 5.1 experiment: S = 6e4) of the compensated model (9): a free decay
for "free", the clamped chirp for "motor-disk"/"motor-disk-coulomb", the
full chirp for "full" and "two-step"; the static curve of figure 2(a) for
"dead-zone". Timed: :func:`iwp.identify.identify` on the in-memory log,
i.e. windowing, differentiation (default Savitzky-Golay, 101 samples),
regressor, the least squares (13), the measurement-noise covariance and the
diagnostics; the best and the median of ``--repeat`` runs after one warm-up
(numba compilation).

Multithreaded BLAS can stall when other processes compete for the cores;
``OPENBLAS_NUM_THREADS=1`` gives steadier numbers. The machine's core count
and load are printed with the table.

Run: python benchmarks/bench_identify.py [--repeat N] [--both] [--docs docs/identification.md]
(``--both`` times in two subprocesses, with the default OpenBLAS threads and with one thread;
``--docs`` replaces the table between the ``bench:identify`` markers in that file).
"""

from __future__ import annotations

import argparse
import os
import re
import time
from pathlib import Path

import numpy as np

from iwp.ident.identification import identify
from iwp.models import LumpedParameters, StartupFriction
from iwp.rig import RigTruth, VirtualRig

TRUTH = LumpedParameters(p1=21.0, p2=0.0125, p3=0.0240, rho=190.0, sigma_a1=0.0045, sigma_v1=0.016,
                         sigma_b1=0.0009, v_dz_pos=30.0, v_dz_neg=26.0)
MARK_START = "<!-- bench:identify:start -->"
MARK_END = "<!-- bench:identify:end -->"


def logs():
    truth = RigTruth(lumped=TRUTH, belt=None, startup=StartupFriction(break_ratio=0.0, omega_s=2.0))
    rig = VirtualRig(truth, seed=1)
    vdz = (TRUTH.v_dz_pos, TRUTH.v_dz_neg)
    return {
        "free": rig.run("free-pendulum", duration=300.0),
        "md": rig.run("motor-disk-chirp", duration=300.0, v_dz=vdz),
        "full": rig.run("full-chirp", duration=300.0, v_dz=vdz),
        "curve": VirtualRig(seed=1).run("static-curve"),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15, help="timed runs per set-up (default 15)")
    ap.add_argument("--docs", default=None, help="write the table into this markdown file (between markers)")
    ap.add_argument("--both", action="store_true", help="time with the default BLAS threads and with one thread")
    args = ap.parse_args()
    if args.both:
        import subprocess
        import sys

        tables = []
        for threads in (None, "1"):
            env = dict(os.environ)
            env.pop("OPENBLAS_NUM_THREADS", None)
            if threads:
                env["OPENBLAS_NUM_THREADS"] = threads
            out = subprocess.run([sys.executable, __file__, "--repeat", str(args.repeat)], env=env, check=True,
                                 capture_output=True, text=True).stdout
            tables.append(out.strip())
        table = "\n\n".join(tables)
        print(table)
        if args.docs:
            _write_docs(args.docs, table)
        return
    data = logs()
    free_res = identify(data["free"], "free")
    cases = [
        ("full", lambda: identify(data["full"], "full"), data["full"].n_samples),
        ("motor-disk", lambda: identify(data["md"], "motor-disk"), data["md"].n_samples),
        ("motor-disk-coulomb", lambda: identify(data["md"], "motor-disk-coulomb"), data["md"].n_samples),
        ("free", lambda: identify(data["free"], "free"), data["free"].n_samples),
        ("two-step", lambda: identify(data["full"], "two-step", pendulum=free_res), data["full"].n_samples),
        ("dead-zone", lambda: identify(data["curve"], "dead-zone"), data["curve"].n_points),
    ]
    rows = []
    for name, fn, n in cases:
        res = fn()  # warm-up (numba, caches)
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        t = np.array(times) * 1e3
        unit = "points" if name == "dead-zone" else "samples"
        rows.append(f"| {name} | {n:,} {unit} ({res.samples:,} used) | {t.min():.1f} | {np.median(t):.1f} |")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    threads = os.environ.get("OPENBLAS_NUM_THREADS", "default")
    table = "\n".join([
        f"Machine: {os.cpu_count()} cores, load average {load:.2f} at the start, OpenBLAS threads: {threads}; "
        f"{args.repeat} runs per set-up after a warm-up.",
        "",
        "| set-up | log | best [ms] | median [ms] |",
        "|---|---|---|---|",
        *rows,
    ])
    print(table)
    if args.docs:
        _write_docs(args.docs, table)


def _write_docs(docs: str, table: str) -> None:
    path = Path(docs)
    text = path.read_text()
    pattern = re.compile(re.escape(MARK_START) + ".*?" + re.escape(MARK_END), re.S)
    if not pattern.search(text):
        raise SystemExit(f"{path}: markers {MARK_START} ... {MARK_END} not found")
    path.write_text(pattern.sub(lambda m: f"{MARK_START}\n{table}\n{MARK_END}", text))
    print(f"wrote the table into {path}")


if __name__ == "__main__":
    main()

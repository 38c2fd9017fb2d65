"""Benchmark of the calibration of the twin (``iwp rig calibrate``, :func:`iwp.calibration.calibrate`).

Every iteration of the calibration runs the paper's experiments on the twin
and applies the paper's procedures: one *twin evaluation*. Its time is the
baseline, measured in the same run; the calibration's time is reported in
seconds and as a multiple of it (the number of evaluations the optimiser
needed, plus the overhead of the optimiser).

(a) one twin evaluation: :func:`iwp.calibration.statistics.paper_numbers` on the default truth, full-length experiments;
(b) a calibration of 5 structural parameters from a perturbed start (full-length experiments, the paper's targets);
(c) the calibration of all 17 parameters from the uncalibrated truth (Table 1 with the paper's Coulomb model,
    :func:`iwp.rig.uncalibrated_truth`), as ``iwp rig calibrate --truth START.json`` runs it; a few minutes.

Usage::

    python benchmarks/bench_calibrate.py             # (a), (b) and (c), Markdown on stdout
    python benchmarks/bench_calibrate.py --reduced   # (a) and (b) only
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from iwp.calibration import DEFAULT_FREE, calibrate, paper_numbers, truth_with
from iwp.ident.problem import SolverOptions
from iwp.rig import default_truth, uncalibrated_truth

FREE5 = ("lumped.p3", "lumped.v_dz_pos", "lumped.v_dz_neg", "lumped.sigma_c2", "resistance_ratio")


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reduced", action="store_true", help="skip (c), the calibration of all parameters")
    a = ap.parse_args(argv)
    truth = default_truth()
    paper_numbers(truth)  # warm-up: numba kernels loaded or compiled
    runs = []
    for _ in range(3):
        t0 = time.perf_counter()
        paper_numbers(truth)
        runs.append(time.perf_counter() - t0)
    base = min(runs)
    L = truth.lumped
    start = truth_with(truth, {"lumped.p3": L.p3 * 1.05, "lumped.v_dz_pos": L.v_dz_pos + 2.0,
                               "lumped.v_dz_neg": L.v_dz_neg - 1.5, "lumped.sigma_c2": L.sigma_c2 * 0.85,
                               "resistance_ratio": 1.0 + 0.5 * (truth.resistance_ratio - 1.0)})
    t0 = time.perf_counter()
    res = calibrate(start=start, free=FREE5, warn=False)
    t5 = time.perf_counter() - t0
    print(f"Machine: {os.cpu_count()} cores. The paper's targets; full-length experiments (as `iwp rig run`).\n")
    print("| what | twin evaluations | time | / one evaluation | graded targets within |")
    print("|---|---:|---:|---:|---|")
    print(f"| (a) one twin evaluation (best of 3) | 1 | {base:.2f} s | 1 | |")
    print(f"| (b) calibration, 5 parameters from a perturbed start | {res.nfev} | {t5:.1f} s | {t5 / base:.0f}x "
          f"| {res.within} of {res.graded} |")
    if not a.reduced:
        t0 = time.perf_counter()
        full = calibrate(start=uncalibrated_truth(), free=DEFAULT_FREE, options=SolverOptions(tol=1e-3, max_nfev=60),
                         warn=False)
        tf = time.perf_counter() - t0
        print(f"| (c) calibration, {len(DEFAULT_FREE)} parameters from the uncalibrated truth | {full.nfev} | "
              f"{tf:.0f} s | {tf / base:.0f}x | {full.within} of {full.graded} |")
    print(f"\n(b): cost {res.cost_start:.3g} -> {res.cost:.3g}, {res.message}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

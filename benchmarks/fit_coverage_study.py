"""Coverage of ``iwp fit``'s 95 % intervals and prediction bands on logs iwp did not simulate (issue 39).

The logs are :mod:`ls_coverage_study`'s: model (9) with Table 1, integrated by
numpy RK4 with the input held, 2000-count encoders whose zeros fall anywhere
within a count, optional white sensor noise. Each seed: three 40 s chirps
(amplitudes 40, 50, 60) to train and three held out (amplitudes 45, 55, 35, a
slower chirp), every run from rest with the pendulum hanging, each log's
encoder zero its own (a run zeroes its encoders); ``fit_logs`` fits model (9)
(``--model 9``) and simulates each held-out log from its measured initial
state. Reported: per parameter, how often the 95 % interval contains the
truth, the spread of z = error / stderr and the ratio of the root-mean-square
standard error to the estimates' spread over the seeds; per output, the
share of held-out samples inside the 95 % prediction band.

    python benchmarks/fit_coverage_study.py [--seeds 20] [--duration 40] [--noise RAD]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ls_coverage_study as logs  # noqa: E402 (the independent simulator)

from iwp.data import ExperimentData  # noqa: E402
from iwp.ident.logfit import LogFitOptions, fit_logs  # noqa: E402

FREE = ("p1", "p2", "p3", "rho")


def experiments(rng, seeds: int, duration: float, amplitudes, w0: float, noise: float):
    n = int(round(duration / logs.TS)) + 1
    t = np.arange(n) * logs.TS
    a = np.asarray(amplitudes, dtype=float)[:, None]
    u1 = a * np.sin((w0 + t / 100.0) * t)
    u = np.concatenate([u1 for _ in range(seeds)])
    X = logs.simulate_held(u, np.zeros((4, u.shape[0])), logs.TRUTH)  # each run from rest, hanging
    k = len(amplitudes)
    return [[ExperimentData(t=t, q1=logs.quantize(X[0, j], rng, noise), q2=logs.quantize(X[1, j], rng, noise),
                            u=u[j], source=f"s{s}_{j}.csv")
             for j in range(s * k, (s + 1) * k)] for s in range(seeds)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--duration", type=float, default=40.0)
    ap.add_argument("--noise", type=float, default=0.0)
    a = ap.parse_args()
    rng = np.random.default_rng(39)
    t0 = time.perf_counter()
    train = experiments(rng, a.seeds, a.duration, (40.0, 50.0, 60.0), 3.0, a.noise)
    held = experiments(rng, a.seeds, a.duration, (45.0, 55.0, 35.0), 2.0, a.noise)
    print(f"simulated {a.seeds} x 6 logs of {a.duration:g} s in {time.perf_counter() - t0:.0f} s; "
          f"white noise {a.noise:g} rad")
    est, band, fits, secs = [], [], [], []
    for s in range(a.seeds):
        t1 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = fit_logs(train[s], validate=held[s], options=LogFitOptions(), warn=False)
        secs.append(time.perf_counter() - t1)
        est.append({n: (r.refinement.parameters[n].value, r.refinement.parameters[n].stderr,
                        *r.refinement.parameters[n].ci95) for n in FREE if n in r.refinement.parameters})
        band.append({k: np.mean([v.coverage.get(k, np.nan) for v in r.validation]) for k in r.outputs})
        fits.append({k: np.mean([v.fit[k] for v in r.validation]) for k in r.outputs})
    print("| parameter | coverage | mean error | sd of z | rms stderr / spread |")
    print("|---|---:|---:|---:|---:|")
    hits = []
    for n in FREE:
        rows = [e[n] for e in est if n in e]
        v = np.array([r[0] for r in rows])
        se = np.array([r[1] for r in rows])
        lo = np.array([r[2] for r in rows])
        hi = np.array([r[3] for r in rows])
        truth = float(getattr(logs.TRUTH, n))
        inside = (lo <= truth) & (truth <= hi)
        hits.extend(inside)
        z = (v - truth) / se
        print(f"| {n} | {100 * inside.mean():.0f} % | {100 * (v.mean() / truth - 1):+.4f} % | {z.std(ddof=1):.2f} | "
              f"{np.sqrt(np.mean(se ** 2)) / v.std(ddof=1):.2f} |")
    print(f"\npooled: {100 * np.mean(hits):.1f} % of {len(hits)} intervals")
    for k in band[0]:
        b = np.array([x[k] for x in band])
        f = np.array([x[k] for x in fits])
        print(f"held out, {k}: samples inside the 95 % band {100 * np.nanmean(b):.1f} % (seeds "
              f"{100 * np.nanmin(b):.0f}-{100 * np.nanmax(b):.0f} %), fit {np.mean(f):.1f} %")
    print(f"fit_logs: {np.mean(secs):.1f} s a seed")


if __name__ == "__main__":
    main()

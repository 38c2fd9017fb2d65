"""iwp's intervals, bands and warnings on logs from a simulator that shares no code with iwp (issue 50).

The logs come from ``tests/independent.py`` (scipy's DOP853 at 1e-10 on the
equations written out again, the input held between samples, AR(1) or white
sensor noise, then a 2000-count encoder whose zero falls anywhere within a
count). Per seed:

* ``iwp fit --model 9`` (``fit_logs``, no ladder) on three 30 s training logs
  (random multilevel steps, a multisine, steps again) and three 20 s held-out
  logs starting at rest (a multisine, steps, a chirp): per parameter whether
  the 95 % interval holds the truth, its half-width in standard errors, the
  standard error over the estimates' spread across seeds, the structure
  verdict (``structure_error``), and per output the share of held-out samples
  inside the 95 % prediction band;
* ``iwp identify --setup full`` on each training log: whether its intervals
  hold the truth and whether the "model misfit" warning fires; then the same
  on logs of a rig with the wheel's Coulomb friction that model (9) lacks.

    python benchmarks/independent_study.py [--seeds 10] [--truth direct] [--noise 1e-3] [--corr 0.02]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import independent as ind  # noqa: E402 (the simulator that shares nothing with iwp)
from iwp.ident.identification import identify  # noqa: E402
from iwp.ident.logfit import LogFitOptions, fit_logs  # noqa: E402

FREE = ("p1", "p2", "p3", "rho")
FULL = ("p1", "p2", "p3", "rho")  # what identify's full set-up is checked on


@dataclass
class Tally:
    cover: dict = field(default_factory=dict)  # parameter -> list of bool
    width: dict = field(default_factory=dict)  # parameter -> list of half-width / stderr
    z: dict = field(default_factory=dict)  # parameter -> list of (value - truth) / stderr
    value: dict = field(default_factory=dict)
    stderr: dict = field(default_factory=dict)
    band: dict = field(default_factory=dict)  # output -> list of per-seed mean coverage
    structure: list = field(default_factory=list)
    reliable: list = field(default_factory=list)
    seconds: list = field(default_factory=list)

    def add(self, name, truth, p):
        for d, v in ((self.cover, p.ci95_low <= truth <= p.ci95_high),
                     (self.width, 0.5 * (p.ci95_high - p.ci95_low) / p.stderr),
                     (self.z, (p.value - truth) / p.stderr), (self.value, p.value), (self.stderr, p.stderr)):
            d.setdefault(name, []).append(v)


def fit_study(truth: ind.Truth, seeds, noise: float, corr: float, hold: str = "zoh") -> Tally:
    t = Tally()
    for s in seeds:
        logs = ind.study_logs(truth, s, noise=noise, corr=corr, hold=hold)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = fit_logs(logs.train, validate=logs.held, options=LogFitOptions(), warn=False)
        t.seconds.append(time.perf_counter() - t0)
        for n in FREE:
            t.add(n, getattr(truth, n), r.refinement.parameters[n])
        rel = r.refinement.reliability
        t.structure.append(bool(rel is not None and rel.structure_error))
        t.reliable.append(bool(rel is not None and rel.reliable))
        for o in r.outputs:
            cov = [v.coverage.get(o, np.nan) for v in r.validation]
            t.band.setdefault(o, []).append(float(np.nanmean(cov)))
    return t


def identify_study(truth: ind.Truth, seeds, noise: float, corr: float) -> tuple[Tally, list[bool]]:
    t = Tally()
    misfit = []
    for s in seeds:
        logs = ind.study_logs(truth, s, noise=noise, corr=corr)
        for d in logs.train:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = identify(d, "full")
            for n in FULL:
                if n in res.parameters and math.isfinite(res.parameters[n].stderr):
                    t.add(n, getattr(truth, n), res.parameters[n])
            misfit.append(any(w.startswith("model misfit") for w in res.warnings))
    return t, misfit


def report_fit(t: Tally, truth: ind.Truth, label: str) -> None:
    print(f"\n## iwp fit --model 9, {label}: {len(t.structure)} seeds, {np.mean(t.seconds):.1f} s a fit")
    print("| parameter | coverage | median half-width / stderr | sd of z | rms stderr / spread |")
    print("|---|---:|---:|---:|---:|")
    pooled = []
    for n in t.cover:
        c = np.array(t.cover[n])
        pooled.extend(c)
        v, se = np.array(t.value[n]), np.array(t.stderr[n])
        ratio = np.sqrt(np.mean(se ** 2)) / v.std(ddof=1) if v.size > 1 else math.nan
        print(f"| {n} | {100 * c.mean():.0f} % | {np.median(t.width[n]):.2f} | {np.std(t.z[n], ddof=1):.2f} | "
              f"{ratio:.2f} |")
    print(f"pooled coverage {100 * np.mean(pooled):.1f} % of {len(pooled)}; structure error on "
          f"{sum(t.structure)} of {len(t.structure)} fits; intervals called reliable on {sum(t.reliable)}")
    for o, b in t.band.items():
        print(f"held-out {o}: inside the 95 % band {100 * np.nanmean(b):.1f} % (seeds {100 * np.nanmin(b):.0f}-"
              f"{100 * np.nanmax(b):.0f} %)")


def report_identify(t: Tally, misfit: list[bool], label: str) -> None:
    pooled = [x for n in t.cover for x in t.cover[n]]
    cov = ", ".join(f"{n} {100 * np.mean(c):.0f} %" for n, c in t.cover.items())
    print(f"identify --setup full, {label}: coverage {cov} (pooled {100 * np.mean(pooled):.1f} %); median "
          f"half-width / stderr {np.median([w for n in t.width for w in t.width[n]]):.2f}; model-misfit warning on "
          f"{sum(misfit)} of {len(misfit)} logs")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--truth", default="direct", choices=sorted(ind.TRUTHS))
    ap.add_argument("--noise", type=float, default=1e-3, help="sensor noise [rad] before the encoder")
    ap.add_argument("--corr", type=float, default=0.02, help="its correlation time [s] (0: white)")
    ap.add_argument("--hold", default="zoh", choices=["zoh", "continuous"])
    ap.add_argument("--skip-fit", action="store_true")
    ap.add_argument("--skip-identify", action="store_true")
    a = ap.parse_args()
    truth = ind.TRUTHS[a.truth]
    seeds = range(a.seeds)
    label = (f"truth {a.truth}, input {a.hold}, noise {a.noise:g} rad"
             + (f" AR(1) {1e3 * a.corr:g} ms" if a.corr > 0 else " white"))
    if not a.skip_identify:
        t, m = identify_study(truth, seeds, a.noise, a.corr)
        report_identify(t, m, label)
        coul = replace(truth, sigma_c2=0.15 * truth.p3 * truth.amplitude)
        t, m = identify_study(coul, seeds, a.noise, a.corr)
        report_identify(t, m, label + ", the wheel's Coulomb friction missing from the model")
    if not a.skip_fit:
        report_fit(fit_study(truth, seeds, a.noise, a.corr, a.hold), truth, label)


if __name__ == "__main__":
    main()

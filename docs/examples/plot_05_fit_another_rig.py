"""
Fit another rig from its logs
=============================

A lab rig unlike the paper's: a direct-drive wheel whose **speed** is logged
as the board's mean over each 20 ms period, the pendulum in encoder counts,
a PWM duty in [-1, 1] as input, the motor current. Its rig description says
so once; :func:`iwp.ident.logfit.fit_logs` (``iwp fit``) reads the logs
through it, fits model (9) by simulation error on the training logs and
validates it on a held-out one.

The logs come from :class:`iwp.rig.described.DescribedRig`, the virtual rig
logging as that rig would, with a known truth, written to a temporary folder
first, as a rig's own files would be.
"""

import tempfile
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from iwp import Chirp, LumpedParameters
from iwp.data.rig_description import RigDescription
from iwp.ident.logfit import fit_logs
from iwp.rig.described import DescribedRig, prbs, write_rig_csv

rig = RigDescription.from_dict({
    "kind": "iwp-rig", "name": "lab rig B", "sample_period": 0.02,
    "time": {"column": "t", "unit": "s"},
    "pendulum": {"column": "theta", "unit": "counts", "counts_per_rev": 4096},
    "wheel": {"column": "phidot", "quantity": "speed", "unit": "rad/s", "sampling": "mean", "counts_per_rev": 1200},
    "current": {"column": "I", "unit": "A"},
    "input": {"column": "u", "kind": "duty"},
    "drive": {"kind": "direct"},
}, where="rig.json")
truth = LumpedParameters(p1=40.0, p2=0.06, p3=12.0, rho=30.0, sigma_a1=0.02, sigma_v1=0.05, sigma_b1=1e-4)
virtual = DescribedRig(rig, truth)

folder = Path(tempfile.mkdtemp())
train = [write_rig_csv(virtual.run(Chirp(0.3, 2.0, 15.0), duration=20.0), folder / "chirp1.csv"),
         write_rig_csv(virtual.run(Chirp(0.2, 3.0, 20.0), duration=20.0), folder / "chirp2.csv")]
held = write_rig_csv(virtual.run(prbs(751, hold=15, amplitude=0.2, seed=3), duration=15.0), folder / "prbs.csv")
print(Path(train[0]).read_text().splitlines()[-1], "(the last line of a log: t, u, theta, phidot, I)")

with warnings.catch_warnings():
    warnings.simplefilter("ignore")         # the fit's notes are in r.warnings
    r = fit_logs(train, rig=rig, validate=[held], warn=False)

for name in ("p1", "p3", "rho"):
    print(f"{name:>4} = {getattr(r.params, name):8.4g}   (truth {getattr(truth, name):g})")
v = r.validation[0]
print(f"held-out log: fit q1 {v.fit['q1']:.1f} %")
assert abs(r.params.p1 / truth.p1 - 1) < 0.02

fig, ax = plt.subplots(figsize=(7, 3))
ax.plot(v.t, v.measured["q1"], lw=0.8, label="held-out log")
ax.plot(v.t, v.simulated["q1"], "--", lw=0.8, label="fitted model, simulated")
ax.set_xlabel("t [s]")
ax.set_ylabel("q1 [rad]")
ax.legend()
ax.set_title(f"another rig: fit {v.fit['q1']:.1f} % on a held-out PRBS")
print("max |error| q1:", np.round(v.max_abs_error["q1"], 4), "rad")

"""
The calibrated twin
===================

The paper's Table 1 is what its procedures *returned* on its rig, biased by
everything model (9) leaves out (the belt, the dead zone, the encoders). The
virtual rig's truth is therefore not Table 1: it is calibrated by indirect
inference so that the paper's procedures, applied to the twin's logs, return
the paper's published numbers (:mod:`iwp.calibration`). Here the truth's
lumped parameters are compared with Table 1, and the record says where each
value came from.
"""

import matplotlib.pyplot as plt
import numpy as np

from iwp import default_truth, table1
from iwp.calibration import load_targets
from iwp.rig import truth_record

truth = default_truth().lumped
t1 = table1()
names = ["p1", "p2", "p3", "rho", "sigma_a1", "sigma_v1", "sigma_b1"]
ratio = np.array([getattr(truth, n) / getattr(t1, n) for n in names])
for n, q in zip(names, ratio):
    print(f"{n:>9}: truth {getattr(truth, n):10.4g}  Table 1 {getattr(t1, n):10.4g}  ratio {q:6.3f}")

targets = load_targets()
print(f"{len(targets)} published numbers are calibration targets, e.g. {targets[0].key}")
record = truth_record()
print("record sections:", sorted(record))
assert abs(truth.p1 / t1.p1 - 1) < 0.05           # the pendulum's frequency is close to the paper's

fig, ax = plt.subplots(figsize=(6, 3))
ax.bar(names, ratio)
ax.axhline(1, color="k", lw=0.6)
ax.set_ylabel("truth / Table 1")
ax.set_title("the twin's truth against the paper's Table 1")

"""
The models of the paper side by side
====================================

One input, three models: the compensated model (9) driven by ``u``; the raw
model (6) driven by ``v`` through the feedforward (7)-(8) of the dead zone
(5), which (9) assumes perfect (exact, and with the virtual rig's asymmetric
thresholds 33/29 compensated by the paper's 31); and the flexible belt (15) between the motor
and the disk. With the pendulum clamped and the sinusoid ``u = 20 sin 5t``
of figure 4, the small input shows where the compensation and the belt
matter most.
"""

import matplotlib.pyplot as plt
import numpy as np

from iwp import Plant, Sine, paper_belt, simulate, table1
from iwp.sim import Feedforward, SimOptions

p = table1()
u = Sine(amplitude=20, omega=5)
runs = {
    "(9) compensated": simulate(Plant(p, locked=True), input=u, t_end=10),
    "(6) raw, exact feedforward": simulate(Plant(p, model="raw", locked=True), input=u, t_end=10,
                                           options=SimOptions(feedforward=Feedforward.of_plant(p))),
    "(6) raw, dead zone 33/29, feedforward 31": simulate(
        Plant(p.replace(v_dz_pos=33.0, v_dz_neg=29.0), model="raw", locked=True), input=u, t_end=10,
        options=SimOptions(feedforward=Feedforward(31.0, 31.0))),
    "(15) belt": simulate(Plant(p, model="belt", belt=paper_belt(), locked=True), input=u, t_end=10),
}
ref = runs["(9) compensated"].q4
for name, r in runs.items():
    print(f"{name:>40}: max |q4| = {np.abs(r.q4).max():6.2f} rad/s, rms difference from (9) "
          f"{np.sqrt(np.mean((r.q4 - ref) ** 2)):.3f} rad/s")

fig, ax = plt.subplots(figsize=(7, 3.5))
for name, r in runs.items():
    ax.plot(r.t, r.q4, lw=0.8, label=name)
ax.set_xlabel("t [s]")
ax.set_ylabel("q4 [rad/s]")
ax.set_title("u = 20 sin 5t, pendulum clamped")
ax.legend(fontsize=8)
assert np.sqrt(np.mean((runs["(6) raw, exact feedforward"].q4 - ref) ** 2)) < 1e-3   # exact compensation is (9)

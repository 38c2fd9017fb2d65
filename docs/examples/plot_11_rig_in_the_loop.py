"""
A rig in the loop: the emulated twin
====================================

:mod:`iwp.device` drives a board running iwp's firmware through its wire
protocol, at a fixed rate, stopping the motor on every way out. Without a
board, :class:`iwp.device.TwinRig` is the same interface around the
firmware's core with the twin as its plant (``iwp rig run ... --port twin``);
``fast=True`` runs it by the host's clock, faster than real time, with the
same results. Here a sine of the paper with the pendulum clamped, then the
Hopf law ``k1 = -10``, ``k2 = 0.1`` running on the device.
"""

import matplotlib.pyplot as plt
import numpy as np

from iwp import table1
from iwp.device import ControlRun, TwinRig, run_control, run_on_rig

with TwinRig(fast=True) as rig:
    sine = run_on_rig(rig, "sine-60", fast=True, duration=10)
with TwinRig(fast=True) as rig:
    hopf = run_control(rig, ControlRun("hopf", duration=40), params=table1(), fast=True)

log = hopf.log
print(f"sine-60: {sine.reason}, {len(sine.log.t)} samples; hopf: {hopf.reason}, {len(log.t)} samples")
amplitude = np.abs(log.q1[log.t > 30]).max()
print(f"Hopf oscillation on the twin: {amplitude:.2f} rad (the paper measured 2.58)")
assert not hopf.interrupted and abs(amplitude - 2.58) < 0.25

fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 5))
ax1.plot(sine.log.t, sine.log.q2, lw=0.7)
ax1.set_ylabel("q2 [rad]")
ax1.set_title("sine-60 on the twin (pendulum clamped)")
ax2.plot(log.t, log.q1, lw=0.7)
ax2.set_ylabel("q1 [rad]")
ax2.set_xlabel("t [s]")
ax2.set_title("the Hopf law on the device")
fig.tight_layout()

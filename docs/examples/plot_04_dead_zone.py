"""
The dead zone and its compensation
==================================

The motor driver does not move the disk until ``|v|`` exceeds a threshold:
the dead zone (5). A static curve (each input held until the disk speed
settles, pendulum clamped) shows it; the ``dead-zone`` set-up fits the two
straight parts and returns the thresholds where they meet ``q4 = 0``. The
feedforward (7)-(8), ``v = u + v_dz sgn(u)``, then makes the input ``u`` of
model (9) act linearly.
"""

import matplotlib.pyplot as plt
import numpy as np

from iwp import VirtualRig, feedforward, identify
from iwp.plotting import plot_static_curve

curve = VirtualRig().run("static-curve")               # v in [-100, 100], no compensation
dz = identify(curve, "dead-zone")
v_pos, v_neg = dz.value("v_dz_pos"), dz.value("v_dz_neg")
print(f"apparent thresholds: v+ = {v_pos:.2f}, v- = {v_neg:.2f} (the rig compensates with 31)")
assert abs(v_pos - 31) < 1.5 and abs(v_neg - 31) < 1.5

u = np.linspace(-60, 60, 7)
print("u  ->", u)
print("v  ->", np.round(feedforward(u, v_pos, v_neg), 2))

fig, ax = plt.subplots(figsize=(6, 4))
plot_static_curve(curve.input, curve.q4, input_name="v", ax=ax, title="static curve and its dead zone (5)")

"""
Balance and swing-up
====================

Beyond the paper: an energy-pumping swing-up brings the pendulum from rest
at the bottom to the top, where an LQR designed on the linearisation of (9)
at the upright balances it. By default :func:`iwp.swing_up` runs on the
rig's conditions: model (6) with its dead zone compensated, encoders of 2000
counts per turn, an observer and a controller every 5 ms, ``|u| <= 100``.
"""

import numpy as np

from iwp import lqr_balance, swing_up, table1
from iwp.plotting import plot_swingup

p = table1()
lqr = lqr_balance(p, Ts=0.005)
print("LQR gains K =", np.round(lqr.K, 3))
print("closed-loop poles:", np.round(lqr.poles, 3))

res = swing_up(p, t_end=15)
print(res.summary() if hasattr(res, "summary") else res)
assert res.success

plot_swingup(res)

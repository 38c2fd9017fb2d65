"""
The Gymnasium environment
=========================

``iwp.gym_env`` wraps model (9) (or (6) with the dead zone) as a Gymnasium
environment for reinforcement learning: observations ``cos q1, sin q1, q3,
q4``, an action in [-1, 1] scaled by ``u_max``, a reward that penalises the
distance from the upright. Here two policies start near the top: no action,
which lets the pendulum fall, and the balance LQR of :func:`iwp.lqr_balance`
reading the true state, which keeps it up and earns a higher return.
"""

import gymnasium
import matplotlib.pyplot as plt
import numpy as np

import iwp.gym_env  # noqa: F401  (registers iwp/InertiaWheelPendulum-v0)
from iwp import lqr_balance, table1

lqr = lqr_balance(table1(), Ts=0.005)


def episode(policy, steps=600, seed=1):
    env = gymnasium.make("iwp/InertiaWheelPendulum-v0", init="top")
    obs, info = env.reset(seed=seed)
    total, thetas = 0.0, []
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(np.array([policy(info["state"])], dtype=np.float32))
        total += reward
        thetas.append(info["theta"])
        if terminated or truncated:
            break
    env.close()
    return total, np.array(thetas)


ret_zero, th_zero = episode(lambda x: 0.0)
ret_lqr, th_lqr = episode(lambda x: lqr(x) / 100.0)
print(f"return over 3 s: no action {ret_zero:.1f}, LQR {ret_lqr:.1f}")
print(f"largest |theta| under the LQR: {np.abs(th_lqr).max():.3f} rad")
assert ret_lqr > ret_zero and np.abs(th_lqr).max() < 0.2

fig, ax = plt.subplots(figsize=(7, 3))
ax.plot(np.arange(len(th_zero)) * 0.005, th_zero, label=f"no action (return {ret_zero:.0f})")
ax.plot(np.arange(len(th_lqr)) * 0.005, th_lqr, label=f"LQR (return {ret_lqr:.0f})")
ax.set_xlabel("t [s]")
ax.set_ylabel("angle from the upright [rad]")
ax.legend()

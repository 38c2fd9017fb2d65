"""
Identify each set-up of section 5
=================================

The virtual rig runs the paper's experiments on a truth plant richer than
model (9) (a belt, the dead zone, encoders of 2000 counts per turn); each
least-squares set-up of section 5 returns its parameters with standard
errors. The twin is calibrated so that the paper's procedures return the
paper's numbers; here the experiments are shortened to keep the example
fast, so the numbers differ a little from the 300 s runs.
"""

import matplotlib.pyplot as plt

from iwp import VirtualRig, identify, table1

rig = VirtualRig()
md = rig.run("motor-disk-chirp", duration=60)      # pendulum clamped: (14)
free = rig.run("free-pendulum")                      # u = 0, released from -1.422 rad
chirp = rig.run("full-chirp", duration=60)          # the full system (9)

results = {
    "motor-disk": identify(md, "motor-disk"),
    "free": identify(free, "free", t_start=0.5),
    "full": identify(chirp, "full"),
}
results["two-step"] = identify(chirp, "two-step", pendulum=results["free"])

t1 = table1()
for name, r in results.items():
    shown = ", ".join(f"{k} = {r.value(k):.4g} +- {r.stderr(k):.2g}" for k in list(r.values())[:3])
    print(f"{name:>10}: {shown}")

p1_free = results["free"].value("p1")
print(f"sqrt(p1) from the free swing: {p1_free ** 0.5:.3f} rad/s (Table 1: {t1.p1 ** 0.5:.3f})")
assert abs(p1_free / t1.p1 - 1) < 0.03

fig, ax = plt.subplots(figsize=(7, 3))
ax.plot(free.t, free.q1, lw=0.7)
ax.set_xlabel("t [s]")
ax.set_ylabel("q1 [rad]")
ax.set_title("the free pendulum on the virtual rig (figure 8's experiment)")

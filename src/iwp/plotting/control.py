"""Figures of :mod:`iwp.control`: the Hopf bifurcation diagram, swing-up runs, the pendulum animation.

Same conventions as :mod:`iwp.plotting`: the functions draw what they are
given and compute nothing; each takes ``ax=`` (or ``axes=``) and returns a
dict of the matplotlib artists it made. Result objects' ``.plot()`` and
``.animate()`` methods delegate here.
"""

from __future__ import annotations

import math

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .base import stacked_axes  # noqa: E402

__all__ = ["plot_bifurcation", "plot_branch_details", "plot_swingup", "animate_pendulum"]


def plot_bifurcation(branch, *, ax=None, simulations=None, prediction=None, design=None, label=None):
    """Amplitude ``max q1`` against ``k1`` along the Hopf branch (section 5.3).

    Stable orbits solid, unstable dashed; the Hopf point as a dot; the
    hanging equilibrium (amplitude 0) stable for ``k1 > k1*`` and unstable
    below, drawn the same way.

    Parameters
    ----------
    branch : HopfBranch
    ax : Axes, optional
    simulations : (k1, amplitude) pair of arrays, or list of SimulatedOscillation, optional
        Amplitudes reached by long simulations, drawn as markers.
    prediction : (k1, amplitude) pair of arrays, optional
        The small-amplitude (normal form) prediction, drawn dotted.
    design : HopfDesign, optional
        A designed point, drawn as a star.
    label : str, optional
        Legend label of the branch.

    Returns
    -------
    dict
        ``{"figure", "axes", "lines", "markers"}``.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from iwp import continue_hopf, table1
    >>> from iwp.plotting import plot_bifurcation
    >>> out = plot_bifurcation(continue_hopf(table1(), 0.1, a_max=1.0))
    >>> [t.get_text() for t in out["axes"][0].get_legend().get_texts()]
    ['periodic orbits, $k_2$ = 0.1 (stable)', 'hanging equilibrium', 'Hopf point $k_1^*$ = -0.9447']
    >>> plt.close(out["figure"])
    """
    if ax is None:
        fig, ax = plt.subplots(figsize=(7.0, 4.2), constrained_layout=True)
    else:
        fig = ax.figure
    k1 = np.asarray(branch.k1)
    amp = np.asarray(branch.amplitude)
    stable = np.asarray(branch.stable, dtype=bool)
    lines = []
    base = label or f"periodic orbits, $k_2$ = {branch.k2:g}"
    # split into runs of equal stability
    start = 0
    first_s = first_u = True
    color = "C0"
    for i in range(1, k1.size + 1):
        if i == k1.size or stable[i] != stable[start]:
            j = min(i + 1, k1.size)
            st = stable[start]
            lab = None
            if st and first_s:
                lab, first_s = f"{base} (stable)", False
            elif not st and first_u:
                lab, first_u = f"{base} (unstable)", False
            (ln,) = ax.plot(k1[start:j], amp[start:j], "-" if st else "--", color=color, lw=1.6, label=lab)
            lines.append(ln)
            start = i
    k_lo = min(k1.min(), branch.hopf.k1) - 0.05 * (abs(k1.min() - branch.hopf.k1) + 1)
    k_hi = branch.hopf.k1 + 0.15 * (abs(k1.min() - branch.hopf.k1) + 1)
    side = branch.hopf.orbit_side
    (l_eq_s,) = ax.plot([branch.hopf.k1, k_hi if side < 0 else k_lo], [0, 0], "-", color="k", lw=1.2,
                        label="hanging equilibrium")
    (l_eq_u,) = ax.plot([branch.hopf.k1, k_lo if side < 0 else k_hi], [0, 0], "--", color="k", lw=1.2)
    lines += [l_eq_s, l_eq_u]
    markers = []
    markers.append(ax.plot([branch.hopf.k1], [0.0], "o", color="C3", ms=6,
                           label=f"Hopf point $k_1^*$ = {branch.hopf.k1:.4g}")[0])
    if prediction is not None:
        (lp,) = ax.plot(prediction[0], prediction[1], ":", color="C2", lw=1.4, label="normal-form prediction")
        lines.append(lp)
    if simulations is not None:
        if isinstance(simulations, (list, tuple)) and simulations and hasattr(simulations[0], "amplitude"):
            ks = [s.k1 for s in simulations]
            am = [s.amplitude for s in simulations]
        else:
            ks, am = simulations
        markers.append(ax.plot(ks, am, "x", color="C1", ms=8, mew=1.8, label="long simulation")[0])
    if design is not None:
        markers.append(ax.plot([design.k1], [design.amplitude], "*", color="C4", ms=13,
                               label=f"design: A = {design.amplitude:g} rad, $k_1$ = {design.k1:.4g}")[0])
    for b in getattr(branch, "bifurcations", ()):
        markers.append(ax.plot([b["k1"]], [b["amplitude"]], "s", color="C5", ms=6, mfc="none",
                               label=f"stability change ({b['kind']})")[0])
    ax.axhline(math.pi, color="0.6", lw=0.8, ls="-.")
    ax.set_xlabel(r"$k_1$ [-]")
    ax.set_ylabel(r"amplitude $\max q_1$ [rad]")
    ax.set_title(r"Hopf anticontrol $u = k_1 q_3 + k_2 q_3^3$: bifurcation diagram")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower left", fontsize=8)
    return {"figure": fig, "axes": [ax], "lines": lines, "markers": markers}


def plot_branch_details(branch, *, axes=None):
    """Period and largest non-trivial Floquet multiplier along the branch.

    Parameters
    ----------
    branch : HopfBranch
    axes : two Axes, optional

    Returns
    -------
    dict
        ``{"figure", "axes", "lines"}``.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from iwp import continue_hopf, table1
    >>> from iwp.plotting import plot_branch_details
    >>> out = plot_branch_details(continue_hopf(table1(), 0.1, a_max=1.0))
    >>> len(out["axes"]), out["axes"][0].get_ylabel()  # the period, and the Floquet multiplier below
    (2, 'period [s]')
    >>> plt.close(out["figure"])
    """
    fig, axes = stacked_axes(2, axes, figsize=(7.0, 4.6))
    k1 = np.asarray(branch.k1)
    mult = np.asarray(branch.floquet)
    # largest |mu| after dropping the trivial multiplier (the one nearest to 1)
    big = np.full(k1.size, np.nan)
    for i, m in enumerate(mult):
        if np.all(np.isfinite(m)):
            j = int(np.argmin(np.abs(m - 1.0)))
            big[i] = np.max(np.abs(np.delete(m, j)))
    (l1,) = axes[0].plot(k1, branch.period, "-", color="C0")
    axes[0].set_ylabel("period [s]")
    axes[0].grid(True, alpha=0.3)
    (l2,) = axes[1].semilogy(k1, big, "-", color="C1")
    axes[1].axhline(1.0, color="k", lw=0.8)
    axes[1].set_ylabel(r"max non-trivial $|\mu|$")
    axes[1].set_xlabel(r"$k_1$ [-]")
    axes[1].grid(True, alpha=0.3)
    return {"figure": fig, "axes": axes, "lines": [l1, l2]}


def plot_swingup(result, *, axes=None, label=None):
    """A swing-up and balance run: angle from the upright, velocities and input.

    Parameters
    ----------
    result : SwingUpResult
    axes : four Axes, optional
    label : str, optional

    Returns
    -------
    dict
        ``{"figure", "axes", "lines"}``.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from iwp import swing_up, table1
    >>> from iwp.plotting import plot_swingup
    >>> out = plot_swingup(swing_up(table1(), t_end=10.0, rig=None))  # ideal conditions
    >>> [ax.get_ylabel() for ax in out["axes"]]
    ['$q_1$ [rad]', '$q_3$ [rad/s]', '$q_4$ [rad/s]', '$u$ [-]']
    >>> plt.close(out["figure"])
    """
    fig, axes = stacked_axes(4, axes, figsize=(7.5, 7.5))
    r = result.result
    lines = []
    # the upright(s) q1 = (2k + 1) pi are marked with the success band
    lines.append(axes[0].plot(r.t, r.q1, lw=1.0, label=label)[0])
    lo, hi = float(np.nanmin(r.q1)), float(np.nanmax(r.q1))
    for k in range(int(math.floor((lo / math.pi - 1) / 2)), int(math.ceil((hi / math.pi - 1) / 2)) + 1):
        up = (2 * k + 1) * math.pi
        if lo - 0.5 <= up <= hi + 0.5:
            axes[0].axhspan(up - result.tolerance, up + result.tolerance, color="C2", alpha=0.25, lw=0)
            axes[0].axhline(up, color="C2", lw=0.6)
    axes[0].set_ylabel(r"$q_1$ [rad]")
    lines.append(axes[1].plot(r.t, r.q3, lw=1.0)[0])
    axes[1].set_ylabel(r"$q_3$ [rad/s]")
    lines.append(axes[2].plot(r.t, r.q4, lw=1.0, color="C1")[0])
    axes[2].set_ylabel(r"$q_4$ [rad/s]")
    lines.append(axes[3].plot(r.t, r.u, lw=0.8, color="C3")[0])
    axes[3].axhline(result.u_max, color="0.5", lw=0.6, ls=":")
    axes[3].axhline(-result.u_max, color="0.5", lw=0.6, ls=":")
    axes[3].set_ylabel(r"$u$ [-]")
    axes[3].set_xlabel("t [s]")
    for t_sw, mode in result.switches:
        for ax in axes:
            ax.axvline(t_sw, color="C2" if mode == "balance" else "C3", lw=0.8, ls="--")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    status = "balanced" if result.success else "NOT balanced"
    axes[0].set_title(f"swing-up and balance ({result.conditions}): {status}, catch at t = {result.t_catch:.2f} s")
    return {"figure": fig, "axes": axes, "lines": lines}


def animate_pendulum(t, q1, q2, path, *, frames: int = 100, fps: int = 20, u=None, size: float = 3.2,
                     dpi: int = 80, title: str = "inertia wheel pendulum"):
    """Write an animation of the pendulum and its disk (GIF with Pillow; MP4 needs ffmpeg).

    The arm goes from the pivot to the disk axis at angle ``q1`` (0 hanging
    down); the disk's spoke shows its absolute angle ``q1 + q2``.

    Parameters
    ----------
    t, q1, q2 : array_like
        Time [s] and angles [rad].
    path : str or Path
        Output file (``.gif`` or ``.mp4``).
    frames : int
        Number of frames, evenly spaced over ``t``.
    fps : int
        Frames per second of the file.
    u : array_like, optional
        Input, shown as a bar.
    size : float
        Figure size [inch]; ``dpi`` its resolution.

    Returns
    -------
    dict
        ``{"figure", "axes", "path", "frames"}``.

    Examples
    --------
    Four seconds of the Hopf law of section 5.3 from just off the bottom, as a 10-frame GIF (needs Pillow):

    >>> import matplotlib.pyplot as plt
    >>> from iwp import HopfController, Plant, simulate, table1
    >>> from iwp.plotting import animate_pendulum
    >>> res = simulate(Plant(table1()), input=HopfController(k1=-10, k2=0.1), x0=[0.1, 0, 0, 0], t_end=4.0)
    >>> out = animate_pendulum(res.t, res.q1, res.q2, "hopf.gif", frames=10, fps=5, size=2.0, dpi=50)
    >>> out["frames"], str(out["path"])
    (10, 'hopf.gif')
    >>> plt.close(out["figure"])
    """
    from matplotlib import animation

    t = np.asarray(t, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    q2 = np.asarray(q2, dtype=float)
    idx = np.linspace(0, t.size - 1, max(2, int(frames))).round().astype(int)
    fig, ax = plt.subplots(figsize=(size, size), dpi=dpi)
    ax.set_xlim(-1.4, 1.4)
    ax.set_ylim(-1.4, 1.4)
    ax.set_aspect("equal")
    ax.axis("off")
    ax.plot([0], [0], "ko", ms=4)
    (arm,) = ax.plot([], [], "-", color="0.3", lw=3)
    disk = plt.Circle((0, 0), 0.25, fc="C0", ec="k", alpha=0.6)
    ax.add_patch(disk)
    (spoke,) = ax.plot([], [], "-", color="C3", lw=2)
    ubar = None
    if u is not None:
        u = np.asarray(u, dtype=float)
        umax = max(1.0, float(np.nanmax(np.abs(u))))
        ubar = ax.barh([-1.3], [0.0], height=0.08, color="C3")[0]
        ax.text(-1.35, -1.22, "u", fontsize=7)
    text = ax.text(-1.35, 1.25, "", fontsize=8)
    ax.set_title(title, fontsize=9)

    def draw(k):
        i = idx[k]
        x, y = math.sin(q1[i]), -math.cos(q1[i])
        arm.set_data([0, x], [0, y])
        disk.center = (x, y)
        a = q1[i] + q2[i]
        spoke.set_data([x, x + 0.25 * math.sin(a)], [y, y - 0.25 * math.cos(a)])
        text.set_text(f"t = {t[i]:5.2f} s")
        artists = [arm, disk, spoke, text]
        if ubar is not None:
            w = 1.0 * u[i] / umax if np.isfinite(u[i]) else 0.0
            ubar.set_x(min(0.0, w))
            ubar.set_width(abs(w))
            artists.append(ubar)
        return artists

    anim = animation.FuncAnimation(fig, draw, frames=idx.size, interval=1000.0 / fps, blit=False)
    path = str(path)
    if path.lower().endswith(".mp4"):
        writer = animation.FFMpegWriter(fps=fps)
    else:
        writer = animation.PillowWriter(fps=fps)
    anim.save(path, writer=writer, dpi=dpi)
    plt.close(fig)
    return {"figure": fig, "axes": [ax], "path": path, "frames": int(idx.size)}

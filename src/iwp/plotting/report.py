"""Figures of the reproduction report: the paper's figures 2-10 drawn from prepared series.

Same conventions as :mod:`iwp.plotting`: the functions draw what they are
given and compute nothing (the pipeline, :mod:`iwp.reproduce`, computes the
errors, fits and decimated series); each takes ``ax=`` (or ``axes=``) and
returns a dict of the matplotlib artists it made.

A *series* is a pair ``(t, y)`` of equal-length arrays; the measured,
simulated and error curves may have different time grids (the pipeline
decimates each one for small SVG files).
"""

from __future__ import annotations

import matplotlib.pyplot as plt  # noqa: E402

from .base import SIGNAL_LABELS  # noqa: E402

__all__ = [
    "SIGNAL_LABELS",
    "plot_static_curve",
    "plot_dead_zone",
    "plot_comparison_panel",
    "plot_comparisons",
    "plot_errors",
]

_MEASURED_STYLE = {"color": "C0", "ls": "-", "lw": 1.0}
_SIM_STYLES = [
    {"color": "C3", "ls": "--", "lw": 1.1},
    {"color": "C2", "ls": "-.", "lw": 1.1},
    {"color": "C1", "ls": ":", "lw": 1.3},
]
_ERROR_STYLES = [
    {"color": "k", "ls": "-", "lw": 0.7},
    {"color": "C2", "ls": "-", "lw": 0.7},
    {"color": "C1", "ls": "-", "lw": 0.7},
]


def plot_static_curve(x, q4, *, input_name="v", lines=(), ax=None, title=None, label="steady state (rig)"):
    """A static input / steady disk velocity curve (figure 2), with optional straight lines.

    Parameters
    ----------
    x, q4 : array_like
        Input values [input units] and steady disk velocities [rad/s].
    input_name : {'v', 'u'}
        Names the horizontal axis (raw input ``v`` or compensated ``u``).
    lines : sequence of (x, y, label)
        Straight-line approximations or extrapolations to draw (dashed).
    ax : Axes, optional
    title : str, optional
    label : str
        Legend label of the points.

    Returns
    -------
    dict
        ``{"figure", "axes": [ax], "points": Line2D, "lines": [Line2D, ...]}``.
    """
    if ax is None:
        fig, ax = plt.subplots(figsize=(5.0, 3.8), constrained_layout=True)
    else:
        fig = ax.figure
    (pts,) = ax.plot(x, q4, "o", ms=3.5, color="C0", label=label)
    out = []
    for i, (lx, ly, lab) in enumerate(lines):
        style = _SIM_STYLES[i % len(_SIM_STYLES)]
        (ln,) = ax.plot(lx, ly, label=lab, **style)
        out.append(ln)
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.axvline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel(SIGNAL_LABELS.get(input_name, input_name))
    ax.set_ylabel(r"steady $q_4$ [rad/s]")
    if title:
        ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", fontsize=7)
    return {"figure": fig, "axes": [ax], "points": pts, "lines": out}


def plot_dead_zone(raw, compensated, *, raw_lines=(), compensated_lines=(), axes=None):
    """Figure 2: (a) the static curve without compensation, (b) with the feedforward.

    Parameters
    ----------
    raw, compensated : (x, q4) pairs
        The two static curves.
    raw_lines, compensated_lines : sequences of (x, y, label)
        Straight lines drawn over each panel.
    axes : pair of Axes, optional

    Returns
    -------
    dict
        ``{"figure", "axes": [ax_a, ax_b], "points": [..], "lines": [..]}``.
    """
    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.8), constrained_layout=True)
    else:
        fig = axes[0].figure
    a = plot_static_curve(raw[0], raw[1], input_name="v", lines=raw_lines, ax=axes[0],
                          title="(a) without compensation")
    b = plot_static_curve(compensated[0], compensated[1], input_name="u", lines=compensated_lines, ax=axes[1],
                          title=r"(b) with the feedforward $v = u + v_{dz}\,\mathrm{sgn}\,u$")
    return {"figure": fig, "axes": [axes[0], axes[1]], "points": [a["points"], b["points"]],
            "lines": a["lines"] + b["lines"]}


def plot_comparison_panel(measured, simulated, error=None, *, signal="q4", ax=None, error_ax=None, title=None,
                          measured_label="experimental data (virtual rig)"):
    """Measured against simulated signal, with the error below (figures 3-10).

    Parameters
    ----------
    measured : (t, y)
        The measured signal.
    simulated : (t, y, label) or a list of them
        One or more simulations.
    error : (t, e, label) or a list of them, optional
        Error curves for ``error_ax`` (one per simulation, usually).
    signal : str
        ``q1`` .. ``q4``, names the vertical axis.
    ax, error_ax : Axes, optional
        Without ``ax`` a new figure with both axes is made; without
        ``error_ax`` (but with ``ax``) the error is not drawn.
    title : str, optional
    measured_label : str

    Returns
    -------
    dict
        ``{"figure", "axes", "lines"}``: ``lines`` holds the measured line,
        then the simulated ones, then the error ones.
    """
    if ax is None:
        fig, (ax, error_ax) = plt.subplots(2, 1, sharex=True, figsize=(7.0, 4.2), constrained_layout=True,
                                           gridspec_kw={"height_ratios": [2, 1]})
    else:
        fig = ax.figure
    sims = [simulated] if isinstance(simulated, tuple) else list(simulated)
    (lm,) = ax.plot(measured[0], measured[1], label=measured_label, **_MEASURED_STYLE)
    lines = [lm]
    for i, (ts, ys, lab) in enumerate(sims):
        (ln,) = ax.plot(ts, ys, label=lab, **_SIM_STYLES[i % len(_SIM_STYLES)])
        lines.append(ln)
    label = SIGNAL_LABELS.get(signal, signal)
    ax.set_ylabel(label)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=7)
    if title:
        ax.set_title(title, fontsize=10)
    axes = [ax]
    if error_ax is not None and error is not None:
        errs = [error] if isinstance(error, tuple) else list(error)
        for i, (te, e, lab) in enumerate(errs):
            (ln,) = error_ax.plot(te, e, label=lab, **_ERROR_STYLES[i % len(_ERROR_STYLES)])
            lines.append(ln)
        error_ax.set_ylabel(f"error e [{label.split('[')[-1]}" if "[" in label else "error e")
        error_ax.set_xlabel("t [s]")
        error_ax.grid(True, alpha=0.3)
        if len(errs) > 1:
            error_ax.legend(loc="upper right", fontsize=7)
        axes.append(error_ax)
    else:
        ax.set_xlabel("t [s]")
    return {"figure": fig, "axes": axes, "lines": lines}


def plot_comparisons(panels, *, axes=None, width=8.0, panel_height=3.0):
    """Several comparison panels stacked, each with its error below (e.g. figure 3 (a) and (b)).

    Parameters
    ----------
    panels : sequence of dict
        Keyword arguments of :func:`plot_comparison_panel` (``measured``,
        ``simulated``, ``error``, ``signal``, ``title``, ...).
    axes : sequence of Axes, optional
        ``2 * len(panels)`` axes: signal, error, signal, error, ...
    width, panel_height : float
        Figure size of a new figure [inch].

    Returns
    -------
    dict
        ``{"figure", "axes", "lines", "panels": [dict per panel]}``.
    """
    n = len(panels)
    if axes is None:
        fig, axs = plt.subplots(2 * n, 1, figsize=(width, panel_height * n + 0.3), constrained_layout=True,
                                gridspec_kw={"height_ratios": [2, 1] * n})
        axs = list(axs)
    else:
        axs = list(axes)
        if len(axs) != 2 * n:
            raise ValueError(f"axes must hold {2 * n} axes (signal and error per panel), got {len(axs)}")
        fig = axs[0].figure
    out = []
    for i, kw in enumerate(panels):
        out.append(plot_comparison_panel(ax=axs[2 * i], error_ax=axs[2 * i + 1], **kw))
    lines = [ln for p in out for ln in p["lines"]]
    return {"figure": fig, "axes": axs, "lines": lines, "panels": out}


def plot_errors(errors, *, signal="q1", ax=None, title=None):
    """Error curves of several models on one axis (e.g. before and after refinement).

    Parameters
    ----------
    errors : sequence of (t, e, label)
    signal : str
    ax : Axes, optional
    title : str, optional

    Returns
    -------
    dict
        ``{"figure", "axes": [ax], "lines"}``.
    """
    if ax is None:
        fig, ax = plt.subplots(figsize=(8.0, 3.0), constrained_layout=True)
    else:
        fig = ax.figure
    lines = []
    for i, (t, e, lab) in enumerate(errors):
        style = dict(_ERROR_STYLES[i % len(_ERROR_STYLES)])
        style["lw"] = 0.8
        (ln,) = ax.plot(t, e, label=lab, **style)
        lines.append(ln)
    label = SIGNAL_LABELS.get(signal, signal)
    ax.set_ylabel(f"error in {label}")
    ax.set_xlabel("t [s]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=7)
    if title:
        ax.set_title(title, fontsize=10)
    return {"figure": fig, "axes": [ax], "lines": lines}

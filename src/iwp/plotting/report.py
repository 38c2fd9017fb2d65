"""Figures of the reproduction report: the paper's figures 2-10 drawn from prepared series.

Same conventions as :mod:`iwp.plotting`: the functions draw what they are
given and compute nothing (the pipeline, :mod:`iwp.reproduce`, computes the
errors and fits); each takes ``ax=`` (or ``axes=``) and returns a dict of
the matplotlib artists it made.

A *series* is a pair ``(t, y)`` of equal-length arrays at full resolution;
the measured, simulated and error curves may have different time grids. A
long record is drawn as its envelope per pixel column, with a few seconds
in full in a zoom panel beside it (:mod:`iwp.plotting.records`); legends go
in an empty corner or above the axes (:mod:`iwp.plotting.legends`).
"""

from __future__ import annotations

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .base import SIGNAL_LABELS  # noqa: E402
from .legends import place_legend, settle_legends  # noqa: E402
from .records import LINE_SAMPLES_PER_COLUMN, axes_columns, draw_record, zoom_window  # noqa: E402

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

    Examples
    --------
    Figure 2(a) on the virtual rig, with a straight line from the threshold ``v+ = 31`` (as
    :func:`~iwp.ident.identify_dead_zone` fits it):

    >>> import matplotlib.pyplot as plt
    >>> from iwp.plotting import plot_static_curve
    >>> from iwp.rig import run_experiment
    >>> curve = run_experiment("static-curve", step=10.0, duration=2.0)
    >>> out = plot_static_curve(curve.input, curve.q4, lines=[([31.0, 100.0], [0.0, 213.3], "v+ = 31")])
    >>> out["axes"][0].get_xlabel(), len(out["points"].get_xdata()), len(out["lines"])
    ('$v$ [-]', 21, 1)
    >>> plt.close(out["figure"])
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
    place_legend(ax)
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

    Examples
    --------
    Figure 2 on the virtual rig, every 10 input units:

    >>> import matplotlib.pyplot as plt
    >>> from iwp.plotting import plot_dead_zone
    >>> from iwp.rig import run_experiment
    >>> raw = run_experiment("static-curve", step=10.0, duration=2.0)
    >>> compensated = run_experiment("static-curve-compensated", step=10.0, duration=2.0)
    >>> out = plot_dead_zone((raw.input, raw.q4), (compensated.input, compensated.q4))
    >>> [ax.get_xlabel() for ax in out["axes"]]
    ['$v$ [-]', '$u$ [-]']
    >>> plt.close(out["figure"])
    """
    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.8), constrained_layout=True)
    else:
        fig = axes[0].figure
    a = plot_static_curve(raw[0], raw[1], input_name="v", lines=raw_lines, ax=axes[0],
                          title="(a) without compensation")
    b = plot_static_curve(compensated[0], compensated[1], input_name="u", lines=compensated_lines, ax=axes[1],
                          title=r"(b) with the feedforward $v = u + v_{dz}\,\mathrm{sgn}\,u$")
    settle_legends(fig)
    return {"figure": fig, "axes": [axes[0], axes[1]], "points": [a["points"], b["points"]],
            "lines": a["lines"] + b["lines"]}


def plot_comparison_panel(measured, simulated, error=None, *, signal="q4", axes=None, title=None,
                          measured_label="experimental data (virtual rig)", zoom=None):
    """Measured against simulated signal, with the error below (figures 3-10).

    A record with more samples than the axes have pixel columns is drawn as
    its envelope (:func:`iwp.plotting.records.draw_record`); with zoom axes,
    a few seconds of it are drawn in full beside it and marked on the panel.
    The legend goes in an empty corner, else above the axes.

    Parameters
    ----------
    measured : (t, y)
        The measured signal, at full resolution.
    simulated : (t, y, label) or a list of them
        One or more simulations.
    error : (t, e, label) or a list of them, optional
        Error curves for the error axes (one per simulation, usually).
    signal : str
        ``q1`` .. ``q4``, names the vertical axis.
    axes : sequence of Axes, optional
        ``[ax]``, ``[ax, error_ax]`` or ``[ax, error_ax, zoom_ax, zoom_error_ax]``; without it a new figure
        with a signal and an error axes is made (and zoom axes for a long record, see
        :func:`iwp.plotting.records.zoom_window`).
    title : str, optional
    measured_label : str
    zoom : (float, float) or bool, optional
        The zoomed window [s]; False: none; None: the last seconds of a long record (with new or zoom axes).

    Returns
    -------
    dict
        ``{"figure", "axes", "lines", "zoom_axes", "zoom_lines", "window"}``: ``lines`` holds the measured
        artist, then the simulated ones, then the error ones (a line, or the filled envelope of a long record).

    Examples
    --------
    Table 1's model (9) against 4 s of figure 3(a) on the virtual rig:

    >>> import matplotlib.pyplot as plt
    >>> from iwp import table1, validate
    >>> from iwp.rig import run_experiment
    >>> v = validate(run_experiment("sine-60", duration=4.0), table1(), signals=["q4"])  # figure 3(a), 4 s
    >>> from iwp.plotting import plot_comparison_panel
    >>> error = v.measured["q4"] - v.simulated["q4"]
    >>> out = plot_comparison_panel((v.t, v.measured["q4"]), (v.t, v.simulated["q4"], "model (9), Table 1"),
    ...                             (v.t, error, "error"), title="figure 3(a)")
    >>> len(out["axes"]), out["zoom_axes"]  # a short record: no zoom panel
    (2, [])
    >>> plt.close(out["figure"])
    """
    if axes is None:
        window = zoom_window(measured[0], zoom)
        fig, grid = _panel_grid(1, window is not None)
        axes = grid[0]
    else:  # zoom axes given: zoom any record longer than the window
        axes = list(axes)
        window = zoom_window(measured[0], True if zoom is None else zoom) if len(axes) > 2 else None
    ax, error_ax, zax, zeax = (axes + [None] * 4)[:4]
    fig = ax.figure
    sims = [simulated] if isinstance(simulated, tuple) else list(simulated)
    errs = [] if error is None or error_ax is None else ([error] if isinstance(error, tuple) else list(error))
    curves = [(ax, zax, measured[0], measured[1], measured_label, _MEASURED_STYLE)]
    curves += [(ax, zax, ts, ys, lab, _SIM_STYLES[i % len(_SIM_STYLES)]) for i, (ts, ys, lab) in enumerate(sims)]
    curves += [(error_ax, zeax, te, e, lab, _ERROR_STYLES[i % len(_ERROR_STYLES)])
               for i, (te, e, lab) in enumerate(errs)]
    lines, zlines = [], []
    for a, za, t, y, lab, style in curves:
        lines.append(draw_record(a, t, y, label=lab, style=style))
        if window is not None and za is not None:
            zlines.append(_draw_zoom(za, t, y, style, window))
    label = SIGNAL_LABELS.get(signal, signal)
    ax.set_ylabel(label)
    ax.grid(True, alpha=0.3)
    if title:
        ax.set_title(title, fontsize=10)
    used = [ax]
    if errs:
        error_ax.set_ylabel(f"error e [{label.split('[')[-1]}" if "[" in label else "error e")
        error_ax.set_xlabel("t [s]")
        error_ax.grid(True, alpha=0.3)
        used.append(error_ax)
    else:
        ax.set_xlabel("t [s]")
    zused = [a for a in (zax, zeax if errs else None) if a is not None and window is not None]
    for a in zused:
        a.grid(True, alpha=0.3)
        a.tick_params(labelsize=7)
    if zused:
        zused[0].set_title(f"zoom: {window[0]:.4g} to {window[1]:.4g} s", fontsize=8)
        zused[-1].set_xlabel("t [s]")
        for a in used:
            a.axvspan(window[0], window[1], color="0.88", zorder=0, lw=0)
    place_legend(ax, above=len(measured[0]) > LINE_SAMPLES_PER_COLUMN * axes_columns(ax))
    if len(errs) > 1:
        place_legend(error_ax)
    return {"figure": fig, "axes": used, "lines": lines, "zoom_axes": zused, "zoom_lines": zlines,
            "window": window}


def _draw_zoom(ax, t, y, style, window):
    """The samples of ``(t, y)`` in ``window`` as a line (full resolution)."""
    t = np.asarray(t, dtype=float)
    m = (t >= window[0]) & (t <= window[1])
    (ln,) = ax.plot(t[m], np.asarray(y, dtype=float)[m], **style)
    return ln


def _panel_grid(n, zoom, width=8.0, panel_height=3.0):
    """A new figure of ``n`` panels (signal above error), with a narrower zoom column if ``zoom``."""
    fig = plt.figure(figsize=(width + (2.4 if zoom else 0.0), panel_height * n + 0.3), layout="constrained")
    gs = fig.add_gridspec(2 * n, 2 if zoom else 1, height_ratios=[2, 1] * n,
                          width_ratios=[3.3, 1] if zoom else None)
    grid = []
    for i in range(n):
        row = [fig.add_subplot(gs[2 * i, 0]), fig.add_subplot(gs[2 * i + 1, 0])]
        if zoom:
            row += [fig.add_subplot(gs[2 * i, 1]), fig.add_subplot(gs[2 * i + 1, 1])]
        grid.append(row)
    return fig, grid


def plot_comparisons(panels, *, axes=None, width=8.0, panel_height=3.0):
    """Several comparison panels stacked, each with its error below (e.g. figure 3 (a) and (b)).

    Parameters
    ----------
    panels : sequence of dict
        Keyword arguments of :func:`plot_comparison_panel` (``measured``,
        ``simulated``, ``error``, ``signal``, ``title``, ``zoom``, ...).
    axes : sequence of Axes, optional
        ``2 * len(panels)`` axes: signal, error, signal, error, ... (no zoom panels).
    width, panel_height : float
        Figure size of a new figure [inch], without its zoom column.

    Returns
    -------
    dict
        ``{"figure", "axes", "lines", "panels": [dict per panel], "zoom_axes"}``.

    Examples
    --------
    Figures 3(a) and 4 (4 s each on the virtual rig) against Table 1's model (9):

    >>> import matplotlib.pyplot as plt
    >>> from iwp import table1, validate
    >>> from iwp.plotting import plot_comparisons
    >>> from iwp.rig import run_experiment
    >>> panels = []
    >>> for name in ("sine-60", "sine-20"):
    ...     v = validate(run_experiment(name, duration=4.0), table1(), signals=["q4"])
    ...     panels.append({"measured": (v.t, v.measured["q4"]), "simulated": (v.t, v.simulated["q4"], "model (9)"),
    ...                    "error": (v.t, v.measured["q4"] - v.simulated["q4"], "error"), "title": name})
    >>> out = plot_comparisons(panels)
    >>> len(out["panels"]), len(out["axes"])  # a signal and an error axes per panel
    (2, 4)
    >>> plt.close(out["figure"])
    """
    n = len(panels)
    if axes is None:
        zoom = any(zoom_window(p["measured"][0], p.get("zoom")) is not None for p in panels)
        fig, grid = _panel_grid(n, zoom, width, panel_height)
    else:
        axs = list(axes)
        if len(axs) != 2 * n:
            raise ValueError(f"axes must hold {2 * n} axes (signal and error per panel), got {len(axs)}")
        fig = axs[0].figure
        grid = [axs[2 * i:2 * i + 2] for i in range(n)]
    out = [plot_comparison_panel(axes=grid[i], **kw) for i, kw in enumerate(panels)]
    if axes is None:
        for row, p in zip(grid, out):
            for a in row[2:]:
                if a not in p["zoom_axes"]:
                    a.remove()
        settle_legends(fig)
    lines = [ln for p in out for ln in p["lines"]]
    return {"figure": fig, "axes": [a for row in grid for a in row[:2]], "lines": lines, "panels": out,
            "zoom_axes": [a for p in out for a in p["zoom_axes"]]}


def plot_errors(errors, *, signal="q1", ax=None, title=None, zoom=None):
    """Error curves of several models on one axis (e.g. before and after refinement).

    Long records are drawn as envelopes, with a zoom panel beside them (see :func:`plot_comparison_panel`).

    Parameters
    ----------
    errors : sequence of (t, e, label)
        At full resolution.
    signal : str
    ax : Axes or pair of Axes, optional
        The error axes, or the error and the zoom axes.
    title : str, optional
    zoom : (float, float) or bool, optional
        The zoomed window [s]; False: none; None: the last seconds of a long record.

    Returns
    -------
    dict
        ``{"figure", "axes": [ax], "lines", "zoom_axes", "zoom_lines", "window"}``.

    Examples
    --------
    The error of Table 1's model (9) on 4 s of figure 3(a):

    >>> import matplotlib.pyplot as plt
    >>> from iwp import table1, validate
    >>> from iwp.rig import run_experiment
    >>> v = validate(run_experiment("sine-60", duration=4.0), table1(), signals=["q4"])  # figure 3(a), 4 s
    >>> from iwp.plotting import plot_errors
    >>> out = plot_errors([(v.t, v.measured["q4"] - v.simulated["q4"], "Table 1")], signal="q4")
    >>> len(out["axes"]), [line.get_label() for line in out["lines"]]
    (1, ['Table 1'])
    >>> plt.close(out["figure"])
    """
    t_all = errors[0][0] if errors else ()
    if ax is None:
        window = zoom_window(t_all, zoom)
        fig = plt.figure(figsize=(8.0 + (2.4 if window else 0.0), 3.2), layout="constrained")
        gs = fig.add_gridspec(1, 2 if window else 1, width_ratios=[3.3, 1] if window else None)
        ax, zax = fig.add_subplot(gs[0, 0]), (fig.add_subplot(gs[0, 1]) if window else None)
    else:
        ax, zax = (list(ax) + [None])[:2] if hasattr(ax, "__len__") else (ax, None)
        window = zoom_window(t_all, True if zoom is None else zoom) if zax is not None else None
        fig = ax.figure
    lines, zlines = [], []
    for i, (t, e, lab) in enumerate(errors):
        style = dict(_ERROR_STYLES[i % len(_ERROR_STYLES)])
        style["lw"] = 0.8
        lines.append(draw_record(ax, t, e, label=lab, style=style))
        if window is not None:
            zlines.append(_draw_zoom(zax, t, e, style, window))
    label = SIGNAL_LABELS.get(signal, signal)
    ax.set_ylabel(f"error in {label}")
    ax.set_xlabel("t [s]")
    ax.grid(True, alpha=0.3)
    if title:
        ax.set_title(title, fontsize=10)
    zused = []
    if window is not None:
        ax.axvspan(window[0], window[1], color="0.88", zorder=0, lw=0)
        zax.set_title(f"zoom: {window[0]:.4g} to {window[1]:.4g} s", fontsize=8)
        zax.set_xlabel("t [s]")
        zax.grid(True, alpha=0.3)
        zax.tick_params(labelsize=7)
        zused.append(zax)
    place_legend(ax)
    settle_legends(fig)
    return {"figure": fig, "axes": [ax], "lines": lines, "zoom_axes": zused, "zoom_lines": zlines,
            "window": window}

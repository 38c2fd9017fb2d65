"""Figures of validation and refinement. Plot functions draw what they are given and compute nothing.

Every function takes an optional ``axes=``/``ax=`` and returns the
matplotlib artists it made (``{"figure", "axes", "lines", ...}``), like
:mod:`iwp.plotting`. :meth:`iwp.validate.ValidationResult.plot` delegates here.
"""

from __future__ import annotations

import math

import matplotlib.pyplot as plt  # noqa: E402

from .simulation import plot_comparison  # noqa: E402

__all__ = ["plot_validation", "plot_correlation"]


def plot_validation(t, measured, simulated, *, signals=None, fit=None, restart_times=(), axes=None,
                    labels=("experimental data", "numerical simulation"), band=None, coverage=None):
    """Measured against simulated signals, each with its error ``measured - simulated`` below (figures 3-10).

    Parameters
    ----------
    t : array_like
        Sample times [s].
    measured, simulated : dict of str to array_like
        Signals by name (``q1`` ... ``q4``).
    signals : sequence of str, optional
        Which signals (default: all of ``measured``).
    fit : dict of str to float, optional
        Fit per signal [%], shown in the panel titles.
    restart_times : sequence of float
        Restart times of the simulation [s] (figure 9b), drawn as vertical lines.
    axes : sequence of Axes, optional
        ``2 * len(signals)`` axes: signal, error, signal, error, ...
    band : PredictionBand, optional
        Its 95 % parameter and prediction bands, shaded around the simulation.
    coverage : dict of str to float, optional
        The share of the measured samples inside the prediction band, in the titles.

    Returns
    -------
    dict
        ``{"figure", "axes", "lines", "restart_lines"}``.

    Examples
    --------
    Table 1's model (9) against 4 s of figure 3(a) on the virtual rig:

    >>> import matplotlib.pyplot as plt
    >>> from iwp import table1, validate
    >>> from iwp.rig import run_experiment
    >>> v = validate(run_experiment("sine-60", duration=4.0), table1(), signals=["q4"])  # figure 3(a), 4 s
    >>> from iwp.plotting import plot_validation
    >>> out = plot_validation(v.t, v.measured, v.simulated, fit=v.fit)
    >>> len(out["axes"]), out["axes"][0].get_title()  # the signal, and its error below
    (2, 'q4: fit 90.6 %')
    >>> plt.close(out["figure"])
    """
    sig = list(signals) if signals is not None else list(measured)
    if not sig:
        raise ValueError("no signal to plot")
    if axes is None:
        ratios = [2, 1] * len(sig)
        fig, ax_list = plt.subplots(2 * len(sig), 1, sharex=True, figsize=(7.0, 3.2 * len(sig) + 0.6),
                                    constrained_layout=True, gridspec_kw={"height_ratios": ratios})
        ax_list = list(ax_list)
    else:
        ax_list = list(axes)
        if len(ax_list) != 2 * len(sig):
            raise ValueError(f"axes must hold {2 * len(sig)} axes (signal and error per signal), got {len(ax_list)}")
        fig = ax_list[0].figure
    lines, rlines = [], []
    for i, name in enumerate(sig):
        ax, eax = ax_list[2 * i], ax_list[2 * i + 1]
        b = None
        if band is not None and name in band.lower:
            b = (band.lower[name], band.upper[name], band.pred_lower[name], band.pred_upper[name])
        out = plot_comparison(t, measured[name], simulated[name], name=name, ax=ax, error_ax=eax, labels=labels,
                              band=b)
        lines.extend(out["lines"])
        title = []
        if fit is not None and name in fit and fit[name] is not None and math.isfinite(fit[name]):
            title.append(f"fit {fit[name]:.1f} %")
        if coverage is not None and name in coverage and math.isfinite(coverage[name]):
            title.append(f"{100 * coverage[name]:.0f} % of the samples in the 95 % prediction band")
        if title:
            ax.set_title(f"{name}: " + ", ".join(title), fontsize=9)
        for rt in restart_times:
            for a in (ax, eax):
                rlines.append(a.axvline(rt, color="0.5", ls=":", lw=1.0))
    return {"figure": fig, "axes": ax_list, "lines": lines, "restart_lines": rlines}


def plot_correlation(names, correlation, *, ax=None, threshold=0.95):
    """The correlation matrix of estimated parameters as a heat map, values written in the cells.

    Parameters
    ----------
    names : sequence of str
    correlation : array_like, shape (n, n)
    threshold : float
        Cells with ``|correlation|`` above it (off the diagonal) are written in bold.

    Returns
    -------
    dict
        ``{"figure", "axes", "image", "texts"}``.

    Examples
    --------
    The free pendulum's least squares (set-up (c)) on 10 s of the virtual rig, as the paper runs them (nothing
    held: :data:`~iwp.ident.identification.AS_PRINTED`): ``sigma_a1`` and ``sigma_v1`` cannot be told apart,
    and their cells are bold (iwp's default holds ``sigma_a1`` at its prior there):

    >>> import matplotlib.pyplot as plt
    >>> from iwp import identify
    >>> from iwp.ident.identification import AS_PRINTED
    >>> from iwp.plotting import plot_correlation
    >>> from iwp.rig import run_experiment
    >>> res = identify(run_experiment("free-pendulum", duration=10.0), "free", options=AS_PRINTED)
    >>> out = plot_correlation(res.names, res.correlation)
    >>> [t.get_text() for t in out["texts"] if t.get_fontweight() == "bold"]
    ['-0.96', '-0.96']
    >>> plt.close(out["figure"])
    """
    if ax is None:
        fig, ax = plt.subplots(figsize=(1.0 + 0.8 * len(names), 0.8 + 0.8 * len(names)), constrained_layout=True)
    else:
        fig = ax.figure
    im = ax.imshow(correlation, vmin=-1.0, vmax=1.0, cmap="RdBu_r")
    ax.set_xticks(range(len(names)), names, rotation=45, ha="right")
    ax.set_yticks(range(len(names)), names)
    texts = []
    for i in range(len(names)):
        for j in range(len(names)):
            c = correlation[i][j]
            txt = "nan" if c != c else f"{c:+.2f}"
            bold = i != j and c == c and abs(c) > threshold
            texts.append(ax.text(j, i, txt, ha="center", va="center", fontsize=8,
                                 fontweight="bold" if bold else "normal"))
    fig.colorbar(im, ax=ax, shrink=0.8)
    return {"figure": fig, "axes": [ax], "image": im, "texts": texts}

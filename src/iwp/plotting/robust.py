"""Figures of :mod:`iwp.control.robust`: an outcome's distribution over parameter draws, capture probabilities.

Same conventions as :mod:`iwp.plotting`: the functions draw what they are
given (the sorted values and their empirical cumulative probabilities, the
quantiles, the Wilson intervals, all computed by the result objects) and
compute nothing; each takes ``axes=`` and returns a dict of the artists.
"""

from __future__ import annotations

import math

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

__all__ = ["plot_distribution", "plot_capture"]


def _axes(n: int, axes, figsize):
    if axes is not None:
        axes = list(axes)
        if len(axes) != n:
            raise ValueError(f"axes must hold {n} axes, got {len(axes)}")
        return axes[0].figure, axes
    fig, ax = plt.subplots(1, n, figsize=figsize, constrained_layout=True)
    return fig, list(np.atleast_1d(ax))


def _draw_spread(ax_hist, ax_ecdf, spread, nominal, label):
    """Histogram and ECDF of ``spread`` (a :class:`~iwp.control.robust.Spread`) with its interval and the nominal."""
    artists = {}
    if spread.count:
        artists["hist"] = ax_hist.hist(spread.values, bins=max(5, min(40, int(math.sqrt(spread.count)) + 1)),
                                       color="tab:blue", alpha=0.7, label=f"{spread.count} draws")
        artists["ecdf"] = ax_ecdf.step(spread.values, spread.probability, where="post", color="tab:blue",
                                       label="empirical CDF")
        for ax in (ax_hist, ax_ecdf):
            ax.axvspan(spread.low, spread.high, color="tab:blue", alpha=0.12,
                       label=f"{100 * spread.level:g} % interval" if spread.is_interval
                       else f"range of {spread.count} draws")
            ax.axvline(spread.median, color="tab:blue", lw=1.0, ls="--", label="median")
    else:
        for ax in (ax_hist, ax_ecdf):
            ax.text(0.5, 0.5, "no draw with this outcome", transform=ax.transAxes, ha="center", va="center")
    if nominal is not None and math.isfinite(nominal):
        for ax in (ax_hist, ax_ecdf):
            ax.axvline(nominal, color="k", lw=1.5, label="nominal")
    ax_hist.set_xlabel(label)
    ax_hist.set_ylabel("draws")
    ax_ecdf.set_xlabel(label)
    ax_ecdf.set_ylabel("share of draws")
    ax_ecdf.set_ylim(0.0, 1.02)
    ax_hist.legend(fontsize=8)
    return artists


def plot_distribution(spread, *, nominal=None, label="outcome", title=None, axes=None):
    """An outcome over parameter draws: histogram and empirical CDF, the 95 % interval shaded, the nominal marked.

    Parameters
    ----------
    spread : Spread
        Sorted values, their cumulative probabilities, median and interval
        (:func:`iwp.control.robust.spread_of`).
    nominal : float, optional
        The outcome with the nominal parameters, drawn as a black line.
    label : str
        Axis label with the unit.
    title : str, optional
    axes : pair of Axes, optional

    Returns
    -------
    dict
        ``{"figure", "axes", ...}``.

    Examples
    --------
    The settling time of the balance LQR over 20 parameter draws (:func:`~iwp.control.robust.robust_balance`):

    >>> import numpy as np
    >>> import matplotlib.pyplot as plt
    >>> from iwp import robust_balance, table1
    >>> from iwp.sim.uncertainty import ParameterUncertainty
    >>> p = table1()
    >>> sd = [0.01 * p.p1, 0.05 * p.p2, 0.01 * p.p3]  # standard errors of a fit
    >>> fit = ParameterUncertainty(p, ("p1", "p2", "p3"), np.diag(np.square(sd)))
    >>> r = robust_balance(fit, angles=(0.03, 0.08), draws=20, t_end=3.0)
    >>> from iwp.plotting import plot_distribution
    >>> out = plot_distribution(r.settling_time, label="settling time [s]")
    >>> len(out["axes"]), out["axes"][0].get_xlabel()  # the histogram, and the empirical CDF beside it
    (2, 'settling time [s]')
    >>> plt.close(out["figure"])
    """
    fig, (ax_h, ax_e) = _axes(2, axes, (10.0, 3.8))
    out = _draw_spread(ax_h, ax_e, spread, nominal, label)
    if title:
        fig.suptitle(title, fontsize=10)
    return {"figure": fig, "axes": [ax_h, ax_e], **out}


def plot_capture(proportions, *, labels, nominal_captured, settling, nominal_settling=None, title=None, axes=None):
    """Probability of capture per initial state (Wilson intervals), and the settling time's distribution.

    Parameters
    ----------
    proportions : list of Proportion
        The capture probability from each initial state, with ``low``/``high``.
    labels : list of str
        The initial states.
    nominal_captured : sequence of bool
        Whether the nominal plant was captured from each (drawn as a black cross at 0 or 1).
    settling : Spread
        The settling time over the captured runs [s].
    nominal_settling : float, optional
        The nominal's settling time [s].
    title : str, optional
    axes : three Axes, optional

    Returns
    -------
    dict

    Examples
    --------
    The balance LQR over 20 parameter draws, released 0.03 rad and 0.08 rad from the upright
    (:func:`~iwp.control.robust.robust_balance`):

    >>> import numpy as np
    >>> import matplotlib.pyplot as plt
    >>> from iwp import robust_balance, table1
    >>> from iwp.sim.uncertainty import ParameterUncertainty
    >>> p = table1()
    >>> sd = [0.01 * p.p1, 0.05 * p.p2, 0.01 * p.p3]  # standard errors of a fit
    >>> fit = ParameterUncertainty(p, ("p1", "p2", "p3"), np.diag(np.square(sd)))
    >>> r = robust_balance(fit, angles=(0.03, 0.08), draws=20, t_end=3.0)
    >>> from iwp.plotting import plot_capture
    >>> out = plot_capture(r.capture_by_state, labels=["0.03 rad", "0.08 rad"], nominal_captured=r.nominal_captured,
    ...                    settling=r.settling_time)
    >>> len(out["axes"]), [float(bar.get_height()) for bar in out["bars"]]  # the probability of capture from each
    (3, [1.0, 0.0])
    >>> plt.close(out["figure"])
    """
    fig, (ax_c, ax_h, ax_e) = _axes(3, axes, (13.0, 3.8))
    x = np.arange(len(labels))
    p = np.array([q.p for q in proportions])
    lo = np.array([q.low for q in proportions])
    hi = np.array([q.high for q in proportions])
    bars = ax_c.bar(x, p, color="tab:green", alpha=0.6, label="draws")
    err = ax_c.errorbar(x, p, yerr=[p - lo, hi - p], fmt="none", ecolor="k", capsize=4, label="95 % Wilson")
    nom = ax_c.plot(x, np.asarray(nominal_captured, dtype=float), "kx", ms=8, label="nominal")
    ax_c.set_xticks(x)
    ax_c.set_xticklabels(labels, rotation=30, fontsize=8)
    ax_c.set_xlabel(r"initial $q_1 - \pi$")
    ax_c.set_ylabel("probability of capture")
    ax_c.set_ylim(0.0, 1.05)
    ax_c.legend(fontsize=8)
    out = _draw_spread(ax_h, ax_e, settling, nominal_settling, "settling time [s]")
    if title:
        fig.suptitle(title, fontsize=10)
    return {"figure": fig, "axes": [ax_c, ax_h, ax_e], "bars": bars, "errorbars": err, "nominal": nom, **out}

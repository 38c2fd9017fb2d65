"""Figures of simulations and of measured-against-simulated signals."""

from __future__ import annotations

import matplotlib.pyplot as plt  # noqa: E402

from .base import SIGNAL_LABELS, stacked_axes

__all__ = ["plot_simulation", "plot_comparison"]

def plot_simulation(result, signals=("q1", "q2", "q3", "q4", "u"), axes=None, label=None, band=None, **line_kw):
    """Plot simulated signals against time, one panel each.

    Parameters
    ----------
    result : SimulationResult
    signals : sequence of str
        Names among ``q1 q2 q3 q4 u`` (and ``v`` when the command differs).
    axes : sequence of Axes, optional
        One per signal; new figure if omitted.
    label : str, optional
        Legend label of the lines.
    band : PredictionBand, optional
        Shade its 95 % parameter and prediction bands around the signals it holds.

    Returns
    -------
    dict
        ``{"figure": Figure, "axes": [...], "lines": [...]}``.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from iwp import Plant, simulate, table1
    >>> from iwp.plotting import plot_simulation
    >>> res = simulate(Plant(table1(), model="free"), x0=[1.0, 0, 0, 0], t_end=5.0)
    >>> out = plot_simulation(res, signals=("q1", "q3"), label="free pendulum")
    >>> [ax.get_ylabel() for ax in out["axes"]]
    ['$q_1$ [rad]', '$q_3$ [rad/s]']
    >>> plt.close(out["figure"])
    """
    cols = result.columns()
    fig, axs = stacked_axes(len(signals), axes)
    lines = []
    for ax, name in zip(axs, signals):
        if name not in cols:
            raise ValueError(f"signal {name!r} not in the result; available: {', '.join(cols)}")
        if band is not None and name in band.lower:
            ax.fill_between(band.t, band.pred_lower[name], band.pred_upper[name], color="C0", alpha=0.15, lw=0)
            ax.fill_between(band.t, band.lower[name], band.upper[name], color="C0", alpha=0.35, lw=0)
        (ln,) = ax.plot(cols["t"], cols[name], label=label, **line_kw)
        lines.append(ln)
        ax.set_ylabel(SIGNAL_LABELS.get(name, name))
        ax.grid(True, alpha=0.3)
    axs[-1].set_xlabel("t [s]")
    if label is not None:
        axs[0].legend(loc="upper right")
    return {"figure": fig, "axes": axs, "lines": lines}


def plot_comparison(t, measured, simulated, *, name="q4", ax=None, error_ax=None, labels=("experimental data",
                    "numerical simulation"), band=None):
    """Measured against simulated signal, with the error below (the paper's figures 3-10).

    ``band``: optional ``(lower, upper, pred_lower, pred_upper)`` arrays of the
    95 % parameter and prediction bands (:class:`iwp.sim.uncertainty.PredictionBand`),
    shaded around the simulation.

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times [s].
    measured : ndarray, shape (n,)
        Measured signal [rad or rad/s].
    simulated : ndarray, shape (n,)
        Simulated signal at the same times [rad or rad/s].
    name : str, default "q4"
        Signal name (``"q1"`` ... ``"q4"``), for the axis labels.
    ax : matplotlib Axes, optional
        Axes of the signals; None (default): a new figure with the signals above and the error below.
    error_ax : matplotlib Axes, optional
        Axes of the error ``measured - simulated``; only used with ``ax`` (None: no error panel).
    labels : (str, str), default ("experimental data", "numerical simulation")
        Legend labels of the measured and the simulated signal.
    band : tuple of 4 ndarray, shape (n,), optional
        ``(lower, upper, pred_lower, pred_upper)`` bounds of the 95 % parameter and prediction bands.

    Returns
    -------
    dict
        ``{"figure", "axes", "lines", "bands"}``; ``lines`` holds the measured, simulated and error lines.

    Examples
    --------
    Table 1's model (9) against 4 s of figure 3(a) on the virtual rig:

    >>> import matplotlib.pyplot as plt
    >>> from iwp import table1, validate
    >>> from iwp.rig import run_experiment
    >>> v = validate(run_experiment("sine-60", duration=4.0), table1(), signals=["q4"])  # figure 3(a), 4 s
    >>> from iwp.plotting import plot_comparison
    >>> out = plot_comparison(v.t, v.measured["q4"], v.simulated["q4"], name="q4")
    >>> len(out["axes"]), [line.get_label() for line in out["lines"][:2]]  # the signals, and the error below
    (2, ['experimental data', 'numerical simulation'])
    >>> plt.close(out["figure"])
    """
    if ax is None:
        fig, (ax, error_ax) = plt.subplots(2, 1, sharex=True, figsize=(7.0, 4.2), constrained_layout=True,
                                           gridspec_kw={"height_ratios": [2, 1]})
    else:
        fig = ax.figure
    bands = []
    if band is not None:
        lo, hi, plo, phi = band
        bands.append(ax.fill_between(t, plo, phi, color="C1", alpha=0.15, lw=0, label="95 % prediction band"))
        bands.append(ax.fill_between(t, lo, hi, color="C1", alpha=0.35, lw=0, label="95 % parameter band"))
    (l1,) = ax.plot(t, measured, "-", lw=1.0, label=labels[0])
    (l2,) = ax.plot(t, simulated, "--", lw=1.0, label=labels[1])
    ax.set_ylabel(SIGNAL_LABELS.get(name, name))
    ax.legend(loc="upper right")
    ax.grid(True, alpha=0.3)
    lines = [l1, l2]
    axes = [ax]
    if error_ax is not None:
        (l3,) = error_ax.plot(t, measured - simulated, "-", lw=0.8, color="k")
        error_ax.set_ylabel(f"e ({name})")
        error_ax.set_xlabel("t [s]")
        error_ax.grid(True, alpha=0.3)
        lines.append(l3)
        axes.append(error_ax)
    else:
        ax.set_xlabel("t [s]")
    return {"figure": fig, "axes": axes, "lines": lines, "bands": bands}

"""What every figure shares: matplotlib without a screen, signal labels, stacked panels, saving."""

from __future__ import annotations

import matplotlib.pyplot as plt  # noqa: E402

__all__ = ["SIGNAL_LABELS", "stacked_axes", "savefig"]

#: Axis labels of the signals [unit], shared by every plotting module.
SIGNAL_LABELS = {
    "q1": r"$q_1$ [rad]",
    "q2": r"$q_2$ [rad]",
    "q3": r"$q_3$ [rad/s]",
    "q4": r"$q_4$ [rad/s]",
    "u": r"$u$ [-]",
    "v": r"$v$ [-]",
}


def stacked_axes(n: int, axes=None, sharex=True, figsize=None):
    """``(figure, [n axes])``: the caller's axes (checked to be ``n``) or ``n`` new stacked panels.

    Parameters
    ----------
    n : int
        Number of panels.
    axes : matplotlib Axes or sequence of Axes, optional
        The caller's axes (one Axes for ``n = 1``); None (default): a new figure.
    sharex : bool, default True
        New panels share the x axis.
    figsize : (float, float), optional
        Size of a new figure [inch]; default ``(7, 1.8 n + 0.8)``.

    Returns
    -------
    figure : matplotlib.figure.Figure
        The figure of the axes.
    axes : list of matplotlib Axes
        The ``n`` axes, top to bottom.

    Raises
    ------
    ValueError
        ``axes`` does not hold ``n`` axes.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from iwp.plotting import stacked_axes
    >>> fig, axes = stacked_axes(3)  # e.g. q1, q4 and u against time
    >>> len(axes), [float(x) for x in fig.get_size_inches()]
    (3, [7.0, 6.2])
    >>> plt.close(fig)
    """
    if axes is not None:
        axes = list(axes) if hasattr(axes, "__len__") else [axes]
        if len(axes) != n:
            raise ValueError(f"axes must hold {n} axes, got {len(axes)}")
        return axes[0].figure, axes
    fig, ax = plt.subplots(n, 1, sharex=sharex, figsize=figsize or (7.0, 1.8 * n + 0.8), constrained_layout=True)
    return fig, list(ax) if n > 1 else [ax]



def savefig(fig, path, *, dpi=150):
    """Save ``fig`` to ``path`` (format from the extension) and close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        Figure to save.
    path : str or path-like
        Output file; its extension chooses the format (``.png``, ``.pdf``, ``.svg``, ...).
    dpi : float, default 150
        Resolution of raster formats [dots per inch].

    Returns
    -------
    str or path-like
        ``path``, as given.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from iwp.plotting import savefig
    >>> fig, ax = plt.subplots()
    >>> _ = ax.plot([0, 1], [0, 1])
    >>> savefig(fig, "line.svg")
    'line.svg'
    >>> plt.fignum_exists(fig.number)  # closed
    False
    """
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path

"""The report's folder: the output policy and the figures written beside the page."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..files import prepare_output_dir  # the one folder policy, re-exported here

__all__ = ["prepare_output_dir", "save_figure", "decimate", "PLOT_POINTS"]

#: Plotted series are decimated to at most this many points (min/max per bucket, see :func:`decimate`).
PLOT_POINTS = 3000


def save_figure(fig, out_dir: str | os.PathLike, name: str, *, dpi: int = 110) -> tuple[bytes, list[Path]]:
    """Save ``fig`` as ``out_dir/figures/NAME.png`` and ``.svg``; close it; return the PNG bytes and the paths.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; it is closed.
    out_dir : str or path-like
        Report folder; ``figures/`` is created in it.
    name : str
        File name without extension.
    dpi : int, default 110
        Resolution of the PNG [dots per inch].

    Returns
    -------
    png : bytes
        Contents of the PNG file.
    paths : list of Path
        The PNG and the SVG file.
    """
    import matplotlib.pyplot as plt

    d = Path(out_dir) / "figures"
    d.mkdir(parents=True, exist_ok=True)
    png = d / f"{name}.png"
    svg = d / f"{name}.svg"
    try:
        fig.savefig(png, dpi=dpi)
        if fig.get_layout_engine() is not None:
            fig.set_layout_engine("none")  # keep the layout just computed: the SVG is drawn identically, faster
        fig.savefig(svg)
    finally:
        plt.close(fig)
    return png.read_bytes(), [png, svg]



def decimate(t, y, n_max: int = PLOT_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Keep the minimum and the maximum of ``y`` in each of ``n_max/2`` buckets (the visual envelope).

    Series with at most ``n_max`` points are returned as they are. Used by
    the pipeline so that SVG figures stay small; plotting computes nothing.

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times [s].
    y : array_like, shape (n,)
        Signal (any unit); NaN samples are never chosen as a bucket's extreme.
    n_max : int, default PLOT_POINTS
        Largest number of points kept (about); below 4 nothing is dropped.

    Returns
    -------
    t : ndarray, shape (m,)
        The kept times [s], first and last included.
    y : ndarray, shape (m,)
        The kept values, in ``y``'s unit.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    n = t.size
    if n <= n_max or n_max < 4:
        return t.copy(), y.copy()
    nb = n_max // 2
    b = int(math.ceil(n / nb))
    nb = int(math.ceil(n / b))
    pad = nb * b - n
    yy = np.concatenate([y, np.full(pad, y[-1])]) if pad else y
    finite = np.isfinite(yy)
    if not finite.all():
        yy = np.where(finite, yy, 0.0)
    blocks = yy.reshape(nb, b)
    base = np.arange(nb) * b
    i_min = base + np.argmin(blocks, axis=1)
    i_max = base + np.argmax(blocks, axis=1)
    idx = np.unique(np.minimum(np.concatenate([i_min, i_max, [0, n - 1]]), n - 1))
    return t[idx], y[idx]



"""The report's folder: the output policy and the figures written beside the page."""

from __future__ import annotations

import os
from pathlib import Path

from ..files import prepare_output_dir  # the one folder policy, re-exported here

__all__ = ["prepare_output_dir", "save_figure"]


def save_figure(fig, out_dir: str | os.PathLike, name: str, *, dpi: int = 110) -> tuple[bytes, list[Path]]:
    """Save ``fig`` as ``out_dir/figures/NAME.svg``, close it, and return its PNG (for the page) and the path.

    The vector file is what a paper prints; the page embeds the PNG, so no PNG file duplicates it.

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
        The figure as a PNG image.
    paths : list of Path
        The SVG file.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> from iwp import Plant, simulate, table1
    >>> from iwp.report import save_figure
    >>> res = simulate(Plant(table1(), model="free"), x0=[1.0, 0, 0, 0], t_end=5.0)
    >>> fig, ax = plt.subplots()
    >>> _ = ax.plot(res.t, res.q1)
    >>> png, paths = save_figure(fig, "report", "free-swing")
    >>> png[1:4], [p.as_posix() for p in paths]  # the PNG for the page, the SVG beside it
    (b'PNG', ['report/figures/free-swing.svg'])
    >>> plt.fignum_exists(fig.number)  # closed
    False
    """
    import io

    import matplotlib.pyplot as plt

    d = Path(out_dir) / "figures"
    d.mkdir(parents=True, exist_ok=True)
    svg = d / f"{name}.svg"
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", dpi=dpi)
        if fig.get_layout_engine() is not None:
            fig.set_layout_engine("none")  # keep the layout just computed: the SVG is drawn identically, faster
        fig.savefig(svg)
    finally:
        plt.close(fig)
    return buf.getvalue(), [svg]

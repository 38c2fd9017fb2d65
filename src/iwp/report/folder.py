"""The report's folder: the output policy and the figures written beside the page."""

from __future__ import annotations

import os
from pathlib import Path

from ..files import prepare_output_dir  # the one folder policy, re-exported here

__all__ = ["prepare_output_dir", "save_figure"]


def save_figure(fig, out_dir: str | os.PathLike, name: str, *, laid_out: bool = False) -> tuple[bytes, list[Path]]:
    """Save ``fig`` as ``out_dir/figures/NAME.svg``, close it, and return the SVG (for the page) and the path.

    The vector file is what a paper prints, and the page embeds the same
    bytes: one rendering per figure.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; it is closed.
    out_dir : str or path-like
        Report folder; ``figures/`` is created in it.
    name : str
        File name without extension.
    laid_out : bool, default False
        The figure was laid out after its last change (as
        :func:`~iwp.plotting.legends.settle_legends` leaves it): its layout
        engine's result is kept instead of computed again.

    Returns
    -------
    svg : bytes
        The figure as an SVG image (as written).
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
    >>> svg, paths = save_figure(fig, "report", "free-swing")
    >>> svg == paths[0].read_bytes(), [p.as_posix() for p in paths]  # the page's image is the file beside it
    (True, ['report/figures/free-swing.svg'])
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
        if laid_out and fig.get_layout_engine() is not None:
            fig.set_layout_engine("none")  # keep the layout computed last
        fig.savefig(buf, format="svg")
    finally:
        plt.close(fig)
    data = buf.getvalue()
    svg.write_bytes(data)
    return data, [svg]

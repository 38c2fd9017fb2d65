"""Legends off the data: in an empty corner of the axes if one is free, else above the axes.

:func:`place_legend` tries the corners of the axes and keeps the first
whose legend box covers no plotted data (no line passes through it, no
filled area reaches into it); when none is free, the legend goes above the
axes, with the axes' title as its own title so that the two stack.
:func:`settle_legends` checks a finished figure again (a layout that moved
the axes may have pushed data under a corner legend) and moves such a
legend above its axes.
"""

from __future__ import annotations

__all__ = ["place_legend", "settle_legends", "covers_data", "CORNERS"]

#: Corners tried, in order.
CORNERS = ("upper right", "upper left", "lower left", "lower right")


def covers_data(box, axes) -> int:
    """How many data artists of ``axes`` are drawn inside the display box ``box``.

    Lines drawn in data coordinates (their segments, markers included) and filled areas (their polygons) count;
    guides (``axhline``, ``axvline``, spans), axis lines and grids do not.

    Parameters
    ----------
    box : matplotlib.transforms.Bbox
        In display coordinates [pixel].
    axes : sequence of matplotlib Axes

    Returns
    -------
    int
        The number of artists that reach into ``box``.
    """
    n = 0
    for ax in axes:
        for ln in ax.get_lines():
            if not ln.get_visible() or ln.get_xydata().size == 0 or ln.get_transform() is not ax.transData:
                continue
            path = ln.get_transform().transform_path(ln.get_path())
            if path.intersects_bbox(box, filled=False) or box.count_contains(path.vertices):
                n += 1
        for coll in ax.collections:
            if not coll.get_visible():
                continue
            tr = coll.get_transform()
            if any(tr.transform_path(p).intersects_bbox(box, filled=True) for p in coll.get_paths()):
                n += 1
    return n


def _inside(ax) -> bool:
    """Whether the legend of ``ax`` sits inside the axes (a corner), not above them."""
    box = ax.get_legend().get_window_extent()
    return bool(ax.bbox.contains(0.5 * (box.x0 + box.x1), 0.5 * (box.y0 + box.y1)))


def _above(ax, handles, labels, fontsize):
    """The legend above ``ax`` in as many columns (at most 3) as fit its width, the axes' title as its title."""
    title = ax.get_title()
    ax.set_title("")
    width = ax.get_window_extent().width
    for ncols in range(min(len(handles), 3), 0, -1):
        leg = ax.legend(handles, labels, loc="lower left", bbox_to_anchor=(0.0, 1.01), ncols=ncols,
                        fontsize=fontsize, title=title or None, title_fontsize=fontsize + 2, alignment="left",
                        frameon=False, borderaxespad=0.0, borderpad=0.2)
        if leg.get_window_extent().width <= width:
            break
    return leg


def place_legend(ax, *, fontsize: float = 7, above: bool = False):
    """Put the legend of ``ax`` in the first corner free of data, else above the axes.

    Parameters
    ----------
    ax : matplotlib Axes
        Its labelled artists make the legend.
    fontsize : float, default 7
        [pt].
    above : bool, default False
        Put it above the axes without trying the corners (dense records fill every corner).

    Returns
    -------
    matplotlib.legend.Legend or None
        None if nothing is labelled.
    """
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    ax.get_xlim(), ax.get_ylim()  # the limits the data set so far (the transforms below use them)
    if not above:
        for loc in CORNERS:
            leg = ax.legend(handles, labels, loc=loc, fontsize=fontsize)
            box = leg.get_window_extent()
            if not covers_data(box.expanded(1.08, 1.15), [ax]):
                return leg
    return _above(ax, handles, labels, fontsize)


def settle_legends(fig, *, fontsize: float = 7, rounds: int = 3):
    """Move a corner legend of ``fig`` that covers data after the layout above its axes; repeat until none does.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    fontsize : float, default 7
        [pt] of a moved legend.
    rounds : int, default 3
        Most passes (a move changes the layout).

    Returns
    -------
    int
        The number of legends moved. The figure is left laid out after its last change (its layout engine's
        result current).
    """
    moved = 0
    for _ in range(rounds):
        _lay_out(fig)
        bad = [ax for ax in fig.axes if ax.get_legend() is not None and _inside(ax)
               and covers_data(ax.get_legend().get_window_extent(), [ax])]
        if not bad:
            break
        for ax in bad:
            handles, labels = ax.get_legend_handles_labels()
            _above(ax, handles, labels, fontsize)
            moved += 1
    else:
        _lay_out(fig)  # the last round moved a legend: its layout
    return moved


def _lay_out(fig) -> None:
    """The figure's layout engine run (where a drawing would put the axes, without drawing them), and every
    axes' limits brought up to date (the data-to-display transforms read them)."""
    engine = fig.get_layout_engine()
    if engine is not None:
        engine.execute(fig)
    for ax in fig.axes:
        ax.get_xlim(), ax.get_ylim()

"""Long records on paper: a min/max envelope per pixel column, and a zoom that shows a few seconds in full.

A 300 s chirp sampled every 5 ms has 60 000 samples and hundreds of periods
across some 600 pixel columns: drawn as a line it is a solid band, and its
vector file holds every sample. :func:`draw_record` draws a record the axes
resolve as the line through each column's least and largest sample (the
same pixels as every sample, in a few hundred vertices), and one that swings
within the columns as its filled envelope, the least and the largest sample
of each column (:func:`envelope`). :func:`zoom_window` picks a few seconds
that a zoom panel shows at full resolution. Decimating for display is all
this module computes; the physics is computed by the callers.
"""

from __future__ import annotations

import numpy as np

__all__ = ["envelope", "trace", "is_dense", "draw_record", "axes_columns", "zoom_window", "LINE_SAMPLES_PER_COLUMN",
           "ZOOM_SECONDS"]

#: A record with more samples than this per pixel column is drawn as its envelope.
LINE_SAMPLES_PER_COLUMN = 2.0

#: The envelope of a column spans this share of the axes' columns around it (1 %: a few pixels), so that an
#: oscillation a little slower than the columns shows its amplitude, not a moire of partial swings.
ENVELOPE_SPAN = 0.01

#: A record whose median column spans more than this share of its whole range is drawn as an envelope.
DENSE_SHARE = 0.2

#: Length of the zoomed window [s].
ZOOM_SECONDS = 4.0

#: A record at least this many zoom windows long gets a zoom panel (its waveform is not resolved whole).
ZOOM_FACTOR = 10.0


def envelope(t, y, columns: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The minimum and maximum of ``y`` in ``columns`` equal spans of ``t`` (empty or all-NaN spans left out).

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times [s], increasing.
    y : array_like, shape (n,)
        The record (any unit).
    columns : int
        Number of spans (about the pixel columns the record covers); at least 1.

    Returns
    -------
    tc : ndarray, shape (m,)
        The middle of each kept span [s]; the first and the last are the record's ends.
    low, high : ndarray, shape (m,)
        The least and the largest sample of each span, in ``y``'s unit.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    if t.size == 0:
        return t, y, y
    columns = max(1, int(columns))
    t0, t1 = float(t[0]), float(t[-1])
    width = (t1 - t0) / columns if t1 > t0 else 1.0
    col = np.minimum(((t - t0) / width).astype(np.int64), columns - 1)
    starts = np.flatnonzero(np.r_[True, col[1:] != col[:-1]])
    low = np.minimum.reduceat(y, starts)
    high = np.maximum.reduceat(y, starts)
    tc = t0 + (col[starts] + 0.5) * width
    tc[0], tc[-1] = t0, t1
    return tc, low, high


def _widen(low, high, k: int):
    """The least of ``low`` and the largest of ``high`` over the ``k`` columns centred on each."""
    if k <= 1 or low.size < k:
        return low, high
    from numpy.lib.stride_tricks import sliding_window_view

    h = k // 2
    lo = np.pad(low, (h, k - 1 - h), mode="edge")
    hi = np.pad(high, (h, k - 1 - h), mode="edge")
    return sliding_window_view(lo, k).min(axis=1), sliding_window_view(hi, k).max(axis=1)


def _corners(v) -> np.ndarray:
    """Where ``v`` is not the same as both its neighbours (the ends always)."""
    keep = np.ones(v.size, dtype=bool)
    keep[1:-1] = (v[1:-1] != v[:-2]) | (v[1:-1] != v[2:])
    return keep


def axes_columns(ax) -> int:
    """The pixel columns of ``ax`` at the figure's resolution (from its position before any layout).

    Parameters
    ----------
    ax : matplotlib Axes

    Returns
    -------
    int
        The axes' width [pixel], at least 1.
    """
    fig = ax.figure
    return max(1, int(round(fig.get_figwidth() * fig.dpi * ax.get_position().width)))


def trace(t, y, columns: int) -> tuple[np.ndarray, np.ndarray]:
    """The samples that are the least and the largest of each of ``columns`` equal spans, in time order.

    Drawn as a line, they cover the same pixels as every sample would (a record resolved by the columns).

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times [s], increasing.
    y : array_like, shape (n,)
        The record (any unit); NaN samples are never a span's extreme.
    columns : int
        Number of spans; at least 1.

    Returns
    -------
    t, y : ndarray
        The kept samples, the first and the last included.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    n = t.size
    if n <= 2 * columns:
        return t, y
    t0, t1 = float(t[0]), float(t[-1])
    col = np.minimum(((t - t0) / ((t1 - t0) / columns)).astype(np.int64), columns - 1)
    starts = np.flatnonzero(np.r_[True, col[1:] != col[:-1]])
    yy = np.where(np.isfinite(y), y, np.nan)
    lo = np.where(np.isfinite(yy), yy, np.inf)
    hi = np.where(np.isfinite(yy), yy, -np.inf)
    i_min = np.array([s + int(np.argmin(lo[s:e])) for s, e in zip(starts, np.r_[starts[1:], n])])
    i_max = np.array([s + int(np.argmax(hi[s:e])) for s, e in zip(starts, np.r_[starts[1:], n])])
    idx = np.unique(np.concatenate([i_min, i_max, [0, n - 1]]))
    return t[idx], y[idx]


def is_dense(low, high) -> bool:
    """Whether a record swings across much of its range within a column (in most columns): unresolved.

    Parameters
    ----------
    low, high : ndarray
        Its envelope (:func:`envelope`).

    Returns
    -------
    bool
        True if the median column spans more than :data:`DENSE_SHARE` of the whole range.
    """
    if low.size == 0:
        return False
    whole = float(np.max(high) - np.min(low))
    return whole > 0 and float(np.median(high - low)) > DENSE_SHARE * whole


def draw_record(ax, t, y, *, label=None, style=None, columns=None):
    """Draw a record: its samples as a line if the axes resolve it, else its envelope per pixel column.

    A record with few samples is drawn as it is; a longer one that the columns resolve as the line through
    each column's extremes (:func:`trace`, the same pixels); one that swings within the columns
    (:func:`is_dense`) as its filled envelope.

    Parameters
    ----------
    ax : matplotlib Axes
    t, y : array_like, shape (n,)
        Sample times [s] and the record.
    label : str, optional
        Legend label.
    style : dict, optional
        Line style (``color``, ``ls``, ``lw``); the envelope is filled in the colour, light, its edges in the style.
    columns : int, optional
        Pixel columns of the axes (default :func:`axes_columns`).

    Returns
    -------
    matplotlib.lines.Line2D or matplotlib.collections.PolyCollection
        The line, or the filled envelope.
    """
    style = dict(style or {})
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    columns = axes_columns(ax) if columns is None else int(columns)
    if t.size <= LINE_SAMPLES_PER_COLUMN * columns:
        (ln,) = ax.plot(t, y, label=label, **style)
        return ln
    tc, low, high = envelope(t, y, columns)
    if not is_dense(low, high):
        (ln,) = ax.plot(*trace(t, y, columns), label=label, **style)
        return ln
    from matplotlib.colors import to_rgba

    tc, low, high = envelope(t, y, max(1, columns // 2))  # a filled band needs no finer edges than 2 pixels
    low, high = _widen(low, high, max(1, int(round(ENVELOPE_SPAN * columns / 2))))
    keep = _corners(low) | _corners(high)  # a plateau's inner vertices add bytes, not ink
    tc, low, high = tc[keep], low[keep], high[keep]
    color = style.get("color", "C0")
    return ax.fill_between(tc, low, high, facecolor=to_rgba(color, 0.3), edgecolor=color,
                           linewidth=0.6 * style.get("lw", 1.0), linestyle=style.get("ls", "-"), label=label)


def zoom_window(t, zoom=None, *, seconds: float = ZOOM_SECONDS):
    """The window ``(t0, t1)`` [s] a zoom panel shows, or None for a record short enough to read whole.

    Parameters
    ----------
    t : array_like
        Sample times of the record [s].
    zoom : (float, float) or bool, optional
        A window to use; False: none; None or True: the last ``seconds`` of a record at least
        :data:`ZOOM_FACTOR` windows long (True: of any record longer than the window).
    seconds : float, default ZOOM_SECONDS
        Length of the default window [s].

    Returns
    -------
    tuple of float or None
    """
    if zoom is False:
        return None
    if zoom is not None and zoom is not True:
        t0, t1 = zoom
        return float(t0), float(t1)
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        return None
    span = float(t[-1] - t[0])
    if span <= seconds or (zoom is None and span < ZOOM_FACTOR * seconds):
        return None
    return float(t[-1]) - seconds, float(t[-1])

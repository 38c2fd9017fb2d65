"""Glitches of logged signals: found, reported, and (spikes only) replaced, never silently.

Real rigs log samples that are not measurements of the motion:

* **spikes**: one sample far from both neighbours, which agree with each
  other, e.g. a wheel speed of 1500-2700 rad/s at ``t = 0`` (the board's
  first backward difference of an encoder that was not reset);
* **dropouts**: a spike to exactly 0 (a lost sample);
* **jumps**: the pendulum angle steps by a few hundredths of a radian
  between two samples and stays there (play at the encoder's coupling).

:func:`find_glitches` finds them with robust statistics of the signal's
own sample-to-sample behaviour (no model). Every glitch becomes a
:class:`Glitch` record. Spikes and dropouts are replaced by the mean of
their neighbours (the record keeps the logged value); jumps are only
recorded (the angle may really have moved). :meth:`iwp.data.ExperimentData.with_glitches_found`
attaches the records to a log, and the fits leave the replaced samples out
of their residuals.

Criteria
--------
For a sample ``y[k]`` with neighbours, the deviation from the neighbours'
mean is ``e[k] = y[k] - (y[k-1] + y[k+1]) / 2`` (at the first sample: from the
linear extrapolation of the two next samples; the last sample is not
checked, a step there looks the same). With the logged input, the part of
``e`` its steps explain is removed first (a driven speed's real corner where
the input reverses, :func:`find_glitches`), and a sample must stick out both
with and without it (the input's part excuses a corner, never makes one). ``s`` is 1.4826 times the
median absolute ``e`` over the signal (the spread of a smooth signal's
curvature plus its noise). A spike is a sample with

    |e[k]| > SPIKE_SIGMAS * s,  |e[k]| > floor,  |e[k]| > 2 |y[k+1] - y[k-1]|

(it sticks out and its neighbours agree), with ``floor = SPIKE_FLOOR`` of the
signal's robust range (1st to 99th percentile). A jump of an angle is an
outlier of the first difference ``d[k] = y[k+1] - y[k]`` against its
neighbours' mean, beyond ``JUMP_SIGMAS`` robust spreads and
``jump_floor`` [rad], that is not followed by the opposite step (which would
make it a spike), and whose neighbours deviate as a step's do (by half of it
the other way, against the deviations two samples away: a coarsely sampled
fast swing deviates alike at a sample and beside it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import InputError

__all__ = ["Glitch", "find_glitches", "repair", "summarize", "GLITCH_KINDS", "SPIKE_SIGMAS", "SPIKE_FLOOR",
           "JUMP_SIGMAS", "JUMP_FLOOR"]

#: Kinds of glitch.
GLITCH_KINDS = ("spike", "dropout", "jump")
#: A spike deviates from its neighbours' mean by more than this many robust spreads ...
SPIKE_SIGMAS = 12.0
#: ... and by more than this fraction of the signal's robust range.
SPIKE_FLOOR = 0.05
#: A jump of an angle is a first difference this many robust spreads from its neighbours' ...
JUMP_SIGMAS = 8.0
#: ... and at least this large [rad].
JUMP_FLOOR = 0.01


@dataclass(frozen=True)
class Glitch:
    """One glitch of one logged signal.

    Attributes
    ----------
    column : str
        The iwp signal (``"q1"``, ``"q4"``, ``"current"``, ...).
    index : int
        Sample number in the log (0-based).
    t : float
        Its time [s].
    kind : {"spike", "dropout", "jump"}
    value : float
        The logged value (a jump: the size of the step) [unit of the signal].
    replacement : float or None
        The value put in its place (mean of the neighbours), None if the sample was kept (jumps).
    """

    column: str
    index: int
    t: float
    kind: str
    value: float
    replacement: float | None = None

    def __post_init__(self):
        if self.kind not in GLITCH_KINDS:
            raise InputError(f"Glitch.kind must be one of {', '.join(GLITCH_KINDS)}, got {self.kind!r}")

    @property
    def repaired(self) -> bool:
        """True if the sample was replaced."""
        return self.replacement is not None

    def describe(self) -> str:
        """One short phrase, e.g. ``"q4 spike at t = 0 s (2345 -> 12.1)"``."""
        if self.kind == "jump":
            return f"{self.column} jump of {self.value:+.3g} at t = {self.t:.6g} s (kept)"
        return f"{self.column} {self.kind} at t = {self.t:.6g} s ({self.value:.4g} -> {self.replacement:.4g})"

    def to_dict(self) -> dict[str, Any]:
        return {"column": self.column, "index": int(self.index), "t": float(self.t), "kind": self.kind,
                "value": float(self.value),
                "replacement": None if self.replacement is None else float(self.replacement)}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "Glitch":
        try:
            rep = d.get("replacement")
            return cls(str(d["column"]), int(d["index"]), float(d["t"]), str(d["kind"]), float(d["value"]),
                       None if rep is None else float(rep))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"a glitch record needs column, index, t, kind, value: {exc}") from None


def _robust_spread(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return 0.0
    return 1.4826 * float(np.median(np.abs(x - np.median(x))))


def _deviation(y: np.ndarray) -> np.ndarray:
    """``y[k]`` minus its neighbours' mean; at the ends minus the extrapolation of the next two samples."""
    e = np.zeros_like(y)
    e[1:-1] = y[1:-1] - 0.5 * (y[:-2] + y[2:])
    e[0] = y[0] - (2.0 * y[1] - y[2])
    e[-1] = y[-1] - (2.0 * y[-2] - y[-3])
    return e


def _input_explained(e: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``e`` less the part of it the input's steps explain (fitted, robustly, over the log).

    The deviation of a sample from its neighbours' mean is the signal's
    curvature; where the input steps (a pseudo-random input reversing) the
    acceleration of a driven signal changes at once, a real corner that is
    no glitch. Its size is linear in the step: ``e[k] ~ sum_j c_j (u[k+j] -
    u[k+j-1])`` for ``j = -1, 0, 1`` (the hold and a mean-sampled speed shift
    it by a sample), with ``c`` fitted by least squares, once again without
    the samples beyond 5 robust spreads (the glitches themselves).
    """
    n = e.size
    du = np.zeros(n + 2)
    du[2:n + 1] = np.diff(u)  # du[k + 1] = u[k] - u[k-1]
    X = np.column_stack([du[j:j + n] for j in (0, 1, 2)])  # steps at k-1, k, k+1
    inner = np.arange(1, n - 1)
    if not np.any(X[inner]):
        return e
    keep = inner
    c = np.zeros(3)
    for _ in range(2):
        c, *_ = np.linalg.lstsq(X[keep], e[keep], rcond=None)
        r = e[inner] - X[inner] @ c
        s = _robust_spread(r)
        keep = inner[np.abs(r) <= 5.0 * s] if s > 0 else inner
        if keep.size < 4:
            break
    out = e.copy()
    out[inner] = e[inner] - X[inner] @ c
    return out


def _spikes(y: np.ndarray, u: np.ndarray | None = None) -> list[int]:
    n = y.size
    if n < 5:
        return []
    raw = _deviation(y)
    # the input's part only excuses a deviation (a real corner), never makes one: fitted to a smooth input
    # (a chirp) the regression is ill-conditioned and its extrapolation at the log's start is no measurement
    e = _input_explained(raw, u) if u is not None else raw
    s = _robust_spread(e[1:-1])
    lo, hi = np.percentile(y, [1.0, 99.0])
    floor = SPIKE_FLOOR * float(hi - lo)
    thr = max(SPIKE_SIGMAS * s, floor, 1e-12)
    out = []
    for k in np.flatnonzero((np.abs(e) > thr) & (np.abs(raw) > thr)):
        k = int(k)
        if k == n - 1:  # a step at the last sample looks the same: not told apart, not reported
            continue
        spread = abs(y[k + 1] - y[k - 1]) if k > 0 else abs(y[2] - y[1])
        if k == 0 and u is not None and abs(y[1] - y[0]) <= np.max(np.abs(np.diff(y[1:]))):
            continue  # the input started at t0: a change no faster than the log's own is motion
        if abs(e[k]) > 2.0 * spread:
            out.append(k)
    # a spike makes its neighbours look odd at the ends: keep the largest of adjacent candidates
    kept: list[int] = []
    for k in out:
        if kept and k == kept[-1] + 1:
            if abs(e[k]) > abs(e[kept[-1]]):
                kept[-1] = k
            continue
        kept.append(k)
    return kept


def _jumps(y: np.ndarray, floor: float, skip: set[int]) -> list[tuple[int, float]]:
    n = y.size
    if n < 6:
        return []
    d = np.diff(y)
    e = np.zeros_like(d)
    e[1:-1] = d[1:-1] - 0.5 * (d[:-2] + d[2:])
    s = _robust_spread(e[1:-1])
    thr = max(JUMP_SIGMAS * s, floor)
    out = []
    a = np.abs(e)
    for k in np.flatnonzero(a > thr):
        k = int(k)
        if k == 0 or k >= d.size - 1:
            continue
        if k in skip or k + 1 in skip:  # a spike's own steps
            continue
        if a[k] < a[k - 1] or a[k] < a[k + 1]:
            continue  # a step's neighbours deviate by half of it: keep the largest
        if any(np.sign(e[j]) == -np.sign(e[k]) and a[j] > 0.7 * a[k] for j in (k - 1, k + 1)):
            continue  # up and down again (deviations -1.5A, +1.5A): a spike, not a step
        if 2 <= k < d.size - 3:
            # a step A leaves the deviations two samples away alone and those next to it at -A/2 from them; a
            # fast smooth motion (a swing sampled coarsely) deviates alike at k and beside it: no step
            base = 0.5 * (e[k - 2] + e[k + 2])
            step = e[k] - base
            if any(abs(e[j] - base + 0.5 * step) > 0.25 * abs(step) for j in (k - 1, k + 1)):
                continue
        out.append((k + 1, float(e[k])))
    return out


def find_glitches(t, columns: Mapping[str, Any], *, angles: Sequence[str] = ("q1",),
                  jump_floor: float = JUMP_FLOOR, input=None) -> list[Glitch]:
    """Find spikes, dropouts and (for ``angles``) jumps in logged signals.

    Parameters
    ----------
    t : array_like
        Sample times [s].
    columns : dict of str to array_like
        The signals to check, by iwp name (``q1``, ``q3``, ``q4``, ``current``, ...).
        Inputs should not be passed: a pseudo-random input legitimately jumps.
    angles : sequence of str
        Columns that are angles [rad], checked for jumps too.
    jump_floor : float
        Smallest jump reported [rad].
    input : array_like, optional
        The logged input: a sample whose deviation its steps explain (a
        speed's corner where a pseudo-random input reverses) is no spike,
        nor is a first sample that changes no faster than the log does
        elsewhere while the input starts.

    Returns
    -------
    list of Glitch
        Sorted by time; spikes and dropouts carry their replacement (mean
        of the neighbours, or the extrapolation at the ends).
    """
    t = np.asarray(t, dtype=float)
    u = None
    if input is not None:
        u = np.asarray(input, dtype=float)
        if u.shape != t.shape:
            raise InputError(f"find_glitches: input has {u.size} samples but t has {t.size}")
        if not np.all(np.isfinite(u)) or np.ptp(u) == 0:
            u = None
    out: list[Glitch] = []
    for name, col in columns.items():
        if col is None:
            continue
        y = np.asarray(col, dtype=float)
        if y.size != t.size:
            raise InputError(f"find_glitches: column {name!r} has {y.size} samples but t has {t.size}")
        spikes = _spikes(y, u)
        for k in spikes:
            rep = _neighbour_value(y, k)
            kind = "dropout" if y[k] == 0.0 and rep != 0.0 else "spike"
            out.append(Glitch(name, k, float(t[k]), kind, float(y[k]), float(rep)))
        if name in angles:
            fixed = repair(y, [g for g in out if g.column == name])
            for k, size in _jumps(fixed, jump_floor, set(spikes)):
                out.append(Glitch(name, k, float(t[k]), "jump", size, None))
    out.sort(key=lambda g: (g.t, g.column))
    return out


def _neighbour_value(y: np.ndarray, k: int) -> float:
    n = y.size
    if 0 < k < n - 1:
        return 0.5 * (y[k - 1] + y[k + 1])
    if k == 0:
        return 2.0 * y[1] - y[2]
    return 2.0 * y[-2] - y[-3]


def repair(y, glitches: Sequence[Glitch]) -> np.ndarray:
    """A copy of ``y`` with each replaced glitch's sample set to its replacement.

    Parameters
    ----------
    y : array_like, shape (n,)
        Logged signal [unit of the signal].
    glitches : sequence of Glitch
        Glitches found in ``y``; those with a ``replacement`` of None are left as logged.

    Returns
    -------
    ndarray, shape (n,)
        Repaired float copy of ``y``; ``y`` is not changed.

    Raises
    ------
    InputError
        A replaced glitch's ``index`` outside ``[0, n)``.
    """
    out = np.array(y, dtype=float)
    for g in glitches:
        if g.replacement is not None:
            if not 0 <= g.index < out.size:
                raise InputError(f"glitch at sample {g.index} outside the signal ({out.size} samples)")
            out[g.index] = g.replacement
    return out


def summarize(glitches: Sequence[Glitch], limit: int = 4) -> str:
    """``"3 glitches: q4 spike at t = 0 s (2345 -> 12.1), ..."``.

    Parameters
    ----------
    glitches : sequence of Glitch
        Glitches to describe.
    limit : int, default 4
        Most glitches described one by one; the rest are counted (``"; and 2 more"``).

    Returns
    -------
    str
        One line, ``"no glitches"`` for an empty sequence.
    """
    n = len(glitches)
    if n == 0:
        return "no glitches"
    shown = "; ".join(g.describe() for g in glitches[:limit])
    more = f"; and {n - limit} more" if n > limit else ""
    return f"{n} glitch{'es' if n != 1 else ''}: {shown}{more}"

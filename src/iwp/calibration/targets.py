"""The paper's published numbers as targets: where each is printed, how precisely, and within what tolerance.

The paper's numbers are what its procedures *returned* on its rig (section
5), biased by everything its model leaves out. A faithful twin is one on
which the same procedures return the same numbers. The numbers are shipped
with iwp as ``paper_targets.json`` (:data:`TARGETS_FILE`), one entry per
number:

``key``
    A short name.
``quantity``, ``reference``
    What it is and where the paper prints it (section, equation, figure).
``statistic``
    How a twin reproduces it: a name of :mod:`iwp.calibration.statistics`.
``published`` or ``published_range``
    The number, or ``[low, high]`` where the paper prints two values for
    one quantity (inside the range the deviation is 0).
``printed``, ``precision``
    The number as printed and half a unit of its last printed digit.
``tolerance``
    Relative tolerance within which a twin reproduces it (issue 12: 5 %,
    10 % for the dead zone, 20 % for ``sigma~_c2(1+rho)``, 25-30 % for the
    small pendulum friction terms, 2 % for ``rho`` and the closed-loop
    amplitudes).
``graded``
    One of the 21 numbers that issue 12 grades.
``calibrate``
    Used in the calibration's objective (:func:`iwp.calibration.calibrate.calibrate`);
    ``false`` for a number no twin of the family reaches, with the reason
    in ``note``.

:func:`load_targets` reads such a file (the shipped one by default);
:func:`compare_targets` sets a twin's numbers against them
(:class:`TargetRow`: published, reproduced, deviation, within tolerance).
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from ..errors import InputError
from ..files import read_json
from .statistics import check_statistic

__all__ = ["PaperTarget", "TargetRow", "TARGETS_FILE", "load_targets", "compare_targets"]

#: The paper's numbers, shipped with iwp.
TARGETS_FILE = Path(__file__).with_name("paper_targets.json")

_REQUIRED = ("key", "quantity", "reference", "statistic", "printed", "precision", "tolerance", "graded", "calibrate")
_OPTIONAL = ("published", "published_range", "note")


@dataclass(frozen=True)
class PaperTarget:
    """One published number of the paper (see the module docstring for the fields)."""

    key: str
    quantity: str
    reference: str
    statistic: str
    published: float | None
    published_range: tuple[float, float] | None
    printed: str
    precision: float
    tolerance: float
    graded: bool
    calibrate: bool
    note: str = ""

    @property
    def scale(self) -> float:
        """``|published|`` (the lower end of a range): the deviation's denominator."""
        return abs(self.published) if self.published is not None else abs(self.published_range[0])

    @property
    def published_text(self) -> str:
        """The published number or range as text."""
        if self.published_range is not None:
            return f"{self.published_range[0]:g} - {self.published_range[1]:g}"
        return f"{self.published:g}"

    def deviation(self, value: float) -> float:
        """Signed relative deviation of ``value`` from the published number (0 inside a range)."""
        if not math.isfinite(value):
            return math.nan
        if self.published_range is not None:
            lo, hi = self.published_range
            d = 0.0 if lo <= value <= hi else (value - lo if value < lo else value - hi)
            return d / (abs(lo) if value < lo else abs(hi))
        return (value - self.published) / self.scale

    def residual(self, value: float) -> float:
        """The deviation in units of the tolerance (the calibration's residual)."""
        return self.deviation(value) / self.tolerance

    def within(self, value: float) -> bool:
        """True if ``value`` reproduces the number within the tolerance."""
        d = self.deviation(value)
        return math.isfinite(d) and abs(d) <= self.tolerance

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["published_range"] = None if self.published_range is None else list(self.published_range)
        return d


@dataclass(frozen=True)
class TargetRow:
    """One published number against a twin's: the residual table of a calibration and of the report."""

    target: PaperTarget
    reproduced: float

    @property
    def deviation(self) -> float:
        """Signed relative deviation (see :meth:`PaperTarget.deviation`)."""
        return self.target.deviation(self.reproduced)

    @property
    def within(self) -> bool:
        return self.target.within(self.reproduced)

    def to_dict(self) -> dict[str, Any]:
        t = self.target
        return {"key": t.key, "quantity": t.quantity, "reference": t.reference, "statistic": t.statistic,
                "published": t.published if t.published_range is None else list(t.published_range),
                "printed": t.printed, "tolerance": t.tolerance, "reproduced": _finite(self.reproduced),
                "deviation": _finite(self.deviation), "within": bool(self.within), "graded": t.graded,
                "calibrate": t.calibrate, "note": t.note}


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _target(entry: Any, where: str) -> PaperTarget:
    if not isinstance(entry, Mapping):
        raise InputError(f"{where}: expected an object with the fields {', '.join(_REQUIRED)}")
    missing = [k for k in _REQUIRED if k not in entry]
    if missing:
        raise InputError(f"{where}: missing field {missing[0]!r}")
    unknown = sorted(set(entry) - set(_REQUIRED) - set(_OPTIONAL))
    if unknown:
        raise InputError(f"{where}: unknown field {unknown[0]!r}; known: {', '.join(_REQUIRED + _OPTIONAL)}")
    for k in ("key", "quantity", "reference", "statistic", "printed"):
        if not isinstance(entry[k], str) or not entry[k]:
            raise InputError(f"{where}: field {k!r} must be a non-empty string")
    for k in ("graded", "calibrate"):
        if not isinstance(entry[k], bool):
            raise InputError(f"{where}: field {k!r} must be true or false")

    def number(k: str, val: Any, positive: bool = False) -> float:
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
            raise InputError(f"{where}: field {k!r} must be a finite number, got {val!r}")
        if positive and val <= 0:
            raise InputError(f"{where}: field {k!r} must be > 0, got {val!r}")
        return float(val)

    has_value, has_range = "published" in entry, "published_range" in entry
    if has_value == has_range:
        raise InputError(f"{where}: give exactly one of 'published' and 'published_range'")
    published, rng = None, None
    if has_value:
        published = number("published", entry["published"])
        if published == 0.0:
            raise InputError(f"{where}: field 'published' must not be 0 (deviations are relative)")
    else:
        r = entry["published_range"]
        if not isinstance(r, (list, tuple)) or len(r) != 2:
            raise InputError(f"{where}: field 'published_range' must be [low, high]")
        lo, hi = number("published_range", r[0]), number("published_range", r[1])
        if not lo < hi or lo == 0.0 or (lo < 0 < hi):
            raise InputError(f"{where}: field 'published_range' must be [low, high] with low < high, "
                             f"both of one sign, got {list(r)}")
        rng = (lo, hi)
    check_statistic(entry["statistic"], f"{where}: field 'statistic'")
    note = entry.get("note", "")
    if not isinstance(note, str):
        raise InputError(f"{where}: field 'note' must be a string")
    return PaperTarget(key=entry["key"], quantity=entry["quantity"], reference=entry["reference"],
                       statistic=entry["statistic"], published=published, published_range=rng,
                       printed=entry["printed"], precision=number("precision", entry["precision"]),
                       tolerance=number("tolerance", entry["tolerance"], positive=True),
                       graded=entry["graded"], calibrate=entry["calibrate"], note=note)


def load_targets(path: str | os.PathLike | None = None) -> list[PaperTarget]:
    """Read a targets file (default: the paper's, :data:`TARGETS_FILE`).

    Parameters
    ----------
    path : str or path-like, optional
        Targets file (JSON, ``"kind": "paper-targets"``); None (default): :data:`TARGETS_FILE`.

    Returns
    -------
    list of PaperTarget
        The targets, in the file's order.

    Raises
    ------
    InputError
        No such file, not JSON, or an entry that is not a valid target
        (naming the file, the entry and the field); repeated keys.

    Examples
    --------
    >>> from iwp.calibration import load_targets
    >>> targets = load_targets()
    >>> len(targets), sum(t.graded for t in targets)  # the paper's numbers, those the twin is graded on
    (27, 21)
    >>> t = targets[7]
    >>> t.key, t.statistic, t.published, t.tolerance  # Table 1's p1 within 5 %
    ('c_p1', 'free.p1', 26.095, 0.05)
    """
    p = TARGETS_FILE if path is None else Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such targets file")
    doc = read_json(p)
    if not isinstance(doc, Mapping) or doc.get("kind") != "paper-targets" or not isinstance(doc.get("targets"), list):
        raise InputError(f"{p}: not a targets file (expected an object with \"kind\": \"paper-targets\" and a list "
                         "\"targets\")")
    out = [_target(e, f"{p}: targets[{i}]") for i, e in enumerate(doc["targets"])]
    if not out:
        raise InputError(f"{p}: the list \"targets\" is empty")
    keys = [t.key for t in out]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise InputError(f"{p}: target key {dup[0]!r} appears more than once")
    return out


def compare_targets(targets: Sequence[PaperTarget], values: Mapping[str, float]) -> list[TargetRow]:
    """Each target against the reproduced value of its statistic (``values``: statistic name -> value).

    Parameters
    ----------
    targets : sequence of PaperTarget
        The targets.
    values : mapping of str to float
        Reproduced value of each statistic, by statistic name (in the statistic's unit).

    Returns
    -------
    list of TargetRow
        One row per target, in order.

    Raises
    ------
    InputError
        ``values`` lacks the statistic of a target.

    Examples
    --------
    The paper's numbers against what the default twin reproduced when it was calibrated (its record):

    >>> from iwp.calibration import compare_targets, load_targets
    >>> from iwp.rig import truth_record
    >>> reproduced = {r["statistic"]: r["reproduced"] for r in truth_record()["calibration"]["residuals"]}
    >>> rows = compare_targets(load_targets(), reproduced)
    >>> row = rows[7]
    >>> row.target.key, row.target.published, round(row.reproduced, 3), round(row.deviation, 4), row.within
    ('c_p1', 26.095, 26.361, 0.0102, True)
    >>> sum(r.within for r in rows if r.target.graded)  # of 21
    20
    """
    rows = []
    for t in targets:
        if t.statistic not in values:
            raise InputError(f"no value for the statistic {t.statistic!r} of target {t.key!r}")
        rows.append(TargetRow(t, float(values[t.statistic])))
    return rows

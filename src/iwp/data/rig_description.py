"""The rig description: what another inertia wheel pendulum logs, and how (a small JSON file).

A rig description tells iwp how a rig's log maps onto iwp's signals: which
columns hold the time, the pendulum angle, the wheel's angle or speed, the
motor current and the input; their units; where the pendulum angle's zero
is; how the wheel speed is sampled (at an instant, or as the board's
backward difference: the mean over the preceding period); the input's kind,
scale and limits; the drive (belt, gear, direct) and the sample period. The
format, with every key, is in ``docs/rig-description.md``; this module
checks a description key by key (one-line errors naming the key, the
equivalent of a JSON schema) and holds it as frozen dataclasses.
:func:`iwp.data.rig_log.read_rig_log` reads a log with it;
:mod:`iwp.rig.described` runs the virtual rig as such a rig.

>>> rig = RigDescription.from_dict({"pendulum": {"column": "theta", "unit": "deg"},
...                                 "wheel": {"column": "phidot", "quantity": "speed", "sampling": "mean"},
...                                 "input": {"column": "u", "kind": "duty"}})
>>> rig.input.limits
(-1.0, 1.0)
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Mapping

from ..errors import InputError
from ..files import read_json
from ..models.plant import EXPERIMENT_KINDS
from .plausibility import SAMPLE_PERIOD_RANGE

__all__ = [
    "RigDescription",
    "MatrixSpec",
    "TimeSpec",
    "PendulumSpec",
    "WheelSpec",
    "CurrentSpec",
    "InputSpec",
    "DriveSpec",
    "ControllerSpec",
    "ExperimentSpec",
    "load_rig",
    "ANGLE_UNITS",
    "SPEED_UNITS",
    "TIME_UNITS",
    "INPUT_KINDS",
    "DRIVE_KINDS",
]

#: Time units and their factor to seconds.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "min": 60.0}
#: Angle units and their factor to rad (``counts`` uses ``counts_per_rev``).
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0, "counts": None}
#: Speed units and their factor to rad/s.
SPEED_UNITS = {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": 2.0 * math.pi / 60.0}
#: Current units and their factor to A.
CURRENT_UNITS = {"A": 1.0, "mA": 1e-3}
#: Input kinds: volts at the driver, the paper's units, a PWM duty in [-1, 1], counts of a DAC.
INPUT_KINDS = ("volts", "units", "duty", "dac")
#: Drive kinds between motor and wheel: direct, a gear (rigid, a ratio), a belt (flexible: model (15)).
DRIVE_KINDS = ("direct", "gear", "belt")
ZEROS = {"down": 0.0, "up": math.pi}


def _where(where: str, key: str) -> str:
    return f"{where}: key {key!r}"


def _obj(where: str, key: str, value: Any, known: tuple[str, ...]) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise InputError(f"{_where(where, key)} must be an object {{...}}, got {value!r}")
    bad = sorted(set(value) - set(known))
    if bad:
        raise InputError(f"{where}: unknown key '{key}.{bad[0]}'; known: {', '.join(known)}")
    return value


def _num(where: str, key: str, value: Any, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{_where(where, key)} must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise InputError(f"{_where(where, key)} must be > 0, got {value!r}")
    return float(value)


def _choice(where: str, key: str, value: Any, choices) -> str:
    if value not in choices:
        raise InputError(f"{_where(where, key)} must be one of {', '.join(map(str, choices))}, got {value!r}")
    return value


def _column(where: str, key: str, value: Any, *, optional: bool = False) -> str | None:
    if value is None and optional:
        return None
    if not isinstance(value, str) or not value.strip():
        raise InputError(f"{_where(where, key)} must name a column of the log (a non-empty string), got {value!r}")
    return value.strip()


def _sign(where: str, key: str, value: Any) -> float:
    if value not in (1, -1) or isinstance(value, bool):
        raise InputError(f"{_where(where, key)} must be 1 or -1 (the direction of positive angles), got {value!r}")
    return float(value)


@dataclass(frozen=True)
class TimeSpec:
    """The time column: its name (None: none, times from ``sample_period``) and unit (``s``, ``ms``, ``us``)."""

    column: str | None = "t"
    unit: str = "s"


@dataclass(frozen=True)
class PendulumSpec:
    """The pendulum angle.

    Attributes
    ----------
    column : str
    unit : {"rad", "deg", "counts"}
        ``counts``: encoder counts, ``counts_per_rev`` per turn (an IMU logs ``deg``).
    counts_per_rev : float or None
    zero : float
        Where the log's 0 is, in iwp's angle [rad]: 0 for ``"down"`` (hanging), pi for ``"up"``.
    offset : float or None
        The log's angle minus the true angle after ``zero`` [rad] (a reset a few hundredths off),
        subtracted from ``q1``; None (``"estimate"``): estimated per log by the fit.
    sign : float
        1, or -1 if the log counts the other way round.
    scale : float
        A correction factor on the angle in its unit (e.g. a lab's factor for an encoder whose gain is
        known to be off); default 1. The angle is ``sign * scale * x * unit + zero - offset``.
    """

    column: str
    unit: str = "rad"
    counts_per_rev: float | None = None
    zero: float = 0.0
    offset: float | None = None
    sign: float = 1.0
    scale: float = 1.0

    @property
    def factor(self) -> float:
        """Log unit -> rad (with ``scale``)."""
        f = ANGLE_UNITS[self.unit]
        return self.scale * (2.0 * math.pi / self.counts_per_rev if f is None else f)


@dataclass(frozen=True)
class WheelSpec:
    """The wheel's sensor: its angle or its speed, at the wheel or at the motor shaft.

    Attributes
    ----------
    column : str
    quantity : {"speed", "angle"}
    unit : str
        Speed: ``rad/s``, ``deg/s``, ``rpm``; angle: ``rad``, ``deg``, ``counts``.
    sampling : {"instant", "mean"}
        Speed only: the speed at the sample instant, or the mean over the
        preceding sample period (a board's backward difference of an encoder).
    at : {"wheel", "motor"}
        Where the sensor sits; at the motor shaft the reading is divided by the drive's ratio.
    counts_per_rev : float or None
        Angle in counts (required then); for a speed, the encoder behind it (informative,
        and the virtual rig's quantisation).
    sign : float
    scale, bias : float
        An affine correction of the reading in its unit, ``scale * (x - bias)`` (default 1 and 0).
    """

    column: str
    quantity: str = "speed"
    unit: str = "rad/s"
    sampling: str = "instant"
    at: str = "wheel"
    counts_per_rev: float | None = None
    sign: float = 1.0
    scale: float = 1.0
    bias: float = 0.0

    def factor(self, ratio: float) -> float:
        """Log unit -> rad (or rad/s) of the wheel relative to the arm (with ``scale``)."""
        if self.quantity == "speed":
            f = SPEED_UNITS[self.unit]
        else:
            f = ANGLE_UNITS[self.unit]
            f = 2.0 * math.pi / self.counts_per_rev if f is None else f
        f = self.scale * f
        return f / ratio if self.at == "motor" else f


@dataclass(frozen=True)
class CurrentSpec:
    """The motor current: column, unit (``A``, ``mA``) and an affine correction ``scale * (x - bias)`` in that unit."""

    column: str
    unit: str = "A"
    scale: float = 1.0
    bias: float = 0.0


@dataclass(frozen=True)
class InputSpec:
    """The logged input and how it maps to the model's input.

    The model's input is ``scale (clip(x, limits) - offset)`` for a logged
    value ``x``: values beyond ``limits`` (a controller's output before the
    driver saturates it) are clipped, counted and reported.

    Attributes
    ----------
    column : str or None
        None: no input logged (zero input, e.g. free swings).
    kind : {"volts", "units", "duty", "dac"}
    scale : float
        Model input units per logged unit (e.g. 12 V per unit of duty; default 1).
    offset : float
        The logged value of zero command (a DAC's mid-scale count; default 0).
    limits : (float, float) or None
        Saturation of the logged value: default ``(-1, 1)`` for ``duty``,
        ``(0, 2**bits - 1)`` for ``dac`` with ``bits``, none otherwise.
    bits : int or None
        DAC resolution.
    compensated : bool
        The log holds the paper's ideal input ``u`` (the rig's software adds
        the dead-zone feedforward (7)-(8)); default False: the raw command ``v``.
    """

    column: str | None = "u"
    kind: str = "units"
    scale: float = 1.0
    offset: float = 0.0
    limits: tuple[float, float] | None = None
    bits: int | None = None
    compensated: bool = False

    @property
    def name(self) -> str:
        """The iwp input name the log gets: ``u`` (compensated) or ``v``."""
        return "u" if self.compensated else "v"


@dataclass(frozen=True)
class DriveSpec:
    """How the motor drives the wheel: ``direct``, ``gear`` or ``belt``.

    The ratio ``N`` is in motor turns per wheel turn [-].
    """

    kind: str = "direct"
    ratio: float = 1.0


@dataclass(frozen=True)
class MatrixSpec:
    """A MATLAB log holding one numeric matrix, one column per signal (or one row per signal).

    Attributes
    ----------
    columns : tuple of str
        The names of its columns, in order (the names the other keys use).
    variable : str or None
        The matrix variable's name; None: the file's only two-dimensional numeric variable.
    """

    columns: tuple[str, ...]
    variable: str | None = None


@dataclass(frozen=True)
class ControllerSpec:
    """The feedback law of a rig's closed-loop logs: the Hopf law ``u = k1 q3 + k2 q3^3`` (section 5.3).

    Attributes
    ----------
    law : {"hopf"}
    k1 : float
        Linear gain [input units s/rad], in the logs' input units.
    k2 : float
        Cubic gain [input units s^3/rad^3].
    ts : float or None
        The law's sample period [s], held between samples; None: continuous.
    """

    law: str
    k1: float
    k2: float
    ts: float | None = None


#: the feedback laws a rig description can name for its closed-loop logs
CONTROLLER_LAWS = ("hopf",)


@dataclass(frozen=True)
class ExperimentSpec:
    """Which of a rig's logs come from which set-up (``experiments`` in the description).

    Attributes
    ----------
    files : tuple of str
        Patterns of the logs' file names (``*``, ``?``, ``[...]`` as in a shell), matched from the right of
        the path as given (:meth:`pathlib.PurePath.match`): ``clamp_*.mat`` matches the file's name,
        ``day2/*.mat`` the files of any folder ``day2``.
    kind : str
        The set-up (:data:`~iwp.models.plant.EXPERIMENT_KINDS`): ``free``, ``clamped``, ``wheel-locked`` or
        ``closed-loop``.
    controller : ControllerSpec or None
        The feedback law of ``closed-loop`` logs (required for them, refused for the others).
    """

    files: tuple[str, ...]
    kind: str
    controller: ControllerSpec | None = None

    def matches(self, path: str | os.PathLike) -> bool:
        """Whether the log file ``path`` is one of this set-up's (see ``files``)."""
        p = Path(path)
        return any(p.match(pat) for pat in self.files)


_TOP = ("kind", "name", "notes", "sample_period", "time", "pendulum", "wheel", "current", "input", "drive",
        "matrix", "experiments")


@dataclass(frozen=True)
class RigDescription:
    """A rig: its signals, input, drive and sample period (see the module docstring and ``docs/rig-description.md``).

    Build it with :meth:`from_dict` or :func:`load_rig` (which check every key).
    """

    pendulum: PendulumSpec
    wheel: WheelSpec | None = None
    current: CurrentSpec | None = None
    input: InputSpec | None = None
    drive: DriveSpec = field(default_factory=DriveSpec)
    time: TimeSpec = field(default_factory=TimeSpec)
    sample_period: float | None = None
    name: str = ""
    notes: str = ""
    source: str = "<memory>"
    matrix: MatrixSpec | None = None
    experiments: tuple[ExperimentSpec, ...] = ()

    def experiment_of(self, path: str | os.PathLike) -> ExperimentSpec | None:
        """The set-up the description gives the log file ``path`` (the first entry of ``experiments`` whose
        pattern matches it), or None."""
        return next((e for e in self.experiments if e.matches(path)), None)

    def to_dict(self) -> dict[str, Any]:
        """The description as JSON-ready dict (the format :meth:`from_dict` reads)."""
        d: dict[str, Any] = {"kind": "iwp-rig", "name": self.name}
        if self.notes:
            d["notes"] = self.notes
        if self.sample_period is not None:
            d["sample_period"] = self.sample_period
        d["time"] = asdict(self.time)
        p = asdict(self.pendulum)
        p["zero"] = next((k for k, v in ZEROS.items() if v == self.pendulum.zero), self.pendulum.zero)
        p["offset"] = "estimate" if self.pendulum.offset is None else self.pendulum.offset
        d["pendulum"] = _drop_none(p)
        for key in ("wheel", "current", "input"):
            val = getattr(self, key)
            if val is not None:
                dd = asdict(val)
                if key == "input" and dd["limits"] is not None:
                    dd["limits"] = list(dd["limits"])
                d[key] = _drop_none(dd) if key != "input" else {k: v for k, v in dd.items()
                                                                  if v is not None or k == "column"}
        d["drive"] = asdict(self.drive)
        if self.matrix is not None:
            d["matrix"] = _drop_none({"variable": self.matrix.variable, "columns": list(self.matrix.columns)})
        if self.experiments:
            d["experiments"] = [{"files": list(e.files), "kind": e.kind}
                                | ({"controller": _drop_none(asdict(e.controller))} if e.controller else {})
                                for e in self.experiments]
        return d

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], *, where: str = "rig") -> "RigDescription":
        """Check a description key by key and build it; errors are one line naming ``where`` and the key."""
        if not isinstance(doc, Mapping):
            raise InputError(f"{where}: expected a JSON object (the rig description)")
        bad = sorted(set(doc) - set(_TOP))
        if bad:
            raise InputError(f"{where}: unknown key {bad[0]!r}; known: {', '.join(_TOP)}")
        kind = doc.get("kind", "iwp-rig")
        if kind != "iwp-rig":
            raise InputError(f"{_where(where, 'kind')} must be 'iwp-rig', got {kind!r}")
        name = doc.get("name", "")
        notes = doc.get("notes", "")
        for key, val in (("name", name), ("notes", notes)):
            if not isinstance(val, str):
                raise InputError(f"{_where(where, key)} must be a string, got {val!r}")
        Ts = doc.get("sample_period")
        if Ts is not None:
            Ts = _num(where, "sample_period", Ts, positive=True)
            lo, hi = SAMPLE_PERIOD_RANGE
            if not lo <= Ts <= hi:
                hint = f" (in seconds: {Ts / 1000:g} for {Ts:g} ms)" if Ts > hi else ""
                raise InputError(f"{_where(where, 'sample_period')} is {Ts:g} s, which cannot be the sample period "
                                 f"of a rig ({lo:g} to {hi:g} s){hint}")
        # time
        tdoc = _obj(where, "time", doc.get("time", {}), ("column", "unit"))
        time = TimeSpec(_column(where, "time.column", tdoc.get("column", "t"), optional=True),
                        _choice(where, "time.unit", tdoc.get("unit", "s"), tuple(TIME_UNITS)))
        if time.column is None and Ts is None:
            raise InputError(f"{where}: key 'time.column' is null (no time column): give 'sample_period' [s]")
        # pendulum
        if "pendulum" not in doc:
            raise InputError(f"{where}: key 'pendulum' is required (the pendulum angle's column and unit)")
        pdoc = _obj(where, "pendulum", doc["pendulum"],
                    ("column", "unit", "counts_per_rev", "zero", "offset", "sign", "scale"))
        if "column" not in pdoc:
            raise InputError(f"{where}: key 'pendulum.column' is required")
        unit = _choice(where, "pendulum.unit", pdoc.get("unit", "rad"), tuple(ANGLE_UNITS))
        cpr = _counts(where, "pendulum", pdoc, unit == "counts")
        zero = pdoc.get("zero", "down")
        if isinstance(zero, str):
            zero_v = ZEROS[_choice(where, "pendulum.zero", zero, tuple(ZEROS))]
        else:
            zero_v = _num(where, "pendulum.zero", zero)
            if abs(zero_v) > 2.0 * math.pi:
                raise InputError(f"{_where(where, 'pendulum.zero')} = {zero_v!r} rad: the angle of the log's zero "
                                 "lies within one turn (|zero| <= 2 pi rad), or 'down' / 'up'")
        off = pdoc.get("offset", "estimate")
        if off == "estimate":
            off_v = None
        else:
            try:
                off_v = _num(where, "pendulum.offset", off)
            except InputError:
                raise InputError(f"{_where(where, 'pendulum.offset')} must be a number [rad] or 'estimate', "
                                 f"got {off!r}") from None
            if abs(off_v) > 0.5:
                raise InputError(f"{_where(where, 'pendulum.offset')} = {off_v!r} rad: an offset is a small "
                                 "correction (|offset| <= 0.5 rad); put the angle of the log's zero in "
                                 "'pendulum.zero'")
        pend = PendulumSpec(_column(where, "pendulum.column", pdoc["column"]), unit, cpr, zero_v, off_v,
                            _sign(where, "pendulum.sign", pdoc.get("sign", 1)), _scale(where, "pendulum", pdoc))
        # drive
        ddoc = _obj(where, "drive", doc.get("drive", {}), ("kind", "ratio"))
        dkind = _choice(where, "drive.kind", ddoc.get("kind", "direct"), DRIVE_KINDS)
        if dkind != "direct" and "ratio" not in ddoc:
            raise InputError(f"{where}: key 'drive.ratio' is required for a {dkind} drive (motor turns per wheel "
                             "turn)")
        ratio = _num(where, "drive.ratio", ddoc.get("ratio", 1.0), positive=True)
        if dkind == "direct" and ratio != 1.0:
            raise InputError(f"{_where(where, 'drive.ratio')} must be 1 for a direct drive, got {ratio!r}")
        drive = DriveSpec(dkind, ratio)
        # wheel
        wheel = None
        if doc.get("wheel") is not None:
            wdoc = _obj(where, "wheel", doc["wheel"],
                        ("column", "quantity", "unit", "sampling", "at", "counts_per_rev", "sign", "scale", "bias"))
            if "column" not in wdoc:
                raise InputError(f"{where}: key 'wheel.column' is required")
            qty = _choice(where, "wheel.quantity", wdoc.get("quantity", "speed"), ("speed", "angle"))
            units = tuple(SPEED_UNITS) if qty == "speed" else tuple(ANGLE_UNITS)
            wunit = _choice(where, "wheel.unit", wdoc.get("unit", units[0]), units)
            sampling = _choice(where, "wheel.sampling", wdoc.get("sampling", "instant"), ("instant", "mean"))
            if qty == "angle" and sampling != "instant":
                raise InputError(f"{_where(where, 'wheel.sampling')} applies to a speed; the wheel.quantity is "
                                 "'angle'")
            at = _choice(where, "wheel.at", wdoc.get("at", "wheel"), ("wheel", "motor"))
            wcpr = _counts(where, "wheel", wdoc, wunit == "counts")
            wheel = WheelSpec(_column(where, "wheel.column", wdoc["column"]), qty, wunit, sampling, at, wcpr,
                              _sign(where, "wheel.sign", wdoc.get("sign", 1)), _scale(where, "wheel", wdoc),
                              _num(where, "wheel.bias", wdoc.get("bias", 0.0)))
        current = None
        if doc.get("current") is not None:
            cdoc = _obj(where, "current", doc["current"], ("column", "unit", "scale", "bias"))
            if "column" not in cdoc:
                raise InputError(f"{where}: key 'current.column' is required")
            current = CurrentSpec(_column(where, "current.column", cdoc["column"]),
                                  _choice(where, "current.unit", cdoc.get("unit", "A"), tuple(CURRENT_UNITS)),
                                  _scale(where, "current", cdoc), _num(where, "current.bias", cdoc.get("bias", 0.0)))
        inp = None
        if doc.get("input") is not None:
            idoc = _obj(where, "input", doc["input"],
                        ("column", "kind", "scale", "offset", "limits", "bits", "compensated"))
            col = _column(where, "input.column", idoc.get("column", "u"), optional=True)
            ikind = _choice(where, "input.kind", idoc.get("kind", "units"), INPUT_KINDS)
            bits = idoc.get("bits")
            if bits is not None:
                if isinstance(bits, bool) or not isinstance(bits, int) or not 1 <= bits <= 32:
                    raise InputError(f"{_where(where, 'input.bits')} must be an integer from 1 to 32, got {bits!r}")
                if ikind != "dac":
                    raise InputError(f"{_where(where, 'input.bits')} applies to input.kind 'dac', not {ikind!r}")
            limits = idoc.get("limits")
            if limits is None:
                lim = (-1.0, 1.0) if ikind == "duty" else ((0.0, float(2 ** bits - 1)) if bits else None)
            else:
                if not isinstance(limits, (list, tuple)) or len(limits) != 2:
                    raise InputError(f"{_where(where, 'input.limits')} must be [low, high], got {limits!r}")
                lo = _num(where, "input.limits", limits[0])
                hi = _num(where, "input.limits", limits[1])
                if not lo < hi:
                    raise InputError(f"{_where(where, 'input.limits')} must have low < high, got {limits!r}")
                lim = (lo, hi)
            if ikind == "duty" and lim is not None and (lim[0] < -1.0 or lim[1] > 1.0):
                raise InputError(f"{_where(where, 'input.limits')} of a PWM duty must lie within [-1, 1], got "
                                 f"{list(lim)}")
            if ikind == "dac" and "offset" not in idoc:
                raise InputError(f"{where}: key 'input.offset' is required for a DAC (the count of zero command, "
                                 "e.g. 2048 for 12 bits)")
            comp = idoc.get("compensated", False)
            if not isinstance(comp, bool):
                raise InputError(f"{_where(where, 'input.compensated')} must be true or false, got {comp!r}")
            inp = InputSpec(col, ikind, _num(where, "input.scale", idoc.get("scale", 1.0)),
                            _num(where, "input.offset", idoc.get("offset", 0.0)), lim, bits, comp)
            if inp.scale == 0:
                raise InputError(f"{_where(where, 'input.scale')} must not be 0")
            if inp.column is None:
                inp = None
        if wheel is None:
            raise InputError(f"{where}: key 'wheel' is required (the wheel's angle or speed column); iwp's models "
                             "need the wheel")
        matrix = None
        if doc.get("matrix") is not None:
            mdoc = _obj(where, "matrix", doc["matrix"], ("variable", "columns"))
            names = mdoc.get("columns")
            if (not isinstance(names, (list, tuple)) or len(names) < 2
                    or not all(isinstance(c, str) and c.strip() for c in names)):
                raise InputError(f"{_where(where, 'matrix.columns')} must list the names of the matrix's columns "
                                 f"in order (at least two), got {names!r}")
            if len(set(names)) != len(names):
                dup = next(c for c in names if names.count(c) > 1)
                raise InputError(f"{_where(where, 'matrix.columns')} names {dup!r} twice")
            var = mdoc.get("variable")
            if var is not None and (not isinstance(var, str) or not var.strip()):
                raise InputError(f"{_where(where, 'matrix.variable')} must be a variable's name, got {var!r}")
            matrix = MatrixSpec(tuple(names), var)
        experiments = _experiments(where, doc.get("experiments", []))
        rig = cls(pend, wheel, current, inp, drive, time, Ts, name, notes, where, matrix, experiments)
        _check_distinct_columns(rig)
        return rig

    def columns(self) -> dict[str, str]:
        """iwp signal -> the log's column (``t``, ``q1``, ``q2`` or ``q4``, ``current``, ``input``)."""
        out = {}
        if self.time.column is not None:
            out["t"] = self.time.column
        out["q1"] = self.pendulum.column
        if self.wheel is not None:
            out["q4" if self.wheel.quantity == "speed" else "q2"] = self.wheel.column
        if self.current is not None:
            out["current"] = self.current.column
        if self.input is not None:
            out["input"] = self.input.column
        return out


def _experiments(where: str, value: Any) -> tuple[ExperimentSpec, ...]:
    """The ``experiments`` list: each entry's file patterns, set-up and (closed loop) feedback law, checked."""
    if not isinstance(value, (list, tuple)):
        raise InputError(f"{_where(where, 'experiments')} must be a list of {{\"files\": [...], \"kind\": ...}} "
                         f"objects, got {value!r}")
    out = []
    for i, item in enumerate(value):
        key = f"experiments[{i}]"
        edoc = _obj(where, key, item, ("files", "kind", "controller"))
        files = edoc.get("files")
        files = [files] if isinstance(files, str) else files
        if (not isinstance(files, (list, tuple)) or not files
                or not all(isinstance(f, str) and f.strip() for f in files)):
            raise InputError(f"{_where(where, key + '.files')} must be a file-name pattern or a list of them "
                             f"(e.g. \"clamped_*.mat\"), got {edoc.get('files')!r}")
        if "kind" not in edoc:
            raise InputError(f"{where}: key '{key}.kind' is required (one of {', '.join(EXPERIMENT_KINDS)})")
        kind = _choice(where, f"{key}.kind", edoc["kind"], tuple(EXPERIMENT_KINDS))
        controller = None
        if kind == "closed-loop":
            if "controller" not in edoc:
                raise InputError(f"{where}: key '{key}.controller' is required for closed-loop logs (their feedback "
                                 "law, e.g. {\"law\": \"hopf\", \"k1\": -10, \"k2\": 0.1})")
            cdoc = _obj(where, f"{key}.controller", edoc["controller"], ("law", "k1", "k2", "ts"))
            for req in ("law", "k1", "k2"):
                if req not in cdoc:
                    raise InputError(f"{where}: key '{key}.controller.{req}' is required")
            law = _choice(where, f"{key}.controller.law", cdoc["law"], CONTROLLER_LAWS)
            ts = cdoc.get("ts")
            controller = ControllerSpec(law, _num(where, f"{key}.controller.k1", cdoc["k1"]),
                                        _num(where, f"{key}.controller.k2", cdoc["k2"]),
                                        None if ts is None else _num(where, f"{key}.controller.ts", ts,
                                                                     positive=True))
        elif "controller" in edoc:
            raise InputError(f"{_where(where, key + '.controller')}: a feedback law belongs to closed-loop logs, "
                             f"and these are {kind}")
        out.append(ExperimentSpec(tuple(f.strip() for f in files), kind, controller))
    return tuple(out)


def _counts(where: str, part: str, d: Mapping[str, Any], required: bool) -> float | None:
    v = d.get("counts_per_rev")
    if v is None:
        if required:
            raise InputError(f"{where}: key '{part}.counts_per_rev' is required with unit 'counts'")
        return None
    return _num(where, f"{part}.counts_per_rev", v, positive=True)


def _scale(where: str, part: str, d: Mapping[str, Any]) -> float:
    """A signal's correction factor ``part.scale``: finite and not 0."""
    v = _num(where, f"{part}.scale", d.get("scale", 1.0))
    if v == 0:
        raise InputError(f"{_where(where, part + '.scale')} must not be 0 (it multiplies the reading)")
    return v


def _check_distinct_columns(rig: RigDescription) -> None:
    """Refuse a description that maps two signals onto one column."""
    seen: dict[str, str] = {}
    for key, col in (("time.column", rig.time.column), ("pendulum.column", rig.pendulum.column),
                     ("wheel.column", rig.wheel.column if rig.wheel else None),
                     ("current.column", rig.current.column if rig.current else None),
                     ("input.column", rig.input.column if rig.input else None)):
        if col is None:
            continue
        if col in seen:
            raise InputError(f"{rig.source}: keys '{seen[col]}' and '{key}' both name the column {col!r}; each "
                             "signal needs its own column")
        seen[col] = key
    if rig.matrix is not None:
        missing = [c for c in seen if c not in rig.matrix.columns]
        if missing:
            key = next(k for c, k in seen.items() if c == missing[0])
            raise InputError(f"{rig.source}: key '{key}' names the column {missing[0]!r}, which 'matrix.columns' "
                             f"does not list ({', '.join(rig.matrix.columns)})")


def _drop_none(d: dict) -> dict:
    return {k: v for k, v in d.items() if v is not None}


def load_rig(path: str | os.PathLike | RigDescription, *, flag: str = "--rig") -> RigDescription:
    """Load a rig description from JSON (a :class:`RigDescription` is returned as it is).

    Errors are one line naming the file (and ``flag`` when the file is missing).

    Parameters
    ----------
    path : str or PathLike or RigDescription
        The JSON file (``docs/rig-description.md`` lists its keys and units).
    flag : str
        The command-line flag named when the file is missing.

    Returns
    -------
    RigDescription

    Raises
    ------
    InputError
        A missing file, bad JSON, an unknown key, or a wrong value (naming the key).
    """
    if isinstance(path, RigDescription):
        return path
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{flag} {p}: no such file")
    return RigDescription.from_dict(read_json(p), where=str(p))

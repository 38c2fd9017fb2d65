"""The virtual rig: a truth plant richer than the identified model, with the rig's sensors.

Users without a rig, and every test, need experiment data that behaves like
the paper's rig. :class:`VirtualRig` runs the paper's experiments (section 5)
on a *truth plant* and returns what the rig would log: quantised encoder
positions sampled every ``Ts``, and the input. The logs are
:class:`iwp.io.ExperimentData` (time series) or :class:`iwp.io.StaticCurve`
(figure 2), in the data format that the rest of iwp reads.

The truth plant
---------------
Model (6) driven by the raw driver input ``v``, made richer than the model
that the paper identifies (its eq. (9)) in the ways the paper reports
(sections 3.2 and 5.1); it is the model ``"belt-full"`` of :mod:`iwp.models`:

* the pendulum (4a) with viscous and rolling friction (section 3.1);
* an asymmetric dead zone (5), ``v+ != v-``, with a break-away at start-up
  (:class:`~iwp.models.StartupFriction`): at rest the thresholds are
  ``(1 + break_ratio)`` times larger, which gives the discontinuity of
  figure 2(a) when the disk starts;
* viscous friction and Coulomb friction ``sigma~_c2 sgn q4`` at the disk
  (section 5.1, "Analysis of the Coulomb friction phenomenon");
* the rubber belt of eq. (15) with the play hysteresis of figure 5 between
  motor and disk (motor inertia neglected, as in the paper);
* optionally a clamp holding the pendulum at rest (section 5.1).

The rig's sensors and actuator
------------------------------
* Optical encoders with ``counts_per_rev = 2000`` (318.31 counts/rad,
  section 5): the logged positions are ``round((q + noise) / step) * step``
  with ``step = 2 pi / counts_per_rev`` exactly (rounding to the nearest
  count, a mid-tread quantiser: zero reads zero and the error is within
  ``+-step/2``).
* Optional Gaussian measurement noise of standard deviation ``noise_std``
  [rad], added before quantisation, drawn from
  ``numpy.random.default_rng(seed)``: a seed makes every run bitwise
  identical.
* Sampling every ``Ts = 5 ms``; digital controllers run at the same rate,
  see only the quantised positions and hold their output (zero-order hold).
* Input saturation: the driver command ``v`` is clipped to ``+-saturation``.
* Dead-zone compensation (eq. (7)-(8)) is done by the rig's software with
  the paper's ``v_dz = 31`` on both sides: it does *not* know the truth's
  asymmetric thresholds.

What a log contains
-------------------
``t``, the measured ``q1``, ``q2`` and the input: ``u`` (the ideal input) for
compensated experiments, ``v`` (the raw driver input) for uncompensated
ones. No velocities are logged (a real rig has none; differentiate the
positions, as the paper does). For comparison and tests only, the
noise-free, unquantised states of the truth plant are added as extra
columns ``true_q1, true_q2, true_q3, true_q4`` [rad, rad/s]; compensated
logs also carry the driver command after compensation and saturation as
``v_command``. Metadata (``# key: value``) record the experiment, the seed,
the input, the compensation and the truth as one-line JSON.

Default truth values (:func:`default_truth`)
--------------------------------------------
Pendulum and ``rho``: Table 1 (``p1 = 26.095``, ``rho = 247.24``,
``sigma~_a1 = 0.003``, ``sigma~_v1 = 0.01``, ``sigma~_b1 = 0.0005``).

Disk: the values of the paper's Coulomb model (section 5.1, set-up (b)):
``p2 (1 + rho) = 2.19`` (``p2 = 0.00882``), ``p3 (1 + rho) = 7.795``
(``p3 = 0.0314``) and ``sigma~_c2 (1 + rho) = 40`` (``sigma~_c2 = 0.161``).
With this truth a least-squares fit of the motor-disk chirp that neglects
the Coulomb term finds a larger ``p2 (1 + rho)`` than one that includes it
(about 2.35 against 2.18 from the encoder positions), as the paper did
(2.93 against 2.19), though by less.

Dead zone: ``v+ = 33``, ``v- = 29`` (asymmetric, both near the paper's 31);
break-away ``break_ratio = 0.15`` with ``omega_s = 2 rad/s``. Without
compensation the disk starts from rest at
``v = (1 + 0.15) v+ + sigma~_c2 / p3 = 43.1`` and ``-38.5`` (figure 2a).
With the paper's compensation ``v_dz = 31`` it starts at ``u = 12.1`` and
``-7.5``, and a moving disk keeps turning down to ``u = 7.1`` (residual
dead zone 2 plus the Coulomb equivalent ``sigma~_c2/p3 = 5.1``); at
``u = 15`` the disk turns at ``~28 rad/s`` where the static line
``q4 = p3 u / p2`` of model (9) predicts ``~53 rad/s``: the paper's "error
of 25 rad/s at u = 15" (figure 2b). The break-away ratio 0.15 (not larger) keeps the disk moving
at ``|u| = 15`` after compensation, as the paper reports.

Belt (eq. (15), figure 5): the paper's ``d = 2``, ``N = 13.5``; the stiffness
``k/I2 = 250 s^-2``, ``b2/I2 = 0.5 s^-1``, and ``k/gamma``,
``kT beta/(R gamma)`` from :meth:`BeltParameters.from_rigid` so that the rigid
limit of the belt reproduces the truth's ``p2 rho`` and ``p3 rho``. The
paper's own belt numbers (``b2/I2 = 10 s^-1``, ``k/gamma = 780 s^-1``,
``kT beta/(R gamma) = 26``) are not consistent with Table 1: their rigid
limit is ``p2 rho = 10 + N^2 (k/I2)/(k/gamma) = 24 s^-1`` and
``p3 rho = N (kT beta/(R gamma)) (k/I2)/(k/gamma) = 27``, against ``2.6`` and
``7.1`` from Table 1 (and ``b2/I2 = 10`` alone exceeds ``p2 rho``). The
stiffness was tuned, starting from the paper's 60 s^-2, so that, as in
figures 3 and 4, the rigid model (9) with the truth's lumped parameters
predicts the disk velocity for ``u = 60 sin 5t`` well and for
``u = 20 sin 5t`` clearly worse (a distorted sinusoid). Normalised RMS error
of the rigid prediction (:func:`rigid_fit_error`) for A = 60 / 40 / 20:

=========  ======  ======  ======
k/I2       A = 60  A = 40  A = 20
=========  ======  ======  ======
60         0.159   0.182   0.272
150        0.089   0.115   0.208
**250**    0.072   0.098   0.191
1000       0.054   0.081   0.173
=========  ======  ======  ======

(With a soft belt even A = 60 fits badly; a stiffer belt leaves the play of
``d = 2`` and the break-away as the only distortions.)

Closed loop (figure 10): with ``k1 = -10``, ``k2 = 0.1`` the rig settles on
an oscillation of amplitude ~2.55 rad (the paper: 2.58); model (9) with the
truth's lumped parameters gives 2.51. Coulomb friction and the residual
dead zone stop oscillations smaller than ~0.15 rad from growing, hence the
default start ``q1 = 0.3 rad`` (the paper does not give its initial state).

Sensors: 2000 counts/rev, ``Ts = 5 ms``, no noise, saturation 100.

Every value can be overridden from JSON (:meth:`RigTruth.from_json`, one
field at a time) or in Python (:meth:`RigTruth.replace`).

The experiments (:func:`list_experiments`)
------------------------------------------
``static-curve``, ``static-curve-compensated`` (figure 2), ``motor-disk-chirp``
(section 5.1), ``sine-60``, ``sine-40``, ``sine-20`` (figures 3, 4),
``free-pendulum`` (figure 8), ``full-chirp`` (figure 9) and ``closed-loop``
(figure 10), each with the paper's settings.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from ._util import check_finite, check_nonnegative, check_positive, prepare_output_file, read_json
from .errors import InputError
from .inputs import CallableController, Chirp, Constant, Sine, _Input
from .models import COULOMB_EPS, StartupFriction
from .params import BeltParameters, LumpedParameters

__all__ = [
    "RigTruth",
    "ExperimentSpec",
    "VirtualRig",
    "default_truth",
    "list_experiments",
    "run_experiment",
    "quantize",
    "rigid_fit_error",
    "write_result",
    "check_output_path",
    "PAPER_V_DZ",
    "EXPERIMENTS",
]

#: The paper's dead-zone compensation threshold ``v_dz`` (section 5.1) [input units].
PAPER_V_DZ = 31.0
#: Integration tolerances of the truth plant (the belt play makes it non-smooth).
RIG_RTOL = 1e-8
RIG_ATOL = 1e-8
#: Time constant of the first-order filter of the rig's velocity estimate [s].
VELOCITY_FILTER_TAU = 0.01
#: Window over which the static curves fit the disk velocity [s].
STATIC_WINDOW = 1.0



# --------------------------------------------------------------------------
# the truth
# --------------------------------------------------------------------------
def _default_lumped() -> LumpedParameters:
    return LumpedParameters(
        p1=26.0950,
        p2=0.00882,  # p2 (1 + rho) = 2.19, section 5.1 Coulomb model
        p3=0.0314,  # p3 (1 + rho) = 7.795
        rho=247.24,
        sigma_a1=0.0030,
        sigma_v1=0.01,
        sigma_b1=0.0005,
        v_dz_pos=33.0,
        v_dz_neg=29.0,
        sigma_c2=0.161,  # sigma~_c2 (1 + rho) = 40
    )


_DEFAULT_STARTUP = StartupFriction(break_ratio=0.15, omega_s=2.0)
_DEFAULT_BELT_SHAPE = {"k_over_I2": 250.0, "d": 2.0, "N": 13.5, "b2_over_I2": 0.5}
_BELT_DERIVED = ("k_over_gamma", "kTbeta_over_Rgamma")


def _rigid_belt(lumped: LumpedParameters, *, k_over_I2: float, d: float, N: float, b2_over_I2: float) -> BeltParameters:
    """The belt whose rigid limit matches ``lumped``'s ``p2 rho`` and ``p3 rho``."""
    return BeltParameters.from_rigid(lumped.p2 * lumped.rho, lumped.p3 * lumped.rho, k_over_I2=k_over_I2, d=d,
                                     N=N, b2_over_I2=b2_over_I2)


@dataclass(frozen=True)
class RigTruth:
    """Parameters of the virtual rig: the truth plant and its sensors.

    Parameters
    ----------
    lumped : LumpedParameters
        Pendulum, disk, dead zone (``v_dz_pos`` != ``v_dz_neg`` allowed) and
        Coulomb friction of the truth, in the units of model (6). Must be
        physical (:meth:`LumpedParameters.check_physical`).
    belt : BeltParameters or None
        The rubber belt (15) with the play hysteresis of figure 5; ``None``
        for a rigid coupling (the truth is then model (6) itself).
    startup : StartupFriction
        Break-away of the dead zone at rest (start-up discontinuity,
        figure 2a).
    coulomb_eps : float
        Regularisation of ``sgn(q4)`` in the Coulomb term [rad/s]
        (``tanh(q4/eps)``).
    counts_per_rev : int
        Encoder resolution [counts/rev]; the quantisation step is
        ``2 pi / counts_per_rev`` [rad] (the paper: 2000).
    Ts : float
        Sample time of the logs and of digital controllers [s] (the paper: 5 ms).
    noise_std : float
        Standard deviation of the Gaussian position noise added before
        quantisation [rad]; 0 for none.
    saturation : float or None
        The driver command is clipped to ``[-saturation, saturation]`` [input
        units]; ``None`` for no clipping.

    Notes
    -----
    Use :func:`default_truth` for the paper-like truth: ``RigTruth()`` alone
    has the default lumped parameters but no belt (a rigid coupling).
    :meth:`replace` changes fields as given; to change lumped parameters
    and keep the belt's rigid limit consistent, use
    ``RigTruth.from_dict({"lumped": {...}}, base=truth)``.
    """

    lumped: LumpedParameters = field(default_factory=_default_lumped)
    belt: BeltParameters | None = None
    startup: StartupFriction = _DEFAULT_STARTUP
    coulomb_eps: float = COULOMB_EPS  # [rad/s]
    counts_per_rev: int = 2000  # [counts/rev]
    Ts: float = 0.005  # [s]
    noise_std: float = 0.0  # [rad]
    saturation: float | None = 100.0  # [input units]

    def __post_init__(self) -> None:
        if not isinstance(self.lumped, LumpedParameters):
            raise InputError(f"RigTruth.lumped must be LumpedParameters, got {type(self.lumped).__name__}")
        self.lumped.check_physical("RigTruth.lumped")
        if self.belt is not None and not isinstance(self.belt, BeltParameters):
            raise InputError(f"RigTruth.belt must be BeltParameters or None, got {type(self.belt).__name__}")
        if not isinstance(self.startup, StartupFriction):
            raise InputError(f"RigTruth.startup must be StartupFriction, got {type(self.startup).__name__}")
        check_nonnegative("RigTruth.coulomb_eps", self.coulomb_eps)
        cpr = self.counts_per_rev
        if isinstance(cpr, bool) or not isinstance(cpr, (int, np.integer)) and not (
                isinstance(cpr, float) and cpr.is_integer()):
            raise InputError(f"RigTruth.counts_per_rev must be a positive integer, got {cpr!r}")
        if int(cpr) < 1:
            raise InputError(f"RigTruth.counts_per_rev must be a positive integer, got {cpr!r}")
        object.__setattr__(self, "counts_per_rev", int(cpr))
        object.__setattr__(self, "Ts", check_positive("RigTruth.Ts", self.Ts))
        object.__setattr__(self, "noise_std", check_nonnegative("RigTruth.noise_std", self.noise_std))
        if self.saturation is not None:
            object.__setattr__(self, "saturation", check_positive("RigTruth.saturation", self.saturation))
        object.__setattr__(self, "coulomb_eps", float(self.coulomb_eps))

    # ------------------------------------------------------------------
    @property
    def step(self) -> float:
        """Encoder quantisation step ``2 pi / counts_per_rev`` [rad]."""
        return 2.0 * math.pi / self.counts_per_rev

    @property
    def model(self) -> str:
        """The :mod:`iwp.models` model of the truth plant (``"belt-full"``, or ``"raw"`` without belt)."""
        return "raw" if self.belt is None else "belt-full"

    def replace(self, **changes: Any) -> "RigTruth":
        """A copy with ``changes`` applied (see :func:`dataclasses.replace`)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready nested dict (the format of :meth:`to_json`)."""
        return {
            "kind": "rig-truth",
            "lumped": self.lumped.to_dict(),
            "belt": None if self.belt is None else self.belt.to_dict(),
            "startup": {"break_ratio": float(self.startup.break_ratio), "omega_s": float(self.startup.omega_s)},
            "coulomb_eps": self.coulomb_eps,
            "counts_per_rev": self.counts_per_rev,
            "Ts": self.Ts,
            "noise_std": self.noise_std,
            "saturation": self.saturation,
        }

    def to_json(self, path: str | os.PathLike, *, force: bool = False) -> Path:
        """Write the truth as JSON (all fields); refuses to overwrite unless ``force``."""
        p = prepare_output_file(path, force=force)
        p.write_text(json.dumps(self.to_dict(), indent=2) + "\n")
        return p

    def to_json_line(self) -> str:
        """The truth as one line of JSON (for log metadata)."""
        return json.dumps(self.to_dict(), separators=(",", ":"))

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], *, base: "RigTruth | None" = None, where: str = "truth") -> "RigTruth":
        """Build a truth from a (possibly partial) dict, overriding ``base`` field by field.

        Accepted keys: ``kind`` (``"rig-truth"``), ``lumped`` / ``belt`` /
        ``startup`` (objects of their fields; ``belt: null`` for a rigid
        coupling), ``coulomb_eps``, ``counts_per_rev``, ``Ts``, ``noise_std``,
        ``saturation`` (``null`` for none). Missing entries keep ``base``'s
        value (default: :func:`default_truth`). When the lumped ``p2``,
        ``p3`` or ``rho`` or the belt's ``k_over_I2``, ``N`` or
        ``b2_over_I2`` change, the belt's ``k_over_gamma`` and
        ``kTbeta_over_Rgamma`` are derived again with
        :meth:`BeltParameters.from_rigid`, so that the belt's rigid limit
        stays consistent with the lumped parameters, unless the dict gives
        them with values other than ``base``'s.

        Raises
        ------
        InputError
            Naming ``where`` and the field (``lumped.p2``, ...): unknown
            field, not a number, not finite, wrong sign.
        """
        base = default_truth() if base is None else base
        if not isinstance(doc, Mapping):
            raise InputError(f"{where}: expected a JSON object with the fields of the rig truth")
        known = {"kind", "lumped", "belt", "startup", "coulomb_eps", "counts_per_rev", "Ts", "noise_std", "saturation"}
        unknown = sorted(set(doc) - known)
        if unknown:
            raise InputError(f"{where}: unknown field {unknown[0]!r}; known: {', '.join(sorted(known))}")
        kind = doc.get("kind", "rig-truth")
        if kind != "rig-truth":
            raise InputError(f"{where}: field 'kind' must be 'rig-truth', got {kind!r}")

        def section(name: str, cls_) -> dict[str, float]:
            values = doc.get(name, {})
            if not isinstance(values, Mapping):
                raise InputError(f"{where}: field {name!r} must be an object of name: number")
            names = [f.name for f in fields(cls_)]
            bad = sorted(set(values) - set(names))
            if bad:
                raise InputError(f"{where}: unknown field '{name}.{bad[0]}'; known: {', '.join(names)}")
            out = {}
            for key, val in values.items():
                out[key] = _number(f"{where}: field '{name}.{key}'", val)
            return out

        lumped_over = section("lumped", LumpedParameters)
        try:
            lumped = dataclasses.replace(base.lumped, **lumped_over)
            lumped.check_physical("")
        except InputError as exc:
            raise InputError(f"{where}: {_field_msg(str(exc), 'lumped')}") from None

        startup_over = section("startup", StartupFriction)
        sfield = {"break_ratio": ">= 0", "omega_s": "> 0"}
        for key, val in startup_over.items():
            if (key == "omega_s" and val <= 0) or (key == "break_ratio" and val < 0):
                raise InputError(f"{where}: field 'startup.{key}' must be {sfield[key]}, got {val!r}")
        startup = dataclasses.replace(base.startup, **startup_over)

        if "belt" in doc and doc["belt"] is None:
            belt = None
        else:
            belt_over = section("belt", BeltParameters)
            for key, val in belt_over.items():
                if val < 0 or (val == 0 and key not in ("d", "b2_over_I2")):
                    rel = ">= 0" if key in ("d", "b2_over_I2") else "> 0"
                    raise InputError(f"{where}: field 'belt.{key}' must be {rel}, got {val!r}")
            shape = dict(_DEFAULT_BELT_SHAPE)
            if base.belt is not None:
                shape = {k: getattr(base.belt, k) for k in _DEFAULT_BELT_SHAPE}
            shape.update({k: v for k, v in belt_over.items() if k in shape})
            rederive = base.belt is None or any(k in lumped_over for k in ("p2", "p3", "rho")) or any(
                k in belt_over for k in ("N", "b2_over_I2", "k_over_I2"))
            if rederive:
                try:
                    belt = _rigid_belt(lumped, **shape)
                except InputError as exc:
                    raise InputError(f"{where}: field 'belt.b2_over_I2': {exc}") from None
            else:
                belt = dataclasses.replace(base.belt, **{k: v for k, v in shape.items()})
            # derived fields left at the base's values (e.g. a file written by to_json whose
            # lumped part was edited) are derived again; other values are taken as given
            explicit = {k: v for k, v in belt_over.items()
                        if k in _BELT_DERIVED and (base.belt is None or v != getattr(base.belt, k))}
            if explicit:
                belt = dataclasses.replace(belt, **explicit)

        scalars: dict[str, Any] = {}
        for key in ("coulomb_eps", "Ts", "noise_std"):
            if key in doc:
                val = _number(f"{where}: field {key!r}", doc[key])
                if (key == "Ts" and val <= 0) or val < 0:
                    raise InputError(f"{where}: field {key!r} must be {'> 0' if key == 'Ts' else '>= 0'}, got {val!r}")
                scalars[key] = val
        if "counts_per_rev" in doc:
            val = doc["counts_per_rev"]
            if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val) \
                    or val != int(val) or val < 1:
                raise InputError(f"{where}: field 'counts_per_rev' must be a positive integer, got {val!r}")
            scalars["counts_per_rev"] = int(val)
        if "saturation" in doc:
            if doc["saturation"] is None:
                scalars["saturation"] = None
            else:
                val = _number(f"{where}: field 'saturation'", doc["saturation"])
                if val <= 0:
                    raise InputError(f"{where}: field 'saturation' must be > 0 (or null for none), got {val!r}")
                scalars["saturation"] = val
        try:
            return cls(lumped=lumped, belt=belt, startup=startup, **{**_scalars_of(base), **scalars})
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None

    @classmethod
    def from_json(cls, path: str | os.PathLike, *, base: "RigTruth | None" = None) -> "RigTruth":
        """Load a truth from JSON, overriding ``base`` (default: :func:`default_truth`) field by field.

        A file may hold only the fields to change, e.g.
        ``{"lumped": {"v_dz_pos": 35}, "noise_std": 0.001}``; see
        :meth:`from_dict` for the format. Errors name the file and the field.
        """
        p = Path(path)
        if not p.is_file():
            raise InputError(f"{p}: no such truth file")
        return cls.from_dict(read_json(p), base=base, where=str(p))


def _scalars_of(t: RigTruth) -> dict[str, Any]:
    return {k: getattr(t, k) for k in ("coulomb_eps", "counts_per_rev", "Ts", "noise_std", "saturation")}


def _number(what: str, val: Any) -> float:
    if isinstance(val, bool) or not isinstance(val, (int, float)):
        raise InputError(f"{what} must be a number, got {val!r}")
    if not math.isfinite(val):
        raise InputError(f"{what} must be finite, got {val!r}")
    return float(val)


def _field_msg(msg: str, prefix: str) -> str:
    """Turn "...: field 'p2' must be ..." into "field 'lumped.p2' must be ..."."""
    i = msg.find("field '")
    if i < 0:
        return msg.lstrip(": ")
    return "field '" + prefix + "." + msg[i + len("field '"):]


def default_truth() -> RigTruth:
    """The default truth plant, close to the paper (see the module docstring for the values and why)."""
    lumped = _default_lumped()
    return RigTruth(lumped=lumped, belt=_rigid_belt(lumped, **_DEFAULT_BELT_SHAPE), startup=_DEFAULT_STARTUP)


def quantize(q, step: float) -> np.ndarray:
    """Encoder reading of the angle ``q``: ``round(q / step) * step`` [rad].

    Rounds to the nearest count (mid-tread quantiser), so every value is an
    integer multiple of ``step`` and the error is within ``+-step/2``.
    """
    return np.round(np.asarray(q, dtype=float) / step) * step


# --------------------------------------------------------------------------
# experiments
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class ExperimentSpec:
    """One of the paper's experiments.

    Attributes
    ----------
    name : str
        Name for :meth:`VirtualRig.run` and ``iwp rig run``.
    description : str
        One line.
    reference : str
        Where it is in the paper.
    settings : dict
        The paper's settings (defaults of the run).
    options : tuple of str
        The overrides :meth:`VirtualRig.run` accepts for it.
    """

    name: str
    description: str
    reference: str
    settings: dict
    options: tuple[str, ...]

    def settings_text(self) -> str:
        """The settings as ``key=value`` pairs."""
        return ", ".join(f"{k}={_fmt(v)}" for k, v in self.settings.items())


def _fmt(v) -> str:
    if isinstance(v, (list, tuple)):
        return "[" + ",".join(_fmt(e) for e in v) + "]"
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


_COMMON = ("duration", "seed", "noise_std")
_STATIC_OPTS = ("amplitude", "step", "duration", "seed", "noise_std")

EXPERIMENTS: dict[str, ExperimentSpec] = {
    spec.name: spec
    for spec in [
        ExperimentSpec(
            "static-curve",
            "static curve v -> steady disk velocity, no compensation, pendulum locked",
            "section 5.1, figure 2(a)",
            {"input": "v", "amplitude": 100.0, "step": 2.0, "duration": 6.0, "locked": True, "compensated": False},
            _STATIC_OPTS,
        ),
        ExperimentSpec(
            "static-curve-compensated",
            "static curve u -> steady disk velocity through the feedforward v = u + 31 sgn u, pendulum locked",
            "section 5.1, figure 2(b)",
            {"input": "u", "amplitude": 60.0, "step": 2.0, "duration": 6.0, "locked": True, "v_dz": PAPER_V_DZ},
            _STATIC_OPTS + ("v_dz",),
        ),
        ExperimentSpec(
            "motor-disk-chirp",
            "chirp u = 60 sin((3.2 + t/75) t), pendulum locked, compensated",
            "section 5.1 (identification of p2(1+rho), p3(1+rho))",
            {"amplitude": 60.0, "w0": 3.2, "tau": 75.0, "duration": 300.0, "locked": True, "v_dz": PAPER_V_DZ},
            ("amplitude",) + _COMMON + ("v_dz",),
        ),
        *[
            ExperimentSpec(
                f"sine-{A}",
                f"sinusoid u = {A} sin(5 t), pendulum locked, compensated",
                f"section 5.1, figure {'3(a)' if A == 60 else '3(b)' if A == 40 else '4'}",
                {"amplitude": float(A), "omega": 5.0, "duration": 20.0, "locked": True, "v_dz": PAPER_V_DZ},
                ("amplitude",) + _COMMON + ("v_dz",),
            )
            for A in (60, 40, 20)
        ],
        ExperimentSpec(
            "free-pendulum",
            "free pendulum released from q1 = -1.422 rad at rest, u = 0",
            "section 5.2, figure 8 (the caption says -1.442 rad, ERRATA item 4)",
            {"x0": [-1.422, 0.0, 0.0, 0.0], "duration": 60.0, "locked": False},
            _COMMON + ("x0",),
        ),
        ExperimentSpec(
            "full-chirp",
            "chirp u = 60 sin((3 + t/100) t), pendulum free, compensated",
            "section 5.2, eq. (16), figure 9",
            {"amplitude": 60.0, "w0": 3.0, "tau": 100.0, "duration": 300.0, "locked": False, "v_dz": PAPER_V_DZ},
            ("amplitude",) + _COMMON + ("v_dz", "x0"),
        ),
        ExperimentSpec(
            "closed-loop",
            "Hopf anticontrol u = k1 q3 + k2 q3^3 on the measured q1, sampled every Ts, compensated",
            "section 5.3, figure 10 (amplitude ~2.58 rad)",
            {"k1": -10.0, "k2": 0.1, "x0": [0.3, 0.0, 0.0, 0.0], "duration": 60.0, "locked": False,
             "v_dz": PAPER_V_DZ, "filter_tau": VELOCITY_FILTER_TAU},
            _COMMON + ("k1", "k2", "x0", "v_dz", "filter_tau"),
        ),
    ]
}


def list_experiments() -> list[ExperimentSpec]:
    """The paper's experiments, in the paper's order (name, description, reference, settings)."""
    return list(EXPERIMENTS.values())


def _spec(name: str) -> ExperimentSpec:
    if not isinstance(name, str) or name not in EXPERIMENTS:
        raise InputError(f"unknown experiment {name!r}; valid: {', '.join(EXPERIMENTS)}")
    return EXPERIMENTS[name]


def _check_seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be an integer >= 0, got {seed!r}")
    return int(seed)


def _v_dz_pair(v_dz) -> tuple[float, float] | None:
    """``v_dz``: None (no compensation), a number (both sides) or a pair (v+, v-)."""
    if v_dz is None:
        return None
    if isinstance(v_dz, (list, tuple, np.ndarray)):
        if len(v_dz) != 2:
            raise InputError(f"v_dz must be a number or a pair (v_dz_pos, v_dz_neg), got {list(v_dz)!r}")
        pos, neg = v_dz
    else:
        pos = neg = v_dz
    return (check_nonnegative("v_dz (positive side)", pos), check_nonnegative("v_dz (negative side)", neg))


def _state4(x0, what: str = "x0") -> np.ndarray:
    if np.isscalar(x0):
        x0 = [x0, 0.0, 0.0, 0.0]
    try:
        x = np.array(x0, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError(f"{what} must be q1 or [q1, q2, q3, q4] (numbers), got {x0!r}") from None
    if x.size == 1:
        x = np.array([x[0], 0.0, 0.0, 0.0])
    if x.size != 4:
        raise InputError(f"{what} must be q1 or [q1, q2, q3, q4], got {x.size} values")
    if not np.all(np.isfinite(x)):
        raise InputError(f"{what} must be finite, got {x.tolist()}")
    return x


class _HopfOnEncoders:
    """The rig's digital Hopf controller: ``u = k1 q3^ + k2 q3^3``.

    ``q3^`` is the backward difference of the measured (quantised) ``q1``,
    low-pass filtered with a first-order filter of time constant ``tau``
    (discretised exactly: ``q3^_k = a q3^_{k-1} + (1 - a) (y_k - y_{k-1})/Ts``
    with ``a = exp(-Ts/tau)``; ``tau = 0``: no filter).
    """

    def __init__(self, k1: float, k2: float, Ts: float, tau: float):
        self.k1, self.k2, self.Ts = k1, k2, Ts
        self.a = math.exp(-Ts / tau) if tau > 0 else 0.0
        self.y_prev: float | None = None
        self.q3 = 0.0

    def __call__(self, t: float, y: np.ndarray) -> float:
        y1 = float(y[0])
        if self.y_prev is not None:
            d = (y1 - self.y_prev) / self.Ts
            self.q3 = self.a * self.q3 + (1.0 - self.a) * d
        self.y_prev = y1
        q3 = self.q3
        return self.k1 * q3 + self.k2 * q3 * q3 * q3


class VirtualRig:
    """The virtual inertia wheel pendulum rig.

    Parameters
    ----------
    truth : RigTruth, optional
        The truth plant and sensors (default: :func:`default_truth`).
    seed : int
        Seed of the measurement noise (``numpy.random.default_rng``); runs
        with the same truth, seed and options are bitwise identical.

    Examples
    --------
    >>> rig = VirtualRig(seed=1)
    >>> log = rig.run("sine-60", duration=5.0)       # ExperimentData
    >>> curve = rig.run("static-curve")               # StaticCurve
    >>> log.to_csv("sine60.csv")
    """

    def __init__(self, truth: RigTruth | None = None, seed: int = 0):
        if truth is None:
            truth = default_truth()
        if not isinstance(truth, RigTruth):
            raise InputError(f"truth must be a RigTruth, got {type(truth).__name__}")
        self.truth = truth
        self.seed = _check_seed(seed)

    def __repr__(self) -> str:
        return f"VirtualRig(seed={self.seed}, model={self.truth.model!r})"

    # ------------------------------------------------------------------
    @staticmethod
    def list_experiments() -> list[ExperimentSpec]:
        """The paper's experiments (see :func:`list_experiments`)."""
        return list_experiments()

    def run(self, name: str, **overrides):
        """Run one of the paper's experiments.

        Parameters
        ----------
        name : str
            One of :func:`list_experiments` (``iwp rig list``).
        **overrides
            Only those the experiment lists in ``options``:

            amplitude : float
                Input amplitude [input units] (static curves: the largest
                ``|v|`` or ``|u|`` of the sweep).
            step : float
                Static curves: spacing of the input values [input units].
            duration : float
                Length of the log [s] (static curves: how long each input is
                held before the velocity is read [s], >= 2).
            seed : int
                Noise seed (default: the rig's).
            noise_std : float
                Position noise [rad] (default: the truth's).
            k1, k2 : float
                Hopf gains [input units s/rad, s^3/rad^3].
            x0 : float or sequence of 4 floats
                Initial ``q1`` or ``[q1, q2, q3, q4]`` [rad, rad/s].
            v_dz : float or (float, float), or None
                Thresholds of the rig's dead-zone compensation (7)-(8);
                ``None`` switches it off.
            filter_tau : float
                Time constant of the velocity filter of the controller [s].

        Returns
        -------
        ExperimentData or StaticCurve

        Raises
        ------
        InputError
            Unknown experiment (the message lists the valid names), an
            option the experiment does not take, or a bad value.
        """
        spec = _spec(name)
        bad = sorted(set(overrides) - set(spec.options))
        if bad:
            raise InputError(
                f"experiment {name!r} does not take {bad[0]!r}; it takes: {', '.join(spec.options)}")
        s = dict(spec.settings)
        s.update({k: v for k, v in overrides.items()})
        seed = self.seed if overrides.get("seed") is None else _check_seed(overrides["seed"])
        noise = self.truth.noise_std if overrides.get("noise_std") is None else check_nonnegative(
            "noise_std", overrides["noise_std"])
        if name.startswith("static-curve"):
            return self._static_curve(spec, s, seed, noise)
        duration = check_positive("duration", s["duration"])
        v_dz = _v_dz_pair(s.get("v_dz"))
        meta = {"experiment": name, "reference": spec.reference, "description": spec.description}
        x0 = _state4(s["x0"]) if "x0" in s else None
        if name == "free-pendulum":
            return self.record(None, duration=duration, x0=x0, locked=False, v_dz=None, seed=seed,
                               noise_std=noise, metadata=meta, log_input=None)
        if name == "closed-loop":
            k1 = check_finite("k1", s["k1"])
            k2 = check_finite("k2", s["k2"])
            tau = check_nonnegative("filter_tau", s["filter_tau"])
            ctrl = _HopfOnEncoders(k1, k2, self.truth.Ts, tau)
            meta.update(k1=repr(k1), k2=repr(k2), filter_tau=repr(tau),
                        controller="u = k1 q3^ + k2 q3^3, q3^ = first-order filtered backward difference of the "
                                   "measured q1, sampled every Ts and held")
            return self.record(None, controller=ctrl, duration=duration, x0=x0, locked=False, v_dz=v_dz,
                               seed=seed, noise_std=noise, metadata=meta)
        inp = _open_loop_input(name, s)
        return self.record(inp, duration=duration, x0=x0, locked=bool(s["locked"]), v_dz=v_dz, seed=seed,
                           noise_std=noise, metadata=meta)

    # ------------------------------------------------------------------
    def record(
        self,
        input: _Input | None = None,
        *,
        controller: Callable[[float, np.ndarray], float] | None = None,
        duration: float,
        x0=None,
        locked: bool = False,
        v_dz=(PAPER_V_DZ, PAPER_V_DZ),
        seed: int | None = None,
        noise_std: float | None = None,
        metadata: Mapping[str, str] | None = None,
        log_input: str | None = "auto",
    ):
        """Run the truth plant with any input or digital controller and log it as the rig does.

        Parameters
        ----------
        input : iwp.inputs signal, optional
            Open-loop ideal input ``u(t)`` (or ``v(t)`` when ``v_dz`` is None)
            [input units]. ``None``: zero.
        controller : callable, optional
            Digital controller ``controller(t, y) -> u`` called every ``Ts``
            with the measured (noisy, quantised) positions ``y = [q1, q2]``
            [rad]; its output is held until the next sample. Exclusive with
            ``input``.
        duration : float
            Length of the log [s]; the log has ``floor(duration/Ts) + 1`` samples.
        x0 : float or sequence of 4 floats, optional
            Initial ``q1`` or ``[q1, q2, q3, q4]`` of the truth (belt relaxed).
            Default: rest at the bottom.
        locked : bool
            Clamp the pendulum at ``q1 = q3 = 0`` (section 5.1).
        v_dz : float, (float, float) or None
            Thresholds of the rig's feedforward (7)-(8); default the paper's
            31. ``None``: no compensation, the input is the raw ``v``.
        seed : int, optional
            Noise seed (default: the rig's).
        noise_std : float, optional
            Position noise [rad] (default: the truth's).
        metadata : dict, optional
            Extra metadata entries.
        log_input : {'auto', 'u', 'v', None}
            The name of the logged input: ``'auto'`` logs ``u`` when
            compensated and ``v`` otherwise; ``None`` logs no input (the
            iwp convention for a free pendulum with the motor off).

        Returns
        -------
        ExperimentData
        """
        from .io import ExperimentData
        from .simulate import simulate

        truth = self.truth
        duration = check_positive("duration", duration)
        if duration < 10 * truth.Ts:
            raise InputError(f"duration must be at least 10 samples ({10 * truth.Ts:g} s), got {duration!r} s")
        seed = self.seed if seed is None else _check_seed(seed)
        noise = truth.noise_std if noise_std is None else check_nonnegative("noise_std", noise_std)
        pair = _v_dz_pair(v_dz)
        if input is not None and controller is not None:
            raise InputError("give either input or controller, not both")
        if controller is not None and not callable(controller):
            raise InputError(f"controller must be callable, got {type(controller).__name__}")
        x = np.zeros(4) if x0 is None else _state4(x0)
        if locked and (x[0] != 0.0 or x[2] != 0.0):
            raise InputError(f"a locked pendulum starts at q1 = q3 = 0, got x0 = {x.tolist()}")
        x0_full = x if truth.belt is None else np.concatenate([x, [0.0, 0.0]])

        n = int(math.floor(duration / truth.Ts + 1e-9)) + 1
        rng = np.random.default_rng(seed)
        noise_arr = rng.normal(0.0, noise, size=(n, 2)) if noise > 0 else np.zeros((n, 2))
        step = truth.step
        seen: dict[int, np.ndarray] = {}
        sim_input = input
        if controller is not None:
            Ts = truth.Ts

            def sampled(t: float, xs: np.ndarray) -> float:
                k = int(round(t / Ts))
                y = quantize(xs[:2] + noise_arr[min(k, n - 1)], step)
                seen[k] = y
                return controller(t, y.copy())

            sim_input = CallableController(sampled, Ts=Ts)
        res = simulate(
            truth.lumped, model=truth.model, x0=x0_full, t_end=(n - 1) * truth.Ts, Ts=truth.Ts, input=sim_input,
            feedforward=pair, saturation=truth.saturation, belt=truth.belt, startup=truth.startup,
            coulomb_eps=truth.coulomb_eps, locked=locked, dead_zone_active=True, rtol=RIG_RTOL, atol=RIG_ATOL,
        )
        X = res.x
        meas = quantize(X[:, :2] + noise_arr[: X.shape[0]], step)
        for k, y in seen.items():  # what the controller saw is what the rig logged
            if k < meas.shape[0]:
                meas[k] = y
        compensated = pair is not None
        if log_input not in ("auto", "u", "v", None):
            raise InputError(f"log_input must be 'auto', 'u', 'v' or None, got {log_input!r}")
        name = ("u" if compensated else "v") if log_input == "auto" else log_input
        extra = {f"true_q{i + 1}": X[:, i].copy() for i in range(4)}
        if compensated:
            extra["v_command"] = res.command.copy()
        inputs = {} if name is None else {name: res.u.copy() if compensated else res.command.copy()}
        meta = {k: str(v) for k, v in (metadata or {}).items()}
        fixed = {
            "source": "iwp virtual rig",
            "seed": str(seed),
            "input": "controller" if controller is not None else (input.describe() if input is not None else "zero"),
            "compensated": "yes" if compensated else ("no" if name is not None else "no (motor off, v = 0)"),
            "v_dz_pos": repr(pair[0]) if compensated else "",
            "v_dz_neg": repr(pair[1]) if compensated else "",
            "pendulum": "locked" if locked else "free",
            "x0": json.dumps([float(e) for e in x]),
            "duration": repr(float(res.t[-1])),
            "Ts": repr(truth.Ts),
            "counts_per_rev": str(truth.counts_per_rev),
            "noise_std": repr(noise),
            "saturation": repr(truth.saturation),
            "columns": "q1, q2: quantised encoder positions [rad]; true_q1..true_q4: noise-free truth states "
                       "[rad, rad/s], not available on a real rig"
                       + ("; v_command: driver command after compensation and saturation" if compensated else ""),
            "truth": truth.replace(noise_std=noise).to_json_line(),
        }
        if not compensated:
            del fixed["v_dz_pos"], fixed["v_dz_neg"]
        for k, v in fixed.items():
            meta.setdefault(k, v)
        return ExperimentData(t=res.t, q1=meas[:, 0], q2=meas[:, 1], extra=extra, metadata=meta,
                              source=f"virtual rig: {meta.get('experiment', 'record')}", **inputs)

    # ------------------------------------------------------------------
    def _static_curve(self, spec: ExperimentSpec, s: dict, seed: int, noise: float):
        """Figure 2: hold each input from rest, read the steady disk velocity from the measured q2."""
        from .io import StaticCurve
        from .simulate import simulate

        truth = self.truth
        amplitude = check_positive("amplitude", s["amplitude"])
        step_in = check_positive("step", s["step"])
        hold = check_finite("duration", s["duration"])
        if hold < 2 * STATIC_WINDOW:
            raise InputError(f"duration (hold time per point) must be >= {2 * STATIC_WINDOW:g} s, got {hold!r} s")
        m = int(math.floor(amplitude / step_in + 1e-9))
        if m > 10_000:
            raise InputError(f"amplitude/step gives {2 * m + 1} points; at most 20001 are allowed")
        grid = step_in * np.arange(-m, m + 1)
        compensated = spec.name.endswith("compensated")
        pair = _v_dz_pair(s.get("v_dz")) if compensated else None
        if compensated and pair is None:
            raise InputError("static-curve-compensated needs v_dz (use static-curve for no compensation)")
        rng = np.random.default_rng(seed)
        Ts = truth.Ts
        n = int(math.floor(hold / Ts + 1e-9)) + 1
        t = Ts * np.arange(n)
        win = t >= t[-1] - STATIC_WINDOW - 1e-9
        x0 = np.zeros(4 if truth.belt is None else 6)
        q4 = np.empty(grid.size)
        for i, val in enumerate(grid):
            res = simulate(truth.lumped, model=truth.model, x0=x0, t_end=(n - 1) * Ts, Ts=Ts, input=Constant(val),
                           feedforward=pair, saturation=truth.saturation, belt=truth.belt, startup=truth.startup,
                           coulomb_eps=truth.coulomb_eps, locked=True, dead_zone_active=True, rtol=RIG_RTOL,
                           atol=RIG_ATOL)
            q2 = res.x[:, 1]
            if noise > 0:
                q2 = q2 + rng.normal(0.0, noise, size=q2.size)
            q2m = quantize(q2, truth.step)
            tw = t[win] - t[win].mean()
            q4[i] = float(np.dot(tw, q2m[win] - q2m[win].mean()) / np.dot(tw, tw)) + 0.0  # no -0.0
        meta = {
            "experiment": spec.name,
            "reference": spec.reference,
            "description": spec.description,
            "source": "iwp virtual rig",
            "seed": str(seed),
            "compensated": "yes" if compensated else "no",
            "pendulum": "locked",
            "hold": repr(hold),
            "velocity": f"least-squares slope of the quantised q2 over the last {STATIC_WINDOW:g} s of each hold, "
                        "each point started from rest",
            "Ts": repr(Ts),
            "counts_per_rev": str(truth.counts_per_rev),
            "noise_std": repr(noise),
            "saturation": repr(truth.saturation),
            "truth": truth.replace(noise_std=noise).to_json_line(),
        }
        if compensated:
            meta.update(v_dz_pos=repr(pair[0]), v_dz_neg=repr(pair[1]))
        return StaticCurve(input_name="u" if compensated else "v", input=grid, q4=q4, metadata=meta,
                           source=f"virtual rig: {spec.name}")


def run_experiment(name: str, *, truth: RigTruth | None = None, seed: int = 0, **overrides):
    """``VirtualRig(truth, seed).run(name, **overrides)``: one experiment of the default rig."""
    return VirtualRig(truth, seed=seed).run(name, **overrides)


_STATIC_EXT = (".csv", ".txt")
_SERIES_EXT = (".csv", ".txt", ".parquet", ".pq", ".mat")  # those of iwp.io.write_experiment


def check_output_path(name: str, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Check, before running experiment ``name``, that its result may be written to ``path``.

    Static curves are CSV (``.csv``/``.txt``); time series are CSV, Parquet
    or MAT by extension (see :func:`iwp.io.write_experiment`). Refuses an
    existing file unless ``force``.
    """
    _spec(name)
    p = Path(path)
    ext = p.suffix.lower()
    if name.startswith("static-curve"):
        if ext not in _STATIC_EXT:
            raise InputError(f"{p}: a static curve is written as CSV; use the extension .csv or .txt")
    elif ext not in _SERIES_EXT:
        raise InputError(f"{p}: cannot tell the output format from the extension {ext or '(none)'!r}; "
                         f"use one of {', '.join(_SERIES_EXT)}")
    return prepare_output_file(p, force=force)


def write_result(result, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Write what :meth:`VirtualRig.run` returned: a static curve as CSV, a log by extension."""
    from .io import ExperimentData, StaticCurve, write_experiment, write_static_curve

    if isinstance(result, StaticCurve):
        if Path(path).suffix.lower() not in _STATIC_EXT:
            raise InputError(f"{path}: a static curve is written as CSV; use the extension .csv or .txt")
        return write_static_curve(result, path, force=force)
    if isinstance(result, ExperimentData):
        return write_experiment(result, path, force=force)
    raise InputError(f"result must be ExperimentData or StaticCurve, got {type(result).__name__}")


def rigid_fit_error(name: str, *, truth: RigTruth | None = None, seed: int = 0, skip: float = 5.0,
                    **overrides) -> float:
    """Normalised RMS error of the rigid model (9) predicting the disk velocity of an experiment.

    Runs the experiment ``name`` (one with an open-loop input, e.g.
    ``"sine-60"``) on the virtual rig, simulates the compensated model (9)
    with the truth's lumped parameters (same input, same clamp, exact
    dead-zone compensation, Coulomb term included, rigid coupling) and
    returns ``std(q4_rigid - q4_true) / std(q4_true)`` over ``t >= skip``,
    with ``q4_true`` the truth's disk velocity (column ``true_q4``): the
    error ``e`` of figures 3 and 4 in relative form.
    """
    from .simulate import simulate

    rig = VirtualRig(truth, seed=seed)
    log = rig.run(name, **overrides)
    s = {**EXPERIMENTS[name].settings, **overrides}
    inp = _open_loop_input(name, s)
    if inp is None:
        raise InputError(f"rigid_fit_error needs an experiment with an open-loop input, not {name!r}")
    res = simulate(rig.truth.lumped, model="compensated", t_end=float(log.t[-1]), Ts=rig.truth.Ts, input=inp,
                   coulomb_eps=rig.truth.coulomb_eps, locked=bool(s.get("locked")), rtol=RIG_RTOL, atol=RIG_ATOL)
    m = log.t >= skip
    q4 = log.extra["true_q4"][m]
    return float(np.std(res.q4[m] - q4) / np.std(q4))


def _open_loop_input(name: str, s: Mapping[str, Any]) -> _Input | None:
    """The ideal input of an open-loop experiment with settings ``s``."""
    if name.startswith("sine-"):
        return Sine(check_finite("amplitude", s["amplitude"]), s["omega"])
    if name.endswith("chirp"):
        return Chirp(check_finite("amplitude", s["amplitude"]), s["w0"], s["tau"])
    return None

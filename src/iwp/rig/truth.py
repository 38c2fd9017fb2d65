"""The truth plant of the virtual rig: richer than the identified model, with the rig's sensors.

Model (6) driven by the raw driver input ``v``, made richer than the model
that the paper identifies (its eq. (9)) in the ways the paper reports
(sections 3.2 and 5.1); it is the model ``"belt-full"`` of
:mod:`iwp.models` (:meth:`RigTruth.plant`):

* the pendulum (4a) with viscous and rolling friction (section 3.1);
* an asymmetric dead zone (5), ``v+ != v-``, with a break-away at start-up
  (:class:`~iwp.models.StartupFriction`): at rest the thresholds are
  ``(1 + break_ratio)`` times larger, which gives the discontinuity of
  figure 2(a) when the disk starts;
* viscous friction and Coulomb friction ``sigma~_c2 sgn q4`` at the disk
  (section 5.1, "Analysis of the Coulomb friction phenomenon");
* a motor gain that may differ by the sign of the voltage (section 3.2,
  :attr:`BeltParameters.gain_neg`), and a winding resistance that may differ
  between the sessions of the paper's experiments (:attr:`RigTruth.resistance_ratio`);
* the rubber belt of eq. (15) with the play hysteresis of figure 5 between
  motor and disk (motor inertia neglected, as in the paper);
* optionally a clamp holding the pendulum at rest (section 5.1).

The default truth (:func:`default_truth`): a calibrated twin
--------------------------------------------------------------
Table 1 is what the paper's procedures *returned* on its rig, biased by the
belt, the dead zone, Coulomb friction and the differentiation; it is not the
rig's truth. The default truth is the one on which the same procedures,
applied as ``iwp rig run NAME`` + ``iwp identify FILE --setup SETUP`` apply
them, return the paper's published numbers: it is found by indirect
inference (:mod:`iwp.calibration.calibrate`, ``iwp rig calibrate``) and shipped as
``default_truth.json`` (:data:`DEFAULT_TRUTH_FILE`), with where each value
came from (the calibration, the paper, an assumption) and the calibration's
residual table (:func:`truth_record`; ``docs/calibration.md`` discusses
them). Beyond what the paper itself describes (dead zone, start-up jump,
Coulomb friction, belt), one structure is what its numbers demand: a winding
resistance that differs between the session of section 5.1 and that of
sections 5.2-5.3 (:attr:`RigTruth.resistance_ratio`,
:meth:`RigTruth.for_session`). The paper's ``p2(1+rho)``, ``p3(1+rho)`` of
the free-pendulum chirp are 11 % and 8 % below those of the locked chirp,
while the free arm's recoil would make them ``(1+rho)/rho`` larger; every
other parameter of the family moves both chirps' estimates together, and a
warmer winding lowers both ``p2`` and ``p3`` by one factor.

:func:`uncalibrated_truth` is the hand-set structure the calibration started
from (Table 1 with the paper's Coulomb model).

Every value can be overridden from JSON (:meth:`RigTruth.from_json`, one
field at a time) or in Python (:meth:`RigTruth.replace`).
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import json
import math
import os
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..checks import check_nonnegative, check_positive
from ..errors import InputError
from ..files import prepare_output_file, read_json
from ..models.actuator import StartupFriction
from ..models.encoder import encoder_step
from ..models.friction import COULOMB_EPS
from ..models.parameters import BeltParameters, LumpedParameters, table1
from ..models.plant import Plant

__all__ = ["RigTruth", "MAX_NOISE", "MIN_COULOMB_EPS", "check_noise", "check_coulomb_eps", "default_truth",
           "uncalibrated_truth", "truth_record", "DEFAULT_TRUTH_FILE", "SESSIONS"]


#: Largest measurement noise of the virtual rig's angles [rad] (an encoder's is a few thousandths).
MAX_NOISE = 1.0
#: Narrowest smoothing of ``sgn(q4)`` the truth's Coulomb friction may have [rad/s]. Narrower makes the
#: truth too stiff to integrate: a 60 s free swing of the default truth took 1.1 s at 1e-3, 3.5 s at 1e-4,
#: 26 s at 1e-5, and stopped at the step limit after 39 s at 1e-6 (2026-12-07, 2-core machine).
MIN_COULOMB_EPS = 1e-4


def check_noise(noise_std: float, name: str = "noise_std") -> float:
    """The standard deviation of the position noise [rad]: finite, from 0 to :data:`MAX_NOISE`.

    ``name`` is the argument as the caller gave it (the key or flag an error names).
    """
    x = check_nonnegative(name, noise_std)
    if x > MAX_NOISE:
        raise InputError(f"{name} = {x:g} rad: a measurement noise beyond {MAX_NOISE:g} rad is no measurement "
                         "of an angle", argument="noise_std")
    return x


def check_coulomb_eps(eps: float, name: str = "coulomb_eps") -> float:
    """The smoothing width of the truth's Coulomb friction [rad/s]: at least :data:`MIN_COULOMB_EPS`."""
    x = check_nonnegative(name, eps)
    if x < MIN_COULOMB_EPS:
        raise InputError(f"{name} = {x:g} rad/s: the virtual rig smooths sgn(q4) over at least {MIN_COULOMB_EPS:g} "
                         "rad/s (narrower, a run of its truth is too stiff to integrate: a 60 s swing at 1e-6 ends at "
                         "the integrator's step limit); the default is 0.01", argument="coulomb_eps")
    return x


def _default_lumped() -> LumpedParameters:
    """Table 1's pendulum and ``rho``; the disk of the paper's Coulomb model; an asymmetric dead zone."""
    return table1().replace(
        p2=0.00882,  # p2 (1 + rho) = 2.19, section 5.1 Coulomb model
        p3=0.0314,  # p3 (1 + rho) = 7.795
        v_dz_pos=33.0,
        v_dz_neg=29.0,
        sigma_c2=0.161,  # sigma~_c2 (1 + rho) = 40
    )


#: Break-away of the default truth's dead zone (start-up discontinuity of figure 2a).
DEFAULT_STARTUP = StartupFriction(break_ratio=0.15, omega_s=2.0)
#: The default belt's shape; its ``k_over_gamma`` and ``kTbeta_over_Rgamma`` follow from the lumped parameters.
DEFAULT_BELT_SHAPE = {"k_over_I2": 250.0, "d": 2.0, "N": 13.5, "b2_over_I2": 0.5, "gain_neg": 1.0}
_BELT_DERIVED = ("k_over_gamma", "kTbeta_over_Rgamma")


#: The scalar fields whose range is checked beyond their sign (as the file names them).
_CHECKS = {"noise_std": check_noise, "coulomb_eps": check_coulomb_eps}


def _rigid_belt(lumped: LumpedParameters, *, k_over_I2: float, d: float, N: float, b2_over_I2: float,
                gain_neg: float = 1.0) -> BeltParameters:
    """The belt whose rigid limit matches ``lumped``'s ``p2 rho`` and ``p3 rho``."""
    return BeltParameters.from_rigid(lumped.p2 * lumped.rho, lumped.p3 * lumped.rho, k_over_I2=k_over_I2, d=d,
                                     N=N, b2_over_I2=b2_over_I2, gain_neg=gain_neg)


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
    resistance_ratio : float
        Winding resistance of the dc motor during the experiments of session
        ``"5.2"`` (free pendulum, full chirp, closed loop: sections 5.2 and
        5.3) over that during session ``"5.1"`` (the motor-disk experiments of
        section 5.1) [-]; 1 for none. A warmer winding (copper: +0.39 % per
        kelvin) lowers the motor's torque constant over resistance ``kT/R``,
        so the gain ``p3`` and the back-emf part of ``p2`` fall by this factor
        (:meth:`for_session`). The values of the other fields are those of
        session ``"5.1"``.

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
    startup: StartupFriction = DEFAULT_STARTUP
    coulomb_eps: float = COULOMB_EPS  # [rad/s]
    counts_per_rev: int = 2000  # [counts/rev]
    Ts: float = 0.005  # [s]
    noise_std: float = 0.0  # [rad]
    saturation: float | None = 100.0  # [input units]
    resistance_ratio: float = 1.0  # [-]

    def __post_init__(self) -> None:
        if not isinstance(self.lumped, LumpedParameters):
            raise InputError(f"RigTruth.lumped must be LumpedParameters, got {type(self.lumped).__name__}")
        self.lumped.check_physical("RigTruth.lumped")
        if self.belt is not None and not isinstance(self.belt, BeltParameters):
            raise InputError(f"RigTruth.belt must be BeltParameters or None, got {type(self.belt).__name__}")
        if not isinstance(self.startup, StartupFriction):
            raise InputError(f"RigTruth.startup must be StartupFriction, got {type(self.startup).__name__}")
        check_coulomb_eps(self.coulomb_eps, "RigTruth.coulomb_eps")
        cpr = self.counts_per_rev
        if isinstance(cpr, bool) or not isinstance(cpr, (int, np.integer)) and not (
                isinstance(cpr, float) and cpr.is_integer()):
            raise InputError(f"RigTruth.counts_per_rev must be a positive integer, got {cpr!r}")
        if int(cpr) < 1:
            raise InputError(f"RigTruth.counts_per_rev must be a positive integer, got {cpr!r}")
        object.__setattr__(self, "counts_per_rev", int(cpr))
        object.__setattr__(self, "Ts", check_positive("RigTruth.Ts", self.Ts))
        object.__setattr__(self, "noise_std", check_noise(self.noise_std, "RigTruth.noise_std"))
        if self.saturation is not None:
            object.__setattr__(self, "saturation", check_positive("RigTruth.saturation", self.saturation))
        object.__setattr__(self, "coulomb_eps", float(self.coulomb_eps))
        object.__setattr__(self, "resistance_ratio", check_positive("RigTruth.resistance_ratio",
                                                                    self.resistance_ratio))

    # ------------------------------------------------------------------
    @property
    def step(self) -> float:
        """Encoder quantisation step ``2 pi / counts_per_rev`` [rad]."""
        return encoder_step(self.counts_per_rev)

    @property
    def model(self) -> str:
        """The :mod:`iwp.models` model of the truth plant (``"belt-full"``, or ``"raw"`` without belt)."""
        return "raw" if self.belt is None else "belt-full"

    def plant(self, *, locked: bool = False) -> Plant:
        """The truth plant: model (6) with the belt (15), driven by ``v`` through the dead zone (5).

        Parameters
        ----------
        locked : bool
            The pendulum clamped at ``q1 = q3 = 0`` (section 5.1).
        """
        return Plant(self.lumped, model=self.model, belt=self.belt, startup=self.startup,
                     coulomb_eps=self.coulomb_eps, locked=locked, dead_zone=True)

    def for_session(self, session: str) -> "RigTruth":
        """The truth as it was during one session of the paper's experiments.

        Session ``"5.1"`` (the motor-disk experiments) is the truth itself.
        In session ``"5.2"`` (free pendulum, full chirp, closed loop) the
        winding resistance is :attr:`resistance_ratio` times larger: the
        motor's ``kT/R`` falls by that factor, hence its gain ``p3`` and the
        back-emf damping ``N^2 kT kF / R`` (the part of ``p2`` that is not the
        disk's viscous friction ``b2``). In the belt (15) with the motor's
        own viscous friction neglected (``gamma = N^2 kT kF / R``), ``k/gamma``
        rises by the factor and ``kT beta/(R gamma)`` stays. The result has
        ``resistance_ratio = 1`` (applying it twice changes nothing).

        Parameters
        ----------
        session : {"5.1", "5.2"}
            :attr:`iwp.rig.ExperimentSpec.session`.
        """
        if session not in SESSIONS:
            raise InputError(f"session must be one of {', '.join(SESSIONS)}, got {session!r}")
        r = self.resistance_ratio
        if session == "5.1" or r == 1.0:
            return self
        L = self.lumped
        if self.belt is None:
            return self.replace(lumped=L.replace(p2=L.p2 / r, p3=L.p3 / r), resistance_ratio=1.0)
        b2 = self.belt.b2_over_I2 / L.rho  # the disk's viscous friction over I1_hat [1/s]
        lumped = L.replace(p2=b2 + (L.p2 - b2) / r, p3=L.p3 / r)
        belt = dataclasses.replace(self.belt, k_over_gamma=self.belt.k_over_gamma * r)
        return self.replace(lumped=lumped, belt=belt, resistance_ratio=1.0)

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
            "resistance_ratio": self.resistance_ratio,
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
        ``saturation`` (``null`` for none), ``resistance_ratio``; the record
        of a calibrated truth (``provenance``, ``calibration``, ``notes``,
        written by ``iwp rig calibrate``) is accepted and not read. Missing entries keep ``base``'s
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
        known = {"kind", "lumped", "belt", "startup", "coulomb_eps", "counts_per_rev", "Ts", "noise_std", "saturation",
                 "resistance_ratio"} | set(_RECORD_KEYS)
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
            shape = dict(DEFAULT_BELT_SHAPE)
            if base.belt is not None:
                shape = {k: getattr(base.belt, k) for k in DEFAULT_BELT_SHAPE}
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
        for key in ("coulomb_eps", "Ts", "noise_std", "resistance_ratio"):
            if key in doc:
                val = _number(f"{where}: field {key!r}", doc[key])
                positive = key in ("Ts", "resistance_ratio")
                if (positive and val <= 0) or val < 0:
                    raise InputError(f"{where}: field {key!r} must be {'> 0' if positive else '>= 0'}, got {val!r}")
                if key in _CHECKS:
                    _CHECKS[key](val, f"{where}: field {key!r}")
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


#: keys of a truth file that record where its values came from; read by :func:`truth_record`, not by the truth
_RECORD_KEYS = ("provenance", "calibration", "notes")
#: the sessions of the paper's experiments (:attr:`iwp.rig.ExperimentSpec.session`)
SESSIONS = ("5.1", "5.2")


def _scalars_of(t: RigTruth) -> dict[str, Any]:
    return {k: getattr(t, k) for k in ("coulomb_eps", "counts_per_rev", "Ts", "noise_std", "saturation",
                                       "resistance_ratio")}


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


def uncalibrated_truth() -> RigTruth:
    """The twin's structure with hand-set values: the start of the shipped calibration.

    Table 1's pendulum and ``rho``, the disk of the paper's Coulomb model
    (``p2(1+rho) = 2.19``, ``p3(1+rho) = 7.795``, ``sigma~_c2(1+rho) = 40``),
    an asymmetric dead zone ``v+ = 33``, ``v- = 29`` with a start-up jump of
    15 %, a belt with ``k/I2 = 250``, ``d = 2`` and the rigid limit of these,
    no difference between the sessions. On it the paper's procedures return
    8 of the paper's 21 numbers within tolerance (issue 12).

    See Also
    --------
    default_truth : The calibrated twin that starts here.

    Examples
    --------
    The calibration moved the hand-set dead zone to what reproduces the paper's ``v+ ~ v- ~ 31``:

    >>> from iwp.rig import default_truth, uncalibrated_truth
    >>> start = uncalibrated_truth()
    >>> start.lumped.v_dz_pos, start.lumped.v_dz_neg
    (33.0, 29.0)
    >>> round(default_truth().lumped.v_dz_pos, 2), round(default_truth().lumped.v_dz_neg, 2)
    (24.71, 24.36)
    """
    lumped = _default_lumped()
    return RigTruth(lumped=lumped, belt=_rigid_belt(lumped, **DEFAULT_BELT_SHAPE), startup=DEFAULT_STARTUP)


#: The calibrated truth shipped with iwp (``iwp rig calibrate`` with the paper's targets).
DEFAULT_TRUTH_FILE = Path(__file__).with_name("default_truth.json")


@functools.lru_cache(maxsize=1)
def _shipped_truth() -> tuple[RigTruth, dict[str, Any]]:
    doc = read_json(DEFAULT_TRUTH_FILE)
    truth = RigTruth.from_dict(doc, base=uncalibrated_truth(), where=str(DEFAULT_TRUTH_FILE))
    return truth, {k: doc[k] for k in _RECORD_KEYS if k in doc}


def default_truth() -> RigTruth:
    """The default truth plant: the calibrated twin of the paper's rig (``default_truth.json``).

    Its values are those of the shipped file :data:`DEFAULT_TRUTH_FILE`,
    written by the calibration (:func:`iwp.calibration.calibrate.calibrate`) with the
    paper's published numbers as targets; where each came from and the
    calibration's residual table are in :func:`truth_record`.

    Examples
    --------
    >>> from iwp import default_truth
    >>> truth = default_truth()
    >>> truth.Ts, truth.counts_per_rev  # the rig's period [s] and encoders
    (0.005, 2000)
    """
    return _shipped_truth()[0]


def truth_record() -> dict[str, Any]:
    """The record of the default truth.

    ``provenance`` (where each value came from), ``calibration`` (settings,
    residual table published against reproduced, sensitivity, outcome) and
    ``notes``.

    Examples
    --------
    >>> from iwp.rig import truth_record
    >>> record = truth_record()
    >>> sorted(record)
    ['calibration', 'notes', 'provenance']
    >>> record["provenance"]["counts_per_rev"]
    'paper, section 5: 2000 counts/rev'
    >>> record["calibration"]["within"]  # the paper's numbers the twin reproduces
    '20 of 21 graded targets'
    >>> row = record["calibration"]["residuals"][0]
    >>> row["key"], row["published"], round(row["reproduced"], 2)
    ('v_dz_pos', 31.0, 30.98)
    """
    return copy.deepcopy(_shipped_truth()[1])

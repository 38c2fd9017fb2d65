"""Parameters of the inertia wheel pendulum.

Two levels, as in the paper:

* :class:`PhysicalParameters` -- masses, inertias, lengths, motor constants
  and friction coefficients in SI units (sections 2 and 3).
* :class:`LumpedParameters` -- the lumped parameters of the state-space models
  (6) and (9) (section 4): ``p1, p2, p3, rho, sigma_a1, sigma_v1, sigma_b1``,
  the dead-zone thresholds ``v_dz_pos, v_dz_neg`` of (5)/(8) in input units,
  and the Coulomb coefficient ``sigma_c2`` of section 5.1; for other rigs,
  the Coulomb friction ``sigma_c1`` of the pendulum joint and an input
  offset ``u_offset`` (both 0 in the paper's model).

:meth:`PhysicalParameters.to_lumped` is the mapping of section 4.
:func:`table1` returns the paper's Table 1. Parameter sets load from and save
to JSON with :func:`load_params` / :func:`save_params`.

Both classes are frozen dataclasses: pass them to the pure functions of
:mod:`iwp.models` and :mod:`iwp.simulate`; change one field with
:func:`dataclasses.replace`.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import warnings
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..files import prepare_output_file, read_json
from .belt_parameters import BELT_INFO, BeltParameters
from .encoder import EncoderZero
from .parameter_info import ParameterInfo, check_fields, info_table, names_with_sign
from .terms import term_parameters

__all__ = [
    "BELT_INFO",
    "DERIVED",
    "LUMPED_INFO",
    "PARAMETER_INFO",
    "ParameterInfo",
    "parameter_info",
    "PhysicalParameters",
    "LumpedParameters",
    "BeltParameters",
    "table1",
    "paper_belt",
    "load_params",
    "save_params",
    "named_params",
    "stored_model",
    "stored_belt",
]


#: The lumped parameters of section 4, then the optional terms' (:data:`iwp.models.terms.TERMS`), by name.
LUMPED_INFO: dict[str, ParameterInfo] = {**info_table("lumped", (
    ("p1", "1/s^2", 26.0, "positive", "gravity term (m1 c + m2 l) g / I1_hat"),
    ("p2", "1/s", 0.01, "nonnegative", "back-emf and viscous friction of the disk over I1_hat"),
    ("p3", "rad/(s^2 in)", 0.03, "positive", "input gain beta N kT / (I1_hat R)"),
    ("rho", "-", 250.0, "positive", "inertia ratio I1_hat / I2"),
    ("sigma_a1", "1/s", 0.003, "nonnegative", "rolling friction |cos q1| q3 of the pendulum (section 3.1)"),
    ("sigma_v1", "1/s", 0.01, "nonnegative", "viscous friction of the pendulum (section 3.1)"),
    ("sigma_b1", "s/rad^2", 5e-4, "nonnegative", "centrifugal rolling friction q3^3 of the pendulum (section 3.1)"),
)), **{p.name: p for p in term_parameters()}}

#: Every model parameter by name (lumped and belt).
PARAMETER_INFO: dict[str, ParameterInfo] = {**LUMPED_INFO, **BELT_INFO}

#: Parameters derived from others, as expressions over their names (section 5.1 identifies these products).
DERIVED: dict[str, tuple[str, str]] = {
    "p2_1rho": ("p2 * (1 + rho)", "1/s"),
    "p3_1rho": ("p3 * (1 + rho)", "rad/(s^2 in)"),
    "sigma_c2_1rho": ("sigma_c2 * (1 + rho)", "rad/s^2"),
}

#: Typical magnitudes by name (:attr:`ParameterInfo.typical`).
TYPICAL: dict[str, float] = {n: i.typical for n, i in PARAMETER_INFO.items()}


def parameter_info(name: str) -> ParameterInfo:
    """The :class:`ParameterInfo` of a parameter name; a clear error for an unknown one.

    Parameters
    ----------
    name : str
        Parameter name (a key of :data:`PARAMETER_INFO`, e.g. ``"p1"``).

    Returns
    -------
    ParameterInfo
        Its description, unit and role.

    Raises
    ------
    InputError
        Unknown name (the message lists the known ones).
    """
    try:
        return PARAMETER_INFO[name]
    except KeyError:
        raise InputError(f"unknown parameter {name!r}; known: {', '.join(PARAMETER_INFO)}") from None


def _with_term_fields(cls):
    """Give ``cls`` a field of default 0 for each optional term's parameter (:func:`iwp.models.terms.term_parameters`),
    after its own, and a line of its docstring for each that it does not already describe."""
    doc = cls.__doc__ or ""
    extra = []
    for info in term_parameters():
        cls.__annotations__[info.name] = "float"
        setattr(cls, info.name, 0.0)
        if not re.search(rf"^ {{4}}(\w+, )*{info.name}(, \w+)* :", doc, re.M):
            extra.append(f"    {info.name} : float\n        {info.description} [{info.unit}]; 0 by default.\n")
    if extra:
        cls.__doc__ = doc.rstrip() + "\n" + "".join(extra) + "    "
    return cls


@dataclass(frozen=True)
@_with_term_fields
class LumpedParameters:
    """Lumped parameters of the state-space models (6) and (9).

    All are normalised by the pendulum inertia about the pivot,
    ``I1_hat = I1 + m1 c^2 + m2 l^2`` (section 4). The input is the
    non-dimensional driver command ``v = V_i / beta`` (or the ideal input ``u``
    of the compensated model (9)); "[in]" below denotes one unit of it.

    Parameters
    ----------
    p1 : float
        ``(m1 c + m2 l) g / I1_hat`` [s^-2]; the small-oscillation frequency of
        the pendulum is ``sqrt(p1)`` [rad/s].
    p2 : float
        ``(N^2 kT kF / R + sigma_v2) / I1_hat`` [s^-1]: back-emf plus viscous
        friction of the disk joint.
    p3 : float
        ``beta N kT / (I1_hat R)`` [rad s^-2 / in]: input gain.
    rho : float
        ``I1_hat / I2`` [-]: inertia ratio.
    sigma_a1 : float
        ``sigma~_a1`` [s^-1]: rolling friction ``|cos q1| q3`` of the pendulum.
    sigma_v1 : float
        ``sigma~_v1`` [s^-1]: viscous friction of the pendulum.
    sigma_b1 : float
        ``sigma~_b1`` [s rad^-2]: centrifugal rolling friction ``q3^3``.
    v_dz_pos, v_dz_neg : float
        Dead-zone thresholds ``v+ = V_dz+/beta`` and ``v- = V_dz-/beta`` [in]
        of (5) and (8); both positive numbers (the negative threshold is
        ``-v_dz_neg``).
    sigma_c2 : float
        ``sigma~_c2 = sigma_c2 / I1_hat`` [rad s^-2]: Coulomb friction of the
        disk joint (section 5.1, "Analysis of the Coulomb friction
        phenomenon"); 0 in the paper's final model.
    sigma_c1 : float
        ``sigma~_c1 = sigma_c1 / I1_hat`` [rad s^-2]: Coulomb friction of the
        pendulum joint, ``xi`` gains ``sigma~_c1 sgn q3`` (regularised as
        ``tanh(q3/eps)``, :func:`iwp.models.pendulum.pendulum_coulomb`). The paper
        neglects it for large oscillations (section 3.1); small-amplitude runs
        of other rigs show it. 0 by default.
    u_offset : float
        Offset of the input [in]: the plant is driven by ``w + u_offset``
        where ``w`` is the logged ``u`` (or ``v``), e.g. a driver whose zero
        command is not zero torque (:func:`iwp.models.actuator.effective_input`).
        0 by default.
    eps_c1, eps_c2 : float
        Smoothing widths of the Coulomb signs of the pendulum and the disk
        [rad/s]: ``sgn q ~ tanh(q / eps)``. 0 (default): the plant's
        ``coulomb_eps`` (0.01 rad/s). Real joints show wider transitions
        (about 0.1 rad/s at a pendulum's bearing); a fit can estimate them.
    """

    p1: float  # [s^-2]
    p2: float  # [s^-1]
    p3: float  # [rad s^-2 per input unit]
    rho: float  # [-]
    sigma_a1: float  # [s^-1]
    sigma_v1: float  # [s^-1]
    sigma_b1: float  # [s rad^-2]
    # then the optional terms' parameters, 0 by default (off): added from iwp.models.terms by _with_term_fields

    def __post_init__(self) -> None:
        # Structural checks only: finiteness and rho > 0 (the models divide by
        # it). Physical signs are checked by :meth:`check_physical`, because
        # an unconstrained least-squares fit (the paper's eq. (16)) may give a
        # negative friction coefficient that one still wants to simulate.
        check_fields(self, "LumpedParameters", positive=("rho",), nonneg=())

    def check_physical(self, where: str = "LumpedParameters") -> "LumpedParameters":
        """Check the physical signs; return ``self``.

        ``p1, p3, rho > 0``; ``p2``, the friction coefficients and the dead-zone
        thresholds ``>= 0``. Raises :class:`~iwp.errors.InputError` naming the
        first offending field.
        """
        check_fields(self, where, positive=names_with_sign(LUMPED_INFO, "positive"),
                      nonneg=names_with_sign(LUMPED_INFO, "nonnegative"))
        return self

    # Derived quantities ---------------------------------------------------
    @property
    def p2_1rho(self) -> float:
        """``p2 (1 + rho)`` [s^-1], as identified by the motor-disk set-up."""
        return self.p2 * (1.0 + self.rho)

    @property
    def p3_1rho(self) -> float:
        """``p3 (1 + rho)`` [rad s^-2 / in], as identified by the motor-disk set-up."""
        return self.p3 * (1.0 + self.rho)

    @property
    def sigma_c2_1rho(self) -> float:
        """``sigma~_c2 (1 + rho)`` [rad s^-2], set-up (b) of section 5.1."""
        return self.sigma_c2 * (1.0 + self.rho)

    @property
    def natural_frequency(self) -> float:
        """Small-oscillation frequency of the free pendulum, ``sqrt(p1)`` [rad/s]."""
        return math.sqrt(self.p1) if self.p1 > 0 else float("nan")

    def to_dict(self) -> dict[str, float]:
        """Field name -> value."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}

    def replace(self, **changes: float) -> "LumpedParameters":
        """A copy with ``changes`` applied (see :func:`dataclasses.replace`)."""
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class PhysicalParameters:
    """Physical parameters in SI units (sections 2 and 3 of the paper).

    Parameters
    ----------
    m1, m2 : float
        Mass of the pendulum arm and of the disk [kg].
    I1, I2 : float
        Moment of inertia of the arm about its centre of mass and of the disk
        about its shaft [kg m^2].
    l, c : float
        Distance from the pivot to the disk shaft and to the arm's centre of
        mass [m].
    g : float
        Gravitational acceleration [m s^-2].
    kT : float
        Motor torque constant [N m / A].
    kF : float
        Motor back-emf constant [V s / rad].
    R : float
        Rotor coil resistance [ohm].
    N : float
        Belt reduction ratio (disk diameter / motor pulley diameter) [-].
    beta : float
        Gain of the motor driver: ``V_i = beta v`` [V per input unit].
    sigma_v1 : float
        Viscous friction of the pendulum joint [N m s / rad].
    sigma_r : float
        Velocity coefficient of the rolling friction ``mu_r = sigma_r q3``
        [s / rad].
    r : float
        Radius of the pendulum shaft [m].
    sigma_v2 : float
        Viscous friction of the disk joint [N m s / rad].
    sigma_c2 : float
        Coulomb friction of the disk joint [N m].
    V_dz_pos, V_dz_neg : float
        Dead-zone thresholds of (5) [V], both positive.
    """

    m1: float  # [kg]
    m2: float  # [kg]
    I1: float  # [kg m^2]
    I2: float  # [kg m^2]
    l: float  # [m]
    c: float  # [m]
    g: float  # [m s^-2]
    kT: float  # [N m / A]
    kF: float  # [V s / rad]
    R: float  # [ohm]
    N: float  # [-]
    beta: float  # [V / input unit]
    sigma_v1: float  # [N m s / rad]
    sigma_r: float  # [s / rad]
    r: float  # [m]
    sigma_v2: float  # [N m s / rad]
    sigma_c2: float = 0.0  # [N m]
    V_dz_pos: float = 0.0  # [V]
    V_dz_neg: float = 0.0  # [V]

    def __post_init__(self) -> None:
        check_fields(
            self,
            "PhysicalParameters",
            positive=("m1", "m2", "I1", "I2", "l", "g", "kT", "R", "N", "beta"),
            nonneg=("c", "kF", "sigma_v1", "sigma_r", "r", "sigma_v2", "sigma_c2", "V_dz_pos", "V_dz_neg"),
        )

    @property
    def I1_hat(self) -> float:
        """Pendulum inertia about the pivot ``I1 + m1 c^2 + m2 l^2`` [kg m^2] (eq. (2))."""
        return self.I1 + self.m1 * self.c**2 + self.m2 * self.l**2

    @property
    def sigma_a1(self) -> float:
        """Rolling friction, gravity part ``sigma_r (m1 + m2) g r`` [N m s / rad]."""
        return self.sigma_r * (self.m1 + self.m2) * self.g * self.r

    @property
    def sigma_b1(self) -> float:
        """Rolling friction, centrifugal part ``sigma_r (m1 c + m2 l) r`` [kg m^2 s / rad^2]."""
        return self.sigma_r * (self.m1 * self.c + self.m2 * self.l) * self.r

    def to_lumped(self) -> LumpedParameters:
        """The lumped parameters of section 4 (definitions below eq. (6))."""
        I1h = self.I1_hat
        return LumpedParameters(
            p1=(self.m1 * self.c + self.m2 * self.l) * self.g / I1h,
            p2=(self.N**2 * self.kT * self.kF / self.R + self.sigma_v2) / I1h,
            p3=self.beta * self.N * self.kT / (I1h * self.R),
            rho=I1h / self.I2,
            sigma_a1=self.sigma_a1 / I1h,
            sigma_v1=self.sigma_v1 / I1h,
            sigma_b1=self.sigma_b1 / I1h,
            v_dz_pos=self.V_dz_pos / self.beta,
            v_dz_neg=self.V_dz_neg / self.beta,
            sigma_c2=self.sigma_c2 / I1h,
        )

    def to_dict(self) -> dict[str, float]:
        """Field name -> value."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}


def table1() -> LumpedParameters:
    """The paper's Table 1, with the dead zone ``v+ = v- = 31`` of section 5.1.

    Table 1 rounds ``sigma~_b1`` to 0.0005 (the free-pendulum identification
    gave 0.00047, ERRATA item 5); this set keeps Table 1's printed value.
    Coulomb friction is not part of the final model (``sigma_c2 = 0``).

    Returns
    -------
    LumpedParameters
        ``p1 = 26.095`` [1/s^2], ``p2 = 0.0106`` [1/s], ``p3 = 0.0286``
        [rad/(s^2 input unit)], ``rho = 247.24`` [-], ``sigma~_a1 = 0.003``,
        ``sigma~_v1 = 0.01`` [1/s], ``sigma~_b1 = 0.0005`` [s/rad^2] of
        model (9), and the dead-zone thresholds ``v_dz_pos = v_dz_neg = 31``
        [input units] of (5).

    Examples
    --------
    >>> from iwp import table1
    >>> p = table1()
    >>> p.p1, p.p2, p.p3, p.rho
    (26.095, 0.0106, 0.0286, 247.24)
    >>> p.v_dz_pos  # the dead zone's threshold [input units]
    31.0
    """
    return LumpedParameters(
        p1=26.0950,
        p2=0.0106,
        p3=0.0286,
        rho=247.24,
        sigma_a1=0.0030,
        sigma_v1=0.01,
        sigma_b1=0.0005,
        v_dz_pos=31.0,
        v_dz_neg=31.0,
        sigma_c2=0.0,
    )


def paper_belt() -> BeltParameters:
    """The belt values of section 5.1 (figure 4b) for model (15).

    Returns
    -------
    BeltParameters
        ``k/I2 = 60`` [1/s^2], ``d = 2`` [-], ``N = 13.5`` [-],
        ``b2/I2 = 10`` [1/s], ``k/gamma = 780`` [1/s^2], ``kT beta/(R gamma) = 26``
        [rad/(s^2 input unit)].

    Examples
    --------
    >>> from iwp import Plant, paper_belt, table1
    >>> belt = paper_belt()
    >>> belt.N  # the reduction ratio disk/pulley
    13.5
    >>> plant = Plant(table1(), model="belt-full", belt=belt)  # the virtual rig's truth structure
    """
    return BeltParameters()


_NAMED = {"table1": table1}


def named_params(name: str) -> LumpedParameters:
    """A built-in parameter set by name (``"table1"``).

    Parameters
    ----------
    name : str
        Name of the built-in set; only ``"table1"`` (the paper's Table 1) is built in.

    Returns
    -------
    LumpedParameters
        A new copy of that set.

    Raises
    ------
    InputError
        Unknown name (the message lists the built-in sets).

    See Also
    --------
    table1 : The paper's Table 1, the one built-in set.

    Examples
    --------
    >>> from iwp import table1
    >>> from iwp.models import named_params
    >>> p = named_params("table1")
    >>> p == table1(), p.p1
    (True, 26.095)
    """
    try:
        return _NAMED[name]()
    except KeyError:
        raise InputError(f"unknown parameter set {name!r}; built-in sets: {', '.join(_NAMED)}") from None


_KINDS = {
    "lumped": LumpedParameters,
    "physical": PhysicalParameters,
    "belt": BeltParameters,
}


def save_params(params, path: str | Path, *, force: bool = False, extra: dict[str, Any] | None = None) -> Path:
    """Write a parameter set to JSON.

    The file is ``{"kind": "lumped"|"physical"|"belt", "parameters": {...}}``
    plus the optional ``extra`` entries (e.g. uncertainties, provenance).
    Refuses to overwrite an existing file unless ``force``.

    Parameters
    ----------
    params : LumpedParameters or PhysicalParameters or BeltParameters
        The set to write (its units: Table 1's, SI, or the belt's).
    path : str or Path
        The ``.json`` file.
    force : bool
        Overwrite an existing file.
    extra : dict, optional
        More top-level entries (JSON-serialisable).

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    OutputExistsError
        The file exists and ``force`` is not set.

    Examples
    --------
    >>> from iwp import load_params, save_params, table1
    >>> save_params(table1(), "table1.json").name
    'table1.json'
    >>> load_params("table1.json") == table1()
    True
    """
    kind = next((k for k, cls in _KINDS.items() if isinstance(params, cls)), None)
    if kind is None:
        kinds = ", ".join(c.__name__ for c in _KINDS.values())
        raise InputError(f"params must be one of {kinds}, got {type(params).__name__}")
    p = prepare_output_file(path, force=force)
    doc: dict[str, Any] = {"kind": kind, "parameters": params.to_dict()}
    if extra:
        doc.update(extra)
    p.write_text(json.dumps(doc, indent=2, sort_keys=False) + "\n")
    return p


#: The ``kind`` of other JSON files iwp writes, which a user may give as a parameter file by mistake.
_OTHER_FILES = {"iwp-fit": "iwp fit's fit.json"}


def _parameter_file(path_or_name: str | Path) -> dict | None:
    """The JSON object of a parameter file, or None (a built-in set, a file that does not read: :func:`load_params`
    reports it)."""
    path = Path(str(path_or_name))
    if str(path_or_name) in _NAMED or not path.is_file():
        return None
    try:
        doc = read_json(path)
    except InputError:
        return None
    return doc if isinstance(doc, dict) else None


def stored_model(path_or_name: str | Path) -> str | None:
    """The model a parameter file says its parameters were fitted with (its ``"model"`` entry, or that of its
    ``"refinement"``), or None (a built-in set, no such entry, a file that does not read).

    Parameters
    ----------
    path_or_name : str or path-like
        Path of a parameter file (JSON), or the name of a built-in set (which gives None).

    Returns
    -------
    str or None
        The model name stored in the file, or None. Never raises for a bad file: :func:`load_params` reports it.
    """
    doc = _parameter_file(path_or_name)
    if doc is None:
        return None
    m = doc.get("model")
    ref = doc.get("refinement")
    if m is None and isinstance(ref, dict):  # written by iwp identify --refine --out
        m = ref.get("model")
    return m if isinstance(m, str) else None


def stored_q1_zero(path_or_name: str | Path) -> EncoderZero:
    """The pendulum zero a parameter file of ``iwp fit`` holds for held-out logs: its ``"q1_offset"``
    (:func:`stored_q1_offset`) with the training offsets' ``"q1_offset_spread"`` [rad^2] and ``"q1_offset_logs"``
    (absent: 0, a held-out zero then known to within its encoder's count).

    Parameters
    ----------
    path_or_name : str or path-like
        Path of a parameter file (JSON), or the name of a built-in set (which gives ``EncoderZero()``).

    Returns
    -------
    EncoderZero

    Raises
    ------
    InputError
        An entry of the wrong type or sign (naming the file and the field).
    """
    doc = _parameter_file(path_or_name) or {}
    value = _q1_offset_of(doc, path_or_name)
    spread, n = doc.get("q1_offset_spread", 0.0), doc.get("q1_offset_logs", 0)
    if isinstance(spread, bool) or not isinstance(spread, (int, float)) or not (math.isfinite(spread)
                                                                                and spread >= 0):
        raise InputError(f"{path_or_name}: 'q1_offset_spread' must be a finite number >= 0 [rad^2], got {spread!r}")
    if isinstance(n, bool) or not isinstance(n, int) or n < 0:
        raise InputError(f"{path_or_name}: 'q1_offset_logs' must be a whole number >= 0, got {n!r}")
    return EncoderZero(value, float(spread), n)


def stored_q1_offset(path_or_name: str | Path) -> float:
    """The pendulum zero offset [rad] a parameter file of ``iwp fit`` holds for held-out logs (its
    ``"q1_offset"``: the training logs' mean, when the rig description did not give the offset), or 0.

    Parameters
    ----------
    path_or_name : str or path-like
        Path of a parameter file (JSON), or the name of a built-in set (which gives 0).

    Returns
    -------
    float
        The offset [rad], 0 without one.

    Raises
    ------
    InputError
        A ``"q1_offset"`` entry that is not a finite number (naming the file and the field).
    """
    return _q1_offset_of(_parameter_file(path_or_name) or {}, path_or_name)


def _q1_offset_of(doc: dict, path_or_name: str | Path) -> float:
    """The ``"q1_offset"`` of a parameter file's object [rad], 0 without one; one that is not a finite number is
    refused, naming the file."""
    entry = doc.get("q1_offset")
    if entry is None:
        return 0.0
    if isinstance(entry, bool) or not isinstance(entry, (int, float)) or not math.isfinite(entry):
        raise InputError(f"{path_or_name}: 'q1_offset' must be a finite number of radians, got {entry!r}")
    return float(entry)


def stored_reads_v_as_u(path_or_name: str | Path) -> bool:
    """True if a parameter file says its fit read a logged raw command ``v`` as the input ``u`` (its
    ``"reads_v_as_u"``, as ``iwp fit`` writes it for model (9) and the belt model).

    Parameters
    ----------
    path_or_name : str or path-like
        Path of a parameter file (JSON), or the name of a built-in set (which gives False).

    Returns
    -------
    bool
    """
    doc = _parameter_file(path_or_name)
    return doc is not None and doc.get("reads_v_as_u") is True


def stored_belt(path_or_name: str | Path) -> "BeltParameters | None":
    """The belt (15) a parameter file of a fit with the belt holds (its ``"belt"`` entry, as ``iwp fit`` writes
    it beside the lumped parameters), or None (a built-in set, a file without one).

    Parameters
    ----------
    path_or_name : str or path-like
        Path of a parameter file (JSON), or the name of a built-in set (which gives None).

    Returns
    -------
    BeltParameters or None

    Raises
    ------
    InputError
        A ``"belt"`` entry that is not a belt's parameters (naming the file and the field).
    """
    path = Path(str(path_or_name))
    doc = _parameter_file(path_or_name)
    entry = None if doc is None else doc.get("belt")
    if entry is None:
        return None
    if not isinstance(entry, dict):
        raise InputError(f"{path}: 'belt' must be an object of the belt's parameters, got {entry!r}")
    try:
        return BeltParameters(**_checked_values(path, entry, "belt"))
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None


def _checked_values(path: Path, values: dict, kind: str) -> dict[str, float]:
    """The ``values`` of a parameter set of ``kind`` (a key of :data:`_KINDS`) read from ``path``, as floats: an
    error naming the file and the parameter for an unknown or missing name or a value that is not a finite number."""
    cls = _KINDS[kind]
    names = {f.name for f in fields(cls)}
    required = {f.name for f in fields(cls) if f.default is dataclasses.MISSING}
    unknown = sorted(set(values) - names)
    if unknown:
        known = ", ".join(sorted(names))
        raise InputError(f"{path}: unknown parameter {unknown[0]!r} for a {kind} set; known: {known}")
    missing = sorted(required - set(values))
    if missing:
        raise InputError(f"{path}: missing parameter {missing[0]!r}")
    for name, val in values.items():
        if isinstance(val, bool) or not isinstance(val, (int, float)):
            raise InputError(f"{path}: parameter {name!r} must be a number, got {val!r}")
        if not math.isfinite(val):
            raise InputError(f"{path}: parameter {name!r} must be finite, got {val!r}")
    return {k: float(v) for k, v in values.items()}


def load_params(path_or_name: str | Path, *, physical_check: bool = True):
    """Load a parameter set from a JSON file, or a built-in set by name.

    Accepts ``{"kind": ..., "parameters": {...}}`` as written by
    :func:`save_params`, or a flat ``{name: value}`` object of lumped
    parameters. A physical parameter set is returned as
    :class:`PhysicalParameters`; use ``.to_lumped()`` for the models.

    A lumped set with wrong signs (negative friction, ...) is refused unless
    the file says ``"unconstrained_fit": true`` (as ``iwp identify --out``
    writes for an unconstrained fit that came out unphysical, like the
    paper's eq. (16)); such a file is loaded with a warning.

    Parameters
    ----------
    path_or_name : str or Path
        A JSON file, or a built-in name (``"table1"``: Table 1).
    physical_check : bool
        Refuse a lumped set with wrong signs (see above).

    Returns
    -------
    LumpedParameters or PhysicalParameters or BeltParameters
        The set, in the units of Table 1 (lumped) or SI (physical).

    Raises
    ------
    InputError
        Naming the file and the field: unknown or missing names, values that
        are not finite numbers, wrong signs (``physical_check``).

    Examples
    --------
    >>> from iwp import load_params, save_params, table1
    >>> load_params("table1").p1  # a built-in name
    26.095
    >>> path = save_params(table1().replace(p1=25.0), "mine.json")
    >>> load_params("mine.json").p1
    25.0
    """
    s = str(path_or_name)
    if s in _NAMED:
        return named_params(s)
    path = Path(s)
    if not path.exists():
        raise InputError(f"{path}: no such parameter file (built-in sets: {', '.join(_NAMED)})")
    doc = read_json(path)
    if not isinstance(doc, dict):
        raise InputError(f"{path}: expected a JSON object of parameters")
    kind = doc.get("kind", "lumped")
    values = doc.get("parameters", doc if "kind" not in doc else None)
    other = _OTHER_FILES.get(kind) if isinstance(kind, str) else None
    if other is None and "kind" not in doc and {"steps", "statements"} <= set(doc):
        other = "iwp reproduce's results.json"
    if other is not None:
        beside = path.parent / "parameters.json"
        raise InputError(f"{path}: this is {other}, not a parameter file; give {beside} (written beside it)")
    if kind not in _KINDS:
        raise InputError(f"{path}: unknown kind {kind!r}; expected one of {', '.join(_KINDS)}")
    if not isinstance(values, dict):
        raise InputError(f"{path}: 'parameters' must be an object of name: value")
    cls = _KINDS[kind]
    values = _checked_values(path, values, kind)
    unconstrained = doc.get("unconstrained_fit") is True
    try:
        params = cls(**values)
        if physical_check and isinstance(params, LumpedParameters):
            try:
                params.check_physical(where=str(path))
            except InputError as exc:
                if not unconstrained:
                    raise
                # a file that declares itself an unconstrained least-squares
                # fit (e.g. the paper's eq. (16)) is used as given, with a warning
                warnings.warn(f"{path}: unconstrained fit with an unphysical value: {str(exc).split(': ', 1)[-1]}; "
                              "using it as given", UserWarning, stacklevel=2)
    except InputError as exc:
        msg = str(exc)
        if not msg.startswith(str(path)):
            msg = f"{path}: {msg.split(': ', 1)[-1]}"
        raise InputError(msg) from None
    return params

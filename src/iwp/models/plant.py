"""The plant: which model of the paper, with which parameters and options.

A :class:`Plant` is what every simulation, fit and analysis of iwp takes in
place of loose model options. It names the model (:data:`MODELS`), holds its
parameter set and the options of that model (belt, break-away of the dead
zone, Coulomb regularisation, clamp of the pendulum, dead zone on or off)
and packs them, once, into the vector the compiled right-hand sides read
(:mod:`iwp.models.layout`).

>>> from iwp import Plant, table1
>>> plant = Plant(table1(), model="compensated")      # model (9)
>>> plant.n_states, plant.input_name
(4, 'u')
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .actuator import StartupFriction
from .equations import rhs
from .friction import COULOMB_EPS
from .guards import SURFACES
from .layout import (
    BELT_INDEX,
    BRK,
    DZ,
    E_EPSC,
    EPSC,
    EPSC1,
    LOCK,
    LUMPED_INDEX,
    M_BELT,
    M_BELT_FULL,
    M_COMP,
    M_EL,
    M_FREE_HELD,
    M_FREE_NOWHEEL,
    M_MD,
    M_MD_RAW,
    M_RAW,
    N_PACK,
    PHYSICAL_FIELDS,
    WS,
)
from .parameters import BELT_INFO, LUMPED_INFO, BeltParameters, LumpedParameters, PhysicalParameters
from .terms import model_parameters

__all__ = ["ModelInfo", "MODELS", "CLAMPABLE", "Plant", "model_info", "EXPERIMENT_KINDS", "plant_for_kind"]


@dataclass(frozen=True)
class ModelInfo:
    """What iwp knows about one model of the paper.

    Attributes
    ----------
    name : str
        The model's name (``model=`` everywhere, ``--model`` in the CLI).
    code : int
        Its code in the compiled code (:mod:`iwp.models.layout`).
    equation : str
        Where it is in the paper.
    input : str or None
        The logged input it takes: ``"u"`` (ideal input), ``"v"`` (raw
        driver command) or ``None`` (none).
    n_states : int
        4 (``q1, q2, q3, q4``) or 6 (plus the belt's ``delta, w``).
    moving : tuple of int
        The states that evolve (the others stay at their initial value).
    depends_on : tuple of int
        The states its right-hand side depends on.
    physical : bool
        Takes :class:`~iwp.models.parameters.PhysicalParameters`.
    description : str
    parameters : tuple of str
        The parameters its outputs determine, so that a fit may free them
        (:data:`~iwp.models.parameters.PARAMETER_INFO`); empty for the
        physical model. ``rho`` is not among the free pendulum's: only
        ``p1 rho/(1 + rho)`` enters its motion.
    pendulum_locked : bool
        The pendulum cannot swing (the motor-disk models (14), the locked belt (15)).
    clampable : bool
        Its pendulum can be clamped (``Plant(..., locked=True)``, the set-ups of section 5.1 on the full model).
    drive : str or None
        The drive model between motor and wheel in place of the rigid one, by name: ``"belt"`` (15), whose
        parameters a :class:`~iwp.models.parameters.BeltParameters` holds (``Plant(..., belt=...)``); None: rigid.
    surfaces : tuple of str
        The families of switching surfaces its right-hand side may have (:data:`iwp.models.guards.SURFACES`:
        ``"kinks"``, the rolling friction's at ``cos q1 = 0``; ``"play"``, the belt's), at which the engine ends
        its steps; active where their parameters are not 0 (``sigma_a1``, the play's ``d``).
    """

    name: str
    code: int
    equation: str
    input: str | None
    n_states: int
    moving: tuple[int, ...]
    depends_on: tuple[int, ...]
    physical: bool
    description: str
    parameters: tuple[str, ...] = ()
    pendulum_locked: bool = False
    clampable: bool = False
    drive: str | None = None
    surfaces: tuple[str, ...] = ("kinks",)

    def __post_init__(self) -> None:
        unknown = [f for f in self.surfaces if f not in SURFACES]
        if unknown:
            raise InputError(f"model {self.name!r}: unknown switching surfaces {unknown}; known: {', '.join(SURFACES)}")

    @property
    def reads_v_as_u(self) -> bool:
        """A logged raw command ``v`` is taken as its ideal input ``u`` (a free pendulum driven by ``u``: a rig
        whose driver has no dead zone, or compensates it, logs the same number as either)."""
        return self.input == "u" and not self.pendulum_locked


_ALL4 = (0, 1, 2, 3)
#: each model's own parameters; those of the optional terms it admits follow (:func:`iwp.models.terms.model_parameters`)
_PENDULUM = ("p1", "sigma_a1", "sigma_v1", "sigma_b1")
_LUMPED = ("p1", "p2", "p3", "rho", "sigma_a1", "sigma_v1", "sigma_b1")
_MOTOR_DISK = ("p2", "p3", "rho")
_BELT = ("k_over_I2", "d", "b2_over_I2", "k_over_gamma", "kTbeta_over_Rgamma", "gain_neg")
#: The models, by name.
MODELS: dict[str, ModelInfo] = {m.name: m for m in (
    ModelInfo("el", M_EL, "(4) with (3), (5)", "v", 4, _ALL4, (0, 2, 3), True,
              "Euler-Lagrange equations with the dc motor, dead zone and friction, in SI parameters"),
    ModelInfo("raw", M_RAW, "(6) with (5)", "v", 4, _ALL4, (0, 2, 3), False,
              "state-space model driven by the raw command v through the dead zone",
              model_parameters("raw", _LUMPED), clampable=True),
    ModelInfo("compensated", M_COMP, "(9)", "u", 4, _ALL4, (0, 2, 3), False,
              "the feedforward-compensated model, driven by the ideal input u",
              model_parameters("compensated", _LUMPED), clampable=True),
    ModelInfo("motor-disk", M_MD, "(14), exact compensation", "u", 4, (1, 3), (3,), False,
              "motor-disk subsystem with the pendulum locked, input u (Coulomb term when sigma_c2 > 0)",
              model_parameters("motor-disk", _MOTOR_DISK), True, surfaces=()),
    ModelInfo("motor-disk-raw", M_MD_RAW, "(14)", "v", 4, (1, 3), (3,), False,
              "motor-disk subsystem with the pendulum locked, raw command v through the dead zone",
              model_parameters("motor-disk-raw", _MOTOR_DISK), True, surfaces=()),
    ModelInfo("belt", M_BELT, "(15), pendulum locked", "u", 6, (1, 3, 4, 5), (3, 4, 5), False,
              "flexible belt with the play hysteresis of figure 5, motor inertia neglected",
              model_parameters("belt", _BELT), True, drive="belt", surfaces=("play",)),
    ModelInfo("belt-full", M_BELT_FULL, "(4a) with (15)", "u", 6, (0, 1, 2, 3, 4, 5), (0, 2, 3, 4, 5), False,
              "the belt with the pendulum free (the virtual rig's truth plant)",
              model_parameters("belt-full", _PENDULUM + ("rho",) + _BELT), clampable=True, drive="belt",
              surfaces=("kinks", "play")),
    ModelInfo("free", M_FREE_HELD, "section 5.2, wheel held", None, 4, (0, 2), (0, 2), False,
              "free pendulum, motor off, the wheel held to the arm: q3' = -xi rho/(1 + rho)",
              model_parameters("free", _PENDULUM)),
    ModelInfo("free-nowheel", M_FREE_NOWHEEL, "section 5.2", None, 4, (0, 2), (0, 2), False,
              "free pendulum without a wheel: q3' = -xi",
              model_parameters("free-nowheel", _PENDULUM)),
)}

#: models that can have their pendulum clamped (``locked=True``)
CLAMPABLE = tuple(name for name, info in MODELS.items() if info.clampable)


def model_info(model: str) -> ModelInfo:
    """The :class:`ModelInfo` of a model name; a clear error for an unknown one.

    Parameters
    ----------
    model : str
        Model name, one of :data:`MODELS`.

    Returns
    -------
    ModelInfo
        The model's description.

    Raises
    ------
    InputError
        Not a string, or an unknown model (the message lists the valid names).

    Examples
    --------
    >>> from iwp.models import model_info
    >>> info = model_info("free")  # the free pendulum of section 5.2
    >>> info.input, info.n_states, info.parameters[:4]
    (None, 4, ('p1', 'sigma_a1', 'sigma_v1', 'sigma_b1'))
    >>> model_info("compensated").equation, model_info("belt").n_states
    ('(9)', 6)
    """
    if not isinstance(model, str) or model not in MODELS:
        raise InputError(f"unknown model {model!r}; choose one of: {', '.join(MODELS)}")
    return MODELS[model]


@dataclass(frozen=True)
class Plant:
    """A model of the paper with its parameters and options.

    Parameters
    ----------
    params : LumpedParameters or PhysicalParameters
        The parameter set (``PhysicalParameters`` for ``"el"``; a physical set
        given to another model is mapped to lumped parameters, section 4).
    model : str
        One of :data:`MODELS` (default ``"compensated"``, model (9)).
    belt : BeltParameters, optional
        Required by the belt models (15).
    startup : StartupFriction, optional
        Break-away of the dead zone (start-up discontinuity of figure 2a).
    coulomb_eps : float
        Regularisation of ``sgn(q4)`` in Coulomb terms [rad/s]; 0 for exact.
    locked : bool
        The pendulum clamped at ``q1 = q3 = 0`` (section 5.1), for
        ``"raw"``, ``"compensated"`` and ``"belt-full"``. The motor-disk
        models (14) have it locked anyway.
    dead_zone : bool, optional
        The dead zone (5) on or off; default on for the raw models
        (``"raw"``, ``"motor-disk-raw"``) and off otherwise.
    """

    params: LumpedParameters | PhysicalParameters
    model: str = "compensated"
    belt: BeltParameters | None = None
    startup: StartupFriction | None = None
    coulomb_eps: float = COULOMB_EPS
    locked: bool = False
    dead_zone: bool | None = None

    def __post_init__(self) -> None:
        info = model_info(self.model)
        p = self.params
        if info.physical:
            if not isinstance(p, PhysicalParameters):
                raise InputError(f"model {self.model!r} (eq. (4)) needs PhysicalParameters; got {type(p).__name__}")
        elif isinstance(p, PhysicalParameters):
            object.__setattr__(self, "params", p.to_lumped())
        elif not isinstance(p, LumpedParameters):
            raise InputError(f"model {self.model!r} needs LumpedParameters; got {type(p).__name__}")
        if info.drive == "belt":
            if self.belt is None:
                raise InputError(f"model {self.model!r} needs belt=BeltParameters(...)")
            if not isinstance(self.belt, BeltParameters):
                raise InputError(f"belt must be BeltParameters, got {type(self.belt).__name__}")
        if self.startup is not None and not isinstance(self.startup, StartupFriction):
            raise InputError(f"startup must be StartupFriction, got {type(self.startup).__name__}")
        eps = self.coulomb_eps
        if isinstance(eps, bool) or not isinstance(eps, (int, float)) or not (math.isfinite(eps) and eps >= 0):
            raise InputError(f"coulomb_eps must be a finite number >= 0, got {eps!r}")
        object.__setattr__(self, "coulomb_eps", float(eps))
        object.__setattr__(self, "locked", bool(self.locked))
        if self.dead_zone is not None:
            object.__setattr__(self, "dead_zone", bool(self.dead_zone))
        packed = _pack(self, info)
        packed.setflags(write=False)
        object.__setattr__(self, "_packed", packed)

    # ------------------------------------------------------------------
    @property
    def info(self) -> ModelInfo:
        """The model's :class:`ModelInfo`."""
        return MODELS[self.model]

    @property
    def code(self) -> int:
        """The model's code in the compiled code."""
        return MODELS[self.model].code

    @property
    def n_states(self) -> int:
        """Number of states: 4, or 6 for the belt models."""
        return MODELS[self.model].n_states

    @property
    def input_name(self) -> str | None:
        """The logged input the model takes: ``"u"``, ``"v"`` or ``None``."""
        return MODELS[self.model].input

    @property
    def lumped(self) -> LumpedParameters:
        """The parameters as :class:`LumpedParameters` (mapped from physical ones, section 4)."""
        p = self.params
        return p.to_lumped() if isinstance(p, PhysicalParameters) else p

    @property
    def pendulum_locked(self) -> bool:
        """True if the pendulum cannot swing: clamped (``locked``), or a model that locks it (14), (15)."""
        return self.locked or MODELS[self.model].pendulum_locked

    @property
    def wheel_held(self) -> bool:
        """True if the wheel does not move relative to the arm (the free-pendulum models: no input)."""
        return MODELS[self.model].input is None

    @property
    def outputs(self) -> tuple[str, ...]:
        """The measurable signals that move in this plant, among ``q1, q2, q3, q4``."""
        pendulum = () if self.pendulum_locked else ("q1", "q3")
        wheel = () if self.wheel_held else ("q2", "q4")
        return tuple(s for s in ("q1", "q2", "q3", "q4") if s in pendulum + wheel)

    def value(self, name: str) -> float:
        """The value of one parameter of the plant (lumped or belt) by name."""
        if name in BELT_INFO:
            if self.belt is None:
                raise InputError(f"parameter {name!r} belongs to the belt (15); model {self.model!r} has none")
            return float(getattr(self.belt, name))
        if name in LUMPED_INFO:
            return float(getattr(self.lumped, name))
        raise InputError(f"unknown parameter {name!r}; known: {', '.join([*LUMPED_INFO, *BELT_INFO])}")

    def value_in_effect(self, name: str) -> float:
        """The value the equations use for parameter ``name``.

        Equal to :meth:`value` except where a stored 0 stands for the plant's
        default: the smoothing widths ``eps_c1``/``eps_c2`` (0: ``coulomb_eps``).
        A fit that frees such a parameter starts from this value.
        """
        if name in LUMPED_INDEX and not self.info.physical:
            return float(self.packed()[LUMPED_INDEX[name]])
        return self.value(name)

    def with_values(self, values) -> "Plant":
        """The same plant with the parameters in ``values`` (``{name: value}``, lumped or belt) changed."""
        lumped = {k: float(v) for k, v in values.items() if k in LUMPED_INFO}
        belt = {k: float(v) for k, v in values.items() if k in BELT_INFO}
        unknown = [k for k in values if k not in LUMPED_INFO and k not in BELT_INFO]
        if unknown:
            raise InputError(f"unknown parameter {unknown[0]!r}; known: {', '.join([*LUMPED_INFO, *BELT_INFO])}")
        if belt and self.belt is None:
            raise InputError(f"parameter {next(iter(belt))!r} belongs to the belt (15); model {self.model!r} has none")
        changes = {}
        if lumped:
            changes["params"] = self.lumped.replace(**lumped)
        if belt:
            changes["belt"] = dataclasses.replace(self.belt, **belt)
        return dataclasses.replace(self, **changes) if changes else self

    @property
    def dead_zone_active(self) -> bool:
        """True if the dead zone (5) acts on the input."""
        if self.dead_zone is not None:
            return self.dead_zone
        return self.code in (M_RAW, M_MD_RAW)

    def packed(self) -> np.ndarray:
        """The packed parameter vector (read-only) of :mod:`iwp.models.layout`."""
        return self._packed  # type: ignore[attr-defined]

    def replace(self, **changes) -> "Plant":
        """A copy with ``changes`` applied (fields of this class)."""
        return dataclasses.replace(self, **changes)

    def with_params(self, params) -> "Plant":
        """The same model and options with another parameter set."""
        return dataclasses.replace(self, params=params)

    def rhs(self, x, w: float = 0.0) -> np.ndarray:
        """The right-hand side ``x' = f(x, w)`` at one state.

        Parameters
        ----------
        x : array_like, shape (n_states,)
            ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s] (``+ delta, w`` for the belt models).
        w : float
            The input: ``v`` for the raw models and ``"el"``, ``u`` otherwise [input units].
        """
        n = self.n_states
        x = np.asarray(x, dtype=float)
        if x.shape != (n,):
            raise InputError(f"x must have shape ({n},) for model {self.model!r}, got {x.shape}")
        dx = np.zeros(n)
        rhs(self.code, np.ascontiguousarray(x), float(w), self._packed, dx)  # type: ignore[attr-defined]
        return dx


def _pack(plant: Plant, info: ModelInfo) -> np.ndarray:
    P = np.zeros(N_PACK)
    params = plant.params
    if info.physical:
        d = params.to_dict()
        for i, name in enumerate(PHYSICAL_FIELDS):
            P[i] = d[name]
        P[E_EPSC] = plant.coulomb_eps
        return P
    for name, index in LUMPED_INDEX.items():
        P[index] = getattr(params, name)
    P[EPSC] = params.eps_c2 if params.eps_c2 > 0 else plant.coulomb_eps
    P[EPSC1] = params.eps_c1 if params.eps_c1 > 0 else plant.coulomb_eps
    if plant.startup is not None:
        P[BRK], P[WS] = plant.startup.break_ratio, plant.startup.omega_s
    else:
        P[WS] = 1.0
    if plant.locked and not info.clampable and not info.pendulum_locked:
        raise InputError(f"locked=True applies to the models {', '.join(CLAMPABLE)}, not {plant.model!r}")
    P[LOCK] = 1.0 if plant.locked else 0.0
    P[DZ] = 1.0 if plant.dead_zone_active else 0.0
    if info.drive == "belt":
        for name, index in BELT_INDEX.items():
            P[index] = getattr(plant.belt, name)
    return P


#: The kinds of experiment a rig runs (and a fit joins), and how each changes the plant it simulates.
EXPERIMENT_KINDS: dict[str, str] = {
    "free": "the arm swings freely: the model as given",
    "clamped": "the pendulum clamped at q1 = q3 = 0 (section 5.1)",
    "wheel-locked": "the wheel locked to the arm: a free pendulum carrying the wheel's inertia (motor torque internal)",
    "closed-loop": "the input was computed by a known feedback law, simulated with the plant",
}


def plant_for_kind(plant: Plant, kind: str) -> Plant:
    """The plant an experiment of ``kind`` (:data:`EXPERIMENT_KINDS`) simulates, with ``plant``'s parameters.

    Parameters
    ----------
    plant : Plant
        The plant whose parameters (and Coulomb smoothing) are used.
    kind : str
        Experiment kind, one of :data:`EXPERIMENT_KINDS`: ``"clamped"`` locks the pendulum, ``"wheel-locked"``
        holds the wheel (the ``"free"`` pendulum model); any other kind keeps ``plant``.

    Returns
    -------
    Plant
        ``plant`` itself when it already fits the kind, else a new plant.

    Raises
    ------
    InputError
        Unknown ``kind``.
    """
    if kind not in EXPERIMENT_KINDS:
        raise InputError(f"unknown experiment kind {kind!r}; choose among {', '.join(EXPERIMENT_KINDS)}",
                         argument="kind")
    if kind == "clamped" and not plant.pendulum_locked:
        return plant.replace(locked=True)
    if kind == "wheel-locked" and not plant.wheel_held:
        return Plant(plant.lumped, model="free", coulomb_eps=plant.coulomb_eps)
    return plant

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
from .layout import (
    B2I2,
    BELT_CODES,
    BRK,
    DPLAY,
    DZ,
    E_EPSC,
    EPSC,
    KBRG,
    KG,
    KI2,
    KNEG,
    LOCK,
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
    NB,
    P1,
    P2,
    P3,
    PHYSICAL_FIELDS,
    RHO,
    SA,
    SB,
    SC1,
    SC2,
    SV,
    UOFF,
    VNEG,
    VPOS,
    WS,
)
from .parameters import BeltParameters, LumpedParameters, PhysicalParameters

__all__ = ["ModelInfo", "MODELS", "Plant", "model_info"]


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


_ALL4 = (0, 1, 2, 3)
#: The models, by name.
MODELS: dict[str, ModelInfo] = {m.name: m for m in (
    ModelInfo("el", M_EL, "(4) with (3), (5)", "v", 4, _ALL4, (0, 2, 3), True,
              "Euler-Lagrange equations with the dc motor, dead zone and friction, in SI parameters"),
    ModelInfo("raw", M_RAW, "(6) with (5)", "v", 4, _ALL4, (0, 2, 3), False,
              "state-space model driven by the raw command v through the dead zone"),
    ModelInfo("compensated", M_COMP, "(9)", "u", 4, _ALL4, (0, 2, 3), False,
              "the feedforward-compensated model, driven by the ideal input u"),
    ModelInfo("motor-disk", M_MD, "(14), exact compensation", "u", 4, (1, 3), (3,), False,
              "motor-disk subsystem with the pendulum locked, input u (Coulomb term when sigma_c2 > 0)"),
    ModelInfo("motor-disk-raw", M_MD_RAW, "(14)", "v", 4, (1, 3), (3,), False,
              "motor-disk subsystem with the pendulum locked, raw command v through the dead zone"),
    ModelInfo("belt", M_BELT, "(15), pendulum locked", "u", 6, (1, 3, 4, 5), (3, 4, 5), False,
              "flexible belt with the play hysteresis of figure 5, motor inertia neglected"),
    ModelInfo("belt-full", M_BELT_FULL, "(4a) with (15)", "u", 6, (0, 1, 2, 3, 4, 5), (0, 2, 3, 4, 5), False,
              "the belt with the pendulum free (the virtual rig's truth plant)"),
    ModelInfo("free", M_FREE_HELD, "section 5.2, wheel held", None, 4, (0, 2), (0, 2), False,
              "free pendulum, motor off, the wheel held to the arm: q3' = -xi rho/(1 + rho)"),
    ModelInfo("free-nowheel", M_FREE_NOWHEEL, "section 5.2", None, 4, (0, 2), (0, 2), False,
              "free pendulum without a wheel: q3' = -xi"),
)}

#: models that can have their pendulum clamped (``locked=True``)
_CLAMPABLE = ("raw", "compensated", "belt-full")


def model_info(model: str) -> ModelInfo:
    """The :class:`ModelInfo` of a model name; a clear error for an unknown one."""
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
        if info.code in BELT_CODES:
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
    P[P1], P[P2], P[P3], P[RHO] = params.p1, params.p2, params.p3, params.rho
    P[SA], P[SV], P[SB] = params.sigma_a1, params.sigma_v1, params.sigma_b1
    P[VPOS], P[VNEG], P[SC2] = params.v_dz_pos, params.v_dz_neg, params.sigma_c2
    P[SC1], P[UOFF] = params.sigma_c1, params.u_offset
    P[EPSC] = plant.coulomb_eps
    if plant.startup is not None:
        P[BRK], P[WS] = plant.startup.break_ratio, plant.startup.omega_s
    else:
        P[WS] = 1.0
    if plant.locked and plant.model not in _CLAMPABLE and info.code not in (M_MD, M_MD_RAW):
        raise InputError(f"locked=True applies to the models {', '.join(_CLAMPABLE)}, not {plant.model!r}")
    P[LOCK] = 1.0 if plant.locked else 0.0
    P[DZ] = 1.0 if plant.dead_zone_active else 0.0
    if info.code in (M_BELT, M_BELT_FULL):
        b = plant.belt
        P[KI2], P[DPLAY], P[NB] = b.k_over_I2, b.d, b.N
        P[B2I2], P[KG], P[KBRG] = b.b2_over_I2, b.k_over_gamma, b.kTbeta_over_Rgamma
        P[KNEG] = b.gain_neg
    return P


def is_pendulum_locked(plant: Plant) -> bool:
    """True if the plant's pendulum cannot swing (clamped, a motor-disk model or the locked belt)."""
    return plant.locked or plant.code in (M_MD, M_MD_RAW, M_BELT)

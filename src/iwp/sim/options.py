"""Simulation options as objects shared by every entry point.

:class:`Tolerances` holds the integrator's error and step knobs and
:class:`CommandChain` the path from the ideal input ``u`` to the plant's
command: the input or controller, the dead-zone feedforward (7)-(8)
(:class:`Feedforward`) and the saturation. Both are frozen and checked
when built, so one object can be passed to :func:`~iwp.sim.simulate.simulate`,
:func:`~iwp.sim.simulate.simulate_batch`,
:func:`~iwp.sim.sensitivity.simulate_sensitivities`,
:func:`~iwp.sim.simulate.simulate_scipy` and
:class:`~iwp.sim.tasks.SimulationTask` alike.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..checks import check_finite, check_positive
from ..errors import InputError

__all__ = ["CommandChain", "Feedforward", "Tolerances"]


def _positive(name: str, value) -> float:
    """``value`` as a positive finite float, or a one-line :class:`InputError` naming ``name``."""
    if isinstance(value, bool):
        raise InputError(f"{name} must be a positive number, got {value!r}", argument=name)
    return check_positive(name, value)


@dataclass(frozen=True)
class Tolerances:
    """The DOP853 integrator's error tolerances and step limits.

    Parameters
    ----------
    rtol : float
        Relative local error tolerance [-].
    atol : float or sequence of float
        Absolute local error tolerance, one value for all states or one per
        state (in the states' units: rad, rad/s), as in
        :func:`scipy.integrate.solve_ivp`; a sequence is kept as a tuple.
    max_step : float, optional
        Largest step [s]; None: unbounded.
    max_steps : int
        Step limit (accepted and rejected steps) [-].

    Notes
    -----
    The per-entry-point defaults differ (:func:`~iwp.sim.simulate.simulate`
    uses ``Tolerances()``, :func:`~iwp.sim.sensitivity.simulate_sensitivities`
    ``Tolerances(rtol=1e-9, atol=1e-9)``); the number of states an ``atol``
    sequence must match is checked when the plant is known.
    """

    rtol: float = 1e-10
    atol: float | tuple[float, ...] = 1e-10
    max_step: float | None = None
    max_steps: int = 50_000_000

    def __post_init__(self) -> None:
        object.__setattr__(self, "rtol", _positive("rtol", self.rtol))
        if np.ndim(self.atol) == 0:
            object.__setattr__(self, "atol", _positive("atol", self.atol))
        else:
            try:
                flat = np.asarray(self.atol, dtype=float).ravel()
            except (TypeError, ValueError):
                raise InputError(f"atol must be a positive number or a sequence of them, got {self.atol!r}",
                                 argument="atol") from None
            values = tuple(_positive(f"atol[{i}]", v) for i, v in enumerate(flat))
            if np.ndim(self.atol) != 1 or not values:
                raise InputError(f"atol must be a positive number or a flat sequence of them, got {self.atol!r}",
                                 argument="atol")
            object.__setattr__(self, "atol", values)
        if self.max_step is not None:
            object.__setattr__(self, "max_step", _positive("max_step", self.max_step))
        m = self.max_steps
        if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 1:
            raise InputError(f"max_steps must be a positive integer, got {m!r}", argument="max_steps")
        object.__setattr__(self, "max_steps", int(m))


@dataclass(frozen=True)
class Feedforward:
    """The dead-zone feedforward (7)-(8): ``u + v_pos`` for ``u > 0``, ``u - v_neg`` for ``u < 0``.

    Parameters
    ----------
    v_pos, v_neg : float
        The compensator's thresholds [input units] (finite; the dead zone's
        ``v_dz_pos, v_dz_neg``). They may differ from the simulated plant's
        own (a compensator tuned on identified values driving another plant).
    """

    v_pos: float
    v_neg: float

    def __post_init__(self) -> None:
        for name in ("v_pos", "v_neg"):
            v = getattr(self, name)
            if isinstance(v, bool):
                raise InputError(f"feedforward {name} must be a number [input units], got {v!r}", argument=name)
            object.__setattr__(self, name, check_finite(f"feedforward {name}", v))

    @classmethod
    def of_plant(cls, plant) -> "Feedforward":
        """The feedforward with ``plant``'s own dead-zone thresholds ``v_dz_pos, v_dz_neg`` [input units]."""
        lp = getattr(plant, "lumped", plant)
        return cls(lp.v_dz_pos, lp.v_dz_neg)


@dataclass(frozen=True)
class CommandChain:
    """From the ideal input ``u`` to the plant's command: input, feedforward, saturation.

    Parameters
    ----------
    input : Input, optional
        The :mod:`iwp.sim.inputs` signal or controller giving ``u``; None: zero.
        :func:`~iwp.sim.simulate.simulate_batch` also takes a list of one type.
    feedforward : Feedforward, optional
        The dead-zone feedforward (7)-(8) applied to ``u``; None: none.
        ``Feedforward.of_plant(plant)`` uses the plant's own thresholds.
    saturation : float, optional
        Clip the command to ``[-saturation, saturation]`` [input units].
    """

    input: object = None
    feedforward: Feedforward | None = None
    saturation: float | None = None

    def __post_init__(self) -> None:
        if self.feedforward is not None and not isinstance(self.feedforward, Feedforward):
            raise InputError(f"feedforward must be a Feedforward(v_pos, v_neg) or None, got "
                             f"{type(self.feedforward).__name__}", argument="feedforward")
        if self.saturation is not None:
            object.__setattr__(self, "saturation", _positive("saturation", self.saturation))

    def feedforward_pair(self) -> tuple[float, float] | None:
        """The feedforward's thresholds ``(v_pos, v_neg)`` [input units], or None."""
        ff = self.feedforward
        return None if ff is None else (ff.v_pos, ff.v_neg)


def as_tolerances(tolerances, default: Tolerances) -> Tolerances:
    """``tolerances`` (a :class:`Tolerances`), or ``default`` for None; anything else is an :class:`InputError`."""
    if tolerances is None:
        return default
    if not isinstance(tolerances, Tolerances):
        raise InputError(f"tolerances must be an iwp.sim.Tolerances, got {type(tolerances).__name__}",
                         argument="tolerances")
    return tolerances


def as_chain(command) -> CommandChain:
    """``command`` as a :class:`CommandChain`: None is the zero input, a bare input the chain of that input alone."""
    if command is None:
        return CommandChain()
    if isinstance(command, CommandChain):
        return command
    if isinstance(command, (Sequence,)) and not isinstance(command, str):
        return CommandChain(input=list(command))
    return CommandChain(input=command)

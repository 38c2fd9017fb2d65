"""Simulation options as objects shared by every entry point.

:class:`Tolerances` holds the integrator's error and step knobs and
:class:`CommandChain` the path from the ideal input ``u`` to the plant's
command: the input or controller, the dead-zone feedforward (7)-(8)
(:class:`Feedforward`) and the saturation. :class:`SimOptions` gathers
what a run needs besides its plant, input, initial state and times (the
feedforward, the saturation, the tolerances and whether a failure raises),
for :func:`~iwp.sim.simulate.simulate` and
:func:`~iwp.sim.sensitivity.simulate_sensitivities`; :class:`BatchOptions`
the same for :func:`~iwp.sim.simulate.simulate_batch`, with what to keep of
each run. All are frozen and checked when built, so one object can be
passed to every entry point (:func:`~iwp.sim.simulate.simulate_scipy` takes a
:class:`SimOptions` too; :class:`~iwp.sim.tasks.SimulationTask`, which
``iwp simulate`` builds, a :class:`CommandChain` and :class:`Tolerances`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import check_finite, check_positive
from ..errors import InputError

__all__ = ["BATCH_STORES", "BatchOptions", "CommandChain", "Feedforward", "SimOptions", "Tolerances"]

#: What :func:`~iwp.sim.simulate.simulate_batch` keeps of each run (:attr:`BatchOptions.store`).
BATCH_STORES = ("samples", "final", "summary")


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
        _check_command(self)

    def feedforward_pair(self) -> tuple[float, float] | None:
        """The feedforward's thresholds ``(v_pos, v_neg)`` [input units], or None."""
        return _pair(self.feedforward)


def _check_command(options) -> None:
    """Check ``options.feedforward`` and normalise ``options.saturation`` (a frozen dataclass's fields)."""
    if options.feedforward is not None and not isinstance(options.feedforward, Feedforward):
        raise InputError(f"feedforward must be a Feedforward(v_pos, v_neg) or None, got "
                         f"{type(options.feedforward).__name__}", argument="feedforward")
    if options.saturation is not None:
        object.__setattr__(options, "saturation", _positive("saturation", options.saturation))


def _pair(feedforward: Feedforward | None) -> tuple[float, float] | None:
    """The thresholds ``(v_pos, v_neg)`` of ``feedforward`` [input units], or None."""
    return None if feedforward is None else (feedforward.v_pos, feedforward.v_neg)


def _flag(name: str, value) -> None:
    """A one-line :class:`InputError` naming ``name`` unless ``value`` is a bool."""
    if not isinstance(value, (bool, np.bool_)):
        raise InputError(f"{name} must be True or False, got {value!r}", argument=name)


@dataclass(frozen=True)
class _Drive:
    """The fields :class:`SimOptions` and :class:`BatchOptions` share (documented there)."""

    feedforward: Feedforward | None = None
    saturation: float | None = None
    tolerances: Tolerances | None = None

    def __post_init__(self) -> None:
        _check_command(self)
        if self.tolerances is not None and not isinstance(self.tolerances, Tolerances):
            raise InputError(f"tolerances must be an iwp.sim.Tolerances or None, got "
                             f"{type(self.tolerances).__name__}", argument="tolerances")

    def feedforward_pair(self) -> tuple[float, float] | None:
        """The feedforward's thresholds ``(v_pos, v_neg)`` [input units], or None."""
        return _pair(self.feedforward)


@dataclass(frozen=True)
class SimOptions(_Drive):
    """How one run is driven and integrated, besides its plant, input, initial state and times.

    Parameters
    ----------
    feedforward : Feedforward, optional
        The dead-zone feedforward (7)-(8) applied to the input ``u`` before the
        plant (its thresholds [input units]); ``Feedforward.of_plant(plant)``
        uses the plant's own ``v_dz_pos, v_dz_neg``, another pair a compensator
        tuned on identified values driving a plant with other ones. Only for
        a model with the dead zone (``model="raw"``). None: none.
    saturation : float, optional
        Clip the command to ``[-saturation, saturation]`` [input units]; None: no clipping.
    tolerances : Tolerances, optional
        The integrator's ``rtol`` [-], ``atol`` [state units], ``max_step`` [s]
        and ``max_steps``; None: the entry point's default
        (:func:`~iwp.sim.simulate.simulate`: ``Tolerances()``,
        :func:`~iwp.sim.sensitivity.simulate_sensitivities`:
        ``Tolerances(rtol=1e-9, atol=1e-9)``).
    check : bool
        Raise :class:`~iwp.errors.SimulationError` when the run fails
        (default); False returns the result with ``success=False`` and the
        samples computed before the failure.
    """

    check: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        _flag("check", self.check)


@dataclass(frozen=True)
class BatchOptions(_Drive):
    """How the runs of a batch are driven and integrated, and what is kept of each.

    Parameters
    ----------
    feedforward : Feedforward, optional
        The dead-zone feedforward (7)-(8) of every run (thresholds [input
        units]), as :class:`SimOptions`'s; None: none.
    saturation : float, optional
        Clip every run's command to ``[-saturation, saturation]`` [input units].
    tolerances : Tolerances, optional
        Of every run (``rtol`` [-], ``atol`` [state units], ``max_step`` [s],
        ``max_steps``); None: ``Tolerances()``.
    store : {"samples", "final", "summary"}
        What to keep of each run: the samples at the output times (``x``,
        ``u``, ``command``); only the final state (``x_final``, always
        kept); or per state the minimum, maximum, mean and RMS over the
        output times (``summary``), so that a sweep of many long runs does
        not hold every sample.
    inputs : bool
        With ``store="samples"``, also compute the input and command columns
        (``u``, ``command``); False leaves them None and saves evaluating the
        input at every sample (a chirp: 0.7 ms per run of 60,001 samples).

    Notes
    -----
    A batch never raises for a failed run: each run's ``status`` says.
    """

    store: str = "samples"
    inputs: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.store not in BATCH_STORES:
            raise InputError(f"store must be one of {', '.join(BATCH_STORES)}, got {self.store!r}", argument="store")
        _flag("inputs", self.inputs)


def as_options(options, kind: type):
    """``options`` (an instance of ``kind``, :class:`SimOptions` or :class:`BatchOptions`), or ``kind()`` for None.

    Raises
    ------
    InputError
        Any other type, in one line naming ``options``.
    """
    if options is None:
        return kind()
    if not isinstance(options, kind):
        raise InputError(f"options must be an iwp.sim.{kind.__name__}, got {type(options).__name__}",
                         argument="options")
    return options

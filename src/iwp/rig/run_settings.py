"""The settings of a run, turned into what a simulation or a rig takes: the open-loop input laws of the
experiments (:class:`~iwp.rig.experiments.InputLaw`; the one place that builds them) and the checks of the run
options (seed, dead-zone compensation, initial state).

The sinusoids and chirps of the paper are :mod:`iwp.sim.inputs` signals the
compiled simulation evaluates; a rig in the loop also takes a PRBS and steps,
evaluated by its host (:class:`HostInput`). Apart from the experiments' table
(:mod:`iwp.rig.experiments`) so that listing the experiments loads neither
numpy nor simulation code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

from ..checks import check_finite, check_nonnegative, check_positive
from ..errors import InputError
from ..sim.inputs import Chirp, Input, Sine
from .experiments import InputLaw, experiment_spec

__all__ = ["law_input", "prbs", "HostInput", "open_loop_input", "check_seed", "compensation_thresholds",
           "initial_state"]


def law_input(law: InputLaw, settings: Mapping[str, Any], Ts: float | None = None):
    """The ideal input ``u(t)`` of the input law ``law`` with ``settings``: the one place that builds them.

    The sinusoids ``u = A sin(omega t)`` (figures 3, 4), the chirps
    ``u = A sin((w0 + t/tau) t)`` (section 5.1 and eq. (16)), and for a rig in
    the loop a PRBS and steps.

    Parameters
    ----------
    law : InputLaw
        The input law.
    settings : mapping of str to object
        Its settings: ``amplitude`` [input units] (sine, chirp, PRBS); ``omega`` [rad/s] (sine); ``w0``
        [rad/s] and ``tau`` [s^2/rad] (chirp); ``hold_time`` [s], ``duration`` [s] and ``seed`` (PRBS);
        ``levels`` [input units] and ``step_time`` [s] (steps).
    Ts : float, optional
        Sample period [s]; needed by the PRBS (its levels are held a whole number of samples).

    Returns
    -------
    Input or HostInput
        :class:`~iwp.sim.inputs.Sine` or :class:`~iwp.sim.inputs.Chirp` (signals the simulation evaluates),
        or a :class:`HostInput` (PRBS, steps: evaluated by the host of a rig in the loop). Each has
        ``evaluate(t)`` [input units], ``t`` [s].

    Raises
    ------
    InputError
        A non-finite amplitude or level, a frequency, ``tau``, hold or step time that is not > 0, no
        levels, or a PRBS without ``Ts``.
    """
    if law is InputLaw.SINE:
        return Sine(check_finite("amplitude", settings["amplitude"]), check_finite("omega", settings["omega"]))
    if law is InputLaw.CHIRP:
        return Chirp(check_finite("amplitude", settings["amplitude"]), check_positive("w0", settings["w0"]),
                     check_positive("tau", settings["tau"]))
    if law is InputLaw.PRBS:
        if Ts is None:
            raise InputError("a PRBS needs the sample period Ts")
        hold = max(1, int(round(check_positive("hold_time", settings["hold_time"]) / Ts)))
        n = int(math.floor(check_positive("duration", settings["duration"]) / Ts)) + 2
        amplitude = check_finite("amplitude", settings["amplitude"])
        values = prbs(n, hold=hold, amplitude=amplitude, seed=int(settings["seed"]))
        return HostInput(lambda t: float(values[min(int(round(t / Ts)), n - 1)]),
                         f"PRBS +-{abs(amplitude):g}, each level held at least {hold} samples")
    if law is InputLaw.STEPS:
        levels = [check_finite("levels", x) for x in settings["levels"]]
        if not levels:
            raise InputError("levels must hold at least one value", argument="levels")
        T = check_positive("step_time", settings["step_time"])
        return HostInput(lambda t: levels[int(t // T) % len(levels)], f"steps {levels} each {T:g} s, repeated")
    raise InputError(f"law must be an InputLaw, got {law!r}")


def prbs(n: int, *, hold: int, amplitude: float, seed: int = 0) -> np.ndarray:
    """A pseudo-random binary sequence of ``n`` samples: +-``amplitude``, each level held ``hold`` samples.

    (The levels come from ``numpy.random.default_rng(seed)``; the sign changes at random multiples of
    ``hold``, as a PRBS of a rig's test does.)

    Parameters
    ----------
    n : int
        Number of samples.
    hold : int
        Samples each level is held at least.
    amplitude : float
        The two levels are ``+-amplitude`` [the rig's input units].
    seed : int
        Seed of the random signs.

    Returns
    -------
    ndarray, shape (n,)
    """
    if n < 1 or hold < 1:
        raise InputError("prbs: n and hold must be >= 1")
    rng = np.random.default_rng(seed)
    levels = rng.integers(0, 2, size=n // hold + 1) * 2 - 1
    return amplitude * np.repeat(levels, hold)[:n].astype(float)


@dataclass(frozen=True)
class HostInput:
    """An input law evaluated by a host in Python (not by the compiled simulation): ``u = function(t)``.

    Attributes
    ----------
    function : callable
        ``function(t) -> u`` [input units], ``t`` [s].
    text : str
        What it is, one line.
    """

    function: Callable[[float], float]
    text: str

    def evaluate(self, t: float, x=None) -> float:
        """The input at time ``t`` [s] [input units] (``x`` is ignored)."""
        return self.function(t)

    def describe(self) -> str:
        """One line."""
        return self.text


def open_loop_input(name: str, settings: Mapping[str, Any]) -> Input | None:
    """The ideal input ``u(t)`` of the paper's experiment ``name`` with ``settings``; ``None`` if not open loop.

    Parameters
    ----------
    name : str
        Experiment name (:data:`EXPERIMENTS`).
    settings : mapping of str to object
        Its settings (see :func:`law_input`).

    Returns
    -------
    Input or None
        The input of its law (:attr:`ExperimentKind.law`): :class:`Sine` or :class:`Chirp`; None for an
        experiment that is not open loop.

    Raises
    ------
    InputError
        An unknown experiment, or a bad setting of its law.
    """
    law = experiment_spec(name).kind.law
    return None if law is None else law_input(law, settings)


# --------------------------------------------------------------------------
# checks of the run options
# --------------------------------------------------------------------------
def check_seed(seed) -> int:
    """``seed`` as an int >= 0 (the noise seed of ``numpy.random.default_rng``)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be an integer >= 0, got {seed!r}")
    return int(seed)


def compensation_thresholds(v_dz) -> tuple[float, float] | None:
    """The thresholds ``(v+, v-)`` of the rig's feedforward (7)-(8) [input units].

    ``v_dz``: ``None`` (no compensation), a number (both sides) or a pair ``(v+, v-)``.
    """
    if v_dz is None:
        return None
    if isinstance(v_dz, (list, tuple, np.ndarray)):
        if len(v_dz) != 2:
            raise InputError(f"v_dz must be a number or a pair (v_dz_pos, v_dz_neg), got {list(v_dz)!r}")
        pos, neg = v_dz
    else:
        pos = neg = v_dz
    return (check_nonnegative("v_dz (positive side)", pos), check_nonnegative("v_dz (negative side)", neg))


def initial_state(x0, what: str = "x0") -> np.ndarray:
    """``x0`` (``q1`` or ``[q1, q2, q3, q4]`` [rad, rad/s]) as the 4 states of the pendulum and disk."""
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

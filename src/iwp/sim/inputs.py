"""Inputs and feedback laws that drive a simulation.

Each is a frozen dataclass; :func:`iwp.sim.simulate.simulate` evaluates it
inside the compiled integrator through :func:`input_value`, and
``.evaluate(t, x)`` gives the same value from Python (the same compiled
function).

Open-loop signals: :class:`Constant`, :class:`Sine`, :class:`Chirp` (the
paper's ``u = A sin(w(t) t)``, ``w(t) = w0 + t/tau``), :class:`Step`,
:class:`Sampled` (an array held over each sample, zero-order hold).
State feedback: :class:`HopfController` (``u = k1 q3 + k2 q3^3``, section
5.3), :class:`BalanceController` (the linear feedback at the upright) and
:class:`CallableController` (any Python function of ``(t, x)``).
Feedback laws are evaluated continuously or, with ``Ts``, sampled every
``Ts`` and held, as a digital controller on the rig is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..checks import check_finite, check_positive
from ..errors import InputError
from ..jit import jit
from ..models.laws import balance_law, hopf_law
from ..models.mathfn import sincos

__all__ = ["Input", "Constant", "Sine", "Chirp", "Step", "Sampled", "HopfController", "BalanceController",
           "CallableController", "make_input", "input_value"]

# input kinds (what the compiled code evaluates)
I_ZERO = 0
I_CONST = 1
I_SINE = 2
I_CHIRP = 3
I_STEP = 4
I_SAMPLES = 5
I_HOPF = 6
I_EXTERNAL = 7  # held values supplied one segment at a time by Python
I_BALANCE = 8
#: length of an input's parameter vector
N_INPUT_PARAMS = 4


@jit(inline=True)
def input_value(kind, input_params, t, x):
    """The ideal input ``u(t, x)`` of a continuous input kind [input units].

    ``input_params`` is the input's parameter vector (:meth:`Input.parameters`).
    """
    if kind == I_CONST:
        return input_params[0]
    if kind == I_SINE:
        return input_params[0] * sincos(input_params[1] * t + input_params[2])[0] + input_params[3]
    if kind == I_CHIRP:
        return input_params[0] * sincos((input_params[1] + t / input_params[2]) * t)[0] + input_params[3]
    if kind == I_STEP:
        if t < input_params[0]:
            return input_params[2]
        return input_params[2] + input_params[1]
    if kind == I_HOPF:
        return hopf_law(input_params[0], input_params[1], x[2])
    if kind == I_BALANCE:
        return balance_law(input_params[0], input_params[1], input_params[2], x[0], x[2], x[3])
    return 0.0


class Input:
    """Base class of the inputs: a kind (compiled code) and a parameter vector."""

    kind: int = I_ZERO
    sampled_period: float | None = None
    #: names of the entries of :meth:`parameters` (for sensitivities)
    parameter_names: tuple[str, ...] = ()

    def parameters(self) -> np.ndarray:
        """The parameter vector that :func:`input_value` reads."""
        return np.zeros(N_INPUT_PARAMS)

    def evaluate(self, t: float, x=None) -> float:
        """The input ``u(t, x)`` [input units] (``x``: state, needed by feedback laws)."""
        xs = np.zeros(4) if x is None else np.asarray(x, dtype=float)
        return float(input_value(self.kind, self.parameters(), float(t), xs))

    def describe(self) -> str:
        return repr(self)

    def largest_phase(self, t0: float, t_end: float) -> float:
        """The largest ``|phase|`` [rad] whose sine the input takes over ``[t0, t_end]`` (0: no sine), which
        :func:`iwp.models.mathfn.sincos` computes exactly up to ``SINCOS_MAX``."""
        return 0.0


@dataclass(frozen=True)
class Constant(Input):
    """Constant input ``u = value`` [input units]."""

    value: float = 0.0

    kind = I_CONST

    def __post_init__(self):
        check_finite("value", self.value)

    def parameters(self):
        return np.array([self.value, 0.0, 0.0, 0.0])


@dataclass(frozen=True)
class Sine(Input):
    """Sinusoid ``u = amplitude sin(omega t + phase) + offset``.

    Parameters
    ----------
    amplitude : float
        [input units]; the paper uses 60, 40 and 20 (figures 3, 4).
    omega : float
        Angular frequency [rad/s]; the paper uses 5.
    phase : float
        [rad].
    offset : float
        [input units].
    """

    amplitude: float
    omega: float = 5.0
    phase: float = 0.0
    offset: float = 0.0

    kind = I_SINE

    def __post_init__(self):
        check_finite("amplitude", self.amplitude)
        check_finite("omega", self.omega)
        check_finite("phase", self.phase)
        check_finite("offset", self.offset)

    def parameters(self):
        return np.array([self.amplitude, self.omega, self.phase, self.offset])

    def largest_phase(self, t0: float, t_end: float) -> float:
        """``max |omega t + phase|`` over ``[t0, t_end]`` [rad] (at an end: the phase is linear in ``t``)."""
        return max(abs(self.omega * t + self.phase) for t in (t0, t_end))


@dataclass(frozen=True)
class Chirp(Input):
    """The paper's chirp ``u = amplitude sin(w(t) t)`` with ``w(t) = w0 + t/tau``.

    Section 5.1 uses ``A = 60, w0 = 3.2, tau = 75``; section 5.2 uses
    ``A = 60, w0 = 3, tau = 100``, both over 300 s. The instantaneous
    frequency is ``w0 + 2 t / tau`` [rad/s].

    Parameters
    ----------
    amplitude : float
        [input units].
    w0 : float
        [rad/s].
    tau : float
        [s^2/rad]: ``w`` grows by 1 rad/s every ``tau`` seconds.
    offset : float
        [input units].
    """

    amplitude: float
    w0: float
    tau: float
    offset: float = 0.0

    kind = I_CHIRP

    def __post_init__(self):
        check_finite("amplitude", self.amplitude)
        check_finite("w0", self.w0)
        check_positive("tau", self.tau)
        check_finite("offset", self.offset)

    def parameters(self):
        return np.array([self.amplitude, self.w0, self.tau, self.offset])

    def largest_phase(self, t0: float, t_end: float) -> float:
        """``max |(w0 + t/tau) t|`` over ``[t0, t_end]`` [rad]: at an end, or at the parabola's vertex."""
        ts = [t0, t_end] + ([-0.5 * self.w0 * self.tau] if t0 < -0.5 * self.w0 * self.tau < t_end else [])
        return max(abs((self.w0 + t / self.tau) * t) for t in ts)


@dataclass(frozen=True)
class Step(Input):
    """Step ``u = initial`` for ``t < t_step``, ``initial + amplitude`` after.

    The integrator restarts at ``t_step`` so the jump is resolved exactly.
    """

    amplitude: float
    t_step: float = 0.0
    initial: float = 0.0

    kind = I_STEP

    def __post_init__(self):
        check_finite("amplitude", self.amplitude)
        check_finite("t_step", self.t_step)
        check_finite("initial", self.initial)

    def parameters(self):
        return np.array([self.t_step, self.amplitude, self.initial, 0.0])


@dataclass(frozen=True, eq=False)
class Sampled(Input):
    """An input array held over each sample (zero-order hold).

    ``u(t) = values[k]`` for ``t0 + k Ts <= t < t0 + (k+1) Ts``; before
    ``t0`` the first value and after the last sample the last value.

    Parameters
    ----------
    values : array_like, shape (n,)
        Input samples [input units].
    Ts : float
        Sample period [s].
    t0 : float
        Time of ``values[0]`` [s].
    """

    values: np.ndarray
    Ts: float
    t0: float = 0.0

    kind = I_SAMPLES

    def __post_init__(self):
        vals = np.ascontiguousarray(np.asarray(self.values, dtype=float).ravel())
        if vals.size == 0:
            raise InputError("Sampled.values is empty")
        bad = np.flatnonzero(~np.isfinite(vals))
        if bad.size:
            raise InputError(f"Sampled.values[{bad[0]}] is not finite ({vals[bad[0]]!r})")
        object.__setattr__(self, "values", vals)
        check_positive("Ts", self.Ts)
        check_finite("t0", self.t0)

    @property
    def sampled_period(self):  # type: ignore[override]
        return self.Ts

    def evaluate(self, t: float, x=None) -> float:
        k = int(math.floor((float(t) - self.t0) / self.Ts + 1e-9))
        return float(self.values[min(max(k, 0), self.values.size - 1)])

    def describe(self) -> str:
        """One line (a log's ``input`` metadata): the samples' count, period and range, not the array."""
        v = self.values
        return f"Sampled({v.size} samples at Ts={self.Ts:g} s from t0={self.t0:g} s, in [{v.min():g}, {v.max():g}])"


@dataclass(frozen=True)
class HopfController(Input):
    """Hopf anticontrol law ``u = k1 q3 + k2 q3^3`` (section 5.3).

    Parameters
    ----------
    k1 : float
        Linear gain [input units s/rad]; the paper uses -10.
    k2 : float
        Cubic gain [input units s^3/rad^3]; the paper uses 0.1.
    Ts : float or None
        ``None``: evaluated continuously. Otherwise sampled every ``Ts`` [s]
        and held (zero-order hold), as on the rig.
    """

    k1: float
    k2: float
    Ts: float | None = None

    kind = I_HOPF
    parameter_names = ("k1", "k2")

    def __post_init__(self):
        check_finite("k1", self.k1)
        check_finite("k2", self.k2)
        if self.Ts is not None:
            check_positive("Ts", self.Ts)

    @property
    def sampled_period(self):  # type: ignore[override]
        return self.Ts

    def parameters(self):
        return np.array([self.k1, self.k2, 0.0, 0.0])


@dataclass(frozen=True)
class BalanceController(Input):
    """Linear state feedback at the upright ``u = -(k_angle wrap(q1 - pi) + k_q3 q3 + k_q4 q4)``.

    The balance LQR of :class:`iwp.control.balance.LQRBalance` as an input
    the compiled simulator evaluates (:func:`iwp.models.laws.balance_law`),
    so that many closed loops run side by side in
    :func:`~iwp.sim.simulate.simulate_batch`; its saturation is the
    simulator's ``saturation``.

    Parameters
    ----------
    k_angle : float
        Gain on the angle from the upright [input units/rad].
    k_q3, k_q4 : float
        Gains on the pendulum and disk velocities [input units s/rad].
    Ts : float or None
        ``None``: evaluated continuously; otherwise sampled every ``Ts`` [s] and held.
    """

    k_angle: float
    k_q3: float
    k_q4: float
    Ts: float | None = None

    kind = I_BALANCE
    parameter_names = ("k_angle", "k_q3", "k_q4")

    def __post_init__(self):
        check_finite("k_angle", self.k_angle)
        check_finite("k_q3", self.k_q3)
        check_finite("k_q4", self.k_q4)
        if self.Ts is not None:
            check_positive("Ts", self.Ts)

    @property
    def sampled_period(self):  # type: ignore[override]
        return self.Ts

    def parameters(self):
        return np.array([self.k_angle, self.k_q3, self.k_q4, 0.0])


@dataclass(frozen=True, eq=False)
class CallableController(Input):
    """Any state feedback ``u = func(t, x)`` written in Python.

    With ``Ts`` (recommended, and how a controller runs on the rig) the
    function is called once per sample and its value held; the integration
    between samples is compiled. With ``Ts=None`` it is evaluated
    continuously: the simulation then runs through
    ``scipy.integrate.solve_ivp`` (DOP853) with the same compiled model
    right-hand side, which is much slower.

    Parameters
    ----------
    func : callable
        ``func(t: float, x: ndarray) -> float``; ``x = [q1, q2, q3, q4, ...]``.
    Ts : float or None
        Sample period [s], or ``None`` for continuous evaluation.
    """

    func: Callable[[float, np.ndarray], float]
    Ts: float | None = None

    kind = I_EXTERNAL

    def __post_init__(self):
        if not callable(self.func):
            raise InputError(f"CallableController.func must be callable, got {type(self.func).__name__}")
        if self.Ts is not None:
            check_positive("Ts", self.Ts)

    @property
    def sampled_period(self):  # type: ignore[override]
        return self.Ts

    def evaluate(self, t: float, x=None) -> float:
        xs = np.zeros(4) if x is None else np.asarray(x, dtype=float)
        val = self.func(float(t), xs)
        try:
            val = float(val)
        except (TypeError, ValueError):
            raise InputError(f"controller returned {val!r} at t = {t:g} s; it must return a number") from None
        if not math.isfinite(val):
            raise InputError(f"controller returned {val!r} at t = {t:g} s; it must return a finite number")
        return val


INPUT_NAMES = ("zero", "constant", "sine", "chirp", "step")
CONTROLLER_NAMES = ("hopf",)


def make_input(name: str, argument: str = "input", **kw) -> Input | None:
    """Build an input by name (used by the CLI): ``zero``, ``constant``, ``sine``, ``chirp``, ``step``, ``hopf``.

    ``kw`` holds the input's settings (``amplitude``, ``omega``, ``w0``, ``tau``,
    ``t_step``; ``k1``, ``k2``, ``Ts`` for the Hopf law), each checked finite;
    ``argument`` names the option in errors.

    Parameters
    ----------
    name : str
        The input's name (case-insensitive); with ``argument="controller"`` only the controllers' names.
    argument : str
        The option named in errors (``"input"`` or ``"controller"``).
    **kw : float
        The settings: ``amplitude`` [input units], ``omega``, ``w0`` [rad/s], ``tau`` [s] (chirp), ``phase``
        [rad], ``t_step`` [s]; ``k1``, ``k2``, ``Ts`` [s] of the Hopf law (section 5.3).

    Returns
    -------
    Input or None
        The input; None for ``zero``.

    Raises
    ------
    InputError
        An unknown name, or a setting that is not finite.

    Examples
    --------
    What ``iwp simulate --input sine --amplitude 60 --omega 2`` builds, and the Hopf law of section 5.3:

    >>> from iwp.sim import make_input
    >>> sine = make_input("sine", amplitude=60.0, omega=2.0)
    >>> sine
    Sine(amplitude=60.0, omega=2.0, phase=0.0, offset=0.0)
    >>> round(sine.evaluate(0.5), 2)  # 60 sin(2 * 0.5) [input units]
    50.49
    >>> make_input("hopf", argument="controller", k1=-10, k2=0.1)
    HopfController(k1=-10, k2=0.1, Ts=None)
    >>> make_input("zero") is None
    True
    """
    for k, v in kw.items():
        if v is not None:
            check_finite(k, v)
    name = name.lower()
    choices = CONTROLLER_NAMES if argument == "controller" else INPUT_NAMES + CONTROLLER_NAMES
    if name not in choices:
        raise InputError(f"{argument} {name!r}: unknown; choose one of: {', '.join(choices)}", argument=argument)
    if name in CONTROLLER_NAMES and (kw.get("k1") is None or kw.get("k2") is None):
        raise InputError(f"{argument} {name!r} is a feedback law with gains k1 and k2: give controller={name} "
                         "with k1 and k2", argument=(argument, "controller", "k1", "k2"))
    if name == "zero":
        return None
    if name == "constant":
        return Constant(kw.get("amplitude", 0.0))
    if name == "sine":
        return Sine(kw["amplitude"], kw.get("omega", 5.0), kw.get("phase", 0.0))
    if name == "chirp":
        return Chirp(kw["amplitude"], kw["w0"], kw["tau"])
    if name == "step":
        return Step(kw["amplitude"], kw.get("t_step", 0.0))
    return HopfController(kw["k1"], kw["k2"], kw.get("Ts"))

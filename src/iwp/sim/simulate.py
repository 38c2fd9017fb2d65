"""Simulation of the inertia wheel pendulum models.

:func:`simulate` integrates a :class:`~iwp.models.plant.Plant` with the
compiled adaptive DOP853 engine (:mod:`iwp.sim.engine`) and returns a
:class:`~iwp.sim.result.SimulationResult` sampled every ``Ts`` (5 ms by
default, the paper's sample time). :func:`simulate_batch` runs many
parameter sets, initial states or gains at once on all cores.
:func:`simulate_scipy` runs the same right-hand side through
:func:`scipy.integrate.solve_ivp`, as a reference.

Restarting from a measured state at a given time (figure 9b) is
``simulate(..., t0=200.0, x0=state_at_200)``: inputs are evaluated at
absolute time.
"""

from __future__ import annotations

import math
import threading
from typing import NamedTuple

import numba
import numpy as np

from ..checks import check_finite, check_positive, check_samples
from ..errors import InputError, SimulationError
from ..models.actuator import command as command_value
from ..models.actuator import command_vector
from ..models.mathfn import SINCOS_MAX
from ..models.parameters import LumpedParameters, PhysicalParameters
from ..models.plant import Plant
from ..threads import thread_map
from . import engine, lanes
from .engine import (
    SEG_CONT,
    SEG_CONTROLLER,
    SEG_SAMPLES,
    ST_DIVERGED,
    ST_OK,
    ST_STEP_TOO_SMALL,
    STATUS_TEXT,
    Segments,
    Span,
    System,
    Tolerances,
    samples_output,
)
from .inputs import I_EXTERNAL, I_ZERO, N_INPUT_PARAMS, CallableController, Input, Sampled, input_value
from .options import BATCH_STORES, BatchOptions, SimOptions, as_options
from .options import Tolerances as TolerancesOptions
from .result import BatchResult, SimulationResult

__all__ = ["BATCH_STORES", "simulate", "simulate_batch", "simulate_scipy", "as_plant", "output_times", "X_MAX"]

#: States beyond this magnitude count as divergence [rad, rad/s].
X_MAX = 1e7

#: :func:`simulate`'s and :func:`simulate_batch`'s default tolerances.
SIM_TOLERANCES = TolerancesOptions()

#: :func:`simulate_scipy`'s default tolerances (its reference runs: a tighter ``atol``).
SCIPY_TOLERANCES = TolerancesOptions(rtol=1e-10, atol=1e-12)


# --------------------------------------------------------------------------
# building the engine's arguments
# --------------------------------------------------------------------------
def as_plant(plant, model: str | None = None) -> Plant:
    """A :class:`Plant` from a plant, or from a parameter set and a model name (default ``"compensated"``).

    Parameters
    ----------
    plant : Plant, LumpedParameters or PhysicalParameters
        The plant, or its parameters.
    model : str, optional
        The model's name (:data:`iwp.models.plant.MODELS`); with a plant, it must be the plant's.

    Returns
    -------
    Plant

    Raises
    ------
    InputError
        Another type, or a model that contradicts the plant's.
    """
    if isinstance(plant, Plant):
        if model is not None and model != plant.model:
            raise InputError(f"model={model!r} contradicts the plant's model {plant.model!r}; give one of them")
        return plant
    if isinstance(plant, (LumpedParameters, PhysicalParameters)):
        return Plant(plant, model=model or "compensated")
    raise InputError(
        f"plant must be a Plant or a parameter set (LumpedParameters, PhysicalParameters), got {type(plant).__name__}"
    )


def output_times(t0: float, t_end: float, Ts: float, t_eval=None) -> np.ndarray:
    """The output times: ``t_eval`` checked, or the grid ``t0, t0 + Ts, ...`` up to ``t_end`` [s].

    Parameters
    ----------
    t0, t_end : float
        Start and end of the run [s].
    Ts : float
        Output period of the grid [s] (without ``t_eval``).
    t_eval : array_like, optional
        Output times [s], strictly increasing, within ``[t0, t_end]``.

    Returns
    -------
    ndarray, shape (n,)
        The output times [s], C-ordered and writeable.

    Raises
    ------
    InputError
        ``t_eval`` empty, not finite, not increasing or outside the span; a grid of too many samples.
    """
    if t_eval is not None:
        # writeable and C-ordered: one compiled signature for every caller
        te = np.require(np.asarray(t_eval, dtype=float).ravel(), requirements=["C", "W"])
        if te.size == 0:
            raise InputError("t_eval is empty")
        if not np.all(np.isfinite(te)):
            raise InputError("t_eval contains NaN or inf")
        if np.any(np.diff(te) <= 0):
            raise InputError("t_eval must be strictly increasing")
        if te[0] < t0 - 1e-12 or te[-1] > t_end + 1e-9:
            raise InputError(f"t_eval must lie within [t0, t_end] = [{t0:g}, {t_end:g}] s")
        return te
    n = check_samples(np.floor((t_end - t0) / Ts + 1e-9) + 1.0, argument=("t_end", "t0", "Ts"),
                      what=f"t_end - t0 = {t_end - t0:.6g} s at Ts = {Ts:.6g} s") - 1
    return t0 + Ts * np.arange(n + 1)


def _check_span(t0, t_end, Ts) -> tuple[float, float, float]:
    t0 = check_finite("t0", t0)
    t_end = check_finite("t_end", t_end)
    if t_end <= t0:
        raise InputError(f"t_end must be > t0 (t0 = {t0:g} s), got t_end = {t_end:g} s", argument=("t_end", "t0"))
    return t0, t_end, check_positive("Ts", Ts)


def _check_input(input, t0: float, t_end: float) -> None:
    if input is not None and not isinstance(input, Input):
        raise InputError(f"input must be an iwp.sim.inputs signal or controller, got {type(input).__name__}")
    if input is not None and input.largest_phase(t0, t_end) > SINCOS_MAX:
        raise InputError(f"the input's sine reaches a phase of {input.largest_phase(t0, t_end):.3g} rad by t_end = "
                         f"{t_end:g} s, beyond the {SINCOS_MAX:g} rad up to which its sine is computed exactly; "
                         "simulate a shorter span (or shift t0)", argument=("t_end", "t0"))


def tolerances(
    n: int, rtol, atol, *, n_err: int | None = None, max_step=None, max_steps: int = 50_000_000
) -> Tolerances:
    """The engine's :class:`~iwp.sim.engine.Tolerances`; ``atol`` is one value or one per state (as scipy's)."""
    rtol = check_positive("rtol", rtol)
    h_max = math.inf if max_step is None else check_positive("max_step", max_step)
    if np.ndim(atol) == 0:
        a = np.full(n, check_positive("atol", atol))
    else:
        try:
            a = np.asarray(atol, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"atol must be a positive number or {n} positive numbers, one per state") from None
        if a.shape != (n,):
            raise InputError(
                f"atol must be a positive number or {n} positive numbers (one per state), got shape {a.shape}"
            )
        for i, v in enumerate(a):
            check_positive(f"atol[{i}]", float(v))
        a = np.ascontiguousarray(a)
    if isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer)) or max_steps < 1:
        raise InputError(f"max_steps must be a positive integer, got {max_steps!r}")
    return Tolerances(rtol, a, h_max, int(max_steps), X_MAX, n if n_err is None else int(n_err))


def engine_tolerances(n: int, opts: TolerancesOptions, *, n_err: int | None = None) -> Tolerances:
    """The engine's :class:`~iwp.sim.engine.Tolerances` of the options ``opts`` for ``n`` states."""
    return tolerances(n, opts.rtol, opts.atol, n_err=n_err, max_step=opts.max_step, max_steps=opts.max_steps)


def initial_state(x0, plant: Plant) -> np.ndarray:
    """``x0`` as the plant's state (zeros by default; a belt model's ``delta, w`` default to 0)."""
    n = plant.n_states
    if x0 is None:
        return np.zeros(n)
    try:
        x = np.array(x0, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError(f"x0 must be a sequence of {n} numbers, got {x0!r}") from None
    if n == 6 and x.size == 4:
        x = np.concatenate([x, [0.0, 0.0]])
    if x.size != n:
        raise InputError(
            f"x0 must have {n} values [q1, q2, q3, q4{', delta, w' if n == 6 else ''}] for model "
            f"{plant.model!r}, got {x.size}"
        )
    if not np.all(np.isfinite(x)):
        raise InputError(f"x0 must be finite, got {x.tolist()}", argument="x0")
    if np.any(np.abs(x) >= X_MAX):
        raise InputError(f"x0 must lie within +-{X_MAX:.0e} [rad, rad/s] (beyond it a run counts as diverged), "
                         f"got {x.tolist()}", argument="x0")
    return x


def command_of(plant: Plant, feedforward=None, saturation=None) -> np.ndarray:
    """The command vector: the feedforward (7)-(8) (``True``: the plant's thresholds, or a pair) and saturation."""
    pair = None
    if feedforward is not None and feedforward is not False:
        if feedforward is True:
            lp = plant.lumped
            pair = (lp.v_dz_pos, lp.v_dz_neg)
        else:
            try:
                pair = (float(feedforward[0]), float(feedforward[1]))
            except (TypeError, ValueError, IndexError):
                raise InputError("feedforward must be True, False or a pair (v_dz_pos, v_dz_neg)") from None
        check_finite("feedforward v_dz_pos", pair[0])
        check_finite("feedforward v_dz_neg", pair[1])
        if not plant.dead_zone_active:
            raise InputError(f"feedforward compensates the dead zone (7)-(8) of the raw command; model "
                             f"{plant.model!r} has none (its input is the compensated u), so the feedforward would "
                             "add the thresholds to it a second time: simulate model='raw'", argument="feedforward")
    sat = None if saturation is None else check_positive("saturation", saturation)
    return command_vector(pair, sat)


def system_of(plant: Plant, input, command_params: np.ndarray) -> System:
    """The engine's :class:`~iwp.sim.engine.System` for a plant driven by ``input``."""
    kind = I_ZERO if input is None else input.kind
    input_params = np.zeros(N_INPUT_PARAMS) if input is None else np.asarray(input.parameters(), dtype=float)
    return System(plant.code, plant.packed(), input_params, command_params, kind)


def segments_of(input, t0: float, external: float = 0.0) -> Segments:
    """How ``input`` is held: continuously evaluated, a held array, or a controller sampled every ``Ts``."""
    if isinstance(input, Sampled):
        # writable, as every array the kernels get: one compiled signature for all callers
        values = np.require(input.values, dtype=float, requirements=["C", "W"])
        return Segments(SEG_SAMPLES, float(input.Ts), float(input.t0), values, 0.0)
    Tc = None if input is None else input.sampled_period
    if Tc is not None:
        return Segments(SEG_CONTROLLER, float(Tc), float(t0), np.zeros(1), float(external))
    return Segments(SEG_CONT, 1.0, 0.0, np.zeros(1), 0.0)


def _finish(plant, t_out, X, inputs, stats, check, input) -> SimulationResult:
    """The result; ``inputs`` is ``(U, W)`` or a :class:`_LazyInputs` evaluated on first access."""
    status = int(stats.status)
    success = status == ST_OK
    if success:
        message = STATUS_TEXT[status]
    else:
        message = f"{STATUS_TEXT.get(status, 'failed')} at t = {stats.t_reached:.6g} s"
        if status == ST_DIVERGED:
            message += f" (a state exceeded {X_MAX:g} or became NaN); check the parameters and the input"
        if check:
            raise SimulationError(message)
        keep = np.all(np.isfinite(X), axis=1)
        t_out, X = t_out[keep], X[keep]
        if not callable(inputs):
            inputs = (inputs[0][keep], inputs[1][keep])
    meta = {"input": input.describe() if input is not None else "zero"}
    return SimulationResult(
        t=t_out,
        x=X,
        inputs=inputs,
        model=plant.model,
        success=success,
        status=status,
        message=message,
        nfev=int(stats.nfev),
        n_steps=int(stats.n_steps),
        n_rejected=int(stats.n_rejected),
        metadata=meta,
    )


class _LazyInputs:
    """``(u, command)`` of a continuous input at given samples, computed when first asked for."""

    def __init__(self, kind, input_params, command_params):
        self.kind, self.input_params, self.command_params = kind, input_params, command_params

    def __call__(self, t, x):
        U = np.empty(t.size)
        W = np.empty(t.size)
        engine.input_samples(self.kind, self.input_params, self.command_params, t, np.ascontiguousarray(x), U, W)
        return U, W


# --------------------------------------------------------------------------
# simulate
# --------------------------------------------------------------------------
def simulate(
    plant,
    *,
    input: Input | None = None,
    x0=None,
    t_end: float,
    t0: float = 0.0,
    Ts: float = 0.005,
    t_eval=None,
    options: SimOptions | None = None,
) -> SimulationResult:
    """Simulate one model of the inertia wheel pendulum.

    Parameters
    ----------
    plant : Plant or LumpedParameters or PhysicalParameters
        The plant (model, parameters and options). A parameter set alone is
        the plant ``Plant(params)`` of model (9), ``"compensated"``; another
        model: ``Plant(params, model="raw")`` (:data:`iwp.models.MODELS`).
    input : signal or controller, optional
        :mod:`iwp.sim.inputs` object giving the ideal input ``u`` [input
        units]. None: zero.
    x0 : array_like, optional
        Initial state ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s] at ``t0``
        (belt models: optionally ``+ [delta, w]``). Default: rest at the bottom.
    t_end : float
        Final time [s], ``> t0``.
    t0 : float
        Initial time [s]; inputs are evaluated at absolute time, so a
        restart (figure 9b) is ``t0=200, x0=measured state``.
    Ts : float
        Output sample time [s] (the paper's 5 ms by default).
    t_eval : array_like, optional
        Output times [s] instead of the ``Ts`` grid, increasing, within
        ``[t0, t_end]``.
    options : SimOptions, optional
        The dead-zone feedforward (7)-(8) and the saturation of the command
        [input units], the integrator's tolerances (default ``Tolerances()``:
        ``rtol = atol = 1e-10``) and whether a failed run raises
        :class:`~iwp.errors.SimulationError` (default) or returns the samples
        computed before the failure with ``success=False``.

    Returns
    -------
    SimulationResult

    Raises
    ------
    InputError
        An argument of the wrong type or value, in one line naming it.
    SimulationError
        The run failed (diverged, step too small) and ``options.check`` is True.

    Examples
    --------
    The Hopf law of section 5.3 on model (9), from just off the bottom:

    >>> from iwp import HopfController, Plant, simulate, table1
    >>> res = simulate(Plant(table1()), input=HopfController(k1=-10, k2=0.1), x0=[0.1, 0, 0, 0], t_end=1.0)
    >>> float(res.t[-1]), res.x.shape  # sampled every 5 ms
    (1.0, (201, 4))
    >>> float(res.q1[0])
    0.1
    """
    opts = as_options(options, SimOptions)
    plant = as_plant(plant)
    t0, t_end, Ts = _check_span(t0, t_end, Ts)
    _check_input(input, t0, t_end)
    x0a = initial_state(x0, plant)
    n = plant.n_states
    run = _Run(plant, x0a, t0, t_end, output_times(t0, t_end, Ts, t_eval),
               command_of(plant, opts.feedforward_pair(), opts.saturation),
               engine_tolerances(n, opts.tolerances or SIM_TOLERANCES))
    if isinstance(input, CallableController):
        if input.Ts is None:
            return _simulate_callable_continuous(run, input, opts.check)
        X, U, W, stats = _run_external(run, input)
        return _finish(plant, run.t_out, X, (U, W), stats, opts.check, input)
    n_out = run.t_out.size
    system = system_of(plant, input, run.command_params)
    seg = segments_of(input, t0)
    # the kernel writes every sample (NaN after a failure); a continuous
    # input is evaluated afterwards, on demand, from t and x
    held = engine.is_held(system.kind, seg.mode)
    X = np.empty((n_out, n))
    U = np.empty(n_out if held else 0)
    W = np.empty(n_out if held else 0)
    stats = engine.kernel(n)(system, seg, run.tol, Span(x0a.copy(), t0, t_end, -1.0),
                             samples_output(run.t_out, X, U, W, False))
    inputs = (U, W) if held else _LazyInputs(system.kind, system.input_params, run.command_params)
    return _finish(plant, run.t_out, X, inputs, stats, opts.check, input)


def integrate_held(
    plant: Plant, x, t: float, t_next: float, value: float, *, command_params=None, tol: Tolerances, h0: float = -1.0
) -> engine.RunStats:
    """Advance ``x`` (in place) from ``t`` to ``t_next`` with the command ``value`` held.

    One held segment of a sampled controller: the building block of Python
    controllers (:class:`~iwp.sim.inputs.CallableController`), the observer's
    prediction and the Gymnasium environment. ``h0`` is the step size to
    start with (the ``h_next`` of the previous segment).
    """
    command_params = command_vector() if command_params is None else command_params
    system = System(plant.code, plant.packed(), np.zeros(N_INPUT_PARAMS), command_params, I_EXTERNAL)
    seg = Segments(SEG_CONTROLLER, t_next - t, t, np.zeros(1), float(value))
    t_out = np.array([t_next])
    X = np.empty((1, plant.n_states))
    U = np.empty(1)
    W = np.empty(1)
    out = samples_output(t_out, X, U, W, False)
    return engine.kernel(plant.n_states)(system, seg, tol, Span(x, t, t_next, h0), out)


class _Run(NamedTuple):
    """One run's checked arguments, as the engine takes them."""

    plant: Plant
    x0: np.ndarray  # initial state [rad, rad/s]
    t0: float  # [s]
    t_end: float  # [s]
    t_out: np.ndarray  # output times [s]
    command_params: np.ndarray  # the feedforward and saturation (command_vector)
    tol: Tolerances  # the engine's


def _run_external(run: _Run, ctrl: CallableController) -> tuple[np.ndarray, np.ndarray, np.ndarray, engine.RunStats]:
    """A Python controller sampled every Ts: call it, integrate one held segment, repeat.

    Returns the states, the controller's ``u``, the command (NaN where not reached) and the run's statistics.
    """
    plant, t0, t_end, t_out, command_params, tol = run.plant, run.t0, run.t_end, run.t_out, run.command_params, run.tol
    Tc = ctrl.Ts
    n = plant.n_states
    X = np.full((t_out.size, n), np.nan)
    U = np.full(t_out.size, np.nan)
    W = np.full(t_out.size, np.nan)
    x = run.x0.copy()
    t = t0
    k = 0
    nfev = nacc = nrej = 0
    j0 = 0
    h_nat = -1.0
    n_out = t_out.size
    tol_t = 1e-9 * max(1.0, abs(t_end))
    status = ST_OK
    run = engine.kernel(n)
    input_params = np.zeros(N_INPUT_PARAMS)
    while t < t_end - tol_t:
        t_b = min(t0 + (k + 1) * Tc, t_end)
        u = ctrl.evaluate(t, x)
        # outputs of this segment: [t, t_b) (and t_end at the end)
        j1 = j0
        last = t_b >= t_end - tol_t
        while j1 < n_out and (t_out[j1] < t_b - tol_t or (last and t_out[j1] <= t_end + tol_t)):
            j1 += 1
        seg_t = t_out[j0:j1]
        Xs = np.full((seg_t.size, n), np.nan)
        Us = np.full(seg_t.size, np.nan)
        Ws = np.full(seg_t.size, np.nan)
        # the step size carries over from one held segment to the next
        st = run(
            System(plant.code, plant.packed(), input_params, command_params, I_EXTERNAL),
            Segments(SEG_CONTROLLER, Tc, t, np.zeros(1), u),
            tol,
            Span(x, t, t_b, h_nat),
            samples_output(seg_t, Xs, Us, Ws, True),
        )
        h_nat = st.h_next
        # the kernel's held value is the command; U records the controller's u
        X[j0:j1], W[j0:j1] = Xs, Ws
        U[j0:j1] = u
        nfev += st.nfev
        nacc += st.n_steps
        nrej += st.n_rejected
        j0 = j1
        t = st.t_reached
        if st.status != ST_OK:
            status = st.status
            break
        k += 1
    return X, U, W, engine.RunStats(status, nfev, nacc, nrej, t, h_nat)


def _simulate_callable_continuous(run: _Run, ctrl: CallableController, check: bool) -> SimulationResult:
    """A Python controller evaluated continuously: the run through :func:`scipy.integrate.solve_ivp` (DOP853)."""
    from scipy.integrate import solve_ivp

    plant, t0, t_end, t_out, command_params, tol = run.plant, run.t0, run.t_end, run.t_out, run.command_params, run.tol

    def f(t, y):
        return plant.rhs(y, command_value(ctrl.evaluate(t, y), command_params))

    sol = solve_ivp(
        f,
        (t0, t_end),
        run.x0,
        method="DOP853",
        t_eval=t_out,
        rtol=tol.rtol,
        atol=tol.atol,
        max_step=tol.h_max if math.isfinite(tol.h_max) else np.inf,
    )
    n = plant.n_states
    X = np.full((t_out.size, n), np.nan)
    X[: sol.y.shape[1]] = sol.y.T
    U = np.array([ctrl.evaluate(t, x) if np.all(np.isfinite(x)) else np.nan for t, x in zip(t_out, X)])
    W = np.array([command_value(u, command_params) if np.isfinite(u) else np.nan for u in U])
    status = ST_OK if sol.status == 0 else ST_STEP_TOO_SMALL
    t_reached = float(sol.t[-1]) if sol.t.size else t0
    return _finish(plant, t_out, X, (U, W), engine.RunStats(status, sol.nfev, 0, 0, t_reached, -1.0), check, ctrl)


# --------------------------------------------------------------------------
# many runs
# --------------------------------------------------------------------------
def simulate_batch(
    plant,
    *,
    input: Input | list | None = None,
    x0=None,
    t_end: float,
    t0: float = 0.0,
    Ts: float = 0.005,
    t_eval=None,
    options: BatchOptions | None = None,
) -> BatchResult:
    """Run many simulations at once, in parallel on all cores.

    Any of ``plant``, ``x0`` and ``input`` may be a list (all lists of the
    same length, the number of runs); the others are shared. Plants in a
    list must share their model; inputs in a list must be of one type (e.g.
    :class:`~iwp.sim.inputs.HopfController` with different gains, or
    :class:`~iwp.sim.inputs.Sampled` arrays on one sample grid); Python
    callables are not supported here.

    Failed runs are reported per run in ``status`` (no exception); their
    samples after the failure are NaN, their summaries NaN.

    Model (9) without optional terms under a constant, a sine, a chirp or
    the continuous Hopf law (a sweep's closed loops, the draws of a
    prediction band) runs 16 at a time on each thread, side by side,
    each with its own step size and error control, vectorised by the
    compiler (:mod:`iwp.sim.lanes`; its result equals that of
    :func:`simulate` up to rounding). Every other batch runs the single-run
    kernel per run on all cores (:func:`iwp.threads.thread_map`); its
    results are :func:`simulate`'s to the last bit.

    Parameters
    ----------
    plant : Plant or LumpedParameters, or a list of them
        The plants (one model; a parameter set alone: model (9)).
    input : Input, or a list of one type, optional
        Inputs or laws (:mod:`iwp.sim.inputs`) [input units].
    x0 : array_like, or a list of them, optional
        Initial states ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s].
    t_end, t0, Ts : float
        Final and initial time, output sample period [s].
    t_eval : array_like, optional
        Output times [s] instead of the ``Ts`` grid.
    options : BatchOptions, optional
        The feedforward (7)-(8) and saturation [input units] of every run,
        the tolerances (default ``Tolerances()``), what to keep of each run
        (``store``: the samples, the final state or a summary) and whether to
        compute the input columns (``inputs``).

    Returns
    -------
    BatchResult
        Times [s], states ``(n_runs, n_out, n_states)`` and inputs per run
        (with ``store="samples"``), the final states, and a status per run
        (0: success).

    Raises
    ------
    InputError
        An argument of the wrong type or value, lists of different lengths,
        plants of different models or inputs of different types.

    Examples
    --------
    Two gains side by side:

    >>> from iwp import HopfController, simulate_batch, table1
    >>> runs = simulate_batch(table1(), input=[HopfController(-10.0, 0.1), HopfController(-9.0, 0.1)],
    ...                       x0=[0.1, 0, 0, 0], t_end=1.0)
    >>> runs.success.tolist(), runs.x_final.shape
    ([True, True], (2, 4))
    """
    opts = as_options(options, BatchOptions)
    p_list, x_list, i_list = _batch_lists(plant, x0, input)
    t0, t_end, Ts = _check_span(t0, t_end, Ts)
    _check_batch_inputs(i_list, t0, t_end)
    first, Pm, X0m = _batch_plants_states(p_list, x_list)
    n, nrun = first.n_states, len(p_list)
    input_params_runs = np.ascontiguousarray(
        [np.zeros(N_INPUT_PARAMS) if i_ is None else i_.parameters() for i_ in i_list], dtype=float
    )
    command_params = command_of(first, opts.feedforward_pair(), opts.saturation)
    tol = engine_tolerances(n, opts.tolerances or SIM_TOLERANCES)
    seg = _batch_segments(i_list, t0, nrun)
    kind = I_ZERO if i_list[0] is None else i_list[0].kind
    t_out = output_times(t0, t_end, Ts, t_eval)
    out = _batch_output(np.empty(0) if opts.store == "final" else t_out, opts, nrun, n)
    batch = lanes.Batch(first.code, Pm, X0m, kind, input_params_runs, command_params, seg, t0, t_end)
    if lanes.vectorised(first.code, kind, seg.mode, Pm, 0, nrun):
        nb = min(numba.get_num_threads(), nrun)
        interruptible(lambda: lanes.kernel(n)(batch, tol, out, nb), out.halt)
    else:
        _single_runs(batch, tol, out, n)
    keep = opts.store == "samples"
    return BatchResult(t=t_out if opts.store != "final" else np.array([t_end]), x=out.X if keep else None,
                       u=out.U if keep and opts.inputs else None, command=out.W if keep and opts.inputs else None,
                       status=out.status, nfev=out.nfev, x_final=out.x_final,
                       summary=_batch_summary(out) if opts.store == "summary" else None, store=opts.store)


def _batch_lists(plant, x0, input) -> tuple[list, list, list]:
    """The plant, initial state and input of each run of a batch: lists of one length, shared values repeated."""
    lists = [len(v) for v in (plant, x0, input) if isinstance(v, (list, tuple)) and not _is_state(v)]
    if lists and len(set(lists)) != 1:
        raise InputError(f"list arguments of simulate_batch must have one length, got lengths {sorted(set(lists))}")
    nrun = lists[0] if lists else 1
    if nrun == 0:
        raise InputError("simulate_batch needs at least one run")
    p_list = plant if isinstance(plant, (list, tuple)) else [plant] * nrun
    x_list = x0 if isinstance(x0, (list, tuple)) and not _is_state(x0) else [x0] * nrun
    i_list = input if isinstance(input, (list, tuple)) else [input] * nrun
    return list(p_list), list(x_list), list(i_list)


def _check_batch_inputs(i_list: list, t0: float, t_end: float) -> None:
    """The inputs of a batch: of one type, built-in (no callables), one sample period."""
    if len({type(i) for i in i_list}) != 1:
        raise InputError("inputs of one batch must all be of one type")
    for i_ in i_list:
        _check_input(i_, t0, t_end)
    if any(isinstance(i, CallableController) for i in i_list):
        raise InputError("simulate_batch supports built-in signals, controllers and sampled arrays, not callables")
    if len({None if i is None else i.sampled_period for i in i_list}) != 1:
        raise InputError("inputs of one batch must share the sample period Ts")


def _batch_plants_states(p_list: list, x_list: list) -> tuple[Plant, np.ndarray, np.ndarray]:
    """The first run's plant and the packed parameters and initial states of every run (rows), each checked once."""
    plants = {}
    for p_ in p_list:
        if id(p_) not in plants:
            plants[id(p_)] = as_plant(p_)
    models = {pl.model for pl in plants.values()}
    if len(models) != 1:
        raise InputError(f"plants of one batch must share their model, got {sorted(models)}")
    first = plants[id(p_list[0])]
    states = {}
    for x_ in x_list:
        if id(x_) not in states:
            states[id(x_)] = initial_state(x_, first)
    packed = {k: pl.packed() for k, pl in plants.items()}
    Pm = np.ascontiguousarray([packed[id(p_)] for p_ in p_list], dtype=float)
    X0m = np.ascontiguousarray([states[id(x_)] for x_ in x_list], dtype=float)
    return first, Pm, X0m


def interruptible(call, halt: np.ndarray) -> None:
    """Run ``call`` (a compiled kernel that releases the GIL and stops when ``halt[0]`` is set) so that a signal
    interrupts it.

    Python runs a signal's handler in the main thread between bytecodes; a kernel the main thread runs holds
    it off until the kernel returns (a sweep's slice of lanes ignored SIGTERM for 16 s). From the main thread the
    kernel therefore runs in a thread of its own, with the caller's number of numba threads, while the main thread
    waits for it where signals reach it; on an interrupt it sets ``halt[0]``, waits for the kernel to stop at its
    next step, and raises the interrupt. From any other thread ``call`` runs there.

    Parameters
    ----------
    call : callable
        The kernel's call, no arguments.
    halt : ndarray of int64, shape (1,)
        The kernel's stop flag.
    """
    if threading.current_thread() is not threading.main_thread():
        call()
        return
    threads = numba.get_num_threads()  # numba's thread count is the calling thread's own
    failed: list[BaseException] = []

    def run() -> None:
        try:
            numba.set_num_threads(threads)
            call()
        except BaseException as exc:  # noqa: BLE001 (handed to the caller)
            failed.append(exc)

    worker = threading.Thread(target=run, name="iwp-kernel", daemon=True)
    worker.start()
    try:
        worker.join()
    except BaseException:
        halt[0] = 1
        worker.join()
        raise
    if failed:
        raise failed[0]


def _batch_output(t_run: np.ndarray, opts: BatchOptions, nrun: int, n: int) -> lanes.BatchOutput:
    """The arrays the runs of a batch write into, as ``opts.store`` and ``opts.inputs`` ask."""
    n_keep = t_run.size if opts.store == "samples" else 0
    X = np.empty((nrun, n_keep, n))
    U = np.empty((nrun, n_keep if opts.inputs else 0))
    W = np.empty((nrun, n_keep if opts.inputs else 0))
    if opts.store == "summary":
        S = np.zeros((nrun, engine.N_SUMMARY, n))
        S[:, 0] = np.inf
        S[:, 1] = -np.inf
    else:
        S = np.zeros((nrun, engine.N_SUMMARY, 1))
    return lanes.BatchOutput(
        t_run, engine.STORE_SUMMARY if opts.store == "summary" else engine.STORE_SAMPLES, X, U, W, S,
        np.empty((nrun, n)), np.zeros(nrun, dtype=np.int64), np.zeros(nrun, dtype=np.int64),
        np.zeros(nrun, dtype=np.int64), np.zeros(nrun, dtype=np.int64), np.zeros(1, dtype=np.int64),
    )


def _batch_summary(out: lanes.BatchOutput) -> dict[str, np.ndarray]:
    """Per run and state the minimum, maximum, mean and RMS over the output times (NaN for a failed run)."""
    S = out.S
    failed = out.status != ST_OK
    m = max(out.t.size, 1)
    summary = {"min": S[:, 0], "max": S[:, 1], "mean": S[:, 2] / m, "rms": np.sqrt(S[:, 3] / m)}
    for v in summary.values():
        v[failed] = np.nan
    return summary


def _single_runs(bt: lanes.Batch, tol: Tolerances, out: lanes.BatchOutput, n: int) -> None:
    """The runs of a batch that the lanes do not vectorise, each with the single-run kernel, on all cores.

    A lane whose right-hand side does not vectorise cost 4-5 times a single
    run with the same steps (when the lanes took such runs: the Hopf law with
    the wheel's Coulomb friction, 1,023 ms of CPU against 216 ms). The runs go
    to :func:`iwp.threads.thread_map` (the kernel releases the GIL) and write
    into their rows of ``out``, as the lanes do.
    """
    kernel = engine.kernel(n)
    held = engine.is_held(bt.kind, bt.seg.mode)
    seg = bt.seg

    def run(r: int) -> None:
        x = bt.X0[r].copy()  # advanced to the final state in place
        o = engine.Output(out.t, out.X[r], out.U[r], out.W[r], False, out.store, out.S[r])
        stats = kernel(System(bt.model, bt.P[r], bt.input_params[r], bt.command_params, bt.kind),
                       Segments(seg.mode, seg.period, seg.start, seg.values[r], seg.external), tol,
                       Span(x, bt.t0, bt.t_end, -1.0), o)
        if out.store == engine.STORE_SAMPLES:
            unreached = np.flatnonzero(np.isnan(out.X[r][:, 0]))
            j = int(unreached[0]) if unreached.size else out.t.size
            if not held and out.U[r].size == out.t.size:  # a continuous input's columns (if kept), from the states
                engine.input_samples(bt.kind, bt.input_params[r], bt.command_params, out.t[:j], out.X[r][:j],
                                     out.U[r][:j], out.W[r][:j])
            out.U[r][j:] = np.nan  # the samples after a failure
            out.W[r][j:] = np.nan
        out.x_final[r] = x
        out.status[r], out.nfev[r] = stats.status, stats.nfev
        out.n_steps[r], out.n_rejected[r] = stats.n_steps, stats.n_rejected

    thread_map(run, range(bt.X0.shape[0]))


def _batch_segments(i_list, t0: float, nrun: int) -> Segments:
    """How the inputs of a batch are held; sampled arrays: one row of held values per run (padded with the last)."""
    first = i_list[0]
    if isinstance(first, Sampled):
        grids = {(float(i.Ts), float(i.t0)) for i in i_list}
        if len(grids) != 1:
            raise InputError("sampled inputs of one batch must share their sample time Ts and start t0")
        m = max(i.values.size for i in i_list)
        values = np.empty((nrun, m))
        for r, i in enumerate(i_list):
            v = np.asarray(i.values, dtype=float)
            values[r, : v.size] = v
            values[r, v.size:] = v[-1]
        return Segments(SEG_SAMPLES, float(first.Ts), float(first.t0), values, 0.0)
    seg = segments_of(first, t0)
    return Segments(seg.mode, seg.period, seg.start, np.zeros((nrun, 1)), 0.0)


def _is_state(v) -> bool:
    """True if ``v`` looks like one state vector (a flat list of numbers)."""
    return isinstance(v, (list, tuple)) and len(v) > 0 and all(isinstance(e, (int, float)) for e in v)


def simulate_scipy(
    plant,
    *,
    input: Input | None = None,
    x0=None,
    t_end: float,
    t0: float = 0.0,
    Ts: float = 0.005,
    t_eval=None,
    options: SimOptions | None = None,
) -> SimulationResult:
    """The same simulation through :func:`scipy.integrate.solve_ivp` (a reference).

    Uses the compiled right-hand side of :mod:`iwp.models` with a continuous
    input (sampled inputs are not supported here). Slower than
    :func:`simulate`; meant for cross-checks.

    Parameters
    ----------
    plant : Plant or LumpedParameters or PhysicalParameters
        As :func:`simulate` (a parameter set alone: model ``"compensated"``;
        another model: ``Plant(params, model=...)``).
    input : Input, optional
        A continuous input or law of :mod:`iwp.sim.inputs` [input units]
        (sampled inputs and Python callables are refused). None: zero.
    x0 : array_like, optional
        Initial state ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s] at ``t0``.
    t_end, t0 : float
        Final and initial time [s].
    Ts : float
        Output sample period [s].
    t_eval : array_like, optional
        Output times [s] instead of the grid of ``Ts``.
    options : SimOptions, optional
        As :func:`simulate`'s: the feedforward (7)-(8) and saturation
        [input units]; the tolerances ``rtol`` [-] and ``atol`` [state units]
        of ``solve_ivp``'s DOP853 (default ``Tolerances(rtol=1e-10,
        atol=1e-12)``; ``max_step`` [s] is passed on, ``max_steps`` unused);
        whether a failed solve raises :class:`~iwp.errors.SimulationError`.

    Returns
    -------
    SimulationResult

    Examples
    --------
    The reference integrator agrees with :func:`simulate`:

    >>> import numpy as np
    >>> from iwp import Plant, simulate, simulate_scipy, table1
    >>> plant = Plant(table1())
    >>> a = simulate_scipy(plant, x0=[0.5, 0, 0, 0], t_end=1.0)
    >>> b = simulate(plant, x0=[0.5, 0, 0, 0], t_end=1.0)
    >>> bool(np.abs(a.q1 - b.q1).max() < 1e-8)
    True
    """
    from scipy.integrate import solve_ivp

    opts = as_options(options, SimOptions)
    plant = as_plant(plant)
    tols = opts.tolerances or SCIPY_TOLERANCES
    t0, t_end, Ts = _check_span(t0, t_end, Ts)
    _check_input(input, t0, t_end)
    x0a = initial_state(x0, plant)
    tol = engine_tolerances(plant.n_states, tols)
    command_params = command_of(plant, opts.feedforward_pair(), opts.saturation)
    seg = segments_of(input, t0)
    if seg.mode != SEG_CONT or isinstance(input, CallableController):
        raise InputError("simulate_scipy supports continuous built-in inputs only", argument="input")
    system = system_of(plant, input, command_params)
    t_out = output_times(t0, t_end, Ts, t_eval)

    def f(t, y):
        return plant.rhs(y, command_value(input_value(system.kind, system.input_params, t, y), command_params))

    sol = solve_ivp(f, (t0, t_end), x0a, method="DOP853", t_eval=t_out, rtol=tol.rtol, atol=tol.atol,
                    **({} if tols.max_step is None else {"max_step": tols.max_step}))
    if sol.status != 0 and opts.check:
        raise SimulationError(f"solve_ivp failed: {sol.message}")
    X = sol.y.T
    U = np.array([input_value(system.kind, system.input_params, t, x) for t, x in zip(sol.t, X)])
    W = np.array([command_value(u, command_params) for u in U])
    status = ST_OK if sol.status == 0 else ST_STEP_TOO_SMALL
    return SimulationResult(
        t=sol.t,
        x=X,
        inputs=(U, W),
        model=plant.model,
        success=sol.status == 0,
        status=status,
        message=sol.message,
        nfev=sol.nfev,
    )

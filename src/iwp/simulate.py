"""Simulation of the inertia wheel pendulum models.

:func:`simulate` integrates one model of :mod:`iwp.models` with the compiled
adaptive DOP853 integrator and returns a :class:`SimulationResult` sampled
every ``Ts`` (5 ms by default, the paper's sample time). :func:`simulate_batch`
runs many parameter sets, initial states or gains at once on all cores.
:func:`simulate_scipy` runs the same right-hand side through
:func:`scipy.integrate.solve_ivp`, as a reference.

Restarting from a measured state at a given time (figure 9b) is
``simulate(..., t0=200.0, x0=state_at_200)``: inputs are evaluated at
absolute time.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numba
import numpy as np

from . import _integrator as _I
from . import _lanes
from ._util import check_finite, check_positive, prepare_output_file
from .errors import InputError, SimulationError
from .inputs import CallableController, Sampled, _Input
from .models import COULOMB_EPS, MODELS, StartupFriction, _rhs, pack
from .params import BeltParameters, LumpedParameters, PhysicalParameters

__all__ = ["SimulationResult", "BatchResult", "simulate", "simulate_batch", "simulate_scipy"]

_STATUS_TEXT = {
    _I.ST_OK: "the simulation reached t_end",
    _I.ST_DIVERGED: "the simulation diverged",
    _I.ST_STEP_TOO_SMALL: "the step size fell below the resolution of t",
    _I.ST_MAX_STEPS: "the step limit was reached",
}

#: States beyond this magnitude count as divergence [rad, rad/s].
X_MAX = 1e7


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """The output of :func:`simulate`.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Output times [s].
    x : ndarray, shape (n, 4) or (n, 6)
        States ``[q1, q2, q3, q4 (, delta, w)]`` [rad, rad/s].
    u : ndarray, shape (n,)
        The ideal input (the signal or controller output) [input units].
    command : ndarray, shape (n,)
        What reached the model after the optional feedforward (7)-(8) and
        saturation (``v`` for the raw models) [input units].

        For a continuous input (signal or Hopf law) ``u`` and ``command``
        are functions of ``t`` and ``x``; they are computed on first access,
        so that a caller who only needs the states does not pay for them.
    model : str
    success : bool
    status : int
        0: reached ``t_end``; 1: diverged; 2: step too small; 3: step limit.
    message : str
    nfev : int
        Right-hand-side evaluations.
    n_steps, n_rejected : int
    """

    t: np.ndarray
    x: np.ndarray
    inputs: "tuple[np.ndarray, np.ndarray] | Callable" = field(repr=False)
    model: str
    success: bool
    status: int
    message: str
    nfev: int = 0
    n_steps: int = 0
    n_rejected: int = 0
    metadata: dict = field(default_factory=dict)

    def _input_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        v = self.inputs
        if callable(v):
            v = v(self.t, self.x)
            object.__setattr__(self, "inputs", v)
        return v

    @property
    def u(self) -> np.ndarray:
        """The ideal input [input units]."""
        return self._input_arrays()[0]

    @property
    def command(self) -> np.ndarray:
        """The command after feedforward and saturation [input units]."""
        return self._input_arrays()[1]

    @property
    def q1(self) -> np.ndarray:
        """Pendulum angle [rad]."""
        return self.x[:, 0]

    @property
    def q2(self) -> np.ndarray:
        """Disk angle relative to the arm [rad]."""
        return self.x[:, 1]

    @property
    def q3(self) -> np.ndarray:
        """Pendulum velocity [rad/s]."""
        return self.x[:, 2]

    @property
    def q4(self) -> np.ndarray:
        """Disk velocity relative to the arm [rad/s]."""
        return self.x[:, 3]

    def columns(self) -> dict[str, np.ndarray]:
        """The columns of the CSV: ``t, q1, q2, q3, q4, u`` (and ``v`` if it differs from ``u``)."""
        cols = {"t": self.t, "q1": self.q1, "q2": self.q2, "q3": self.q3, "q4": self.q4, "u": self.u}
        if not np.array_equal(self.command, self.u):
            cols["v"] = self.command
        return cols

    def to_csv(self, path, *, force: bool = False) -> "object":
        """Write the result as CSV with the header ``t,q1,q2,q3,q4,u`` (+ ``v``).

        Metadata lines (``# key: value``) come first. Refuses to overwrite
        an existing file unless ``force``.
        """
        p = prepare_output_file(path, force=force)
        cols = self.columns()
        data = np.column_stack(list(cols.values()))
        meta = {"source": "iwp simulate", "model": self.model, **self.metadata}
        header = "".join(f"# {k}: {v}\n" for k, v in meta.items()) + ",".join(cols)
        np.savetxt(p, data, delimiter=",", header=header, comments="", fmt="%.17g")
        return p

    def plot(self, **kw):
        """Plot the states and the input; see :func:`iwp.plotting.plot_simulation`."""
        from .plotting import plot_simulation

        return plot_simulation(self, **kw)


@dataclass(frozen=True, eq=False)
class BatchResult:
    """The output of :func:`simulate_batch`.

    Attributes
    ----------
    t : ndarray, shape (n_out,)
    x : ndarray, shape (n_runs, n_out, n_states)
    u, command : ndarray, shape (n_runs, n_out)
    status : ndarray of int, shape (n_runs,)
    nfev : ndarray of int, shape (n_runs,)
    """

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    command: np.ndarray
    status: np.ndarray
    nfev: np.ndarray

    @property
    def success(self) -> np.ndarray:
        """Per run: reached ``t_end``."""
        return self.status == _I.ST_OK


def _output_times(t0: float, t_end: float, Ts: float, t_eval) -> np.ndarray:
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
    n = int(math.floor((t_end - t0) / Ts + 1e-9))
    return t0 + Ts * np.arange(n + 1)


def _prepare(model, params, x0, t0, t_end, Ts, input, feedforward, saturation, belt, startup,
             coulomb_eps, locked, dead_zone_active, rtol, atol, max_step):
    if not isinstance(model, str) or model not in MODELS:
        raise InputError(f"unknown model {model!r}; choose one of: {', '.join(MODELS)}")
    if not isinstance(params, (LumpedParameters, PhysicalParameters)):
        raise InputError(f"params must be LumpedParameters or PhysicalParameters, got {type(params).__name__}")
    t0 = check_finite("t0", t0)
    t_end = check_finite("t_end", t_end)
    if t_end <= t0:
        raise InputError(f"t_end must be > t0 (t0 = {t0:g} s), got t_end = {t_end:g} s")
    Ts = check_positive("Ts", Ts)
    rtol = check_positive("rtol", rtol)
    h_max = math.inf if max_step is None else check_positive("max_step", max_step)
    code, P = pack(model, params, belt=belt, startup=startup, coulomb_eps=coulomb_eps, locked=locked,
                   dead_zone_active=dead_zone_active)
    n = 6 if code in (_I_BELT_CODES) else 4
    x0a = _initial_state(x0, n, model)
    atol = _atol_vector(atol, n)
    _check_input(input)
    # command chain: feedforward thresholds and saturation
    cpar = np.array([0.0, 0.0, 0.0, -math.inf, math.inf])
    if feedforward is not None and feedforward is not False:
        if feedforward is True:
            lp = params.to_lumped() if isinstance(params, PhysicalParameters) else params
            vpos, vneg = lp.v_dz_pos, lp.v_dz_neg
        else:
            try:
                vpos, vneg = (float(feedforward[0]), float(feedforward[1]))
            except (TypeError, ValueError, IndexError):
                raise InputError("feedforward must be True, False or a pair (v_dz_pos, v_dz_neg)") from None
        check_finite("feedforward v_dz_pos", vpos)
        check_finite("feedforward v_dz_neg", vneg)
        cpar[_I.C_FF], cpar[_I.C_FFPOS], cpar[_I.C_FFNEG] = 1.0, vpos, vneg
    if saturation is not None:
        sat = check_positive("saturation", saturation)
        cpar[_I.C_SATLO], cpar[_I.C_SATHI] = -sat, sat
    return code, P, x0a, t0, t_end, Ts, cpar, rtol, atol, h_max


_I_BELT_CODES = (MODELS["belt"], MODELS["belt-full"])


def _check_input(input) -> None:
    if input is not None and not isinstance(input, _Input):
        raise InputError(f"input must be an iwp.inputs signal or controller, got {type(input).__name__}")


def _atol_vector(atol, n: int) -> np.ndarray:
    """``atol`` as one positive value per state (a scalar applies to all), like scipy's."""
    if np.ndim(atol) == 0:
        return np.full(n, check_positive("atol", atol))
    try:
        a = np.asarray(atol, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"atol must be a positive number or {n} positive numbers, one per state") from None
    if a.shape != (n,):
        raise InputError(f"atol must be a positive number or {n} positive numbers (one per state), "
                         f"got shape {a.shape}")
    for i, v in enumerate(a):
        check_positive(f"atol[{i}]", float(v))
    return np.ascontiguousarray(a)


def _initial_state(x0, n, model) -> np.ndarray:
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
            f"x0 must have {n} values [q1, q2, q3, q4{', delta, w' if n == 6 else ''}] for model {model!r}, got {x.size}"
        )
    if not np.all(np.isfinite(x)):
        raise InputError(f"x0 must be finite, got {x.tolist()}")
    return x


def _input_spec(input, t0):
    """(kind, ipar, usamp, seg_mode, seg_T, seg_t0) for the kernel."""
    if input is None:
        return _I.I_ZERO, np.zeros(4), np.zeros(1), _I.SEG_CONT, 1.0, 0.0
    if isinstance(input, Sampled):
        values = np.require(input.values, dtype=float, requirements=["C", "W"])
        return _I.I_SAMPLES, np.zeros(4), values, _I.SEG_SAMPLES, input.Ts, input.t0
    Tc = input.sampled_period
    if Tc is not None:
        return input.kind, input._ipar(), np.zeros(1), _I.SEG_CONTROLLER, float(Tc), t0
    return input.kind, input._ipar(), np.zeros(1), _I.SEG_CONT, 1.0, 0.0


def simulate(
    params,
    *,
    model: str = "compensated",
    x0=None,
    t_end: float,
    t0: float = 0.0,
    Ts: float = 0.005,
    input: _Input | None = None,
    feedforward=None,
    saturation: float | None = None,
    belt: BeltParameters | None = None,
    startup: StartupFriction | None = None,
    coulomb_eps: float = COULOMB_EPS,
    locked: bool = False,
    dead_zone_active: bool | None = None,
    rtol: float = 1e-10,
    atol: float | Sequence[float] = 1e-10,
    max_step: float | None = None,
    max_steps: int = 50_000_000,
    t_eval=None,
    check: bool = True,
) -> SimulationResult:
    """Simulate one model of the inertia wheel pendulum.

    Parameters
    ----------
    params : LumpedParameters or PhysicalParameters
        Parameter set (``PhysicalParameters`` for ``model="el"``).
    model : str
        ``"compensated"`` (9, default), ``"raw"`` (6), ``"el"`` (4 with 3),
        ``"motor-disk"`` / ``"motor-disk-raw"`` (14), ``"belt"`` (15, pendulum
        locked) or ``"belt-full"`` (pendulum free with the belt).
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
    input : signal or controller, optional
        :mod:`iwp.inputs` object giving the ideal input ``u``. ``None``: zero.
    feedforward : bool or (float, float), optional
        Apply the dead-zone feedforward (7)-(8) to ``u`` before the model:
        ``True`` uses ``params``' ``v_dz_pos, v_dz_neg``, a pair gives the
        compensator's own thresholds (a compensator tuned on identified
        values, driving a plant with other ones).
    saturation : float, optional
        Clip the command to ``[-saturation, saturation]`` [input units].
    belt : BeltParameters, optional
        Required by the belt models.
    startup : StartupFriction, optional
        Break-away of the dead zone (start-up discontinuity of figure 2a).
    coulomb_eps : float
        Regularisation of ``sgn(q4)`` in Coulomb terms [rad/s]; 0 for exact.
    locked : bool
        Clamp the pendulum at ``q1 = q3 = 0`` (section 5.1) in ``"raw"``,
        ``"compensated"`` and ``"belt-full"``.
    dead_zone_active : bool, optional
        Force the dead zone on/off (default: on for the raw models).
    rtol : float
        Relative local error tolerance of the DOP853 integrator.
    atol : float or array_like
        Absolute local error tolerance, one value for all states or one per
        state (in the states' units), as in :func:`scipy.integrate.solve_ivp`.
    max_step : float, optional
        Largest step [s].
    max_steps : int
        Step limit.
    t_eval : array_like, optional
        Output times instead of the ``Ts`` grid.
    check : bool
        Raise :class:`~iwp.errors.SimulationError` when the simulation fails
        (default). With ``False`` the result reports ``success=False`` and
        carries the samples computed before the failure.

    Returns
    -------
    SimulationResult
    """
    code, P, x0a, t0, t_end, Ts, cpar, rtol, atol, h_max = _prepare(
        model, params, x0, t0, t_end, Ts, input, feedforward, saturation, belt, startup, coulomb_eps, locked,
        dead_zone_active, rtol, atol, max_step)
    t_out = _output_times(t0, t_end, Ts, t_eval)
    n = x0a.size
    n_out = t_out.size
    if isinstance(input, CallableController):
        X = np.full((n_out, n), np.nan)
        U = np.full(n_out, np.nan)
        W = np.full(n_out, np.nan)
        if input.Ts is None:
            return _simulate_callable_continuous(code, P, model, x0a, t0, t_end, t_out, input, cpar, rtol, atol,
                                                 h_max, check)
        status, nfev, nacc, nrej, t_reached = _run_external(
            code, P, x0a, t0, t_end, t_out, input, cpar, rtol, atol, h_max, max_steps, X, U, W)
    else:
        kind, ipar, usamp, seg_mode, seg_T, seg_t0 = _input_spec(input, t0)
        # the kernel writes every sample (NaN after a failure); a continuous
        # input is evaluated afterwards, on demand, from t and x
        held = _I.is_held(kind, seg_mode)
        X = np.empty((n_out, n))
        U = np.empty(n_out if held else 0)
        W = np.empty(n_out if held else 0)
        x_work = x0a.copy()
        status, nfev, nacc, nrej, t_reached, _h_next = _I.kernels(code)[0](
            P, x_work, t0, t_end, t_out, kind, ipar, usamp, seg_mode, seg_T, seg_t0, cpar, rtol, atol,
            h_max, max_steps, X_MAX, X, U, W, 0.0, -1.0, False)
        inputs = (U, W) if held else _LazyInputs(kind, ipar, cpar)
        return _finish(model, t_out, X, inputs, status, nfev, nacc, nrej, t_reached, check, input)
    return _finish(model, t_out, X, (U, W), status, nfev, nacc, nrej, t_reached, check, input)


class _LazyInputs:
    """``(u, command)`` of a continuous input at given samples, computed when first asked for."""

    def __init__(self, kind, ipar, cpar):
        self.kind, self.ipar, self.cpar = kind, ipar, cpar

    def __call__(self, t, x):
        U = np.empty(t.size)
        W = np.empty(t.size)
        _I.input_samples(self.kind, self.ipar, self.cpar, t, np.ascontiguousarray(x), U, W)
        return U, W


def _finish(model, t_out, X, inputs, status, nfev, nacc, nrej, t_reached, check, input):
    """The result; ``inputs`` is ``(U, W)`` or a :class:`_LazyInputs` evaluated on first access."""
    success = status == _I.ST_OK
    if success:
        message = _STATUS_TEXT[status]
    else:
        message = f"{_STATUS_TEXT.get(status, 'failed')} at t = {t_reached:.6g} s"
        if status == _I.ST_DIVERGED:
            message += f" (a state exceeded {X_MAX:g} or became NaN); check the parameters and the input"
        if check:
            raise SimulationError(message)
        keep = np.all(np.isfinite(X), axis=1)
        t_out, X = t_out[keep], X[keep]
        if not callable(inputs):
            inputs = (inputs[0][keep], inputs[1][keep])
    meta = {"input": input.describe() if input is not None else "zero"}
    return SimulationResult(t=t_out, x=X, inputs=inputs, model=model, success=success, status=int(status),
                            message=message, nfev=int(nfev), n_steps=int(nacc), n_rejected=int(nrej), metadata=meta)


def _run_external(code, P, x0a, t0, t_end, t_out, ctrl, cpar, rtol, atol, h_max, max_steps, X, U, W):
    """A Python controller sampled every Ts: call it, integrate one held segment, repeat."""
    Tc = ctrl.Ts
    x = x0a.copy()
    t = t0
    k = 0
    nfev = nacc = nrej = 0
    j0 = 0
    h_nat = -1.0
    n_out = t_out.size
    tol_t = 1e-9 * max(1.0, abs(t_end))
    status = _I.ST_OK
    dummy = np.zeros(1)
    while t < t_end - tol_t:
        t_b = min(t0 + (k + 1) * Tc, t_end)
        u = ctrl.evaluate(t, x)
        # outputs of this segment: [t, t_b) (and t_end at the end)
        j1 = j0
        last = t_b >= t_end - tol_t
        while j1 < n_out and (t_out[j1] < t_b - tol_t or (last and t_out[j1] <= t_end + tol_t)):
            j1 += 1
        seg_t = t_out[j0:j1]
        Xs = np.full((seg_t.size, x.size), np.nan)
        Us = np.full(seg_t.size, np.nan)
        Ws = np.full(seg_t.size, np.nan)
        # the step size carries over from one held segment to the next
        st, nf, na, nr, t_r, h_nat = _I.kernels(code)[0](P, x, t, t_b, seg_t, _I.I_EXTERNAL, np.zeros(4), dummy,
                                            _I.SEG_CONTROLLER, Tc, t, cpar, rtol, atol,
                                            h_max, max_steps, X_MAX, Xs, Us, Ws, u, h_nat, True)
        # the kernel's held value is the command; U records the controller's u
        X[j0:j1], W[j0:j1] = Xs, Ws
        U[j0:j1] = u
        nfev += nf
        nacc += na
        nrej += nr
        j0 = j1
        t = t_r
        if st != _I.ST_OK:
            status = st
            break
        k += 1
    return status, nfev, nacc, nrej, t


def _simulate_callable_continuous(code, P, model, x0a, t0, t_end, t_out, ctrl, cpar, rtol, atol, h_max, check):
    from scipy.integrate import solve_ivp

    n = x0a.size
    dx = np.zeros(n)

    def f(t, y):
        w = _I._command(ctrl.evaluate(t, y), cpar)
        _rhs(code, y, w, P, dx)
        return dx.copy()

    sol = solve_ivp(f, (t0, t_end), x0a, method="DOP853", t_eval=t_out, rtol=rtol, atol=atol,
                    max_step=h_max if math.isfinite(h_max) else np.inf)
    X = np.full((t_out.size, n), np.nan)
    X[: sol.y.shape[1]] = sol.y.T
    U = np.array([ctrl.evaluate(t, x) if np.all(np.isfinite(x)) else np.nan for t, x in zip(t_out, X)])
    W = np.array([_I._command(u, cpar) if np.isfinite(u) else np.nan for u in U])
    status = _I.ST_OK if sol.status == 0 else _I.ST_STEP_TOO_SMALL
    t_reached = float(sol.t[-1]) if sol.t.size else t0
    return _finish(model, t_out, X, (U, W), status, sol.nfev, 0, 0, t_reached, check, ctrl)


def simulate_batch(
    params,
    *,
    model: str = "compensated",
    x0=None,
    t_end: float,
    t0: float = 0.0,
    Ts: float = 0.005,
    input: _Input | list | None = None,
    feedforward=None,
    saturation: float | None = None,
    belt: BeltParameters | None = None,
    startup: StartupFriction | None = None,
    coulomb_eps: float = COULOMB_EPS,
    locked: bool = False,
    dead_zone_active: bool | None = None,
    rtol: float = 1e-10,
    atol: float | Sequence[float] = 1e-10,
    max_step: float | None = None,
    max_steps: int = 50_000_000,
    t_eval=None,
) -> BatchResult:
    """Run many simulations at once, in parallel on all cores.

    Any of ``params``, ``x0`` and ``input`` may be a list (all lists of the
    same length, the number of runs); the others are shared. Inputs in a list
    must be of one type (e.g. :class:`~iwp.inputs.HopfController` with
    different gains); Python callables are not supported here.

    The other arguments are those of :func:`simulate`. Failed runs are
    reported per run in ``status`` (no exception); their samples after the
    failure are NaN.

    Runs that share one parameter set and have a continuous input (signals,
    the continuous Hopf law) advance 16 at a time on each thread, side by
    side, each with its own step size and error control
    (:mod:`iwp._lanes`); for model (9) with the Hopf law the compiler
    vectorises them (10,000 closed loops of 300 s in about 6.5 s on 2 cores,
    see BENCHMARKS.md). A run's result equals that of :func:`simulate` up
    to rounding. Other batches run one simulation per thread at a time.

    Returns
    -------
    BatchResult
    """
    lists = [len(v) for v in (params, x0, input) if isinstance(v, (list, tuple)) and not _is_state(v)]
    if lists and len(set(lists)) != 1:
        raise InputError(f"list arguments of simulate_batch must have one length, got lengths {sorted(set(lists))}")
    nrun = lists[0] if lists else 1
    p_list = params if isinstance(params, (list, tuple)) else [params] * nrun
    x_list = x0 if isinstance(x0, (list, tuple)) and not _is_state(x0) else [x0] * nrun
    i_list = input if isinstance(input, (list, tuple)) else [input] * nrun
    if nrun == 0:
        raise InputError("simulate_batch needs at least one run")
    kinds = {type(i) for i in i_list}
    if len(kinds) != 1:
        raise InputError("inputs of one batch must all be of one type")
    if any(isinstance(i, (CallableController, Sampled)) for i in i_list):
        raise InputError("simulate_batch supports built-in signals and the Hopf controller, not callables or arrays")
    periods = {None if i is None else i.sampled_period for i in i_list}
    if len(periods) != 1:
        raise InputError("inputs of one batch must share the sample period Ts")
    Pm = []
    X0m = []
    Ipm = []
    cpar0 = None
    done = {}  # (params, x0) already checked and packed: a sweep over gains packs once
    for p_, x_, i_ in zip(p_list, x_list, i_list):
        key = (id(p_), id(x_))
        if key not in done:
            done[key] = _prepare(model, p_, x_, t0, t_end, Ts, i_, feedforward, saturation, belt, startup,
                                 coulomb_eps, locked, dead_zone_active, rtol, atol, max_step)
        code, P, x0a, t0_, t_end_, Ts_, cpar, rtol_, atol_, h_max = done[key]
        _check_input(i_)
        if cpar0 is None:
            cpar0 = cpar
        Pm.append(P)
        X0m.append(x0a)
        Ipm.append(np.zeros(4) if i_ is None else i_._ipar())
    Pm = np.ascontiguousarray(Pm)
    X0m = np.ascontiguousarray(X0m)
    Ipm = np.ascontiguousarray(Ipm)
    kind, _ip, usamp, seg_mode, seg_T, seg_t0 = _input_spec(i_list[0], t0_)
    t_out = _output_times(t0_, t_end_, Ts_, t_eval)
    n = X0m.shape[1]
    X = np.empty((nrun, t_out.size, n))
    U = np.empty((nrun, t_out.size))
    W = np.empty((nrun, t_out.size))
    status = np.zeros(nrun, dtype=np.int64)
    nfev = np.zeros(nrun, dtype=np.int64)
    if bool(np.all(Pm == Pm[0])) and not _I.is_held(kind, seg_mode):
        # one parameter set and a continuous input: many runs side by side
        _lanes.kernel(code)(Pm[0], X0m, t0_, t_end_, t_out, kind, Ipm, cpar0, rtol_, atol_, h_max, max_steps, X_MAX,
                            X, U, W, status, nfev, min(numba.get_num_threads(), nrun))
    else:
        _I.kernels(code)[1](Pm, X0m, t0_, t_end_, t_out, kind, Ipm, usamp, seg_mode, seg_T, seg_t0, cpar0, rtol_,
                            atol_, h_max, max_steps, X_MAX, X, U, W, status, nfev)
    return BatchResult(t=t_out, x=X, u=U, command=W, status=status, nfev=nfev)


def _is_state(v) -> bool:
    """True if ``v`` looks like one state vector (a flat list of numbers)."""
    return isinstance(v, (list, tuple)) and len(v) > 0 and all(isinstance(e, (int, float)) for e in v)


def simulate_scipy(
    params,
    *,
    model: str = "compensated",
    x0=None,
    t_end: float,
    t0: float = 0.0,
    Ts: float = 0.005,
    input: _Input | None = None,
    feedforward=None,
    saturation: float | None = None,
    belt: BeltParameters | None = None,
    startup: StartupFriction | None = None,
    coulomb_eps: float = COULOMB_EPS,
    locked: bool = False,
    dead_zone_active: bool | None = None,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float | Sequence[float] = 1e-12,
    t_eval=None,
) -> SimulationResult:
    """The same simulation through :func:`scipy.integrate.solve_ivp` (a reference).

    Uses the compiled right-hand side of :mod:`iwp.models` with a continuous
    input (sampled inputs are not supported here). Slower than
    :func:`simulate`; meant for cross-checks.
    """
    from scipy.integrate import solve_ivp

    code, P, x0a, t0, t_end, Ts, cpar, rtol, atol, h_max = _prepare(
        model, params, x0, t0, t_end, Ts, input, feedforward, saturation, belt, startup, coulomb_eps, locked,
        dead_zone_active, rtol, atol, None)
    kind, ipar, usamp, seg_mode, seg_T, seg_t0 = _input_spec(input, t0)
    if seg_mode != _I.SEG_CONT:
        raise InputError("simulate_scipy supports continuous inputs only")
    t_out = _output_times(t0, t_end, Ts, t_eval)
    n = x0a.size
    dx = np.zeros(n)

    def f(t, y):
        _I._eval(code, P, t, y, dx, False, 0.0, kind, ipar, cpar)
        return dx.copy()

    sol = solve_ivp(f, (t0, t_end), x0a, method=method, t_eval=t_out, rtol=rtol, atol=atol)
    X = sol.y.T
    U = np.array([_I._signal(kind, ipar, t, x) for t, x in zip(sol.t, X)])
    W = np.array([_I._command(u, cpar) for u in U])
    status = _I.ST_OK if sol.status == 0 else _I.ST_STEP_TOO_SMALL
    return SimulationResult(t=sol.t, x=X, inputs=(U, W), model=model, success=sol.status == 0, status=status,
                            message=sol.message, nfev=sol.nfev)

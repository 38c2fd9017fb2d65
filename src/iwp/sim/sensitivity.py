"""Simulations with forward sensitivities: how the outputs move with the parameters.

:func:`simulate_sensitivities` integrates a plant together with
``S = dx/dtheta`` for chosen plant parameters, input parameters (the gains
of a feedback law) and initial states, with the same compiled DOP853 engine
as :func:`iwp.sim.simulate.simulate` (:mod:`iwp.sim.engine`): the
variational equations ``S' = (df/dx) S + df/dtheta`` ride along on the
steps that the error control chooses for the states. This is what the
simulation-error fits (:mod:`iwp.ident.refinement`) and the shooting of periodic
orbits (:mod:`iwp.control.continuation`) differentiate.

A plant with the belt (15) is not differentiated along its steps: its play
switches a discrete mode, where the variational equations would miss the jump of
the sensitivities, and the belt's parameters are not the lumped ones the
variational equations hold. Its sensitivities are forward differences of whole
simulations, run side by side (:func:`~iwp.sim.simulate.simulate_batch`), with
the step :func:`difference_step` of the simulations' tolerance, as the belt's
fits take their Jacobian.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, SimulationError
from ..models.layout import LUMPED_INDEX, N_PACK
from ..models.parameters import PARAMETER_INFO, TYPICAL
from ..models.plant import Plant
from . import engine
from .engine import ST_OK, STATUS_TEXT, Span, samples_output, sensitivity
from .inputs import Input
from .options import BatchOptions, SimOptions, Tolerances, as_options
from .simulate import (
    command_of,
    engine_tolerances,
    initial_state,
    output_times,
    segments_of,
    simulate_batch,
    system_of,
)

__all__ = ["SensitivityResult", "simulate_sensitivities", "difference_step", "FD_RELATIVE", "STEP_PER_SQRT_RTOL"]

#: Relative forward-difference step of the parameter derivatives (the models
#: are linear in most parameters, so truncation errors are small).
FD_RELATIVE = 1e-7
#: The forward-difference step of whole simulations (relative, or on the log scale) per square root of the
#: simulations' rtol: the step's truncation error against the simulation's error.
STEP_PER_SQRT_RTOL = 3.0


def difference_step(rtol: float) -> float:
    """The relative forward-difference step of whole simulations at ``rtol`` (a model with the belt's play, which is
    not smooth): ``max(3 sqrt(rtol), 1e-6)``."""
    return max(STEP_PER_SQRT_RTOL * math.sqrt(rtol), 1e-6)

#: :func:`simulate_sensitivities`'s default tolerances (of the states).
SENSITIVITY_TOLERANCES = Tolerances(rtol=1e-9, atol=1e-9)


@dataclass(frozen=True, eq=False)
class SensitivityResult:
    """States and their sensitivities at the output times.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Output times [s].
    x : ndarray, shape (N, n)
        States.
    S : ndarray, shape (N, n, k)
        ``dx/d(wrt)`` in the columns of ``wrt`` (parameters first, then
        initial states, named ``"x0[i]"``).
    wrt : tuple of str
        Column names of ``S``.
    success : bool
    status : int
    message : str
    nfev : int
        Evaluations of the augmented right-hand side.
    """

    t: np.ndarray
    x: np.ndarray
    S: np.ndarray
    wrt: tuple[str, ...]
    success: bool
    status: int
    message: str
    nfev: int


def _parameter_index(name: str, plant: Plant, input) -> tuple[int, float]:
    """Index in the engine's parameter space and difference step of one parameter name."""
    names = () if input is None else tuple(input.parameter_names)
    if name in names:
        j = names.index(name)
        v = float(input.parameters()[j])
        return N_PACK + j, FD_RELATIVE * max(abs(v), 1.0)
    if plant.info.physical:
        raise InputError(f"sensitivities to parameters need a lumped model, not {plant.model!r}")
    if name not in LUMPED_INDEX:
        known = ", ".join(list(LUMPED_INDEX) + list(names))
        raise InputError(f"unknown parameter {name!r} for sensitivities; choose among {known}")
    idx = LUMPED_INDEX[name]
    return idx, FD_RELATIVE * max(abs(float(plant.packed()[idx])), TYPICAL[name])


def simulate_sensitivities(
    plant: Plant,
    *,
    input: Input | None = None,
    x0=None,
    t_eval,
    t0: float = 0.0,
    wrt: Sequence[str] = (),
    wrt_x0: Sequence[int] = (),
    options: SimOptions | None = None,
) -> SensitivityResult:
    """Simulate ``plant`` with the sensitivities of its states to parameters and initial states.

    Parameters
    ----------
    plant : Plant
        The plant (a lumped model for sensitivities to its parameters).
    input : Input, optional
        The input [input units]; a log's input is replayed as
        :class:`~iwp.sim.inputs.Sampled`. None: zero.
    x0 : array_like, optional
        Initial state ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s] at ``t0``
        (default rest at the bottom).
    t_eval : array_like
        Output times [s], increasing, within ``[t0, t_eval[-1]]``; the run
        ends at the last (the grid of :func:`~iwp.sim.simulate.simulate`'s
        ``t_end`` and ``Ts`` is :func:`~iwp.sim.simulate.output_times`).
    t0 : float
        Initial time [s].
    wrt : sequence of str
        Parameters: lumped parameter names (``"p1"``, ``"sigma_a1"``, ...)
        or names of the input's parameters (``"k1"``, ``"k2"`` of a Hopf law); for a plant with the belt (15),
        lumped and belt parameters (forward differences of whole simulations, see the module's notes).
    wrt_x0 : sequence of int
        Initial states (indices into the state).
    options : SimOptions, optional
        Feedforward (7)-(8) and saturation [input units], the tolerances of
        the states' error control (the sensitivities ride along; default
        ``Tolerances(rtol=1e-9, atol=1e-9)``), and whether a failed run raises.

    Returns
    -------
    SensitivityResult

    Raises
    ------
    InputError
        An argument of the wrong type or value, in one line naming it.
    SimulationError
        The run failed and ``options.check`` is True.

    Examples
    --------
    How the free swing's states depend on ``p1``:

    >>> from iwp import Plant, simulate_sensitivities, table1
    >>> s = simulate_sensitivities(Plant(table1(), model="free"), x0=[1, 0, 0, 0], wrt=("p1",),
    ...                            t_eval=[0.005 * k for k in range(201)])
    >>> s.x.shape, s.S.shape  # states, and d(state)/d(p1) per sample
    ((201, 4), (201, 4, 1))
    """
    if not isinstance(plant, Plant):
        raise InputError(f"plant must be a Plant, got {type(plant).__name__}", argument="plant")
    opts = as_options(options, SimOptions)
    if t_eval is None:
        raise InputError("give t_eval, the output times of the sensitivities", argument="t_eval")
    t_end = float(np.asarray(t_eval, dtype=float).ravel()[-1])
    n = plant.n_states
    x0a = initial_state(x0, plant)
    t_out = output_times(float(t0), t_end, 0.005, t_eval)  # (the grid step unused with t_eval)
    cols = [int(c) for c in wrt_x0]
    for c in cols:
        if not 0 <= c < n:
            raise InputError(f"wrt_x0 entries must be state indices 0..{n - 1}, got {c}")
    if plant.belt is not None and (len(wrt) or cols):  # (a plain run of it is the plain kernel's, below)
        return _difference_sensitivities(plant, input, x0a, t_out, float(t0), (tuple(wrt), tuple(cols)), opts)
    pidx, psteps = [], []
    for name in wrt:
        i, d = _parameter_index(name, plant, input)
        pidx.append(i)
        psteps.append(d)
    ns = len(pidx) + len(cols)
    y0 = np.zeros(n * (1 + ns))
    y0[:n] = x0a
    for k, c in enumerate(cols):
        y0[n + (len(pidx) + k) * n + c] = 1.0
    tol = engine_tolerances(n, opts.tolerances or SENSITIVITY_TOLERANCES)
    command_params = command_of(plant, opts.feedforward_pair(), opts.saturation)
    system = system_of(plant, input, command_params)
    seg = segments_of(input, float(t0))
    X = np.empty((t_out.size, y0.size))
    # held inputs write the input and the command at every output sample
    U = np.empty(t_out.size)
    W = np.empty(t_out.size)
    span = Span(y0, float(t0), float(t_end), -1.0)
    if ns == 0:  # nothing to differentiate: the plain kernel
        stats = engine.kernel(n)(system, seg, tol, span, samples_output(t_out, X, U, W, False))
    else:
        tol = tol._replace(atol=np.concatenate([tol.atol, np.full(n * ns, np.inf)]), n_err=n)
        sens = sensitivity(n, pidx, psteps, plant.info.depends_on)
        stats = engine.sensitivity_kernel()(system, seg, tol, sens, span, samples_output(t_out, X, U, W, False))
    status = int(stats.status)
    message = STATUS_TEXT.get(status, "failed")
    if status != ST_OK:
        message += f" at t = {stats.t_reached:.6g} s"
        if opts.check:
            raise SimulationError(message)
    S = X[:, n:].reshape(t_out.size, ns, n).transpose(0, 2, 1) if ns else np.zeros((t_out.size, n, 0))
    names = tuple(wrt) + tuple(f"x0[{c}]" for c in cols)
    return SensitivityResult(t=t_out, x=X[:, :n], S=np.ascontiguousarray(S), wrt=names, success=status == ST_OK,
                             status=status, message=message, nfev=int(stats.nfev))


def _difference_sensitivities(plant: Plant, input, x0: np.ndarray, t_out: np.ndarray, t0: float, wrt: tuple,
                              opts: SimOptions) -> SensitivityResult:
    """:func:`simulate_sensitivities` of a plant with the belt (15): forward differences of whole simulations, the
    nominal run and one per column side by side. ``wrt`` is ``(parameter names, initial-state indices)``, the
    indices checked."""
    names, cols = wrt
    n = plant.n_states
    tol = opts.tolerances or SENSITIVITY_TOLERANCES
    rel = difference_step(tol.rtol)
    plants, states, steps = [plant], [x0], []
    for name in names:
        if name not in PARAMETER_INFO:
            raise InputError(f"unknown parameter {name!r} for sensitivities of a plant with the belt (15); choose "
                             f"among {', '.join(PARAMETER_INFO)}")
        v = plant.value(name)
        h = rel * max(abs(v), TYPICAL[name])
        plants.append(plant.with_values({name: v + h}))
        states.append(x0)
        steps.append(h)
    for c in cols:
        h = rel * max(abs(float(x0[c])), 1.0)
        xc = x0.copy()
        xc[c] += h
        plants.append(plant)
        states.append(xc)
        steps.append(h)
    runs = simulate_batch(plants, x0=states, input=input, t0=t0, t_end=float(t_out[-1]), t_eval=t_out,
                          options=BatchOptions(feedforward=opts.feedforward, saturation=opts.saturation,
                                               tolerances=tol, inputs=False))
    failed = np.flatnonzero(runs.status != ST_OK)
    status = int(runs.status[failed[0]]) if failed.size else ST_OK
    message = STATUS_TEXT.get(status, "failed")
    if failed.size and opts.check:
        raise SimulationError(f"{message} (run {int(failed[0])} of the forward differences)")
    X = runs.x
    S = np.stack([(X[1 + j] - X[0]) / h for j, h in enumerate(steps)], axis=2) if steps \
        else np.zeros((t_out.size, n, 0))
    cols_named = tuple(f"x0[{c}]" for c in cols)
    return SensitivityResult(t=t_out, x=np.ascontiguousarray(X[0]), S=np.ascontiguousarray(S),
                             wrt=tuple(names) + cols_named, success=status == ST_OK, status=status, message=message,
                             nfev=int(np.sum(runs.nfev)))

"""The simulation error of measured outputs: the residuals of every simulation-error fit.

A simulation-error (output-error) fit compares what the logs measure with what
the model simulates from each log's initial state with the log's input
replayed (MATLAB's ``nlgreyest`` criterion):

    r_o,e(t_k) = w_o,e(t_k) (y^_o,e(t_k; theta, x0_e) + c_o,e - y_o,e(t_k)) / s_o

over the experiments ``e`` and the outputs ``o`` (``q1``, ``q2`` and the
velocities ``q3``, ``q4``), with ``s_o`` the spread of output ``o`` over the
data, ``c_o,e`` an optional sensor offset and ``w`` 0 at samples left out
(replaced glitches; the first sample of a speed logged as the mean over the
preceding period). :class:`OutputError` is this residual model for
:class:`~iwp.ident.problem.FitProblem`: it prepares the experiments once
(windows, measured signals, initial states, the input replayed with a
zero-order hold on the log's sample grid, exactly as a digital rig applies
it) and evaluates the residuals and their Jacobian for any parameter values
with the one compiled engine (:func:`iwp.sim.sensitivity.simulate_sensitivities`:
forward sensitivities ``dx/dtheta`` and ``dx/dx0`` ride along), or by forward
differences of whole simulations for non-smooth models (the belt's play).

Each experiment has a kind (:data:`EXPERIMENT_KINDS`), so that one fit joins
every set-up of a rig, as section 5 combines its experiments: the pendulum
clamped (section 5.1), the wheel locked to the arm, the arm free, a closed
loop with a known law.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Collection, Mapping, Sequence

import numpy as np

from ..data import ExperimentData, check_distinct
from ..errors import InputError
from ..models.parameters import PARAMETER_INFO
from ..models.plant import EXPERIMENT_KINDS, Plant, plant_for_kind
from ..sim.inputs import Input, Sampled
from ..sim.options import SimOptions, Tolerances
from ..sim.sensitivity import simulate_sensitivities
from ..threads import thread_map
from .differentiate import Differentiator
from .fit_parameters import Parameter, Parameters
from .problem import FitProblem, FitResult, Loss, SolverOptions
from .signals import hold_of, position_noise

__all__ = [
    "band_as_measured",
    "measured_initial_state",
    "EXPERIMENT_KINDS",
    "Experiment",
    "Evaluation",
    "OutputError",
    "PreparedExperiment",
    "initial_state",
    "start_state",
    "StartEstimate",
    "plant_state",
    "measured_signals",
    "measured_state",
    "state_differentiator",
    "measured_state_covariance",
    "plant_for_kind",
    "replay",
    "x0_name",
    "offset_name",
    "solve_output_error",
    "X0_MISFIT_RMS",
]

STATE_NAMES = ("q1", "q2", "q3", "q4")
OUTPUT_INDEX = {"q1": 0, "q2": 1, "q3": 2, "q4": 3}
#: residual of a sample a failed simulation did not reach (the trust region then shrinks)
BAD_RESIDUAL = 1e6
#: the span of :func:`state_differentiator`'s filter [s] (21 samples at 5 ms)
STATE_FILTER_SECONDS = 0.1


def state_differentiator(Ts: float) -> Differentiator:
    """The filter of the measured states and velocities of a log sampled every ``Ts`` [s].

    A cubic Savitzky-Golay filter over about :data:`STATE_FILTER_SECONDS`
    (``2 round(0.05 / Ts) + 1`` samples, at least 5): 21 samples at the paper's
    5 ms. A fixed 21 samples spans a second at 50 ms, about a swing of a
    pendulum; at a log's first sample it gave a swing released from rest at
    1.32 rad the state 1.62 rad, -6.1 rad/s.

    Parameters
    ----------
    Ts : float
        Sample time [s].

    Returns
    -------
    Differentiator
    """
    return Differentiator.savgol_spanning(STATE_FILTER_SECONDS, Ts, min_window=5)
#: fewest samples an experiment's window keeps
MIN_SAMPLES = 10


def x0_name(state: int, experiment: int) -> str:
    """The name of an initial state of an experiment as a fit parameter.

    Parameters
    ----------
    state : int
        State index, 0 to 3 (``q1`` ... ``q4``).
    experiment : int
        Experiment number.

    Returns
    -------
    str
        ``"q1(0) of experiment 2"``.
    """
    return f"{STATE_NAMES[state]}(0) of experiment {experiment}"


def offset_name(output: str, experiment: int) -> str:
    """The name of the sensor offset of an output of an experiment as a fit parameter.

    Parameters
    ----------
    output : str
        Output name (``"q1"``, ...).
    experiment : int
        Experiment number.

    Returns
    -------
    str
        ``"offset of q1 in experiment 2"``.
    """
    return f"offset of {output} in experiment {experiment}"


# --------------------------------------------------------------------------
# measured signals and states
# --------------------------------------------------------------------------
def replay(data: ExperimentData, input_name: str | None) -> Sampled | None:
    """A log's input ``u`` or ``v`` replayed with a zero-order hold on its sample grid, or ``None``.

    A rig's controller held each sample until the next, and so does the replay. A log whose metadata
    ``input_hold`` says ``continuous`` (the virtual rig's chirps and sines) sampled an input that moved between
    the samples: each interval then holds the mean of its two ends, the input's average over it to second
    order, instead of its first sample, which would lag the input half a sample (on the twin's 60 s full chirp
    at 5 ms: a wheel-speed error of 0.58 rad/s and a fit of 99.1 % for the true model, against 0.002 rad/s
    and 99.997 % with the means).

    Parameters
    ----------
    data : ExperimentData
        The log.
    input_name : {"u", "v"} or None
        Which input to replay; None gives None.

    Returns
    -------
    Sampled or None
        The input [input units], held from ``t[0]`` every ``Ts``; None without an input.
    """
    if input_name is None or data.input_name is None:
        return None
    values = np.asarray(getattr(data, input_name), dtype=float)
    if hold_of(data, "auto") == "continuous":
        values = interval_means(values)
    return Sampled(values, data.Ts, float(data.t[0]))


def interval_means(u: np.ndarray) -> np.ndarray:
    """Each sample interval's mean of an input that moved continuously between its samples ``u`` [input units]:
    the mean of the cubic (Catmull-Rom) through the four samples around it, ``(-u[k-1] + 13 u[k] + 13 u[k+1] -
    u[k+2]) / 24``, exact to fourth order (the mean of the two ends, ``(u[k] + u[k+1]) / 2``, is off by
    ``Ts^2 u'' / 12``: 7.5e-4 of a multisine's amplitude at 19 rad/s and 5 ms, tens of the standard errors of
    ``p3`` on 30 s logs); the ends' intervals the mean of their two ends, the last value held.

    Parameters
    ----------
    u : ndarray, shape (n,)
        The input at the samples.

    Returns
    -------
    ndarray, shape (n,)
        The mean over ``[t[k], t[k+1]]`` at ``k`` (the last sample's value at ``n - 1``).
    """
    u = np.asarray(u, dtype=float)
    out = u.copy()
    if u.size >= 2:
        out[:-1] = 0.5 * (u[:-1] + u[1:])
    if u.size >= 4:
        out[1:-2] = (-u[:-3] + 13.0 * u[1:-2] + 13.0 * u[2:-1] - u[3:]) / 24.0
    return out


def measured_signals(data: ExperimentData, names: Sequence[str], differentiator: Differentiator | None = None
                     ) -> dict[str, np.ndarray]:
    """Measured ``q1, q2`` and velocities ``q3, q4`` of a log.

    Velocities come from the log's ``q3``/``q4`` columns when present, else
    from differentiating the positions (by default :func:`state_differentiator`:
    Savitzky-Golay over 0.1 s, cubic).

    Parameters
    ----------
    data : ExperimentData
        The log.
    names : sequence of str
        Signals wanted, among ``"q1"``, ``"q2"``, ``"q3"``, ``"q4"``.
    differentiator : Differentiator, optional
        Filter for velocities not logged; None (default): :func:`state_differentiator` of the log's ``Ts``.

    Returns
    -------
    dict of str to ndarray, shape (n,)
        Each signal by name [rad or rad/s].

    Raises
    ------
    InputError
        An unknown name, ``q2`` from a log without a wheel angle, or ``q4`` from a log with neither ``q2`` nor
        ``q4``.
    """
    out: dict[str, np.ndarray] = {}
    d = differentiator or state_differentiator(data.Ts)
    for n in names:
        if n not in OUTPUT_INDEX:
            raise InputError(f"unknown signal {n!r}; choose among q1, q2, q3, q4")
        if n in ("q1", "q2"):
            if getattr(data, n) is None:
                raise InputError(f"{data.source} has no wheel angle q2 (only the wheel speed q4); compare q4 "
                                 "instead: signals=q1,q4", argument="signals")
            out[n] = np.asarray(getattr(data, n), dtype=float)
        else:
            col = getattr(data, n)
            if col is not None:
                out[n] = np.asarray(col, dtype=float)
            else:
                pos = getattr(data, "q1" if n == "q3" else "q2")
                if pos is None:
                    raise InputError(f"{data.source} logs neither q2 nor q4; the output q4 cannot be formed")
                out[n] = d.derivatives(data.Ts, pos).velocity
    return out


def measured_state(data: ExperimentData, index: int, differentiator: Differentiator | None = None) -> np.ndarray:
    """The state ``[q1, q2, q3, q4]`` of a log at sample ``index``: smoothed positions, differentiated velocities.

    Parameters
    ----------
    data : ExperimentData
        The log.
    index : int
        Sample number (0-based).
    differentiator : Differentiator, optional
        Filter of the positions; None (default): :func:`state_differentiator` of the log's ``Ts``. A log
        shorter than the filter uses central differences.

    Returns
    -------
    ndarray, shape (4,)
        ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s]; logged ``q3``/``q4`` are used as they are (``q2 = 0``
        without a wheel angle).
    """
    d = differentiator or state_differentiator(data.Ts)
    q = np.column_stack([data.q1, data.q2 if data.q2 is not None else np.zeros_like(data.q1)])
    if data.n_samples >= d.min_samples(data.Ts):
        pos, vel, _ = d.derivatives(data.Ts, q)
    else:  # too short to filter: plain central differences
        pos = q
        vel = np.gradient(q, data.t, axis=0)
    x = np.array([pos[index, 0], pos[index, 1], vel[index, 0], vel[index, 1]])
    if data.q3 is not None:
        x[2] = data.q3[index]
    if data.q4 is not None:
        x[3] = data.q4[index]
        if data.q4_sampling == "mean" and index + 2 < data.n_samples:
            # samples are means over the preceding periods (at t_k - Ts/2): the speed at t_k lies between two
            # of them; the first sample has no preceding period, extrapolate the next two
            y = data.q4
            x[3] = 0.5 * (y[index] + y[index + 1]) if index > 0 else 1.5 * y[1] - 0.5 * y[2]
    return x


#: the local quadratic of :func:`measured_state_covariance` spans about this long [s] (at least 7 samples)
LOCAL_SECONDS = 0.1


def _local_fit(t: np.ndarray, y: np.ndarray, index: int, m: int) -> tuple[float, float, np.ndarray]:
    """Value and slope at ``t[index]`` of a quadratic fitted to ``m`` samples around it, and their covariance."""
    lo = max(0, min(index - m // 2, t.size - m))
    sl = slice(lo, lo + m)
    tt = t[sl] - t[index]
    X = np.column_stack([np.ones(m), tt, tt * tt])
    coef, *_ = np.linalg.lstsq(X, y[sl], rcond=None)
    resid = y[sl] - X @ coef
    quantum = angle_quantum(y[sl])
    s2 = max(float(resid @ resid) / max(m - 3, 1), quantum * quantum / 12.0)
    cov = np.linalg.inv(X.T @ X)[:2, :2] * s2
    return float(coef[0]), float(coef[1]), cov


def measured_state_covariance(data: ExperimentData, index: int) -> np.ndarray:
    """The covariance of a measured state ``[q1, q2, q3, q4]`` at sample ``index`` [rad, rad/s squared].

    From a quadratic fitted to about :data:`LOCAL_SECONDS` of each angle around
    the sample (one-sided at the ends of the log): its residual variance (at
    least the encoder's quantisation, ``step^2 / 12``) through the least
    squares gives the variance of the position and of the slope, the
    velocity. A logged speed ``q4`` is treated as a measured value with the
    spread of its own local quadratic.

    Parameters
    ----------
    data : ExperimentData
        The log.
    index : int
        Sample number (0-based).

    Returns
    -------
    ndarray, shape (4, 4)
        The covariance; zero rows and columns for a signal the log does not hold.
    """
    m = min(max(7, int(round(LOCAL_SECONDS / data.Ts)) + 1), data.n_samples)
    t = np.asarray(data.t, dtype=float)
    C = np.zeros((4, 4))
    for pos, vel in ((0, 2), (1, 3)):
        y = data.q1 if pos == 0 else data.q2
        if y is None:
            continue
        _v, _s, c = _local_fit(t, np.asarray(y, dtype=float), index, m)
        C[np.ix_([pos, vel], [pos, vel])] = c
    if data.q4 is not None:
        _v, _s, c = _local_fit(t, np.asarray(data.q4, dtype=float), index, m)
        C[3, :] = 0.0
        C[:, 3] = 0.0
        C[3, 3] = c[0, 0]
    return C


#: the measured initial state: a quadratic fitted to the first samples over about this long [s]
X0_SECONDS = 0.1

#: an estimated initial state stays within this many standard deviations of the measured one
#: (:func:`initial_state_bounds`)
X0_BOUND_SD = 5.0
#: ... or within this many RMS of its output's simulation error beyond those bounds (:func:`solve_output_error`):
#: a model whose simulation sits that far off every other sample may sit that far off the first one too
X0_MISFIT_RMS = 2.0
#: the covariance of :func:`start_state`'s fit to the first samples (:class:`~iwp.ident.problem.FitProblem`)
START_COVARIANCE = "hac"


#: The step of the finest encoder a rig has (2^20 counts a turn) [rad]: the least an initial angle may move in a
#: fit where its log never changed (a clamped log whose wheel stood still gave bounds (0, 0), an internal error).
FINEST_STEP = 2 * np.pi / 2**20


def angle_quantum(y: np.ndarray) -> float:
    """The smallest nonzero step between consecutive samples of an angle [rad] (its encoder's resolution), or 0."""
    diffs = np.abs(np.diff(np.asarray(y, dtype=float)))
    diffs = diffs[diffs > 0]
    return float(diffs.min()) if diffs.size else 0.0


def initial_state_bounds(data: ExperimentData) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of an estimated initial state ``[q1, q2, q3, q4]`` at a log's first sample.

    The measured state (:func:`measured_initial_state`) plus or minus
    :data:`X0_BOUND_SD` of its standard deviations
    (:func:`measured_state_covariance`), and at least one encoder step for an
    angle, and for a velocity at least one step per sample period and the
    range of the speeds over the first :data:`X0_SECONDS` (a log that starts
    driven accelerates within them): an initial state the
    fit may adjust within what the encoders saw, not one that explains a
    misfit by a wheel spinning at a speed no sample shows.

    Parameters
    ----------
    data : ExperimentData
        The log (windowed: its first sample is the initial state's time).

    Returns
    -------
    low, high : ndarray, shape (4,)
        [rad, rad, rad/s, rad/s]; ``-inf, inf`` for a signal the log does not hold.
    """
    centre = measured_initial_state(data)
    sd = np.sqrt(np.clip(np.diag(measured_state_covariance(data, 0)), 0.0, None))
    half = np.full(4, np.inf)
    m = min(max(5, int(round(X0_SECONDS / data.Ts)) + 1), data.n_samples)
    for pos, vel, y in ((0, 2, data.q1), (1, 3, data.q2)):
        if y is None:
            continue
        step = angle_quantum(y) or FINEST_STEP  # a signal that never changed: the finest encoder's step
        # the speeds the first samples show: a log that starts driven accelerates within them, and the quadratic's
        # slope at its first sample is then biased by more than its standard deviation says
        speeds = np.diff(np.asarray(y[:m], dtype=float)) / data.Ts
        half[pos] = max(X0_BOUND_SD * sd[pos], step)
        half[vel] = max(X0_BOUND_SD * sd[vel], step / data.Ts, float(np.ptp(speeds)) if speeds.size else 0.0)
    if data.q4 is not None and data.q4_sampling == "mean":  # a mean over the preceding period: not the state at t[0]
        half[3] = np.inf
    elif data.q4 is not None:
        q4 = np.asarray(data.q4[:m], dtype=float)
        half[3] = max(X0_BOUND_SD * sd[3], angle_quantum(data.q4) or FINEST_STEP / data.Ts,
                      float(np.ptp(q4)) if q4.size else 0.0)
    return centre - half, centre + half


def measured_initial_state(d: ExperimentData) -> np.ndarray:
    """The state ``[q1, q2, q3, q4]`` a log measures at its first sample.

    ``q1`` and ``q3``: a quadratic fitted by least squares to the first
    ``max(5, 0.1 s / Ts)`` samples of the angle (a short one-sided window: a
    longer filter at the start of a log is biased by the input's steps),
    its value and slope at ``t[0]``; ``q2``: the same, or 0 without a wheel
    angle; ``q4``: the measured speed at ``t[0]`` (a glitch replaced: the
    quadratic through the next samples), or for a speed sampled as the mean
    over the preceding period, the next two means extrapolated to ``t[0]``
    (``1.5 y[1] - 0.5 y[2]``).

    Parameters
    ----------
    d : ExperimentData
        The log.

    Returns
    -------
    ndarray, shape (4,)
        ``[q1, q2, q3, q4]`` at ``t[0]`` [rad, rad, rad/s, rad/s].
    """
    m = max(5, int(round(X0_SECONDS / d.Ts)) + 1)
    m = min(m, d.n_samples)
    tt = d.t[:m] - d.t[0]

    def value_slope(y):
        c = np.polyfit(tt, y[:m], 2)
        return float(c[2]), float(c[1])

    q1, q3 = value_slope(d.q1)
    q2, q4 = value_slope(d.q2) if d.q2 is not None else (0.0, 0.0)
    if d.q4 is not None:
        y = np.asarray(d.q4, dtype=float)
        if d.q4_sampling == "mean":
            q4 = 1.5 * y[1] - 0.5 * y[2]
        elif d.glitch_mask("q4")[0]:
            c = np.polyfit(tt[1:], y[1:m], 2)
            q4 = float(c[2])
        else:
            q4 = float(y[0])
    return np.array([q1, q2, q3, q4])


@dataclass(frozen=True, eq=False)
class StartEstimate:
    """A log's state at its first sample and its covariance (:func:`start_state`).

    Attributes
    ----------
    x0 : ndarray, shape (4,)
        ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s].
    covariance : ndarray, shape (4, 4)
        Its covariance, from the noise of the first samples.
    method : {"model", "quadratic"}
        The model's response fitted, or the quadratic of :func:`measured_initial_state`.
    """

    x0: np.ndarray
    covariance: np.ndarray
    method: str


def start_state(data: ExperimentData, plant: Plant, controller: Input | None = None) -> StartEstimate:
    """The state ``[q1, q2, q3, q4]`` at a log's first sample that the model, driven by the log's input, puts through
    the log's angles (and its wheel speed, where it logs no wheel angle) over the first :data:`X0_SECONDS`.

    :func:`measured_initial_state` fits a quadratic to the first samples: right for a log that starts at rest or
    coasting, biased for one whose input drives the rig from its first sample (a wheel accelerated at 220 rad/s^2
    by a step whose acceleration decays within the 0.1 s read as spinning at 1.7 rad/s; the held-out prediction
    band then held 12-15 % of a log that the true model predicts to its noise, issue 50). Here the model's own
    response to the logged input over those samples is fitted instead (its parameters fixed, the initial state
    free; Gauss-Newton from the quadratic's state): the same first samples, and nothing after them, so that a
    prediction from it is still one. A model without sensitivities (the belt) or a fit that fails keeps the
    quadratic's state.

    Parameters
    ----------
    data : ExperimentData
        The log (windowed: its first sample is the initial state's time).
    plant : Plant
        The model and its parameters.
    controller : Input, optional
        The feedback law of a closed-loop log (simulated instead of replaying the logged input).

    Returns
    -------
    StartEstimate
        ``[q1, q2, q3, q4]`` at ``t[0]`` as the state of ``plant``, and its covariance.
    """
    guess = plant_state(measured_initial_state(data), plant)
    quadratic = StartEstimate(guess, measured_state_covariance(data, 0), "quadratic")
    m = min(max(5, int(round(X0_SECONDS / data.Ts)) + 1), data.n_samples)
    outputs = tuple(o for o in ("q1", "q2") if getattr(data, o) is not None and o in plant.outputs)
    if "q2" not in outputs and data.q4 is not None and "q4" in plant.outputs:
        # a wheel logged by its speed alone (a mean-sampled one too): through q1 alone its start was 8 rad/s
        # uncertain and read 15-26 rad/s on logs from rest (the held-out bands then held 41-79 % of q1 on four of nine
        # logs of the right model)
        outputs += ("q4",)
    if plant.belt is not None or not outputs or m < 5:
        return quadratic
    kind = "closed-loop" if controller is not None else "free"
    exp = Experiment(data, kind=kind, window=(float(data.t[0]), float(data.t[m - 1])), x0=guess, estimate_x0=True,
                     x0_bounded=False, controller=controller)
    try:
        model = OutputError(plant, [exp], outputs, fitting=False)
        # each output weighed by its noise over the whole log (not by its spread over a window it may barely move in)
        noise = position_noise(np.column_stack([getattr(data, o) for o in outputs]))
        model.scale = {o: max(float(v), angle_quantum(getattr(data, o)) / math.sqrt(12.0), 1e-12)
                       for o, v in zip(outputs, noise)}
        res = FitProblem(model.parameters(), model, covariance=START_COVARIANCE).solve(
            SolverOptions(rtol=1e-9, atol=1e-9))
    except (InputError, ValueError, FloatingPointError):
        return quadratic
    x0 = np.asarray(model.states(res.parameters.values())[0][:4], dtype=float)
    if not (res.success and np.all(np.isfinite(x0))):
        return quadratic
    return StartEstimate(x0, model.start_covariance(res), "model")


def initial_state(data: ExperimentData, index: int, plant: Plant,
                  differentiator: Differentiator | None = None) -> np.ndarray:
    """The measured state of a log at sample ``index`` as the state of ``plant``.

    Positions smoothed and velocities differentiated (:func:`measured_state`);
    a held wheel (the free-pendulum models) has ``q4 = 0``; a locked pendulum
    has ``q1 = q3 = 0``.

    Parameters
    ----------
    data : ExperimentData
        The log.
    index : int
        Sample number (0-based).
    plant : Plant
        The plant the state is for.
    differentiator : Differentiator, optional
        Filter of the positions; None (default): :func:`state_differentiator` of the log's ``Ts``.

    Returns
    -------
    ndarray, shape (4,)
        ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s].
    """
    return plant_state(measured_state(data, index, differentiator), plant)


def plant_state(x, plant: Plant) -> np.ndarray:
    """A measured state ``[q1, q2, q3, q4]`` as the state of ``plant``: ``q4 = 0`` for a held wheel (the
    free-pendulum models), ``q1 = q3 = 0`` for a locked pendulum.

    Parameters
    ----------
    x : array_like, shape (4,)
        The measured state [rad, rad, rad/s, rad/s].
    plant : Plant
        The plant the state is for.

    Returns
    -------
    ndarray, shape (4,)
        A new array.
    """
    x = np.array(x, dtype=float)
    if plant.wheel_held:
        x[3] = 0.0
    if plant.pendulum_locked:
        x[0] = 0.0
        x[2] = 0.0
    return x


# --------------------------------------------------------------------------
# experiments
# --------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Experiment:
    """One log of a fit, with what the fit assumes and estimates about it.

    Parameters
    ----------
    data : ExperimentData
        The log.
    kind : str
        One of :data:`EXPERIMENT_KINDS` (default ``"free"``: the model as given).
    window : (float or None, float or None)
        Time window [s] (None: open).
    x0 : array_like, optional
        Initial-state guess ``[q1, q2, q3, q4]`` at the window start (default: measured).
    estimate_x0 : bool
        Estimate the initial state with the parameters (else the guess is used as it is).
    x0_bounded : bool
        The estimated initial state stays within what the first samples measured
        (:func:`initial_state_bounds`); False for a log that starts unmeasured
        (its first samples do not show the state, e.g. a glitch or a release
        hidden by a hand).
    offsets : tuple of str
        Outputs whose sensor has an unknown constant offset, estimated (``("q1",)``).
    controller : Input, optional
        ``kind="closed-loop"``: the feedback law simulated instead of replaying the logged input.
    """

    data: ExperimentData
    kind: str = "free"
    window: tuple[float | None, float | None] = (None, None)
    x0: Any = None
    estimate_x0: bool = True
    x0_bounded: bool = True
    offsets: tuple[str, ...] = ()
    controller: Input | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.data, ExperimentData):
            raise InputError(f"an experiment needs an ExperimentData (time series log), got {type(self.data).__name__}")
        if self.kind not in EXPERIMENT_KINDS:
            raise InputError(f"unknown experiment kind {self.kind!r}; choose among {', '.join(EXPERIMENT_KINDS)}",
                             argument="kind")
        if (self.kind == "closed-loop") != (self.controller is not None):
            raise InputError("a closed-loop experiment needs its controller, and only a closed-loop one takes one")
        if self.controller is not None and not isinstance(self.controller, Input):
            raise InputError(f"controller must be an iwp.sim.inputs controller (e.g. HopfController), got "
                             f"{type(self.controller).__name__}")
        object.__setattr__(self, "offsets", (self.offsets,) if isinstance(self.offsets, str) else tuple(self.offsets))
        if self.x0 is not None:
            g = np.asarray(self.x0, dtype=float).ravel()
            if g.size != 4 or not np.all(np.isfinite(g)):
                raise InputError(f"each x0 guess must be 4 finite numbers, got {g.tolist()}")
            object.__setattr__(self, "x0", g)


@dataclass(eq=False)
class PreparedExperiment:
    """An experiment made ready for evaluations: windowed, its outputs measured, its input replayed."""

    spec: Experiment
    index: int
    data: ExperimentData  # the windowed log
    plant: Plant  # the variant its kind simulates (values set at each evaluation)
    t: np.ndarray
    input: Input | None
    y: dict[str, np.ndarray]
    #: per output: weight of each sample (0 at replaced glitches and where a mean has no preceding period)
    w: dict[str, np.ndarray]
    x0: np.ndarray  # the initial-state guess
    est: tuple[int, ...]  # the states estimated
    mean: tuple[str, ...]  # outputs logged as the mean over the preceding sample period
    Ts: float
    #: outputs the log does not hold but its angle's derivative gives (:func:`measured_signals`): the model's are
    #: the same filter's derivative of its angle, with the filter
    derived: tuple[str, ...] = ()
    differentiator: Differentiator | None = None

    @property
    def window(self) -> tuple[float, float]:
        return float(self.t[0]), float(self.t[-1])

    @property
    def not_instant(self) -> tuple[str, ...]:
        """The outputs the log does not measure at the sample instants (:attr:`derived` by a filter, :attr:`mean`
        over the preceding period): a band about the point outputs is moved to them (:func:`band_as_measured`)."""
        return self.derived + self.mean

    def predict(self, o: str, X: np.ndarray) -> np.ndarray:
        """The model's output ``o`` from states ``X`` (N, n) or sensitivities (N, n, k): the state; for a
        mean-sampled speed the difference of its angle over the preceding period over ``Ts``; for a speed the log
        does not hold, the derivative of its angle by the filter that measured the log's (a Savitzky-Golay
        derivative over 0.1 s is 0.23 % off a chirp's wheel speed at 3.8 rad/s: compared with the model's point
        speed, ``p3 (1 + rho)`` and ``rho`` came out 0.23 % low on exact logs, many standard errors)."""
        si = OUTPUT_INDEX[o]
        if o in self.derived:
            return self.differentiator.derivatives(self.Ts, X[:, si - 2]).velocity
        if o in self.mean:
            pos = X[:, si - 2]
            out = np.empty_like(X[:, si])
            out[1:] = (pos[1:] - pos[:-1]) / self.Ts
            out[0] = X[0, si]  # weight 0
            return out
        return X[:, si]


def band_as_measured(band: Any, derived: Collection[str], simulated: Mapping[str, np.ndarray]) -> Any:
    """A prediction band about the model's outputs as the log measures them.

    A speed the log derives from its angle (:attr:`PreparedExperiment.derived`) is the filter's derivative of the
    model's angle, and a speed logged as the mean over the preceding period (:attr:`PreparedExperiment.mean`) the
    difference of its angle over that period, not its point speed: its band (computed about the point speed) is
    moved by the difference. Its width is the point speed's: the parameters move the speed smoothly over a
    sample period, so their share of the band is that of the mean too.

    Parameters
    ----------
    band : PredictionBand
        :func:`iwp.sim.uncertainty.prediction_band` of the point outputs.
    derived : collection of str
        The outputs not measured at the sample instants (:attr:`PreparedExperiment.not_instant`).
    simulated : mapping of str to ndarray
        The model's outputs as measured (:meth:`PreparedExperiment.predict`), on the band's samples.

    Returns
    -------
    PredictionBand
        ``band`` with ``nominal``, ``lower``, ``upper``, ``pred_lower``, ``pred_upper`` moved for ``derived``.
    """
    shift = {o: np.asarray(simulated[o]) - band.nominal[o] for o in derived if o in band.nominal}
    if not shift:
        return band

    def moved(d: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {o: v + shift.get(o, 0.0) for o, v in d.items()}

    return replace(band, nominal=moved(band.nominal), lower=moved(band.lower), upper=moved(band.upper),
                   pred_lower=moved(band.pred_lower), pred_upper=moved(band.pred_upper))


def prepare(spec: Experiment, index: int, plant: Plant, outputs: Sequence[str],
            min_samples: int = MIN_SAMPLES) -> PreparedExperiment:
    """Window the log, measure its outputs and initial state, replay its input (see :class:`PreparedExperiment`)."""
    data = spec.data
    wdata = data.window(*spec.window)
    i0 = int(np.searchsorted(data.t, wdata.t[0]))
    if wdata.n_samples < min_samples:
        raise InputError(f"experiment {index} ({data.source}): the window keeps {wdata.n_samples} samples, "
                         f"at least {min_samples} are needed")
    variant = plant_for_kind(plant, spec.kind)
    need = variant.input_name
    name = data.input_name
    if need is not None and name is not None and name != need and spec.controller is None:
        hint = ("a compensated model ('compensated', 'motor-disk')" if name == "u"
                else "a raw model ('raw', 'motor-disk-raw')")
        raise InputError(f"experiment {index} ({data.source}) logs the input {name!r} but model {variant.model!r} "
                         f"takes {need!r}; use {hint}")
    inp = spec.controller if spec.controller is not None else replay(wdata, need)
    full = measured_signals(data, outputs)
    n = wdata.n_samples
    y = {o: np.ascontiguousarray(full[o][i0:i0 + n]) for o in outputs}
    x0 = np.zeros(variant.n_states)  # the belt's states (delta, w) start relaxed
    x0[:4] = initial_state(data, i0, variant) if spec.x0 is None else spec.x0
    moving = variant.info.moving if not variant.pendulum_locked else (1, 3)
    est: tuple[int, ...] = ()
    if spec.estimate_x0:
        # q2 enters no right-hand side: estimate it only when it is an output; the belt's states start relaxed
        est = tuple(s for s in moving if s < 4 and (s != 1 or "q2" in outputs))
    mean = tuple(o for o in outputs if o == "q4" and data.q4 is not None and data.q4_sampling == "mean")
    derived = tuple(o for o in outputs if o in ("q3", "q4") and getattr(data, o) is None)
    differ = state_differentiator(float(wdata.Ts)) if derived else None
    edge = differ.edge_samples_at(float(wdata.Ts)) if derived else 0
    weights = {}
    for o in outputs:
        if o not in variant.outputs:  # a signal this kind holds still (the clamped pendulum's angle): no residual
            weights[o] = np.zeros(n)
            continue
        wt = np.ones(n)
        col = "q2" if o == "q4" and data.q4 is None else ("q1" if o == "q3" and data.q3 is None else o)
        wt[data.glitch_mask(col)[i0:i0 + n]] = 0.0
        if o in mean:
            wt[0] = 0.0
        if o in derived:  # the filter's ends: the log's derivative saw samples the window leaves out
            wt[:edge] = 0.0
            wt[n - edge:] = 0.0
        weights[o] = wt
    return PreparedExperiment(spec, index, wdata, variant, np.ascontiguousarray(wdata.t, dtype=float), inp, y,
                              weights, x0, est, mean, float(wdata.Ts), derived, differ)


# --------------------------------------------------------------------------
# the residual model
# --------------------------------------------------------------------------
@dataclass(eq=False)
class Evaluation:
    """One evaluation of :class:`OutputError` at given values."""

    values: dict[str, float]
    r: np.ndarray  # the residuals
    J: np.ndarray | None  # d r / d value of the names asked for, or None
    X: list[np.ndarray]  # per experiment, the simulated states at its samples
    status: list[int]  # per experiment, the engine's status (0: reached the end)


@dataclass(eq=False)
class OutputError:
    """The simulation error of measured outputs over experiments (the residual model of a fit).

    Parameters
    ----------
    plant : Plant
        The model and its start parameters (lumped, and the belt's for ``"belt"``).
    experiments : sequence of Experiment
    outputs : tuple of str
        Compared signals, among the plant's (:attr:`Plant.outputs`).
    rtol, atol : float
        Tolerances of the simulations.
    differences : float, optional
        Take the Jacobian by forward differences of whole simulations with this
        step of the optimiser's coordinates (for non-smooth models), not from
        forward sensitivities.
    fitting : bool
        The outputs are fitted (default): each must move in the plant and vary
        in the data. False: they are only compared (a validation compares any
        signal, even one the model holds constant), windows of 2 samples do.
    """

    plant: Plant
    experiments: Sequence[Experiment]
    outputs: tuple[str, ...]
    rtol: float = 1e-8
    atol: float = 1e-8
    differences: float | None = None
    fitting: bool = True
    prepared: list[PreparedExperiment] = field(init=False)
    scale: dict[str, float] = field(init=False)

    def __post_init__(self) -> None:
        self.outputs = (self.outputs,) if isinstance(self.outputs, str) else tuple(self.outputs)
        if not self.outputs:
            raise InputError("outputs is empty")
        for o in self.outputs:
            if o not in OUTPUT_INDEX:
                raise InputError(f"unknown output {o!r}; choose among q1, q2, q3, q4")
        exps = list(self.experiments)
        if not exps:
            raise InputError("no experiments given")
        for i, e in enumerate(exps):
            if not isinstance(e, Experiment):
                raise InputError(f"experiments[{i}] must be an Experiment, got {type(e).__name__}")
            for o in e.offsets:
                if o not in self.outputs:
                    raise InputError(f"output_offsets names {o!r}, which is not an output ({', '.join(self.outputs)})")
        if self.fitting:
            self._check_outputs(exps)
            check_distinct([e.data.window(*e.window) for e in exps], "experiments")
        n_min = MIN_SAMPLES if self.fitting else 2
        self.prepared = [prepare(e, i, self.plant, self.outputs, n_min) for i, e in enumerate(exps)]
        self.scale = {}
        for o in self.outputs:
            spreads = [np.var(p.y[o][p.w[o] > 0]) for p in self.prepared if np.any(p.w[o] > 0)]
            v = float(np.mean(spreads)) if spreads else 0.0
            if not v > 0 and self.fitting:
                raise InputError(f"output {o} is constant in every experiment (nothing to fit); choose other outputs")
            self.scale[o] = math.sqrt(v) if v > 0 else 1.0

    def _check_outputs(self, exps: list[Experiment]) -> None:
        # an experiment compares the outputs its kind moves (a clamped pendulum's angle is no output of it);
        # every experiment must compare one at least, and a plant that holds an output still everywhere has none
        variants = [plant_for_kind(self.plant, e.kind) for e in exps]
        for i, (e, variant) in enumerate(zip(exps, variants)):
            if not any(o in variant.outputs for o in self.outputs):
                where = "" if len(exps) == 1 else f"experiment {i} ({e.data.source}, {e.kind}): "
                why = "has no wheel motion" if variant.wheel_held else "has the pendulum locked"
                raise InputError(f"{where}model {variant.model!r} {why}: it moves {', '.join(variant.outputs)} "
                                 f"only; the outputs {', '.join(self.outputs)} compare none of them")
        still = [o for o in self.outputs if not any(o in v.outputs for v in variants)]
        if still:
            moved = sorted({o for v in variants for o in v.outputs})
            why = ("has no wheel motion" if any(o in ("q2", "q4") for o in still) else "has the pendulum locked")
            raise InputError(f"model {self.plant.model!r} {why} in these experiments: {', '.join(still)} stay "
                             f"still; its outputs are {', '.join(moved)}")

    # ------------------------------------------------------------------ sizes
    @property
    def n_rows(self) -> int:
        """Number of residuals."""
        return sum(p.t.size * len(self.outputs) for p in self.prepared)

    def row_blocks(self) -> np.ndarray:
        """The output of each residual row (an index into :attr:`outputs`): rows are weighted per output."""
        return np.concatenate([np.full(p.t.size, k) for p in self.prepared for k in range(len(self.outputs))])

    def row_used(self) -> np.ndarray:
        """True for the rows that enter the fit (weight > 0)."""
        return np.concatenate([p.w[o] > 0 for p in self.prepared for o in self.outputs])

    def row_experiments(self) -> np.ndarray:
        """The experiment of each residual row (for covariances that treat experiments as independent)."""
        return np.concatenate([np.full(p.t.size * len(self.outputs), p.index) for p in self.prepared])

    def row_times(self) -> np.ndarray:
        """The sample of each residual row within its experiment (the rows of one sample share it)."""
        return np.concatenate([np.tile(np.arange(p.t.size), len(self.outputs)) for p in self.prepared])

    # ------------------------------------------------------------- parameters
    def parameters(self, free: Sequence[str] = (), bounds: Mapping[str, tuple] | None = None, *,
                   log: bool | Collection[str] = False) -> Parameters:
        """The fit's parameters: the plant's (``free`` varied, within ``bounds`` or the physical defaults),
        every experiment's estimated initial states and sensor offsets.

        ``log``: the free model parameters (True) or those named are varied on a
        log scale within their :attr:`~iwp.models.parameters.ParameterInfo.fit_range`.
        """
        free = (free,) if isinstance(free, str) else tuple(free)
        names = self.model_parameter_names()
        for n in free:
            if n not in PARAMETER_INFO:
                raise InputError(f"unknown parameter {n!r}; free parameters are among "
                                 f"{', '.join(self.plant.info.parameters or names)}")
            if n not in self.plant.info.parameters:
                raise InputError(f"parameter {n!r} does not enter model {self.plant.model!r} (its parameters: "
                                 f"{', '.join(self.plant.info.parameters)}); fix it or choose another model")
        if len(set(free)) != len(free):
            raise InputError(f"free lists a parameter twice: {free}")
        bounds = {} if bounds is None else dict(bounds)
        unknown = sorted(set(bounds) - set(free))
        if unknown:
            raise InputError(f"bounds given for {', '.join(unknown)}, which is not free (free: {', '.join(free)})")
        out = []
        for n in names:
            info = PARAMETER_INFO[n]
            if n not in free:
                out.append(Parameter(n, self.plant.value(n), vary=False, unit=info.unit))
                continue
            v = self.plant.value_in_effect(n)
            on_log = log if isinstance(log, bool) else n in log
            lo, hi = _bounds(n, bounds.get(n), info.default_bounds(on_log))
            if on_log:
                out.append(Parameter(n, v, min=lo, max=hi, unit=info.unit, log=True))
            else:
                scale = max(abs(v), info.typical * 1e-3) if v != 0 else info.typical
                out.append(Parameter(n, v, min=lo, max=hi, unit=info.unit, scale=scale))
        for p in self.prepared:
            lo, hi = initial_state_bounds(p.data) if p.spec.x0_bounded else (np.full(4, -np.inf), np.full(4, np.inf))
            for s in p.est:
                if s < 2 and ("q1", "q2")[s] in p.spec.offsets:  # an angle whose zero is estimated: its value is not
                    lo[s], hi[s] = -np.inf, np.inf               # measured, only its changes are
                start = float(np.clip(p.x0[s], lo[s], hi[s]))
                out.append(Parameter(x0_name(s, p.index), start, min=float(lo[s]), max=float(hi[s]), scale=1.0,
                                     kind="initial state", unit="rad" if s < 2 else "rad/s"))
            for o in p.spec.offsets:
                out.append(Parameter(offset_name(o, p.index), 0.0, scale=1.0, kind="offset",
                                     unit="rad" if o in ("q1", "q2") else "rad/s"))
        return Parameters(out)

    def model_parameter_names(self) -> tuple[str, ...]:
        """The plant's parameter names (lumped, and the belt's when it has one)."""
        names = [n for n, i in PARAMETER_INFO.items() if i.owner == "lumped"]
        if self.plant.belt is not None:
            names += [n for n, i in PARAMETER_INFO.items() if i.owner == "belt"]
        return tuple(names)

    # ------------------------------------------------------------- evaluation
    def states(self, values: Mapping[str, float]) -> list[np.ndarray]:
        """Per experiment, the initial state for ``values`` (estimated components from ``values``)."""
        out = []
        for p in self.prepared:
            x = p.x0.copy()
            for s in p.est:
                x[s] = values[x0_name(s, p.index)]
            out.append(x)
        return out

    def start_covariance(self, fit: FitResult, index: int = 0) -> np.ndarray:
        """The 4 x 4 covariance of experiment ``index``'s initial state ``[q1, q2, q3, q4]`` in ``fit`` (zero rows
        and columns for the components not estimated; a NaN of an undetermined one as 0)."""
        est = self.prepared[index].est
        C = np.zeros((4, 4))
        idx = [fit.free.index(x0_name(s, index)) for s in est]
        C[np.ix_(est, est)] = np.nan_to_num(fit.covariance[np.ix_(idx, idx)])
        return C

    def offsets(self, values: Mapping[str, float]) -> list[dict[str, float]]:
        """Per experiment, ``{output: offset}`` for ``values``."""
        return [{o: values[offset_name(o, p.index)] for o in p.spec.offsets} for p in self.prepared]

    def evaluate(self, values: Mapping[str, float], wrt: Sequence[str] = ()) -> Evaluation:
        """The residuals at ``values`` and, for the names ``wrt``, their derivatives (forward sensitivities).

        ``wrt`` may name model parameters, initial states and offsets.
        """
        model_values = {n: values[n] for n in self.model_parameter_names()}
        base = self.plant.with_values(model_values)
        wrt = tuple(wrt)
        wrt_model = tuple(n for n in wrt if n in PARAMETER_INFO)
        nrow = self.n_rows
        r = np.empty(nrow)
        J = np.zeros((nrow, len(wrt))) if wrt else None
        states, offsets = self.states(values), self.offsets(values)

        def run(i: int):
            p = self.prepared[i]
            est = tuple(s for s in p.est if x0_name(s, p.index) in wrt)
            return est, simulate_sensitivities(plant_for_kind(base, p.spec.kind), t_eval=p.t, t0=float(p.t[0]),
                                               x0=states[i], input=p.input, wrt=wrt_model, wrt_x0=est,
                                               options=SimOptions(tolerances=Tolerances(rtol=self.rtol, atol=self.atol),
                                                                  check=False))

        sims = thread_map(run, range(len(self.prepared)))  # the experiments side by side (independent)
        Xs, statuses = [], []
        row = 0
        for p, offs, (est, sim) in zip(self.prepared, offsets, sims):
            Xs.append(sim.x)
            statuses.append(sim.status)
            n = p.t.size
            for o in self.outputs:
                seg = p.w[o] * (p.predict(o, sim.x) + offs.get(o, 0.0) - p.y[o]) / self.scale[o]
                if sim.status != 0:
                    seg = np.where(np.isfinite(seg), seg, BAD_RESIDUAL)
                r[row:row + n] = seg
                if J is not None:
                    Sp = p.predict(o, sim.S) * (p.w[o] / self.scale[o])[:, None]
                    for k, name in enumerate(wrt_model):
                        J[row:row + n, wrt.index(name)] = Sp[:, k]
                    for k, s in enumerate(est):
                        J[row:row + n, wrt.index(x0_name(s, p.index))] = Sp[:, len(wrt_model) + k]
                    if o in offs and offset_name(o, p.index) in wrt:
                        J[row:row + n, wrt.index(offset_name(o, p.index))] = p.w[o] / self.scale[o]
                row += n
        if J is not None and not np.all(np.isfinite(J)):
            J = np.nan_to_num(J, nan=0.0, posinf=0.0, neginf=0.0)
        return Evaluation(dict(values), r, J, Xs, statuses)

    def predictions(self, ev: Evaluation) -> list[dict[str, np.ndarray]]:
        """Per experiment, ``{output: the model's output}`` (offsets included) of an evaluation."""
        return [{o: p.predict(o, X) + offs.get(o, 0.0) for o in self.outputs}
                for p, X, offs in zip(self.prepared, ev.X, self.offsets(ev.values))]

    def output_rms(self, r: np.ndarray) -> list[dict[str, float]]:
        """Per experiment, ``{output: RMS of its simulation error}`` (the output's unit) of residuals ``r``."""
        out, row = [], 0
        for p in self.prepared:
            rms = {}
            for o in self.outputs:
                n = p.t.size
                used = p.w[o] > 0
                seg = r[row:row + n][used]
                rms[o] = float(np.sqrt(np.mean(seg * seg))) * self.scale[o] if seg.size else math.nan
                row += n
            out.append(rms)
        return out


def solve_output_error(model: OutputError, params: Parameters, loss: Loss | None = None,
                       options: SolverOptions | None = None) -> FitResult:
    """Solve a simulation-error fit whose initial states are bounded (:meth:`OutputError.parameters`), the bounds a
    guard that acts only where an initial state strays.

    The fit runs first with every estimated initial state free. An initial state that ends farther outside its
    bounds (:func:`initial_state_bounds`: what the log's first samples measured) than :data:`X0_MISFIT_RMS` times
    the RMS simulation error of the output that measures it (its angle, or a logged speed) has explained a misfit
    by a state no sample shows (a wheel spinning at a speed its first samples do not see): the fit is then solved
    again from the given start with the bounds in force, and a warning says so. A model that misses something (a real
    pendulum's damping that is none of its friction laws) sits off every sample by its error, the first one too:
    held at the first sample's measured value to within the encoder's noise, the real free swing of
    docs/refinement.md stopped at fit 98.51 % (p1 120.30, where its period gives 120.1), free at 98.78 %
    (p1 120.09). Bounds also slow the trust region of ``least_squares`` near them: the 60 s free decay of
    ``benchmarks/bench_refine.py`` took 12 + 12 simulations bounded, 6 + 6 free, to the same optimum. A fit by
    forward differences of whole simulations (:attr:`OutputError.differences`: the belt's play, not smooth) keeps
    its bounds throughout: free, the forced belt fit of ``tests/test_belt_rung.py`` ended in another basin, at
    twice the cost (held-out wheel speed 96.6 % against 97.6 %).

    Parameters
    ----------
    model : OutputError
        The residual model.
    params : Parameters
        Its parameters (:meth:`OutputError.parameters`), initial states with their bounds.
    loss : Loss, optional
        Default: linear.
    options : SolverOptions, optional
        The solver's settings.

    Returns
    -------
    FitResult
        The fit; ``nfev``, ``njev``, ``elapsed`` and ``cost_start`` count both solves where there were two.
    """
    loss = loss or Loss()
    states = [n for n in params if params[n].kind == "initial state" and not params[n].fixed]
    bounded = [n for n in states if math.isfinite(params[n].min) or math.isfinite(params[n].max)]
    if not bounded or model.differences is not None:  # a rough fit (the belt's play) keeps its bounds throughout
        return FitProblem(params, model, loss).solve(options)
    loose = params
    for n in bounded:
        loose = loose.replace(n, min=-math.inf, max=math.inf)
    first = FitProblem(loose, model, loss).solve(options)
    strayed = _strayed_states(model, params, first)
    if not strayed:
        return first
    values = first.parameters.values()
    second = FitProblem(params, model, loss).solve(options)  # from the given start: the stray's is another basin
    names = ", ".join(f"{n} = {values[n]:.4g} (measured range [{params[n].min:.4g}, {params[n].max:.4g}])"
                      for n in strayed)
    note = (f"initial state {names} strayed beyond what the log's first samples measured by more than "
            f"{X0_MISFIT_RMS:g} times the simulation error of its output (a misfit explained by a state no sample "
            "shows); fitted again within the measured range")
    return replace(second, warnings=[note, *second.warnings], cost_start=first.cost_start,
                   nfev=first.nfev + second.nfev, njev=first.njev + second.njev,
                   elapsed=first.elapsed + second.elapsed)


def _strayed_states(model: OutputError, params: Parameters, fit: FitResult) -> list[str]:
    """The bounded initial states of ``params`` that ``fit`` put beyond their bounds by more than
    :data:`X0_MISFIT_RMS` RMS of the simulation error of the output that measures them (angles, or a logged
    speed; no slack for a state no output measures)."""
    values = fit.parameters.values()
    rms = model.output_rms(fit.optimum.r)
    out = []
    for p in model.prepared:
        for s in p.est:
            n = x0_name(s, p.index)
            if n not in params or params[n].fixed:
                continue
            slack = X0_MISFIT_RMS * rms[p.index].get(STATE_NAMES[s], 0.0)
            v, lo, hi = values[n], params[n].min, params[n].max
            if not (lo - slack <= v <= hi + slack):
                out.append(n)
    return out


def _bounds(name: str, given, default: tuple[float, float]) -> tuple[float, float]:
    if given is None:
        return default
    try:
        a, b = given
    except (TypeError, ValueError):
        raise InputError(f"bounds[{name!r}] must be a pair (low, high), got {given!r}") from None
    a = -math.inf if a is None else float(a)
    b = math.inf if b is None else float(b)
    if not a < b or math.isnan(a) or math.isnan(b):
        raise InputError(f"bounds[{name!r}] = ({a}, {b}): low must be < high")
    return a, b

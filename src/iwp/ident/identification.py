"""Parameter identification: every least-squares set-up of the paper, with uncertainty.

From encoder logs (:class:`iwp.data.ExperimentData`) or a static curve
(:class:`iwp.data.StaticCurve`) to the lumped parameters of model (9), as
section 5 of the paper does it, and with standard errors, 95 % intervals,
the correlation of the estimates, the condition number of the regressor,
the residual RMS, the number of samples used, and warnings when the data
cannot support the numbers.

Set-ups (``setup=``, the paper's numbering)
-------------------------------------------
``"full"``
    (10)-(12): both rows of (9), 8 parameters
    ``theta = [p1, sigma_a1, sigma_v1, sigma_b1, p2, p3, p2(1+rho), p3(1+rho)]``
    (section 5.2, eq. (16)). ``rho`` is derived from both ratios.
``"motor-disk"``
    ``theta^a = [p2(1+rho), p3(1+rho)]`` from ``dq4/dt = -p2(1+rho) q4 + p3(1+rho) u``
    with the pendulum locked (section 5.1, eq. (14) after exact compensation).
``"motor-disk-coulomb"``
    ``theta^b = [p2(1+rho), p3(1+rho), sigma~_c2(1+rho)]`` with the Coulomb
    column ``-sgn q4`` (section 5.1); the regressor uses ``u`` where the
    paper prints ``v`` (ERRATA item 6).
``"free"``
    ``theta^c = [p1, sigma_a1, sigma_v1, sigma_b1]`` from the first row of
    (9) with ``u = 0`` (section 5.2, free pendulum).
``"two-step"``
    ``theta^d = [p2, p3, p2(1+rho), p3(1+rho)]`` with
    ``phi^d = [dq3/dt + xi, dq4/dt - xi]`` and
    ``xi = p1 sin q1 + sigma_a1 |cos q1| q3 + sigma_v1 q3 + sigma_b1 q3^3``
    computed from a free-pendulum result (section 5.2). The paper prints the
    rolling-friction term of ``xi`` without its factor ``q3``; by (9) it is
    ``sigma_a1 |cos q1| q3`` (ERRATA item 1), which is what is used.
    ``rho`` is given by both ratios ``rho_1 = theta3/theta1 - 1`` and
    ``rho_2 = theta4/theta2 - 1`` and their mean (ERRATA item 2: the printed
    numbers lack the ``- 1``; the derivation has it).
``"dead-zone"``
    The thresholds ``v+`` and ``v-`` of (5)/(8) from a static curve
    (figure 2a): on each side the straight part of ``q4(v)`` is fitted by a
    line and extrapolated to ``q4 = 0``.

Names in the results: ``p1, p2, p3, rho, sigma_a1, sigma_v1, sigma_b1,
p2_1rho, p3_1rho, sigma_c2_1rho, v_dz_pos, v_dz_neg`` (``sigma_*`` are the
``sigma~`` of the paper, normalised by ``I1_hat``).

The locked pendulum
-------------------
A clamp that holds the pendulum gives ``dq4/dt = rho (-p2 q4 + p3 u)``
(from (4b) with ``q1'' = 0``), whereas the paper's (14) sets ``q1 = q3 = 0``
in the second row of (6) and writes ``1 + rho``. The motor-disk set-ups
keep the paper's names ``p2_1rho``, ``p3_1rho``, ``sigma_c2_1rho``, but on a
clamped rig they estimate ``p2 rho``, ``p3 rho``, ``sigma~_c2 rho`` (0.4 %
apart with Table 1). :meth:`IdentificationResult.to_params` therefore
divides them by ``rho`` (physically right for a clamped rig). In the
two-step and full set-ups the pendulum swings and ``(1 + rho)`` is exact.

How the signals are formed
--------------------------
Each file is windowed (``t_start``, ``t_end``), then differentiated on its
own with one :class:`~iwp.ident.differentiate.Differentiator` ``D`` whose
low-pass filter is ``K`` (default: consistent Savitzky-Golay over 0.5 s,
cubic; chosen by the study in ``docs/identification.md``). The targets are
``dq3/dt = K D2 q1 / Ts^2`` and ``dq4/dt = K D2 q2 / Ts^2`` with ``D2`` the
second difference. The second difference weighs the acceleration over
``+-Ts`` with a triangle (its Peano kernel), so every term ``f`` of the model
enters exactly as ``K S f`` with ``S`` the triangle average
``[1, 10, 1] / 12`` of the term's *point* values. Every regressor column
is built that way, with the same ``K`` as the targets: the term is
evaluated at the measured position and at the point velocity
``(-v[k-1] + 8 v[k] - v[k+1]) / 6`` of the central differences ``v``,
then ``S`` and ``K`` are applied (``K S sin q1``, ``K S (|cos q1| q3)``,
``K S q3``, ``K S q4``, ``K S u``, ``K S sgn q4``). The cube ``q3^3`` is
corrected for the velocity noise, ``E[(v + n)^3] = v^3 + 3 var(n) v``.
Filtering the term rather than evaluating it at the filtered state keeps
the filtered equation exact; with a Savitzky-Golay filter (not flat in its
pass band) the usual way, ``f(K q1, K q3)``, biases ``p1`` by 0.1-0.4 %
and ``sigma_a1`` by 30-300 % (``IdentifyOptions(nonlinear="filtered-states")`` keeps it for
comparison). Discretisation errors are ``O((omega Ts)^4)``.
``max(D.edge_samples_at(Ts), 3)`` samples are dropped at both ends of every
file; the files are then stacked, with sample numbers kept distinct per
file.

The least squares (13) are solved by :func:`iwp.ident.lsq.solve_least_squares`
(column scaling, tall-skinny Householder QR and SVD; no normal matrix is
formed or inverted), with block weights for the two rows of (10).

Uncertainty
-----------
The residuals of differentiated, filtered encoder data are the encoder
noise (quantisation ``step/sqrt(12)`` and sensor noise) passed through known
linear maps: the target's ``K D2 / Ts^2`` and the regressor terms'
``K S (df/dx) ...``. The default covariance (``IdentifyOptions(covariance="noise")``)
propagates white position noise of each encoder through exactly these maps
(adjoint filters, :func:`iwp.ident.noise.noise_covariance`), with the noise level
estimated from the positions' fourth difference. Kernel (HAC) estimators
get this case wrong: the noise spectrum vanishes at low frequency, so
Newey-West overstates the spread of ``p2(1+rho)`` by 1.6x and of ``p1``
by 3x and understates the frictions' by 1.3x on the virtual rig; the noise
covariance gives z scores of unit spread and 93-97 % coverage of the 95 %
intervals (tests). When the residuals are more than twice what the noise
explains (a model misfit: belt, Coulomb friction, dead-zone residue, wrong
known parameters), the HAC covariance is reported instead, with a warning:
the estimates then carry a bias that no standard error shows.
``IdentifyOptions(covariance="hac")`` or ``"ols"`` force the others.

The free pendulum and the disk
------------------------------
With the motor off, the disk still turns as the pendulum swings (``q4`` is
driven by ``xi``; a few rad/s), and the first row of (9) contains
``+ p2 q4``, which ``theta^c`` neglects. On the virtual rig this biases
``sigma_v1`` by tens of per cent (the term acts as extra damping). Give
``p2=`` (a value, or a two-step result) to move ``p2 q4`` into the target;
iterating free -> two-step -> free(p2) -> two-step removes the bias. Without
``p2=`` the set-up is the paper's and a warning estimates the size of the
neglected term with Table 1's ``p2``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from scipy import stats

from ..data import ExperimentData, check_distinct
from ..errors import IdentificationError, InputError, IwpError
from ..files import read_json
from ..models.encoder import quantize
from ..models.parameters import load_params, table1
from ..sim import simulate
from ..sim.inputs import Sampled
from ..sim.uncertainty import Z95, undetermined
from .differentiate import Differentiator
from .fit_parameters import Parameter
from .input_hold import INPUT_HOLDS, InputHoldReading, with_input_hold
from .lsq import LeastSquaresOptions, LeastSquaresResult, lstsq_projection, solve_least_squares
from .misfit import correlated_note, residual_structure
from .noise import NoiseCovariance, noise_covariance, row_weights
from .output_error import measured_initial_state
from .result import IdentificationResult
from .setups import (
    PARAMETER_NAMES,
    PARAMETER_UNITS,
    SETUPS,
    Regression,
    Setup,
    fit_static_curve,
    get_setup,
    pendulum_values,
)
from .signals import Signals, as_list, prepare_signals
from .validation import validation_plant

__all__ = [
    "SETUPS",
    "PARAMETER_NAMES",
    "PARAMETER_UNITS",
    "IDENTIFY_DIFFERENTIATOR",
    "DEFAULT_WINDOW_SECONDS",
    "default_differentiator",
    "IdentificationResult",
    "IdentifyOptions",
    "identify",
    "identify_dead_zone",
    "load_pendulum",
]

DEFAULT_WINDOW_SECONDS = 0.5

#: The differentiator used when none is given, for the rig's Ts = 5 ms: the consistent
#: Savitzky-Golay filter ("savgol"), 101 samples (0.5 s), cubic. Chosen by the study of
#: ``benchmarks/diff_study.py`` (table and reasons in ``docs/identification.md``): among the
#: settings whose errors stay within their standard errors, it gives the smallest error and
#: standard error of the friction coefficients on noisy data, and drops only 50 samples at
#: each end. For another sample time see :func:`default_differentiator`.
IDENTIFY_DIFFERENTIATOR = Differentiator("savgol", window=101, polyorder=3)


def default_differentiator(Ts: float) -> Differentiator:
    """The default differentiator for sample time ``Ts`` [s].

    The Savitzky-Golay filter of :data:`IDENTIFY_DIFFERENTIATOR` with the
    same window length in seconds (:data:`DEFAULT_WINDOW_SECONDS`), i.e.
    ``window = 2 round(0.25 / Ts) + 1`` samples (at least 7), cubic.

    Parameters
    ----------
    Ts : float
        Sample time [s], positive.

    Returns
    -------
    Differentiator
        :data:`IDENTIFY_DIFFERENTIATOR` itself for ``Ts = 0.005`` s, else a cubic Savitzky-Golay filter.

    Raises
    ------
    InputError
        ``Ts`` not a positive finite number.

    Examples
    --------
    The same 0.25 s half-window at the paper's 5 ms and at 10 ms:

    >>> from iwp.ident import default_differentiator
    >>> default_differentiator(0.005)
    Differentiator(method='savgol', window=101, polyorder=3, cutoff=None, order=None)
    >>> default_differentiator(0.01).window
    51
    """
    if not (isinstance(Ts, (int, float)) and math.isfinite(Ts) and Ts > 0):
        raise InputError(f"Ts must be a positive number of seconds, got {Ts!r}")
    if abs(Ts - 0.005) <= 1e-9:
        return IDENTIFY_DIFFERENTIATOR
    return Differentiator.savgol_spanning(DEFAULT_WINDOW_SECONDS, Ts, min_window=7)

#: fewer effectively independent samples per parameter than this -> warning
_MIN_EFF_PER_PARAM = 20
#: |correlation| above which a pair is explained as not separable
_CORR_EXPLAIN = 0.99
#: residuals this many times larger than the measurement noise explains -> model misfit (HAC covariance), unless
#: nothing in them follows the state (:mod:`iwp.ident.misfit`: noise correlated in time)
_MISFIT_RATIO = 2.0
#: ... up to this many times: AR(1) sensor noise of 1 mrad and 20 ms on a 2000-count encoder stands 2.1-3.3 times
#: above its white level in the residuals (tests/independent.py), one of 100 ms about 6 times; residuals beyond it
#: are no encoder's noise, and are a misfit whatever the library of iwp.ident.misfit finds in them
_NOISE_LIKE_MAX = 10.0
#: Least fraction of the regressand's mean square the model must explain, in every row of (10):
#: below it the estimates describe noise or a signal the set-up does not model, not the rig.
MIN_EXPLAINED = 0.5


def explained_fraction(Phi: np.ndarray, phi: np.ndarray, theta: np.ndarray, blocks: np.ndarray | None,
                       labels: list[str]) -> dict[str, float]:
    """``1 - |phi - Phi theta|^2 / |phi|^2`` per row of (10) (the uncentred R^2 of each block)."""
    r = phi - Phi @ theta
    out = {}
    ids = [None] if blocks is None else list(np.unique(blocks))
    for k, b in enumerate(ids):
        rows = slice(None) if b is None else (blocks == b)
        den = float(np.sum(phi[rows] ** 2))
        label = labels[int(b)] if b is not None and int(b) < len(labels) else (labels[0] if labels else str(k))
        out[label] = 1.0 - float(np.sum(r[rows] ** 2)) / den if den > 0.0 else float("nan")
    return out
#: expected signs (for the "unphysical value" warning)
_POSITIVE = ("p1", "p3", "rho", "p3_1rho")
_NONNEG = ("p2", "p2_1rho", "sigma_a1", "sigma_v1", "sigma_b1", "sigma_c2_1rho", "v_dz_pos", "v_dz_neg")


#: what :class:`IdentifyOptions` ``angle_zero`` may say of each log's pendulum angle zero
ANGLE_ZEROS = ("estimate", "logged")


@dataclass(frozen=True)
class IdentifyOptions:
    """How :func:`identify` differentiates, builds the regressor, weighs the rows and reports the uncertainty.

    Parameters
    ----------
    differentiator : Differentiator, optional
        Default: :func:`default_differentiator` for the sample time of the
        first log (Savitzky-Golay over 0.5 s, cubic: 101 samples at 5 ms;
        chosen by the study in ``docs/identification.md``).
    covariance : {"noise", "hac", "ols"}
        ``"noise"`` (default): the encoder noise propagated through the
        differentiator and the model (see the module docstring); falls back
        to ``"hac"`` on a model misfit, for ``"savgol_direct"`` and for
        ``nonlinear="filtered-states"`` (with a warning). ``"hac"``,
        ``"ols"``: the covariances of :func:`iwp.ident.lsq.solve_least_squares`.
    nonlinear : {"filter-terms", "filtered-states"}
        How the nonlinear regressor columns get the filter: ``"filter-terms"``
        (default) filters each term evaluated at the measured position and
        its central-difference velocity, ``K f(q1, q3)``, which keeps the
        filtered equation exact; ``"filtered-states"`` evaluates the term at
        the filtered states, ``f(K q1, K q3)`` (the usual way; biased when
        the filter is not flat over the signal band, kept for comparison).
    weights : {"blocks", "none"}
        Set-ups on both rows of (10) (``"full"``, ``"two-step"``):
        ``"blocks"`` (default) weighs each row by the inverse variance of its
        residuals (feasible weighted least squares,
        :func:`iwp.ident.lsq.solve_least_squares`); ``"none"`` is the paper's
        (13) as printed, the plain sum over both rows, in which the larger
        misfit of the ``dq4/dt`` row moves the parameters shared by both rows
        (the pendulum's in ``"full"``: the paper's eq. (16)).
    admissible : bool
        True (default): a friction coefficient the logs do not identify (its
        estimate negative, or its 95 % interval a hundred times wider than its
        value, :func:`~iwp.sim.uncertainty.undetermined`) is held at its
        prior (``base``, Table 1 by default) and the others are estimated
        again (:data:`HOLDABLE`), with a warning that names the experiment
        that would identify it. False: the unconstrained least squares (13)
        as the paper solves it, negative friction included (eq. (16)).
    input_hold : {"auto", "zoh", "continuous"}
        How the logged input ``u[k]`` acted between the samples. ``"zoh"``:
        held until the next sample, as a rig's digital controller applies
        it; the regression takes the held input's exact average over each
        sample's second difference, ``(u[k-1] + u[k]) / 2``
        (:func:`iwp.ident.signals.held_input`). ``"continuous"``: ``u[k]``
        is the value at ``t[k]`` of an input that varies continuously (the
        virtual rig's chirps and sines, a continuous simulation; the paper's
        procedure, :data:`AS_PRINTED`). ``"auto"`` (default): each log's
        metadata ``input_hold`` (the virtual rig writes it), else read from
        the log itself (:func:`iwp.ident.input_hold.read_input_hold`: both
        readings fitted to the wheel's row, the one with the smaller
        residuals taken, held where the data cannot tell); the result's
        ``details["input_hold"]`` and its summary say which and why.
        Taken as continuous, a held input lags half a sample: on a 60 s chirp
        at 5 ms, ``p2`` and ``p3`` come out 1.1 % and 0.6 % low (25 and 15
        standard errors) and the residuals of the ``dq4/dt`` row 170 times
        the encoder noise.
    angle_zero : {"estimate", "logged"}
        ``"estimate"`` (default): each log's pendulum angle may be off the
        angle at which the pendulum hangs by a constant ``d`` (an encoder
        zeroed where friction held the pendulum, or anywhere within a count):
        ``p1 sin(q1 - d) = p1 cos d sin q1 - p1 sin d cos q1``, so a column
        ``K cos q1`` per log and row of (10) is projected out of the
        regression before the least squares (one degree of freedom each), and
        ``d`` is reported per log from the first row (``details
        ["q1_zero_offset"]``, rad). Set-ups without ``p1`` are not affected.
        ``"logged"``: the logged zero is taken as exact, as the paper's (10)
        does (:data:`AS_PRINTED`); then an offset of 0.8 / 1.6 mrad moves the
        full set-up's ``rho`` by about +0.1-0.3 / +0.6-1.0 % (on quantised
        logs three to four standard errors; BENCHMARKS.md, issue 39).

    Raises
    ------
    InputError
        An unknown covariance, nonlinear mode, weighting, input hold or angle zero; a differentiator that is not a
        :class:`Differentiator`.
    """

    differentiator: Differentiator | None = None
    covariance: str = "noise"
    nonlinear: str = "filter-terms"
    weights: str = "blocks"
    admissible: bool = True
    input_hold: str = "auto"
    angle_zero: str = "estimate"

    def __post_init__(self) -> None:
        if self.angle_zero not in ANGLE_ZEROS:
            raise InputError(f"angle_zero must be 'estimate' or 'logged', got {self.angle_zero!r}",
                             argument="angle_zero")
        if self.input_hold not in INPUT_HOLDS:
            raise InputError(f"input_hold must be 'auto', 'zoh' or 'continuous', got {self.input_hold!r}")
        if self.covariance not in ("noise", "hac", "ols"):
            raise InputError(f"covariance must be 'noise', 'hac' or 'ols', got {self.covariance!r}")
        if self.nonlinear not in ("filter-terms", "filtered-states"):
            raise InputError(f"nonlinear must be 'filter-terms' or 'filtered-states', got {self.nonlinear!r}")
        if self.weights not in ("blocks", "none"):
            raise InputError(f"weights must be 'blocks' or 'none', got {self.weights!r}")
        d = self.differentiator
        if d is not None and not isinstance(d, Differentiator):
            raise InputError(f"differentiator must be a Differentiator, got {type(d).__name__}")
        if not isinstance(self.admissible, bool):
            raise InputError(f"admissible must be True or False, got {self.admissible!r}", argument="admissible")


#: the paper's procedures as printed: the unconstrained least squares (13), negative friction included (eq. (16)),
#: with the logged input taken at its sample (the half-sample lag of a held input included: the paper's numbers
#: carry it) and the logged angle's zero as exact; what the reproduction and the twin's calibration run
AS_PRINTED = IdentifyOptions(admissible=False, input_hold="continuous", angle_zero="logged")


def identify(
    data: Any,
    setup: str,
    *,
    pendulum: Any = None,
    t_start: float | None = None,
    t_end: float | None = None,
    base: Any = None,
    p2: Any = None,
    options: IdentifyOptions | None = None,
) -> IdentificationResult:
    """Identify the parameters of one set-up of section 5 from logs.

    Parameters
    ----------
    data : ExperimentData, list of ExperimentData, or StaticCurve
        The log(s). Several logs of one set-up are stacked (each is
        windowed and differentiated on its own). ``"dead-zone"`` takes a
        :class:`~iwp.data.StaticCurve` (or a list of them, points pooled).
    setup : str
        One of :data:`SETUPS`: ``"full"`` (10)-(12), ``"motor-disk"``
        (theta^a), ``"motor-disk-coulomb"`` (theta^b), ``"free"``
        (theta^c), ``"two-step"`` (theta^d), ``"dead-zone"`` (v+, v-).
    pendulum : IdentificationResult, LumpedParameters or mapping, optional
        ``"two-step"`` only (required there): ``p1`` and ``sigma_a1``,
        ``sigma_v1``, ``sigma_b1`` for ``xi``, normally the result of the
        ``"free"`` set-up; its covariance is propagated into the two-step
        standard errors.
    t_start, t_end : float, optional
        Time window [s] applied to every log before differentiation.
    base : LumpedParameters, optional
        Reference values for warnings (default Table 1); not used in the fit.
    p2 : float, IdentificationResult or LumpedParameters, optional
        ``"free"`` only: a known ``p2`` [1/s]; the term ``p2 q4`` of the first
        row of (9), neglected by theta^c, is moved to the target (see the
        module docstring). A result's ``p2`` variance is propagated.
    options : IdentifyOptions, optional
        Differentiator, covariance (default ``"noise"``), nonlinear terms
        (default ``"filter-terms"``) and row weights (default ``"blocks"``);
        e.g. ``IdentifyOptions(weights="none")`` for the paper's (13) as
        printed.

    Returns
    -------
    IdentificationResult

    Raises
    ------
    InputError
        Unknown set-up, a static curve given to a time-series set-up or vice
        versa, no ``u`` where the set-up needs it, an input in a free-pendulum
        log, ``pendulum`` missing for ``"two-step"``, a window leaving too
        few samples, non-uniform sampling.

    Notes
    -----
    A rank-deficient regressor does not raise: the result has
    ``success=False``, NaN standard errors for the parameters involved and a
    warning naming the collinear columns.

    Examples
    --------
    The free pendulum of section 5.2 (set-up (d)), on a simulated swing:

    >>> from iwp import Plant, identify, simulate, table1
    >>> log = simulate(Plant(table1(), model="free"), x0=[1.0, 0, 0, 0], t_end=20.0).to_experiment()
    >>> res = identify(log, "free")
    >>> res.names
    ('p1', 'sigma_a1', 'sigma_v1', 'sigma_b1')
    >>> round(res.value("p1"), 1)  # Table 1: 26.095
    26.0
    """
    opts = IdentifyOptions() if options is None else options
    if not isinstance(opts, IdentifyOptions):
        raise InputError(f"options must be an IdentifyOptions, got {type(opts).__name__}")
    spec = get_setup(setup)
    spec.check_options(pendulum, p2)
    if spec.static:
        if t_start is not None or t_end is not None:
            raise InputError("t_start/t_end do not apply to set-up 'dead-zone' (a static curve has no time)",
                             argument=("t_start", "t_end"))
        return identify_dead_zone(data)
    plan = _plan_identification(data, spec, _Window(t_start, t_end), _Known(pendulum, p2, base), opts)
    solved = _with_known_uncertainty(plan, _least_squares(plan, opts))
    if opts.admissible:
        plan, solved = _hold_unidentified(plan, opts, solved)
    return _report_identification(plan, _with_held(plan, solved))


@dataclass(frozen=True)
class _Window:
    """The time window [s] of every log (None: its start / end)."""

    t_start: float | None
    t_end: float | None


@dataclass(frozen=True)
class _Known:
    """What the caller knows: the pendulum (two-step), ``p2`` (free) and the reference values for warnings."""

    pendulum: Any
    p2: Any
    base: Any


@dataclass(frozen=True, eq=False)
class _IdentPlan:
    """A set-up's regression (13) on the prepared signals, with the warnings found before the fit."""

    spec: Setup
    window: _Window
    known: _Known
    differentiator: Differentiator
    nonlinear: str
    sig: Signals
    reg: Regression
    sources: list[str]
    pend_vals: Mapping[str, float] | None
    warnings: tuple[str, ...]
    #: columns held at their prior (not identified by these logs), with the prior's value
    held: Mapping[str, float] = field(default_factory=dict)
    #: the logs, for the misfit test's reference run (:func:`_own_model_ratios`); empty in that run itself
    logs: tuple = ()
    #: each log's angle-zero column, projected out of the regression (``angle_zero="estimate"``), or None
    zero: _ZeroColumns | None = None
    #: how each log's input acted between its samples, and why (set-ups with an input)
    holds: tuple[InputHoldReading, ...] = ()

    @property
    def names(self) -> list[str]:
        """The columns estimated (the set-up's, less those held)."""
        return [c for c in self.spec.columns if c not in self.held]


@dataclass(frozen=True, eq=False)
class _Solved:
    """The least-squares solution and the covariance reported with it (and why), in the parameters' units."""

    res: LeastSquaresResult
    cov: np.ndarray
    critical: float
    warnings: tuple[str, ...] = ()
    details: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class _ZeroColumns:
    """Each log's column of an offset ``d`` of its pendulum angle's zero, and the regression it was taken from.

    A logged angle ``q1 = q1_true + d`` puts ``p1 sin(q1 - d) = p1 cos d sin q1 - p1 sin d cos q1`` in ``xi``:
    beside the ``p1`` column (``s K sin q1`` in a row whose ``p1`` column has the sign ``s``) a column
    ``s K cos q1`` per log, with the coefficient ``c = -p1 sin d``. ``N`` holds them, one per log and row of
    (10) (rows of the regression by ``logs x rows``: each row's column is its own, so that the projection keeps
    the rows apart and the rows' weights of the least squares act on it as on the others); :meth:`project`
    removes their span from the regressor and the target (the least squares then estimates the set-up's columns
    as if the ``c`` were estimated with them, to one degree of freedom per log and row), and :meth:`offsets`
    gives ``d`` of each log from the estimates and its first row (the pendulum's, ``dq3/dt``).
    """

    N: np.ndarray
    Phi: np.ndarray
    phi: np.ndarray
    p1: int
    n_logs: int

    def _residual(self, X: np.ndarray) -> np.ndarray:
        coef, *_ = np.linalg.lstsq(self.N, X, rcond=None)
        return X - self.N @ coef

    def project(self, reg: Regression) -> Regression:
        known = reg.known_sensitivity
        return replace(reg, Phi=np.ascontiguousarray(self._residual(reg.Phi)), phi=self._residual(reg.phi),
                       known_sensitivity=None if known is None else self._residual(known))

    def offsets(self, theta: np.ndarray) -> np.ndarray:
        """``d`` [rad] of each log from the estimates ``theta`` over the set-up's columns (held ones at their prior)."""
        c, *_ = np.linalg.lstsq(self.N, self.phi - self.Phi @ theta, rcond=None)
        with np.errstate(invalid="ignore", divide="ignore"):
            return -np.arcsin(np.clip(c[: self.n_logs] / theta[self.p1], -1.0, 1.0))


def _zero_columns(reg: Regression, sig: Signals, spec: Setup) -> _ZeroColumns | None:
    """The angle-zero columns of the set-up's regression (None: a set-up without ``p1``, or rows not one block per
    equation over all samples)."""
    if "p1" not in spec.columns or reg.Phi.shape[0] != len(reg.labels) * sig.n:
        return None
    j = list(spec.columns).index("p1")
    n_logs = len(sig.files)
    N = np.zeros((reg.Phi.shape[0], len(reg.labels) * n_logs))
    for b in range(len(reg.labels)):
        sign = 1.0 if float(reg.Phi[b * sig.n:(b + 1) * sig.n, j] @ sig.S) >= 0.0 else -1.0
        for k in range(n_logs):  # the file's rows of the stacked signals (as the noise covariance reads them)
            rows = sig.file_rows(k)
            N[b * sig.n + rows.start: b * sig.n + rows.stop, b * n_logs + k] = sign * sig.Z[rows]
    return _ZeroColumns(N=N, Phi=reg.Phi.copy(), phi=reg.phi.copy(), p1=j, n_logs=n_logs)


def _plan_identification(data: Any, spec: Setup, window: _Window, known: _Known, opts: IdentifyOptions) -> _IdentPlan:
    """Window and differentiate the logs, build the set-up's regression, and warn of too few samples."""
    datas = as_list(data)
    check_distinct(datas, "data")
    d = _differentiator_for(opts.differentiator, datas)
    pend_vals = pendulum_values(known.pendulum)[0] if spec.takes_pendulum else None
    holds: tuple[InputHoldReading, ...] = ()
    if spec.needs_input:
        datas, readings = with_input_hold(datas, opts.input_hold)  # each log's metadata says its reading
        holds = tuple(readings)
    sig = prepare_signals(spec, datas, d, window.t_start, window.t_end, nonlinear=opts.nonlinear)
    reg = spec.regression(sig, pendulum=known.pendulum, p2=known.p2)
    zero = _zero_columns(reg, sig, spec) if opts.angle_zero == "estimate" else None
    if zero is not None:
        reg = zero.project(reg)
    sources = _sources(datas)
    warnings = list(reg.warnings) + spec.check_signals(sig, sources)
    n_par = len(spec.columns)
    n_eff = sig.n / max(sig.corr_len, 1.0)
    if n_eff < _MIN_EFF_PER_PARAM * n_par:
        warnings.append(
            f"too few samples for set-up {spec.name!r}: {sig.n} samples, about {n_eff:.0f} effectively independent "
            f"(the filter correlates ~{sig.corr_len:.0f} neighbours) for {n_par} parameters; values and "
            f"uncertainty are unreliable below ~{int(_MIN_EFF_PER_PARAM * n_par * sig.corr_len)} samples")
    return _IdentPlan(spec=spec, window=window, known=known, differentiator=d, nonlinear=opts.nonlinear, sig=sig,
                      reg=reg, sources=sources, pend_vals=pend_vals, warnings=tuple(warnings), logs=tuple(datas),
                      zero=zero, holds=holds)


def _solve_lsq(plan: _IdentPlan, opts: IdentifyOptions, covariance: str) -> LeastSquaresResult:
    """Solve (13) with :func:`solve_least_squares`; its input errors name the set-up."""
    reg = plan.reg
    lsq_options = LeastSquaresOptions(covariance=covariance, weights=opts.weights, allow_rank_deficient=True)
    try:
        return solve_least_squares(reg.Phi, reg.phi, plan.names, blocks=reg.blocks, sample_index=reg.sample_index,
                                   options=lsq_options)
    except InputError as exc:
        raise IdentificationError(f"set-up {plan.spec.name!r}: {exc}") from None


def _least_squares(plan: _IdentPlan, opts: IdentifyOptions) -> _Solved:
    """Solve (13) and choose the covariance: the measurement noise's where it applies, else lsq's HAC or OLS.

    The measurement-noise covariance needs only the point estimate from lsq
    (its cheap ``"ols"`` pass); where it does not apply, lsq's HAC
    covariance is used.
    """
    covariance = opts.covariance
    noise_ok = (covariance == "noise" and plan.differentiator.method != "savgol_direct"
                and opts.nonlinear == "filter-terms")
    lsq_cov = "hac" if covariance == "hac" or (covariance == "noise" and not noise_ok) else "ols"
    res = _solve_lsq(plan, opts, lsq_cov)
    tail = {"covariance": res.covariance_method, "regressor_terms": opts.nonlinear}
    if covariance != "noise":
        return _Solved(res=res, cov=np.array(res.covariance, dtype=float), critical=res.critical_value, details=tail)
    nc = noise_covariance(plan.spec, plan.sig, plan.differentiator, plan.reg, res, plan.pend_vals) if noise_ok else None
    if nc is None:
        if lsq_cov != "hac" and res.success:
            res = _solve_lsq(plan, opts, "hac")
        return _Solved(
            res=res, cov=np.array(res.covariance, dtype=float), critical=res.critical_value,
            warnings=("the measurement-noise covariance does not apply here (rank deficiency, method "
                      "'savgol_direct' or nonlinear='filtered-states'); the HAC covariance is reported",),
            details={**tail, "covariance": "hac"})
    return _noise_or_misfit(plan, opts, res, nc)


def _noise_or_misfit(plan: _IdentPlan, opts: IdentifyOptions, res: LeastSquaresResult,
                     nc: NoiseCovariance) -> _Solved:
    """The measurement-noise covariance, or lsq's HAC one when the residuals are more than the noise explains."""
    noise_sd = nc.noise_std
    details: dict[str, Any] = {
        "noise_std": noise_sd,
        "noise_std_note": ("white-equivalent position noise per encoder [rad] from the fourth difference "
                           "of the positions (quantisation alone: step/sqrt(12) = 9.1e-4 rad at 2000 "
                           "counts/rev); from_residuals: the level the residuals of each row would need"),
    }
    ratios = _noise_ratios(noise_sd)
    worst = max(ratios, key=ratios.get) if ratios else None
    if worst is None or not ratios[worst] > _MISFIT_RATIO:
        details.update(covariance="noise", regressor_terms=opts.nonlinear)
        return _Solved(res=res, cov=nc.covariance, critical=float(stats.t.ppf(0.975, max(res.dof, 1))),
                       details=details)
    own = _own_model_ratios(plan, opts, res, noise_sd)
    hac = _solve_lsq(plan, opts, "hac")
    details.update(covariance="hac", regressor_terms=opts.nonlinear)
    row = {"q1": "first (dq3/dt)", "q2": "second (dq4/dt)"}[worst]
    label = {"q1": "q3", "q2": "q4"}[worst]
    structure = residual_structure(plan.sig, plan.reg, np.asarray(res.values, dtype=float))
    details["residual_structure"] = {"explained": structure.explained, "leading": structure.leading}
    if own is not None:
        details["own_model_ratios"] = own
    warnings: tuple[str, ...] = ()
    if own is not None and worst in own and ratios[worst] <= _MISFIT_RATIO * own[worst]:
        # no more than the set-up's own model leaves (quantisation, the differentiator): no missing term to warn of
        details["residuals_note"] = (
            f"the residuals of the {row} row of (10) are {ratios[worst]:.3g} times what the noise of encoder "
            f"{worst} explains, and the set-up's own model, simulated with these estimates on the same inputs and "
            f"logged like these logs, leaves {own[worst]:.3g} times: the excess is what the regression leaves on the "
            "set-up's own model (the encoders' quantisation, the differentiator's error), not a term the model "
            "lacks. Standard errors from the model-free HAC covariance")
    elif not structure.holds_a_term(label) and ratios[worst] < _NOISE_LIKE_MAX:
        # above the white level, but nothing in the residuals follows the state: noise correlated in time
        details["residuals_note"] = correlated_note(ratios[worst], row, worst, structure, label)
    else:
        against = ("" if own is None or worst not in own else
                   f", and {ratios[worst] / own[worst]:.3g} times what the set-up's own model leaves when simulated "
                   f"with these estimates on the same inputs and logged like these logs ({own[worst]:.3g} times)")
        warnings = (
            f"model misfit: the residuals of the {row} row of (10) are {ratios[worst]:.3g} times larger than "
            f"the measurement noise of encoder {worst} ({noise_sd[worst]:.2g} rad) explains{against}, and "
            f"{structure.describe(label)}; the model does not describe these data exactly (unmodelled friction, "
            "belt, dead-zone residue, an input read with the wrong hold, wrong known parameters), so the estimates "
            "carry a bias that no standard error shows. Standard errors from the model-free HAC covariance",)
    return _Solved(res=hac, cov=np.array(hac.covariance, dtype=float), critical=hac.critical_value,
                   warnings=warnings, details=details)


def _logged_like(angle: np.ndarray, logged: np.ndarray, noise_sd: float, rng: np.random.Generator) -> np.ndarray:
    """A simulated ``angle`` [rad] logged as ``logged`` was: on its encoder's grid when every step of ``logged`` is
    a whole number of its smallest step (quantised at a random phase), else with white noise of ``noise_sd``."""
    steps = np.abs(np.diff(np.asarray(logged, dtype=float)))
    moving = steps[steps > 0]
    if moving.size:
        q = float(moving.min())
        if np.all(np.abs(moving / q - np.round(moving / q)) < 1e-6):
            return quantize(angle + rng.uniform(-0.5 * q, 0.5 * q), q)
    return angle + rng.normal(0.0, noise_sd, angle.size)


def _noise_ratios(noise_sd: Mapping[str, Any]) -> dict[str, float]:
    """Per encoder: the noise level the residuals would need over the level the encoder's signal shows."""
    return {ch: v / noise_sd[ch] for ch, v in noise_sd["from_residuals"].items() if noise_sd[ch] > 0}


def _own_model_ratios(plan: _IdentPlan, opts: IdentifyOptions, res: LeastSquaresResult,
                      noise_sd: Mapping[str, Any]) -> dict[str, float] | None:
    """What the set-up's own model leaves: :func:`_noise_ratios` of the same regression on its logs simulated.

    The set-up's model (its ``refine`` model) with the estimates ``res`` is simulated on every log's input from
    the log's measured first state and logged like the log (:func:`_logged_like`), and the same set-up identifies
    from those logs. A model fitted to its own simulation leaves residuals above the noise estimate too: an
    encoder's quantisation is not white noise where the angle moves slowly. ``None`` where no such run is
    possible (no model to simulate, a failed simulation).
    """
    spec = plan.spec
    if not plan.logs or spec.refine is None:
        return None
    values = {**plan.held, **dict(zip(plan.names, np.asarray(res.values, dtype=float)))}
    derived = spec.derive(np.array([values[c] for c in spec.columns]), np.zeros((len(spec.columns),) * 2), 1.96)
    if derived is not None:
        values.update({k: p.value for k, p in derived.parameters.items()})
    rng = np.random.default_rng(0)
    try:
        base = _reference(plan.known.base)
        params = base.replace(**spec.parameter_changes(values, {}, base))
        logs = []
        for d in plan.logs:
            u = d.u if d.u is not None else np.zeros(d.n_samples)
            run = simulate(validation_plant(params, d, spec.refine.model), input=Sampled(u, d.Ts),
                           x0=measured_initial_state(d), t_end=d.t[-1] - d.t[0], Ts=d.Ts)
            if run.t.size != d.n_samples:
                return None
            logs.append(ExperimentData(t=d.t, q1=_logged_like(run.q1, d.q1, noise_sd.get("q1", 0.0), rng),
                                       q2=_logged_like(run.q2, d.q2, noise_sd.get("q2", 0.0), rng), u=d.u,
                                       metadata=dict(d.metadata)))
        held = replace(opts, input_hold="zoh")  # the simulated logs' input is held: no other bias is copied
        own = _plan_identification(logs, spec, plan.window, plan.known, held)
        res_own = _solve_lsq(own, held, "ols")
        nc = noise_covariance(spec, own.sig, own.differentiator, own.reg, res_own, own.pend_vals)
    except (IwpError, ValueError, FloatingPointError):
        return None
    return None if nc is None else _noise_ratios(nc.noise_std)


#: the spread of a held friction's prior, as a share of its value (an assumption): Table 1's value stands for
#: another rig's, which is not Table 1's (the calibrated twin's own sigma_a1 is 1.7 times it, sigma_v1 0.76 times)
PRIOR_SPREAD = 1.0

#: the columns a set-up may hold at their prior when the logs do not identify them (friction coefficients: the
#: gains and inertias p1, p2, p3 are what every set-up is for, and a set-up that cannot find them fails), with the
#: experiment that identifies each
HOLDABLE: dict[str, str] = {
    "sigma_a1": "a free-pendulum release from a large angle (90 degrees or more: |cos q1| must vary), "
                "`iwp identify free.csv --setup free`",
    "sigma_v1": "a free-pendulum release from a large angle (90 degrees or more: |cos q1| must vary), "
                "`iwp identify free.csv --setup free`",
    "sigma_b1": "a free-pendulum release at high speed (a swing through the upright, or a spin)",
    "sigma_c2_1rho": "a motor-disk chirp with the pendulum clamped that dwells at low wheel speeds",
}


#: how a held column is marked in the tables
HELD_NOTE = "held at its prior: not identified by these logs"


def _prior(name: str, base: Any) -> float:
    """The prior of a holdable column: ``base``'s value (Table 1 by default); ``X_1rho`` is ``X (1 + rho)``."""
    ref = _reference(base)
    ref = ref.to_lumped() if hasattr(ref, "to_lumped") else ref
    if name.endswith("_1rho"):
        return float(getattr(ref, name[:-len("_1rho")])) * (1.0 + float(ref.rho))
    return float(getattr(ref, name))


def _unidentified(plan: _IdentPlan, solved: _Solved) -> tuple[str, float, float] | None:
    """The holdable column the logs identify least (negative, its 95 % interval reaching 0, or undetermined,
    :func:`~iwp.sim.uncertainty.undetermined`), or None.

    Returns its name, estimate and standard error; the one with the smallest ``value / stderr`` goes first.
    """
    if not solved.res.success:
        return None
    params = _estimates(plan.names, solved)
    worst = None
    for name, p in params.items():
        if name not in HOLDABLE or not math.isfinite(p.stderr):
            continue
        if p.value < 0.0 or p.value < Z95 * p.stderr or undetermined(name.removesuffix("_1rho"), p.value, p.stderr):
            t = p.value / p.stderr if p.stderr > 0 else -math.inf
            if worst is None or t < worst[0]:
                worst = (t, name, p.value, p.stderr)
    return None if worst is None else worst[1:]


def _held_regression(plan: _IdentPlan, name: str, value: float) -> Regression:
    """The regression with column ``name`` held at ``value``: its term moved to the target, its column removed,
    and the prior's spread (:data:`PRIOR_SPREAD` of ``value``) carried as a known parameter's in the target
    (:func:`_with_known_uncertainty`): the columns correlated with it take in the uncertainty of the guess."""
    reg = plan.reg
    j = plan.names.index(name)
    keep = [k for k in range(reg.Phi.shape[1]) if k != j]
    held = {**reg.details.get("held", {}), name: value}
    column = -reg.Phi[:, j:j + 1]  # d phi / d value
    var = (PRIOR_SPREAD * value) ** 2
    if reg.known_sensitivity is None:
        sens, cov = column, np.array([[var]])
    else:
        k = reg.known_sensitivity.reshape(reg.Phi.shape[0], -1)
        sens = np.hstack([k, column])
        cov = np.zeros((sens.shape[1], sens.shape[1]))
        cov[:-1, :-1] = reg.known_covariance
        cov[-1, -1] = var
    return replace(reg, Phi=np.ascontiguousarray(reg.Phi[:, keep]), phi=reg.phi - reg.Phi[:, j] * value,
                   known_sensitivity=sens, known_covariance=cov, details={**reg.details, "held": held})


def _hold_unidentified(plan: _IdentPlan, opts: IdentifyOptions, solved: _Solved) -> tuple[_IdentPlan, _Solved]:
    """Hold the friction coefficients the logs do not identify at their prior, one at a time, and solve again.

    Each round holds the least identified holdable column (:func:`_unidentified`) and re-solves (13) without it,
    until every holdable column left is positive with a 95 % interval clear of 0 (an estimate that is there). The
    prior is a guess: its spread (:data:`PRIOR_SPREAD` of its value) enters the others' covariance as a known
    parameter's (:func:`_held_regression`); without it, a prior held for a friction whose interval merely reached
    0 biased its correlated partner out of its own interval (tests/test_identify.py).
    A warning names each column held, its unconstrained estimate and the experiment that would identify it.
    """
    notes = []
    while (worst := _unidentified(plan, solved)) is not None:
        name, value, se = worst
        prior = _prior(name, plan.known.base)
        notes.append(f"{name} is not identified by these logs (estimate {value:.4g} +- {se:.2g}"
                     f"{', negative' if value < 0 else ', its 95 % interval reaching 0'}); held "
                     f"at its prior "
                     f"{prior:.4g} ({'Table 1' if plan.known.base is None else 'the base parameters'}); "
                     f"identify it with {HOLDABLE[name]}")
        plan = replace(plan, reg=_held_regression(plan, name, prior), held={**plan.held, name: prior})
        solved = _with_known_uncertainty(plan, _least_squares(plan, opts))
    if not notes:
        return plan, solved
    return plan, replace(solved, warnings=(*solved.warnings, *notes),
                         details={**solved.details, "held": dict(plan.held)})


def _with_held(plan: _IdentPlan, solved: _Solved) -> _Solved:
    """The solution over all the set-up's columns: the held ones at their prior, with zero variance."""
    if not plan.held:
        return solved
    columns = list(plan.spec.columns)
    idx = [columns.index(c) for c in plan.names]
    values = np.array([plan.held.get(c, 0.0) for c in columns], dtype=float)
    values[idx] = solved.res.values
    cov = np.zeros((len(columns), len(columns)))
    cov[np.ix_(idx, idx)] = solved.cov
    res = replace(solved.res, values=values, names=tuple(columns))
    return replace(solved, res=res, cov=cov)


def _with_known_uncertainty(plan: _IdentPlan, solved: _Solved) -> _Solved:
    """Add the uncertainty of the known parameters in the target (pendulum of two-step, known ``p2``)."""
    reg, res, spec = plan.reg, solved.res, plan.spec
    if reg.known_sensitivity is not None and reg.known_covariance is not None and res.success:
        w = row_weights(reg.blocks, res, reg.Phi.shape[0])
        J = lstsq_projection(reg.Phi, reg.known_sensitivity, row_scale=None if np.all(w == 1.0) else w)
        note = ("uncertainty of the pendulum parameters used in xi" if spec.takes_pendulum
                else "uncertainty of the known p2")
        return replace(solved, cov=solved.cov + J @ reg.known_covariance @ J.T,
                       details={**solved.details, "stderr_includes": note})
    if spec.takes_pendulum:
        return replace(solved, details={**solved.details, "stderr_includes": "noise of this experiment only "
                                        "(pendulum parameters taken as exact)"})
    return solved


def _estimates(names: Sequence[str], solved: _Solved) -> dict[str, Parameter]:
    """The estimates with standard errors and 95 % intervals from the reported covariance."""
    cov = solved.cov
    se_all = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    se_all[~np.isfinite(np.diag(cov))] = np.nan
    return {nm: Parameter.estimate(nm, float(solved.res.values[j]), float(se_all[j]), solved.critical)
            for j, nm in enumerate(names)}


def _correlation_of(cov: np.ndarray) -> np.ndarray:
    """Correlation matrix of a covariance (diagonal 1, clipped to [-1, 1])."""
    se_out = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se_out, se_out)
    np.fill_diagonal(corr, 1.0)
    return np.clip(corr, -1.0, 1.0)


#: an offset of the logged angle's zero [rad] above which a warning says so: ``p1`` then comes out ``p1 cos d``
#: (0.005 % low at 0.01 rad) and ``|cos q1|`` of the rolling friction is taken at the logged angle
ZERO_OFFSET_WARN = 0.01


def _zero_offsets_report(plan: _IdentPlan, theta: np.ndarray) -> tuple[list[str], dict[str, Any]]:
    """Each log's offset of its angle's zero (``angle_zero="estimate"``), and a warning where one is large."""
    d = [float(x) for x in plan.zero.offsets(theta)]
    details = {"q1_zero_offset": d,
               "q1_zero_offset_note": "logged pendulum angle minus the true one [rad], per log in the order of "
                                      "'sources': its zero off the hanging position (a column K cos q1 per log, "
                                      "projected out of (10))"}
    large = [(k, v) for k, v in enumerate(d) if abs(v) > ZERO_OFFSET_WARN]
    if not large:
        return [], details
    return ["the pendulum angle's zero is off the hanging position by "
            + ", ".join(f"{v:+.3g} rad in {plan.sources[k]} (log {k + 1})" for k, v in large)
            + "; the estimates allow for it, but p1 comes out p1 cos d and the rolling friction's |cos q1| is "
              "taken at the logged angle: zero the encoder with the pendulum hanging still, or subtract the "
              "offset from the log's q1"], details


def _report_identification(plan: _IdentPlan, solved: _Solved) -> IdentificationResult:
    """Derived parameters (``rho``), correlations, interpretation warnings and the verdict, as one result."""
    spec, sig, reg, res = plan.spec, plan.sig, plan.reg, solved.res
    warnings = [*plan.warnings, *solved.warnings, *res.warnings]
    details = {**reg.details, **solved.details}
    columns = list(spec.columns)
    params = _estimates(columns, solved)
    for name in plan.held:  # no interval: the logs say nothing of it, and its prior's spread is not known
        params[name] = Parameter(name, plan.held[name], vary=False, stderr=math.nan, ci95=(math.nan, math.nan),
                                 unit=params[name].unit, note=HELD_NOTE)
    cov, out_names, rho_info = solved.cov, columns, None
    derived = spec.derive(res.values, cov, solved.critical)
    if derived is not None:
        params.update(derived.parameters)
        cov, out_names, rho_info = derived.covariance, derived.names, derived.rho
        details.update(derived.details)
        warnings.extend(derived.warnings)
    corr = _correlation_of(cov)
    warnings.extend(_explain(spec, params, corr, out_names, sig, res))
    extra_w, extra_d = spec.extra_warnings(reg, sig, res, params, _reference(plan.known.base), plan.known.p2)
    warnings.extend(extra_w)
    details.update(extra_d)
    if plan.holds:
        details["input_hold"] = [r.to_dict() for r in plan.holds]
        details["input_hold_note"] = [r.describe() for r in plan.holds]
    if plan.zero is not None and res.success:
        zero_w, zero_d = _zero_offsets_report(plan, np.asarray(res.values, dtype=float))
        warnings.extend(zero_w)
        details.update(zero_d)
    theta = np.asarray([res.values[columns.index(c)] for c in plan.names], dtype=float)  # the columns of reg.Phi
    explained = explained_fraction(reg.Phi, reg.phi, theta, reg.blocks, reg.labels)
    details["explained_fraction"] = explained
    verdict = _verdict(plan, res, explained, len(warnings))
    residual_rms = {reg.labels[i] if isinstance(k, (int, np.integer)) else str(k): float(v)
                    for i, (k, v) in enumerate(res.residual_rms.items())}
    return IdentificationResult(
        setup=spec.name, samples=sig.n, parameters=params, names=tuple(out_names), covariance=cov, correlation=corr,
        condition_number=float(res.condition_number), residual_rms=residual_rms, lsq=res, rho=rho_info,
        warnings=warnings, success=verdict.success, message=verdict.message,
        differentiator=plan.differentiator.settings(), sources=plan.sources, t_start=plan.window.t_start,
        t_end=plan.window.t_end, details=details,
    )


def _reference(base: Any) -> Any:
    """The reference parameter set of the warnings: ``base``, default Table 1."""
    return table1() if base is None else base


@dataclass(frozen=True)
class _Verdict:
    success: bool
    message: str


def _verdict(plan: _IdentPlan, res: LeastSquaresResult, explained: Mapping[str, float], n_warnings: int) -> _Verdict:
    """Success and the one-line message: lsq's verdict, unless the model explains too little of a row of (10)."""
    setup = plan.spec.name
    success = bool(res.success)
    poor = {k: v for k, v in explained.items() if not (v >= MIN_EXPLAINED)}
    if success and poor:
        row, frac = next(iter(poor.items()))
        return _Verdict(success=False,
                        message=f"set-up {setup!r}: the data do not determine the parameters: the model explains "
                                f"{100 * frac:.0f} % of d{row}/dt (at least {100 * MIN_EXPLAINED:.0f} % needed); "
                                "too little excitation, noise only, or the wrong set-up for this log")
    if not success:
        return _Verdict(success=False, message=f"set-up {setup!r}: {res.message}")
    message = (f"set-up {setup!r}: identified {len(plan.names)} parameter(s) from {plan.sig.n} samples "
               f"({plan.sig.n_files} file(s), {res.n_equations} equations)")
    if plan.held:
        message += f", {len(plan.held)} held at their prior ({', '.join(plan.held)})"
    if n_warnings:
        message += f"; {n_warnings} warning(s)"
    return _Verdict(success=True, message=message)


def _differentiator_for(differentiator: Differentiator | None, datas: list) -> Differentiator:
    """The differentiator given, or the default one for the first log's sample time."""
    if differentiator is None:
        d0 = datas[0] if datas else None
        Ts0 = float(np.median(np.diff(d0.t))) if getattr(d0, "t", None) is not None and len(d0.t) > 1 else 0.005
        return default_differentiator(Ts0)
    if not isinstance(differentiator, Differentiator):
        raise InputError(f"differentiator must be a Differentiator, got {type(differentiator).__name__}")
    return differentiator


def _sources(datas: Sequence[Any]) -> list[str]:
    return [str(getattr(x, "source", "<memory>")) for x in datas]


def _explain(spec: Setup, params: Mapping[str, Parameter], corr: np.ndarray, names: Sequence[str],
             sig: Signals, res: LeastSquaresResult) -> list[str]:
    """Warnings that interpret the numbers: unphysical signs, undetermined values, inseparable pairs."""
    out: list[str] = []
    undetermined = []
    for nm, p in params.items():
        if not math.isfinite(p.stderr):
            continue
        if p.ci95_low <= 0.0 <= p.ci95_high and (nm in _POSITIVE or nm in _NONNEG):
            undetermined.append(f"{nm} = {p.value:.3g} +- {p.stderr:.2g}")
    if undetermined:
        out.append("not determined by these data (the 95 % interval contains 0): " + ", ".join(undetermined))
    unphys = [f"{nm} = {p.value:.4g}" for nm, p in params.items()
              if (nm in _POSITIVE and p.value <= 0) or (nm in _NONNEG and p.value < 0 and p.ci95_high < 0)]
    if unphys:
        out.append("unphysical estimate(s) (negative friction or gain, significantly): " + ", ".join(unphys)
                   + "; the model does not describe these data (see the paper's eq. (16))")
    idx = {nm: i for i, nm in enumerate(names)}
    if "sigma_a1" in idx and "sigma_v1" in idx:
        r = corr[idx["sigma_a1"], idx["sigma_v1"]]
        if math.isfinite(r) and abs(r) > _CORR_EXPLAIN:
            qmax = 0.5 * max(sig.q1_range)
            why = (f"; the swing (about +-{qmax:.2g} rad) keeps |cos q1| near 1, so the columns |cos q1| q3 and q3 "
                   "hardly differ: release the pendulum from a larger angle" if qmax < 0.6 else
                   "; the data move them together")
            out.append(
                f"sigma_a1 and sigma_v1 are not separable (correlation of the estimates {r:+.4f}): only a "
                f"combination of the two is determined, each alone carries the large standard error shown{why}")
    if not res.success:
        out.append(f"rank-deficient regressor for set-up {spec.name!r}: the data do not excite all parameters; "
                   "the values reported for them are not estimates")
    return out


def identify_dead_zone(curve: Any, *, min_fraction: float = 0.2) -> IdentificationResult:
    """Dead-zone thresholds ``v+`` and ``v-`` of (5) from a static curve (figure 2a).

    See :func:`iwp.ident.setups.dead_zone.fit_static_curve` for the method;
    the result carries ``v_dz_pos``, ``v_dz_neg`` [in] with standard errors.

    Parameters
    ----------
    curve : StaticCurve or list of StaticCurve
        Input ``v`` [in] (or ``u`` for a compensated curve) and steady disk velocity ``q4`` [rad/s]; several
        curves are pooled.
    min_fraction : float, default 0.2
        Lower end of the straight part of each side, as a fraction of that side's largest ``|q4|``.

    Returns
    -------
    IdentificationResult
        Set-up ``"dead-zone"``, parameters ``v_dz_pos`` and ``v_dz_neg`` [in].

    Examples
    --------
    Figure 2(a) on the virtual rig, every 5 input units (the paper reads ``v+ ~ v- ~ 31``):

    >>> from iwp.ident import identify_dead_zone
    >>> from iwp.rig import run_experiment
    >>> curve = run_experiment("static-curve", step=5.0, duration=2.0)
    >>> res = identify_dead_zone(curve)
    >>> round(res.value("v_dz_pos"), 2), round(res.value("v_dz_neg"), 2)
    (30.97, 30.99)
    """
    fit = fit_static_curve(curve, min_fraction=min_fraction)
    return IdentificationResult(
        setup="dead-zone", samples=fit.samples, parameters=fit.parameters, names=("v_dz_pos", "v_dz_neg"),
        covariance=fit.covariance, correlation=fit.correlation, condition_number=fit.condition_number,
        residual_rms=fit.residual_rms, lsq=None, rho=None, warnings=fit.warnings, success=True, message=fit.message,
        differentiator={}, sources=fit.sources, details=fit.details,
    )


# ---------------------------------------------------------------------------
# files
# ---------------------------------------------------------------------------
def load_pendulum(path: str | os.PathLike) -> Any:
    """Read the pendulum parameters for the two-step set-up from a file.

    Accepts the JSON printed by ``iwp identify --setup free --json`` (an
    :class:`IdentificationResult` with uncertainties), the parameter file
    written by ``--out`` (whose ``"identification"`` entry carries the same,
    so uncertainties are kept), or any lumped parameter file / built-in name
    (values only).

    Parameters
    ----------
    path : str or path-like
        A JSON file as above, or the name of a built-in parameter set (``"table1"``).

    Returns
    -------
    IdentificationResult or LumpedParameters
        The identification result (with uncertainties), or lumped parameters (values only).

    Raises
    ------
    InputError
        A file that does not read, an identification that did not succeed or has no ``p1``, or ``p1`` not
        positive and finite.

    Examples
    --------
    The result of set-up ``"free"`` saved as ``iwp identify --setup free --json`` prints it, read back with its
    uncertainties:

    >>> from pathlib import Path
    >>> from iwp import identify
    >>> from iwp.ident import load_pendulum
    >>> from iwp.rig import run_experiment
    >>> res = identify(run_experiment("free-pendulum", duration=10.0), "free")
    >>> _ = Path("free.json").write_text(res.to_json())
    >>> pendulum = load_pendulum("free.json")
    >>> round(pendulum.value("p1"), 3), round(pendulum.stderr("p1"), 5)
    (26.361, 0.0009)
    >>> load_pendulum("table1").p1  # a built-in set: values only
    26.095
    """
    p = Path(path)
    obj: Any = None
    if p.is_file():
        doc = read_json(p, argument="pendulum")
        if isinstance(doc, Mapping):
            if "setup" in doc and "parameters" in doc:
                obj = IdentificationResult.from_dict(doc, where=str(p))
            else:
                ident = doc.get("identification")
                if isinstance(ident, Mapping) and "setup" in ident:
                    obj = IdentificationResult.from_dict(ident, where=f"{p}: identification")
    if obj is None:
        obj = load_params(str(path), physical_check=True)
        if hasattr(obj, "to_lumped"):
            obj = obj.to_lumped()
        p1 = obj.p1
    else:
        if not obj.success:
            raise InputError(f"pendulum {p}: the identification in this file did not succeed ({obj.message}); "
                             "it cannot serve as the pendulum", argument="pendulum")
        p1 = obj.parameters["p1"].value if "p1" in obj.parameters else None
        if p1 is None:
            raise InputError(f"pendulum {p}: the {obj.setup!r} result has no p1; give the result of --setup free",
                             argument="pendulum")
    if not (math.isfinite(p1) and p1 > 0.0):
        raise InputError(f"pendulum {p}: p1 = {p1!r} is not a pendulum's (p1 = g (m1 c + m2 l) / I1 > 0)",
                         argument="pendulum")
    return obj

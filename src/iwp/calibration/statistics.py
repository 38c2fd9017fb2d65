"""The paper's numbers from the logs of its experiments: its procedures, applied as ``iwp identify`` applies them.

Every number the paper publishes (:mod:`iwp.calibration.targets`) is a *statistic*
of the logs of its experiments: a least-squares set-up of section 5 applied
to one or two logs, a line through a static curve, the amplitude of an
oscillation. :func:`paper_numbers` runs the experiments on a virtual rig and
applies those procedures exactly as the command line does with its default
settings (``iwp rig run NAME``, then ``iwp identify FILE --setup SETUP``:
:func:`iwp.ident.identification.identify` with its defaults), so that a
calibration (:mod:`iwp.calibration.calibrate`) and a reader checking the twin by
hand get the same numbers. :data:`STATISTICS` names them; the reproduction
(:mod:`iwp.reproduce`) computes the same numbers with the same functions
(:func:`compensated_line`, :func:`oscillation_amplitude`,
:func:`least_squares_parameters`, :func:`closed_loop_model`).

=====================================  ===========================================================
statistic                              procedure (paper)
=====================================  ===========================================================
``dead-zone.v_dz_pos``, ``.v_dz_neg``  set-up ``dead-zone`` on ``static-curve`` (figure 2a)
``static-compensated.error_at_u15``    line fitted for ``|u| > 20`` on ``static-curve-compensated``,
                                       minus the curve at ``u = 15`` [rad/s] (figure 2b)
``motor-disk.*``                       set-up ``motor-disk`` (theta^a) on ``motor-disk-chirp``
``motor-disk-coulomb.*``               set-up ``motor-disk-coulomb`` (theta^b) on ``motor-disk-chirp``
``free.*``                             set-up ``free`` (theta^c) on ``free-pendulum``
``two-step.*``                         set-up ``two-step`` (theta^d) on ``full-chirp`` with the free result
``two-step.ratio_1``, ``.ratio_2``     ``p2(1+rho)/p2`` and ``p3(1+rho)/p3`` (the printed "rho_1", "rho_2",
                                       ERRATA item 2)
``full.*``                             set-up ``full`` (10)-(12) on ``full-chirp`` (eq. (16))
``full.friction_ratio``                geometric mean of ``|sigma(16) / sigma(theta^c)|`` over
                                       ``sigma_a1, sigma_v1, sigma_b1``
``closed-loop.amplitude_rig``          largest ``|q1|`` of the ``closed-loop`` log over its last 20 s
``closed-loop.amplitude_model``        the same for model (9) with the least-squares parameters
                                       (free + two-step), in closed loop with the sampled Hopf law
``closed-loop.model_over_rig``         their ratio (figure 10: "a very close matching")
``full-chirp.fit_q1``                  fit [%] of model (9) with the least-squares parameters to the
                                       ``full-chirp`` log's ``q1`` (figure 9a: "very close")
``full-13.*``                          set-up ``full`` solved as the paper's (13) is printed, the plain
                                       sum over both rows (``IdentifyOptions(weights="none")``), not
                                       the CLI's default; ``full-13.friction_ratio`` likewise
=====================================  ===========================================================

``SETUP.a+b`` is the sum of two parameters of one set-up (e.g.
``free.sigma_a1+sigma_v1``, the combination the free decay determines).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Mapping

import numpy as np

from ..data import ExperimentData, StaticCurve
from ..errors import InputError
from ..ident.identification import AS_PRINTED, identify
from ..ident.result import IdentificationResult
from ..ident.setups import SETUPS
from ..ident.validation import UninformativeValidation, validate
from ..models.parameters import LumpedParameters, table1
from ..rig.truth import RigTruth
from ..rig.virtual import VirtualRig
from ..sim.inputs import HopfController

__all__ = [
    "PaperNumbers",
    "paper_numbers",
    "STATISTICS",
    "IDENTIFICATIONS",
    "check_statistic",
    "PAPER_EXPERIMENTS",
    "compensated_line",
    "oscillation_amplitude",
    "amplitude_window",
    "least_squares_parameters",
    "closed_loop_model",
    "friction_ratio",
]

#: The experiments whose logs the paper's numbers come from.
PAPER_EXPERIMENTS = ("static-curve", "static-curve-compensated", "motor-disk-chirp", "free-pendulum", "full-chirp",
                     "closed-loop")
#: The least-squares set-ups of section 5, with the experiment each one is applied to.
SETUP_EXPERIMENT = {"dead-zone": "static-curve", "motor-disk": "motor-disk-chirp",
                    "motor-disk-coulomb": "motor-disk-chirp", "free": "free-pendulum", "full": "full-chirp",
                    "two-step": "full-chirp"}
#: The friction terms compared between eq. (16) and the free pendulum.
FRICTION_TERMS = ("sigma_a1", "sigma_v1", "sigma_b1")
#: Figure 2(b): the line is fitted where ``|u|`` exceeds this [input units] ...
COMPENSATED_LINEAR_FROM = 20.0
#: ... and read at this input [input units] ("an error of 25 rad/s at u = 15 units").
COMPENSATED_READ_AT = 15.0


# --------------------------------------------------------------------------
# the procedures shared with the reproduction
# --------------------------------------------------------------------------
def compensated_line(curve: StaticCurve) -> dict[str, Any]:
    """Figure 2(b): the straight line through the compensated static curve and its error at ``u = 15``.

    A line ``q4 = a u + b`` is fitted by least squares to the points with
    ``|u| > 20`` (where the paper calls the compensated relation linear);
    ``error_at_u15`` is the line minus the curve at ``u = 15`` [rad/s]
    (the paper: 25 rad/s), the curve interpolated linearly between its
    points; ``linearity`` is the largest residual of the line over
    ``|u| > 20`` relative to the largest ``|q4|`` there.

    Parameters
    ----------
    curve : StaticCurve
        Static curve of the compensated input ``u`` [input units] to the wheel velocity ``q4`` [rad/s].

    Returns
    -------
    dict
        ``"line"``: ``[a, b]`` of ``q4 = a u + b`` [rad/(s input unit), rad/s]; ``"linearity"``: relative
        largest residual [-]; ``"error_at_u15"``: line minus curve at ``u = 15`` [rad/s].

    Raises
    ------
    InputError
        ``curve`` is not a :class:`StaticCurve`, or has fewer than 3 points with ``|u| > 20``.
    """
    if not isinstance(curve, StaticCurve):
        raise InputError(f"compensated_line needs a StaticCurve, got {type(curve).__name__}")
    u, w = np.asarray(curve.input, dtype=float), np.asarray(curve.q4, dtype=float)
    m = np.abs(u) > COMPENSATED_LINEAR_FROM
    if m.sum() < 3:
        raise InputError(f"{curve.source}: fewer than 3 points with |u| > {COMPENSATED_LINEAR_FROM:g}")
    a, b = np.polyfit(u[m], w[m], 1)
    resid = w[m] - (a * u[m] + b)
    order = np.argsort(u)
    at = COMPENSATED_READ_AT
    err = float(a * at + b - np.interp(at, u[order], w[order]))
    return {"line": [float(a), float(b)], "linearity": float(np.max(np.abs(resid)) / np.max(np.abs(w[m]))),
            "error_at_u15": err}


def amplitude_window(duration: float) -> float:
    """The window over which an oscillation's amplitude is read: the last 20 s, or a third of a shorter log [s].

    Parameters
    ----------
    duration : float
        Length of the log [s].

    Returns
    -------
    float
        20 for logs of at least 40 s, else ``duration / 3`` [s].
    """
    return 20.0 if duration >= 40.0 else duration / 3.0


def oscillation_amplitude(t, q1, window: float | None = None) -> float:
    """Largest ``|q1|`` over the last ``window`` seconds [rad] (default :func:`amplitude_window`).

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times [s], increasing.
    q1 : array_like, shape (n,)
        Pendulum angle [rad].
    window : float, optional
        Length of the end of the log read [s]; None (default): ``amplitude_window(t[-1] - t[0])``.

    Returns
    -------
    float
        The amplitude [rad].
    """
    t = np.asarray(t, dtype=float)
    if window is None:
        window = amplitude_window(float(t[-1] - t[0]))
    sel = t >= t[-1] - window
    return float(np.max(np.abs(np.asarray(q1, dtype=float)[sel])))


def least_squares_parameters(free: IdentificationResult, two_step: IdentificationResult,
                             dead_zone: IdentificationResult | None = None) -> LumpedParameters:
    """The paper's final model (its Table 1): the free-pendulum result, then the two-step one.

    ``p1`` and the pendulum frictions from set-up ``free``, ``p2, p3, rho``
    from set-up ``two-step``, the dead zone from set-up ``dead-zone`` (else
    Table 1's 31), no Coulomb friction (the paper's model (9)).

    Parameters
    ----------
    free : IdentificationResult
        Result of set-up ``free`` (``p1`` and the pendulum frictions).
    two_step : IdentificationResult
        Result of set-up ``two-step`` (``p2``, ``p3``, ``rho``).
    dead_zone : IdentificationResult, optional
        Result of set-up ``dead-zone`` (``v_dz_pos``, ``v_dz_neg``); None (default): Table 1's thresholds.

    Returns
    -------
    LumpedParameters
        The combined parameters, ``sigma_c2 = 0``.
    """
    base = free.to_params(table1())
    if dead_zone is not None:
        base = base.replace(v_dz_pos=dead_zone.value("v_dz_pos"), v_dz_neg=dead_zone.value("v_dz_neg"))
    return two_step.to_params(base=base).replace(sigma_c2=0.0)


def closed_loop_model(log: ExperimentData, params: LumpedParameters, *, k1: float | None = None,
                      k2: float | None = None) -> dict[str, Any]:
    """Figure 10: model (9) with ``params`` in closed loop with the Hopf law, against the rig's log.

    The law ``u = k1 q3 + k2 q3^3`` is sampled every ``Ts`` and held, as on
    the rig; the gains are the log's (metadata ``k1``, ``k2``) unless given;
    the simulation starts from the log's initial state. Returns the times,
    the measured and simulated ``q1``, the fit [%], both amplitudes
    (:func:`oscillation_amplitude`) and the window.

    Parameters
    ----------
    log : ExperimentData
        The rig's closed-loop log.
    params : LumpedParameters
        Parameters of model (9).
    k1 : float, optional
        Gain of ``q3`` [input units s/rad]; None (default): the log's metadata ``k1`` (else -10).
    k2 : float, optional
        Gain of ``q3^3`` [input units s^3/rad^3]; None (default): the log's metadata ``k2`` (else 0.1).

    Returns
    -------
    dict
        ``"t"`` [s], ``"measured"`` and ``"simulated"`` ``q1`` [rad], ``"fit"`` [%], ``"k1"``, ``"k2"``,
        ``"window"`` [s], ``"amplitude_rig"`` and ``"amplitude_model"`` [rad].
    """
    k1 = float(log.metadata.get("k1", -10.0)) if k1 is None else float(k1)
    k2 = float(log.metadata.get("k2", 0.1)) if k2 is None else float(k2)
    with warnings.catch_warnings():  # the statistic is the fit, whatever it is
        warnings.simplefilter("ignore", UninformativeValidation)
        r = validate(log, params, model="compensated", signals=("q1",), controller=HopfController(k1, k2, Ts=log.Ts))
    t = np.asarray(r.t, dtype=float)
    meas = np.asarray(r.measured["q1"], dtype=float)
    sim = np.asarray(r.simulated["q1"], dtype=float)
    window = amplitude_window(float(log.t[-1] - log.t[0]))
    return {"t": t, "measured": meas, "simulated": sim, "fit": float(r.fit["q1"]), "k1": k1, "k2": k2,
            "window": window, "amplitude_rig": oscillation_amplitude(log.t, log.q1, window),
            "amplitude_model": oscillation_amplitude(t, sim, window)}


def friction_ratio(full: IdentificationResult | Mapping[str, float],
                   free: IdentificationResult | Mapping[str, float]) -> float:
    """Geometric mean of ``|sigma(16) / sigma(theta^c)|`` over the pendulum frictions (section 5.2).

    The paper's numbers give 930 (``sigma~_a1``), 76 (``sigma~_v1``) and 123
    (``sigma~_b1``): "significantly far". ``inf`` if a free-pendulum value is 0.

    Parameters
    ----------
    full : IdentificationResult or mapping of str to float
        Result of the full identification (16), or its values by name.
    free : IdentificationResult or mapping of str to float
        Result of set-up ``free`` (``theta^c``), or its values by name.

    Returns
    -------
    float
        The ratio [-]; ``inf`` if a free-pendulum value is 0, ``0`` if only a full-model value is 0.
    """
    def value(source, k: str) -> float:
        return source.value(k) if isinstance(source, IdentificationResult) else float(source[k])

    logs = []
    for k in FRICTION_TERMS:
        a, b = value(full, k), value(free, k)
        if b == 0.0 or a == 0.0:
            return math.inf if b == 0.0 else 0.0
        logs.append(math.log(abs(a / b)))
    return float(math.exp(sum(logs) / len(logs)))


# --------------------------------------------------------------------------
# the numbers of one twin
# --------------------------------------------------------------------------
@dataclass(eq=False)
class PaperNumbers:
    """What the paper's procedures return on one set of logs.

    Attributes
    ----------
    identifications : dict of str to IdentificationResult
        By set-up: ``dead-zone``, ``motor-disk``, ``motor-disk-coulomb``,
        ``free``, ``full``, ``two-step``; ``full-13``: set-up ``full`` as
        the paper's (13) is printed (unweighted).
    compensated : dict
        :func:`compensated_line` of ``static-curve-compensated``.
    closed_loop : dict
        :func:`closed_loop_model` of ``closed-loop`` with :attr:`least_squares`.
    least_squares : LumpedParameters
        The paper's final model (:func:`least_squares_parameters`).
    logs : dict
        The logs by experiment name.
    """

    identifications: dict[str, IdentificationResult]
    compensated: dict[str, Any]
    closed_loop: dict[str, Any]
    least_squares: LumpedParameters
    logs: dict[str, Any] = field(default_factory=dict)
    cache: dict[str, float] = field(default_factory=dict)

    def value(self, statistic: str) -> float:
        """The value of one statistic (a name of :data:`STATISTICS` or ``SETUP.PARAMETER[+PARAMETER]``)."""
        return statistic_value(self, statistic)

    def values(self, statistics) -> dict[str, float]:
        """Several statistics by name."""
        return {s: self.value(s) for s in statistics}


#: The identifications of :class:`PaperNumbers` by name, and the set-up of :mod:`iwp.ident.setups` each runs.
IDENTIFICATIONS = {"dead-zone": "dead-zone", "motor-disk": "motor-disk", "motor-disk-coulomb": "motor-disk-coulomb",
                   "free": "free", "full": "full", "two-step": "two-step", "full-13": "full"}


def check_statistic(statistic: Any, name: str = "statistic") -> str:
    """``statistic`` if it names a statistic of :func:`statistic_value`, before anything runs; else InputError.

    ``name`` is what the caller calls it (a file's field), for the message.
    """
    if not isinstance(statistic, str):
        raise InputError(f"{name}: a statistic is named by a string, got {statistic!r}")
    if statistic in STATISTICS:
        return statistic
    setup, _, names = statistic.partition(".")
    if not names:
        raise InputError(f"{name}: unknown statistic {statistic!r}; use SETUP.PARAMETER[+PARAMETER] or one of "
                         f"{', '.join(STATISTICS)}")
    if setup not in IDENTIFICATIONS:
        raise InputError(f"{name}: unknown statistic {statistic!r}: no set-up {setup!r} "
                         f"(set-ups: {', '.join(IDENTIFICATIONS)})")
    known = SETUPS[IDENTIFICATIONS[setup]].parameters
    for n in names.split("+"):
        if n not in known:
            raise InputError(f"{name}: unknown statistic {statistic!r}: set-up {setup!r} has no parameter {n!r} "
                             f"(it has {', '.join(known)})")
    return statistic


def _parameter_statistic(numbers: PaperNumbers, setup: str, names: str) -> float:
    res = numbers.identifications[setup]
    return float(sum(res.value(n) for n in names.split("+")))


def _ratio(numbers: PaperNumbers, num: str, den: str) -> float:
    res = numbers.identifications["two-step"]
    return res.value(num) / res.value(den)


#: The statistics that are not a set-up's parameter (or a sum of them), by name.
STATISTICS: dict[str, Callable[[PaperNumbers], float]] = {
    "static-compensated.error_at_u15": lambda n: float(n.compensated["error_at_u15"]),
    "static-compensated.linearity": lambda n: float(n.compensated["linearity"]),
    "two-step.ratio_1": lambda n: _ratio(n, "p2_1rho", "p2"),
    "two-step.ratio_2": lambda n: _ratio(n, "p3_1rho", "p3"),
    "full.friction_ratio": lambda n: friction_ratio(n.identifications["full"], n.identifications["free"]),
    "closed-loop.amplitude_rig": lambda n: float(n.closed_loop["amplitude_rig"]),
    "closed-loop.amplitude_model": lambda n: float(n.closed_loop["amplitude_model"]),
    "closed-loop.model_over_rig": lambda n: float(n.closed_loop["amplitude_model"] / n.closed_loop["amplitude_rig"]),
    "full-13.friction_ratio": lambda n: friction_ratio(n.identifications["full-13"], n.identifications["free"]),
    "full-chirp.fit_q1": lambda n: chirp_fit(n),
}


def chirp_fit(numbers: PaperNumbers) -> float:
    """Figure 9(a): fit [%] of model (9) with the least-squares parameters to the full chirp's ``q1``."""
    if "full-chirp.fit_q1" not in numbers.cache:
        with warnings.catch_warnings():  # the statistic is the fit, whatever it is
            warnings.simplefilter("ignore", UninformativeValidation)
            r = validate(numbers.logs["full-chirp"], numbers.least_squares, model="compensated", signals=("q1",))
        numbers.cache["full-chirp.fit_q1"] = float(r.fit["q1"])
    return numbers.cache["full-chirp.fit_q1"]


def statistic_value(numbers: PaperNumbers, statistic: str) -> float:
    """The value of ``statistic`` (see the module docstring) in ``numbers``."""
    check_statistic(statistic)
    if statistic in STATISTICS:
        return STATISTICS[statistic](numbers)
    setup, _, names = statistic.partition(".")
    return _parameter_statistic(numbers, setup, names)


def paper_numbers(truth: RigTruth | None = None, *, seed: int = 0,
                  overrides: Mapping[str, Mapping[str, Any]] | None = None,
                  logs: Mapping[str, Any] | None = None) -> PaperNumbers:
    """Run the paper's experiments on the virtual rig and apply its procedures with the CLI's defaults.

    Parameters
    ----------
    truth : RigTruth, optional
        The twin (default :func:`iwp.rig.default_truth`).
    seed : int
        Seed of the rig's measurement noise; the same seed gives the same
        noise sequence for every truth (common random numbers).
    overrides : dict, optional
        Options of :meth:`VirtualRig.run` per experiment name, e.g. shorter
        runs ``{"full-chirp": {"duration": 90.0}}`` for tests; default the
        paper's settings, as ``iwp rig run NAME``.
    logs : dict, optional
        Logs already run, by experiment name (those given are not run again).

    Returns
    -------
    PaperNumbers

    Examples
    --------
    The paper's procedures on shortened experiments of the default twin (the paper: ``v+ ~ 31``,
    ``p1 = 26.095``, ``rho = 247.24``, ``p3(1+rho) = 7.759``):

    >>> from iwp.calibration import paper_numbers
    >>> short = {"static-curve": {"step": 20.0, "duration": 2.0},
    ...          "static-curve-compensated": {"step": 20.0, "duration": 2.0},
    ...          "motor-disk-chirp": {"duration": 5.0}, "full-chirp": {"duration": 5.0},
    ...          "free-pendulum": {"duration": 3.0}, "closed-loop": {"duration": 3.0}}
    >>> numbers = paper_numbers(overrides=short)
    >>> stats = numbers.values(["dead-zone.v_dz_pos", "free.p1", "two-step.rho", "motor-disk.p3_1rho"])
    >>> {k: round(v, 2) for k, v in stats.items()}
    {'dead-zone.v_dz_pos': 30.96, 'free.p1': 26.36, 'two-step.rho': 248.5, 'motor-disk.p3_1rho': 7.76}
    >>> sorted(numbers.logs)[:3]  # the experiments it ran
    ['closed-loop', 'free-pendulum', 'full-chirp']
    """
    overrides = dict(overrides or {})
    unknown = sorted(set(overrides) - set(PAPER_EXPERIMENTS))
    if unknown:
        raise InputError(f"overrides name {unknown[0]!r}, which is not one of {', '.join(PAPER_EXPERIMENTS)}")
    rig = VirtualRig(truth, seed=seed)
    runs = dict(logs or {})
    for name in PAPER_EXPERIMENTS:
        if name not in runs:
            runs[name] = rig.run(name, **dict(overrides.get(name, {})))
    ident = {
        "dead-zone": identify(runs["static-curve"], "dead-zone"),
        "motor-disk": identify(runs["motor-disk-chirp"], "motor-disk", options=AS_PRINTED),
        "motor-disk-coulomb": identify(runs["motor-disk-chirp"], "motor-disk-coulomb", options=AS_PRINTED),
        "free": identify(runs["free-pendulum"], "free", options=AS_PRINTED),
        "full": identify(runs["full-chirp"], "full", options=AS_PRINTED),
    }
    ident["two-step"] = identify(runs["full-chirp"], "two-step", pendulum=ident["free"], options=AS_PRINTED)
    ident["full-13"] = identify(runs["full-chirp"], "full", options=replace(AS_PRINTED, weights="none"))
    ls = least_squares_parameters(ident["free"], ident["two-step"], ident["dead-zone"])
    loop = closed_loop_model(runs["closed-loop"], ls)
    return PaperNumbers(identifications=ident, compensated=compensated_line(runs["static-curve-compensated"]),
                        closed_loop=loop, least_squares=ls, logs=runs)

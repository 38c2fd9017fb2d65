"""The rubber belt (15) identified by simulation error from the disk velocity alone.

The paper models the belt between motor and disk by eq. (15) with the
hysteresis of figure 5 and sets its parameters by hand: "since the angular
position of the motor shaft of the experimental system is not measured, the
parameters of this model cannot be obtained by the proposed identification
procedure" (section 5.1). The least squares (13) indeed need every state of
the model, but a simulation-error fit needs only an output: :func:`refine_belt`
simulates the belt model (``"belt"``: pendulum locked, motor inertia
neglected, the play of half-width ``d``) with the logged input ``u`` replayed
and fits its disk velocity ``q4`` to the measured one (differentiated from
the encoder's ``q2``) over one or more logs, typically the sinusoids
``u = A sin 5t`` of figures 3 and 4.

The fitted parameters are those of :class:`~iwp.models.parameters.BeltParameters`
(``k_over_I2``, ``d``, ``b2_over_I2``, ``k_over_gamma``,
``kTbeta_over_Rgamma``, ``gain_neg``; ``N`` is measured, 13.5) and the disk's
Coulomb friction ``sigma_c2``; all positive, fitted on a log scale within
their :attr:`~iwp.models.parameters.ParameterInfo.fit_range`. The play makes
the model non-smooth in ``d`` (the response depends on ``d`` through the
times the play closes, not through the right-hand side between them), so the
Jacobian is taken by forward differences of whole simulations rather than by
forward sensitivities. It is the same :class:`~iwp.ident.problem.FitProblem`
as :func:`iwp.ident.refinement.refine`, with that Jacobian; the result is a
:class:`~iwp.ident.refinement.RefineResult` with :attr:`belt` set.
"""

from __future__ import annotations

import math
import warnings as _warnings
from dataclasses import replace
from typing import Mapping, Sequence

import numpy as np

from ..data import ExperimentData
from ..errors import InputError
from ..models.plant import MODELS, Plant, model_info
from ..models.terms import BELT_FREE
from ..sim.sensitivity import difference_step
from .output_error import Experiment, OutputError, solve_output_error
from .problem import SolverOptions
from .refinement import BELT_OPTIONS, RefineResult, as_experiments, refine_report

__all__ = ["refine_belt", "BELT_FREE", "BELT_PARAMETERS", "BELT_OPTIONS"]

#: The parameters :func:`refine_belt` can fit: the belt's, and the disk's Coulomb friction (the model's own list).
BELT_PARAMETERS = MODELS["belt"].parameters


def _check_logs(exps: list[Experiment]) -> None:
    for i, e in enumerate(exps):
        d: ExperimentData = e.data
        if d.input_name != "u":
            raise InputError(f"experiment {i} ({d.source}) must log the compensated input u (the belt model (15) is "
                             f"driven by u), it logs {d.input_name!r}")
        if d.q2 is None:
            raise InputError(f"experiment {i} ({d.source}) has no disk angle q2")
        if np.ptp(d.q1) > 0.02:
            raise InputError(f"experiment {i} ({d.source}): the pendulum moves (q1 range {np.ptp(d.q1):.3g} rad); "
                             "the belt model (15) is identified with the pendulum locked (section 5.1)")


def refine_belt(
    experiments,
    start: Plant,
    *,
    free: Sequence[str] = BELT_FREE,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    windows=None,
    options: SolverOptions = BELT_OPTIONS,
    warn: bool = True,
) -> RefineResult:
    """Fit the belt (15) to the disk velocity of locked, compensated logs by simulation error.

    Parameters
    ----------
    experiments : ExperimentData or sequence of ExperimentData
        Logs with the pendulum locked and the compensated input ``u``
        (``sine-60``, ``sine-40``, ``sine-20``, ``motor-disk-chirp``).
    start : Plant
        ``Plant(lumped, model="belt", belt=BeltParameters(...))``: the lumped
        parameters (``rho`` and ``sigma_c2`` enter the belt model) and the
        belt's starting point, e.g. the paper's ``k/I2 = 60``, ``d = 2`` with
        the rigid limit of the identified motor-disk model
        (:meth:`~iwp.models.parameters.BeltParameters.from_rigid`).
    free : sequence of str
        Among :data:`BELT_PARAMETERS`; default :data:`BELT_FREE`.
    bounds : dict, optional
        ``{name: (low, high)}`` (both > 0); default the parameters' fit ranges.
    windows : (t_start, t_end) or list of them, optional
        Time window per experiment [s].
    options : SolverOptions
        Default :data:`BELT_OPTIONS`; ``max_nfev`` defaults to 50 x (number of free parameters + 1).
    warn : bool
        Also issue the warnings with :func:`warnings.warn`.

    Returns
    -------
    RefineResult
        ``belt`` holds the fitted belt; ``parameters`` the free parameters'
        estimates with standard errors (from the Jacobian at the optimum,
        a lower bound: simulation residuals are correlated in time); ``fit``
        and ``fit_start`` the fit of ``q4`` per log [%].

    See Also
    --------
    refine : The same for the rigid models.

    Examples
    --------
    The belt's stiffness, damping and gain on 4 s of figures 3(a) and 4 (``sine-60``, ``sine-20``), from the
    paper's ``k/I2 = 60``, ``d = 2`` around Table 1's rigid disk:

    >>> from iwp import Plant, refine_belt, table1
    >>> from iwp.models import BeltParameters
    >>> from iwp.rig import run_experiment
    >>> p = table1()
    >>> belt = BeltParameters.from_rigid(p.p2 * (1 + p.rho), p.p3 * (1 + p.rho), k_over_I2=60.0, d=2.0)
    >>> logs = [run_experiment("sine-60", duration=4.0), run_experiment("sine-20", duration=4.0)]
    >>> res = refine_belt(logs, Plant(p, model="belt", belt=belt), free=["k_over_I2", "d", "kTbeta_over_Rgamma"],
    ...                   windows=(1.0, None), warn=False)
    >>> [round(f["q4"]) for f in res.fit_start], [round(f["q4"]) for f in res.fit]  # fit of q4 [%]
    ([79, 60], [94, 85])
    >>> round(res.belt.k_over_I2), round(res.belt.kTbeta_over_Rgamma, 1)
    (94, 32.6)
    """
    if not isinstance(start, Plant) or start.belt is None or not model_info(start.model).pendulum_locked:
        raise InputError("the belt model (15) is fitted from Plant(lumped, model='belt', belt=BeltParameters(...))")
    free = (free,) if isinstance(free, str) else tuple(free)
    if not free:
        raise InputError("free is empty: give at least one belt parameter")
    for n in free:
        if n not in BELT_PARAMETERS:
            raise InputError(f"unknown belt parameter {n!r}; choose among {', '.join(BELT_PARAMETERS)}")
    for n, b in (bounds or {}).items():
        try:
            a, c = float(b[0]), float(b[1])
        except (TypeError, ValueError, IndexError):
            raise InputError(f"bounds[{n!r}] must be a pair (low, high), got {b!r}") from None
        if not 0 < a < c or not math.isfinite(c):
            raise InputError(f"bounds[{n!r}] = ({a}, {c}): need 0 < low < high")
    exps = as_experiments(experiments, windows=windows, estimate_x0=True, kind="clamped")
    _check_logs(exps)
    model = OutputError(start, exps, ("q4",), rtol=options.rtol, atol=options.atol,
                        differences=difference_step(options.rtol))
    if options.max_nfev is None:
        options = replace(options, max_nfev=50 * (len(free) + 1))
    res = refine_report(model, solve_output_error(model, model.parameters(free, bounds, log=True), options=options),
                        start)
    if warn:
        for m in res.warnings:
            _warnings.warn(m, stacklevel=2)
    return res

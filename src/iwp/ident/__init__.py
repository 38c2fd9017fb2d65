"""Identification: from logs to parameters with uncertainty, refined, validated.

========================  ==========================================================
module                    what
========================  ==========================================================
:mod:`.identification`    the least squares (13) of every set-up of section 5, with uncertainty
:mod:`.setups`            the set-ups (10)-(12), theta^a..theta^d, the dead zone: one file each
:mod:`.regressors`        the regressor (11) of the rows of (9), written once
:mod:`.signals`           windowed, differentiated, filtered signals of the logs
:mod:`.noise`             covariance from the encoder noise through the differentiator
:mod:`.differentiate`     velocities and accelerations of quantised positions
:mod:`.input_hold`        how a log's input was held between samples, read from the data
:mod:`.misfit`            what a misfit of the residuals follows: the terms a rig may add
:mod:`.lsq`               stable least squares with honest uncertainty
:mod:`.fit_parameters`    a fit's parameters: value, bounds, free/fixed, expression, stderr
:mod:`.problem`           one fit problem: prepare, solve, report (:class:`FitProblem`)
:mod:`.output_error`      the simulation error of measured outputs (the residual model of fits)
:mod:`.covariance`        the covariance of a fit from its Jacobian; what the data cannot tell
:mod:`.jacobian`          the one forward-difference Jacobian
:mod:`.refinement`        refinement by simulation error (output error, forward sensitivities)
:mod:`.belt_fit`          the belt (15) from the disk velocity
:mod:`.validation`        simulation against a log: fit, error, restart (figures 3-10)
:mod:`.logfit`            ``iwp fit``: a rig's logs to a validated model (:func:`fit_logs`), in the steps:
:mod:`.fit_plan`          1. the logs read, sorted by set-up and checked; the fit's options
:mod:`.fit_start`         2. the least-squares start; wrong signs and time units refused
:mod:`.fit_ladder`        3. the fit: one structure or the ladder of them, the unidentified held
:mod:`.structure`         the ladder's structures and the choice among them
:mod:`.drives`            how a drive model (the belt) is fitted: its start from rigid fits, its bounds
:mod:`.fit_report`        4. the result and its report
:mod:`.metrics`           the fit in percent (NRMSE)
:mod:`.result`            :class:`IdentificationResult`
========================  ==========================================================
"""

from __future__ import annotations

from .belt_fit import refine_belt
from .differentiate import Differentiator
from .fit_parameters import Parameter, Parameters
from .identification import IdentifyOptions, default_differentiator, identify, identify_dead_zone, load_pendulum
from .lsq import LeastSquaresOptions, LeastSquaresResult, solve_least_squares
from .metrics import fit_percent
from .output_error import EXPERIMENT_KINDS, Experiment, OutputError
from .problem import FitProblem, FitResult, Loss, SolverOptions
from .refinement import RefineResult, as_experiments, fit_plant, refine, refine_identification
from .result import IdentificationResult
from .setups import PARAMETER_NAMES, PARAMETER_UNITS, SETUPS, Setup, get_setup
from .validation import (
    READS_V_AS_U,
    UninformativeValidation,
    ValidationOptions,
    ValidationResult,
    auto_model,
    held_out_q1_offset,
    model_input,
    validate,
    validation_plant,
)

__all__ = [
    "Differentiator",
    "EXPERIMENT_KINDS",
    "Experiment",
    "FitProblem",
    "FitResult",
    "IdentificationResult",
    "IdentifyOptions",
    "LeastSquaresOptions",
    "LeastSquaresResult",
    "Loss",
    "OutputError",
    "PARAMETER_NAMES",
    "PARAMETER_UNITS",
    "Parameter",
    "Parameters",
    "RefineResult",
    "SETUPS",
    "Setup",
    "SolverOptions",
    "UninformativeValidation",
    "ValidationOptions",
    "ValidationResult",
    "as_experiments",
    "auto_model",
    "held_out_q1_offset",
    "model_input",
    "READS_V_AS_U",
    "default_differentiator",
    "fit_percent",
    "fit_plant",
    "get_setup",
    "identify",
    "identify_dead_zone",
    "load_pendulum",
    "refine",
    "refine_belt",
    "refine_identification",
    "solve_least_squares",
    "validate",
    "validation_plant",
]

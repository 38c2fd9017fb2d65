"""Identification: from logs to parameters with uncertainty, refined, validated.

=====================  ============================================================
module                 what
=====================  ============================================================
:mod:`.identification`  the least squares (13) of every set-up of section 5, with uncertainty
:mod:`.setups`         the set-ups (10)-(12), theta^a..theta^d, the dead zone: one file each
:mod:`.signals`        windowed, differentiated, filtered signals of the logs
:mod:`.noise`          covariance from the encoder noise through the differentiator
:mod:`.differentiate`  velocities and accelerations of quantised positions
:mod:`.lsq`            stable least squares with honest uncertainty
:mod:`.refinement`     refinement by simulation error (output error, forward sensitivities)
:mod:`.validation`     simulation against a log: fit, error, restart (figures 3-10)
:mod:`.fit`            the fit in percent (NRMSE)
:mod:`.result`         :class:`IdentificationResult`
=====================  ============================================================
"""

from __future__ import annotations

from .differentiate import Differentiator
from .fit import fit_percent
from .identification import default_differentiator, identify, identify_dead_zone, load_pendulum
from .lsq import LeastSquaresResult, ParameterEstimate, solve_least_squares
from .refinement import RefineResult, refine, refine_identification
from .result import IdentificationResult
from .setups import PARAMETER_NAMES, PARAMETER_UNITS, SETUPS, Setup, get_setup
from .validation import ValidationResult, auto_model, validate

__all__ = [
    "Differentiator",
    "IdentificationResult",
    "LeastSquaresResult",
    "PARAMETER_NAMES",
    "PARAMETER_UNITS",
    "ParameterEstimate",
    "RefineResult",
    "SETUPS",
    "Setup",
    "ValidationResult",
    "auto_model",
    "default_differentiator",
    "fit_percent",
    "get_setup",
    "identify",
    "identify_dead_zone",
    "load_pendulum",
    "refine",
    "refine_identification",
    "solve_least_squares",
    "validate",
]

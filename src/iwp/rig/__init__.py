"""The virtual rig: a truth plant richer than the identified model, with the rig's sensors.

Users without a rig, and every test, need experiment data that behaves like
the paper's rig. :class:`VirtualRig` runs the paper's experiments (section 5)
on a *truth plant* and returns what the rig would log: quantised encoder
positions sampled every ``Ts``, and the input, as
:class:`iwp.data.ExperimentData` (time series) or :class:`iwp.data.StaticCurve`
(figure 2), in the data format that the rest of iwp reads.

======================  ===========================================================
module                  what
======================  ===========================================================
:mod:`.truth`           :class:`RigTruth`, :func:`default_truth`: the truth plant (model (6) with
                        the belt (15), asymmetric dead zone (5) with break-away, Coulomb friction)
                        and the sensors; its JSON format, the default values and why
:mod:`.experiments`     :data:`EXPERIMENTS`, :func:`list_experiments`: the paper's experiments by
                        name, their settings, how each runs (:class:`ExperimentKind`) and the
                        open-loop input laws
:mod:`.controller`      the rig's digital Hopf controller (section 5.3) on the encoder readings
:mod:`.virtual`         :class:`VirtualRig`, :func:`run_experiment`: the truth plant run through
                        the encoders, the sampling, the compensator (7)-(8) and the driver's
                        saturation
:mod:`.output`          :func:`check_output_path`, :func:`write_result`: writing the results
:mod:`.rigid_fit`       :func:`rigid_fit_error`: how well the rigid model (9) predicts the rig
                        (figures 3 and 4)
======================  ===========================================================

The encoder quantiser :func:`quantize` is :func:`iwp.models.encoder.quantize`.
The calibration of the twin (the paper's procedures applied to its logs, so
that they return the paper's numbers) is :mod:`iwp.calibration`, above both
the rig and the identification.
"""

from __future__ import annotations

from ..models.encoder import quantize
from .controller import EncoderHopfController
from .experiments import (
    EXPERIMENTS,
    PAPER_V_DZ,
    VELOCITY_FILTER_TAU,
    ExperimentKind,
    ExperimentSpec,
    InputLaw,
    RunKind,
    list_experiments,
)
from .output import check_output_path, write_result
from .rigid_fit import rigid_fit_error
from .truth import DEFAULT_TRUTH_FILE, RigTruth, default_truth, truth_record, uncalibrated_truth
from .virtual import RIG_ATOL, RIG_RTOL, STATIC_WINDOW, VirtualRig, run_experiment

__all__ = [
    "RigTruth",
    "ExperimentSpec",
    "ExperimentKind",
    "RunKind",
    "InputLaw",
    "VirtualRig",
    "EncoderHopfController",
    "default_truth",
    "list_experiments",
    "run_experiment",
    "quantize",
    "rigid_fit_error",
    "write_result",
    "check_output_path",
    "PAPER_V_DZ",
    "EXPERIMENTS",
    "RIG_RTOL",
    "RIG_ATOL",
    "VELOCITY_FILTER_TAU",
    "STATIC_WINDOW",
    "truth_record",
    "uncalibrated_truth",
    "DEFAULT_TRUTH_FILE",
]

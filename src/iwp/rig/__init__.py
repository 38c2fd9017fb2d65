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
:mod:`.run_settings`      :func:`~.run_settings.law_input`: the open-loop input laws (sine, chirp, PRBS, steps)
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

Names are loaded on first use (as :mod:`iwp`'s), so that listing the
experiments (``iwp rig list``) loads no simulation code.
"""

from __future__ import annotations

from ..exports import lazy_exports

#: public name -> the module that defines it
_EXPORTS: dict[str, str] = {
    "RigTruth": "iwp.rig.truth",
    "default_truth": "iwp.rig.truth",
    "truth_record": "iwp.rig.truth",
    "uncalibrated_truth": "iwp.rig.truth",
    "DEFAULT_TRUTH_FILE": "iwp.rig.truth",
    "ExperimentSpec": "iwp.rig.experiments",
    "ExperimentKind": "iwp.rig.experiments",
    "RunKind": "iwp.rig.experiments",
    "InputLaw": "iwp.rig.experiments",
    "list_experiments": "iwp.rig.experiments",
    "PAPER_V_DZ": "iwp.rig.experiments",
    "EXPERIMENTS": "iwp.rig.experiments",
    "VELOCITY_FILTER_TAU": "iwp.rig.experiments",
    "VirtualRig": "iwp.rig.virtual",
    "run_experiment": "iwp.rig.virtual",
    "RIG_RTOL": "iwp.rig.virtual",
    "RIG_ATOL": "iwp.rig.virtual",
    "STATIC_WINDOW": "iwp.rig.virtual",
    "EncoderHopfController": "iwp.rig.controller",
    "quantize": "iwp.models.encoder",
    "rigid_fit_error": "iwp.rig.rigid_fit",
    "write_result": "iwp.rig.output",
    "check_output_path": "iwp.rig.output",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

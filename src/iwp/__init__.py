"""iwp: the inertia wheel pendulum toolkit.

Simulate the rig or its virtual twin, identify its parameters from encoder
logs, compensate its motor dead zone, control it, and show how well the model
predicts reality. The equations follow "Modelling an inertia wheel pendulum
benchmark" (the paper); docstrings cite its equation numbers.

The public API is importable from here (``from iwp import simulate, table1,
identify``); the subpackages hold one concept each:

==================  ==========================================================
subpackage          what
==================  ==========================================================
:mod:`iwp.models`   the paper's equations, laws, parameters and the :class:`Plant`
:mod:`iwp.sim`      simulation: the one integration engine, inputs, sensitivities
:mod:`iwp.data`     experiment logs: CSV, MATLAB, Parquet, angle logs
:mod:`iwp.ident`    identification (section 5), refinement, validation
:mod:`iwp.control`  Hopf design and continuation, LQR balance, swing-up
:mod:`iwp.rig`      the virtual rig
:mod:`iwp.calibration`  the twin calibrated so that the paper's procedures return its numbers
:mod:`iwp.device`   the rig in the loop: protocol, rig interface, emulator, safe loop
:mod:`iwp.reproduce`  the paper end to end on the virtual rig
:mod:`iwp.report`   self-contained HTML reports
:mod:`iwp.plotting`  figures
:mod:`iwp.cli`      the ``iwp`` command (parsing only)
==================  ==========================================================

Names are loaded on first use, so that ``import iwp`` (and ``iwp --help``)
stays fast.
"""

from __future__ import annotations

from .exports import lazy_exports

__version__ = "0.1.0"

#: public name -> the module that defines it
_EXPORTS: dict[str, str] = {
    # models
    "Plant": "iwp.models", "MODELS": "iwp.models", "table1": "iwp.models", "LumpedParameters": "iwp.models",
    "PhysicalParameters": "iwp.models", "BeltParameters": "iwp.models", "StartupFriction": "iwp.models",
    "load_params": "iwp.models", "save_params": "iwp.models", "paper_belt": "iwp.models",
    "linearize": "iwp.models", "energy": "iwp.models", "feedforward": "iwp.models", "dead_zone": "iwp.models",
    # simulation
    "simulate": "iwp.sim", "simulate_batch": "iwp.sim", "simulate_scipy": "iwp.sim",
    "simulate_sensitivities": "iwp.sim.sensitivity", "SimulationResult": "iwp.sim", "BatchResult": "iwp.sim",
    "Constant": "iwp.sim", "Sine": "iwp.sim", "Chirp": "iwp.sim", "Step": "iwp.sim", "Sampled": "iwp.sim",
    "HopfController": "iwp.sim", "CallableController": "iwp.sim", "BalanceController": "iwp.sim",
    "Tolerances": "iwp.sim", "CommandChain": "iwp.sim", "Feedforward": "iwp.sim", "SimOptions": "iwp.sim",
    "BatchOptions": "iwp.sim", "BandOptions": "iwp.sim.uncertainty",
    # data
    "ExperimentData": "iwp.data", "StaticCurve": "iwp.data", "read_experiment": "iwp.data",
    "write_experiment": "iwp.data", "read_static_curve": "iwp.data", "convert": "iwp.data",
    # identification
    "identify": "iwp.ident", "refine": "iwp.ident", "refine_identification": "iwp.ident", "validate": "iwp.ident",
    "fit_percent": "iwp.ident", "Differentiator": "iwp.ident", "IdentificationResult": "iwp.ident",
    "RefineResult": "iwp.ident", "ValidationResult": "iwp.ident", "SETUPS": "iwp.ident",
    "FitProblem": "iwp.ident", "FitResult": "iwp.ident", "Parameter": "iwp.ident", "Parameters": "iwp.ident",
    "Experiment": "iwp.ident", "refine_belt": "iwp.ident", "IdentifyOptions": "iwp.ident",
    "ValidationOptions": "iwp.ident",
    # control
    "hopf_point": "iwp.control", "continue_hopf": "iwp.control", "design_hopf": "iwp.control",
    "find_orbit": "iwp.control", "lqr_balance": "iwp.control", "swing_up": "iwp.control",
    "robust_hopf": "iwp.control", "robust_balance": "iwp.control", "robust_swingup": "iwp.control",
    # the virtual rig (the reproduction is iwp.reproduce.reproduce)
    "VirtualRig": "iwp.rig", "RigTruth": "iwp.rig", "default_truth": "iwp.rig",
    # the rig in the loop
    "Rig": "iwp.device", "TwinRig": "iwp.device", "open_rig": "iwp.device", "run_on_rig": "iwp.device",
    "run_control": "iwp.device", "ControlRun": "iwp.device",
    # errors
    "IwpError": "iwp.errors", "InputError": "iwp.errors", "DataFormatError": "iwp.errors",
    "SimulationError": "iwp.errors", "IdentificationError": "iwp.errors", "OutputExistsError": "iwp.errors",
}

__all__ = ["__version__", *_EXPORTS]


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

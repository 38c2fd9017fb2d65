"""Simulation: the integration engine, inputs, and simulations of a plant.

==========================  =====================================================
module                      what
==========================  =====================================================
:mod:`.simulate`            :func:`simulate`, :func:`simulate_batch`, :func:`simulate_scipy`
:mod:`.inputs`              signals and feedback laws that drive a simulation
:mod:`.options`             :class:`SimOptions`, :class:`BatchOptions`, :class:`Tolerances`, :class:`CommandChain`
:mod:`.sensitivity`         simulations with forward sensitivities (fits, shooting)
:mod:`.result`              :class:`SimulationResult`, :class:`BatchResult`
:mod:`.engine`              the compiled adaptive DOP853 (one engine for everything)
:mod:`.lanes`               many runs side by side, vectorised
:mod:`.dop853`              DOP853's stage sums (generated)
==========================  =====================================================
"""

from __future__ import annotations

from .inputs import (
    BalanceController,
    CallableController,
    Chirp,
    Constant,
    HopfController,
    Input,
    Sampled,
    Sine,
    Step,
    make_input,
)
from .options import BatchOptions, CommandChain, Feedforward, SimOptions, Tolerances
from .result import BatchResult, SimulationResult
from .simulate import simulate, simulate_batch, simulate_scipy

__all__ = [
    "BalanceController",
    "BatchOptions",
    "BatchResult",
    "CallableController",
    "Chirp",
    "CommandChain",
    "Constant",
    "Feedforward",
    "HopfController",
    "Input",
    "Sampled",
    "SimOptions",
    "SimulationResult",
    "Sine",
    "Step",
    "Tolerances",
    "make_input",
    "simulate",
    "simulate_batch",
    "simulate_scipy",
]

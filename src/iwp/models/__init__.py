"""The paper's models: equations, laws, parameters and the plant.

========================  ==========================================================
module                    what
========================  ==========================================================
:mod:`.parameters`        Table 1, lumped (section 4) and physical (sections 2-3) parameters, the belt
:mod:`.equations`         right-hand sides (4)+(3), (6), (9), (14); dispatch by model code
:mod:`.pendulum`          the pendulum terms ``xi`` of (6)/(9) and the free pendulum of section 5.2
:mod:`.belt`              the flexible belt (15) with the hysteresis of figure 5
:mod:`.friction`          friction of the pendulum joint (3.1), Coulomb term of the disk (3.2)
:mod:`.actuator`          dead zone (5), break-away, feedforward (7)-(8), saturation
:mod:`.laws`              the Hopf feedback law of section 5.3
:mod:`.encoder`           encoder quantisation (section 5)
:mod:`.plant`             :class:`Plant`: model, parameters and options, packed for the compiled code
:mod:`.analysis`          energy (2), linearisation of (9)
:mod:`.layout`            the packed parameter layout (internal)
========================  ==========================================================

``docs/models.md`` maps every equation of the paper to its function and its test.
"""

from __future__ import annotations

from .actuator import StartupFriction, dead_zone, dead_zone_output, feedforward
from .analysis import energy, linearize, pendulum_energy, to_statespace
from .encoder import encoder_step, quantize
from .friction import COULOMB_EPS
from .mathfn import SINCOS_MAX
from .parameters import (
    BeltParameters,
    LumpedParameters,
    PhysicalParameters,
    load_params,
    named_params,
    paper_belt,
    save_params,
    table1,
)
from .plant import MODELS, ModelInfo, Plant, model_info

__all__ = [
    "BeltParameters",
    "COULOMB_EPS",
    "LumpedParameters",
    "MODELS",
    "ModelInfo",
    "PhysicalParameters",
    "Plant",
    "SINCOS_MAX",
    "StartupFriction",
    "dead_zone",
    "dead_zone_output",
    "encoder_step",
    "energy",
    "feedforward",
    "linearize",
    "load_params",
    "model_info",
    "named_params",
    "paper_belt",
    "pendulum_energy",
    "quantize",
    "save_params",
    "table1",
    "to_statespace",
]

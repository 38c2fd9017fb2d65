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
:mod:`.encoder`           encoder quantisation (section 5) and a log's zero
:mod:`.plant`             :class:`Plant`: model, parameters and options, packed for the compiled code
:mod:`.analysis`          energy (2), linearisation of (9)
:mod:`.terms`             the optional terms (Coulomb, widths, offset, dead zone, belt, Stribeck), one object each
:mod:`.layout`            the packed parameter layout (internal)
========================  ==========================================================

``docs/models.md`` maps every equation of the paper to its function and its test.

Names are loaded on first use (as :mod:`iwp`'s), so that the command line can
read the optional terms (:mod:`.terms`) without compiling the models.
"""

from __future__ import annotations

from ..exports import lazy_exports

#: public name -> the module that defines it
_EXPORTS: dict[str, str] = {
    "BeltParameters": "iwp.models.parameters", "COULOMB_EPS": "iwp.models.friction",
    "LumpedParameters": "iwp.models.parameters", "MODELS": "iwp.models.plant", "ModelInfo": "iwp.models.plant",
    "PhysicalParameters": "iwp.models.parameters", "Plant": "iwp.models.plant", "SINCOS_MAX": "iwp.models.mathfn",
    "StartupFriction": "iwp.models.actuator", "TERMS": "iwp.models.terms", "Term": "iwp.models.terms",
    "dead_zone": "iwp.models.actuator", "dead_zone_output": "iwp.models.actuator",
    "EncoderZero": "iwp.models.encoder", "encoder_step": "iwp.models.encoder", "energy": "iwp.models.analysis",
    "feedforward": "iwp.models.actuator",
    "linearize": "iwp.models.analysis", "load_params": "iwp.models.parameters", "model_info": "iwp.models.plant",
    "named_params": "iwp.models.parameters", "paper_belt": "iwp.models.parameters",
    "pendulum_energy": "iwp.models.analysis", "quantize": "iwp.models.encoder", "save_params": "iwp.models.parameters",
    "table1": "iwp.models.parameters", "to_statespace": "iwp.models.analysis",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)

"""Control of the inertia wheel pendulum.

**Hopf amplitude design** (section 5.3). The closed loop of the compensated
model (9) with the anticontrol law ``u = k1 q3 + k2 q3^3``
(:func:`iwp.models.laws.hopf_law`) oscillates with an amplitude set by
``k1`` and ``k2``; the paper chose them "based on a bifurcation analysis and
numerical continuation". **Swing-up and balance** (beyond the paper): an
LQR at the upright, energy pumping from the bottom, on the rig's conditions
with an observer on quantised encoder angles. **Robust designs**: the
outcome of each over a fit's parameter uncertainty (:mod:`.robust`).

=====================  ==============================================================
module                 what
=====================  ==============================================================
:mod:`.closed_loop`    model (9) under the Hopf law on the reduced state ``(q1, q3, q4)``
:mod:`.hopf`           closed-loop matrix, Hopf point ``k1*``, first Lyapunov coefficient
:mod:`.orbits`         periodic orbits and their shooting equations (forward sensitivities)
:mod:`.continuation`   pseudo-arclength continuation of the Hopf branch; the orbit at given gains
:mod:`.design`         gains for a wanted amplitude; the amplitude a long simulation reaches
:mod:`.balance`        LQR at the upright
:mod:`.conditions`     the rig's conditions (dead zone, encoders, sampling, saturation)
:mod:`.observer`       observer on the quantised encoder angles
:mod:`.swingup`        swing-up by energy pumping, then balance
:mod:`.robust`         the designs over a fit's parameter uncertainty (robust designs)
=====================  ==============================================================

Every integration goes through iwp's one engine (:mod:`iwp.sim`): the
shooting through :func:`iwp.sim.sensitivity.simulate_sensitivities`, the
observer's prediction through :func:`iwp.sim.simulate.integrate_held`; no
model equation is repeated here.
"""

from __future__ import annotations

from ..models.analysis import pendulum_energy
from .balance import LQRBalance, lqr_balance
from .conditions import RigConditions
from .continuation import HopfBranch, continue_hopf, find_orbit
from .design import HopfDesign, SimulatedOscillation, design_hopf, simulated_amplitude
from .hopf import HopfPoint, closed_loop_matrix, hopf_point
from .observer import EncoderObserver
from .orbits import PeriodicOrbit
from .robust import (
    Proportion,
    RobustBalance,
    RobustHopf,
    RobustSwingUp,
    Spread,
    robust_balance,
    robust_hopf,
    robust_swingup,
    wilson_interval,
)
from .swingup import SwingUpController, SwingUpResult, swing_up

__all__ = [
    "closed_loop_matrix",
    "HopfPoint",
    "hopf_point",
    "PeriodicOrbit",
    "HopfBranch",
    "continue_hopf",
    "find_orbit",
    "HopfDesign",
    "design_hopf",
    "simulated_amplitude",
    "SimulatedOscillation",
    "LQRBalance",
    "lqr_balance",
    "RigConditions",
    "EncoderObserver",
    "pendulum_energy",
    "SwingUpController",
    "SwingUpResult",
    "swing_up",
    "Proportion",
    "Spread",
    "wilson_interval",
    "RobustHopf",
    "robust_hopf",
    "RobustBalance",
    "robust_balance",
    "RobustSwingUp",
    "robust_swingup",
]

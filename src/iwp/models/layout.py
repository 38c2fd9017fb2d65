"""Where a plant's numbers sit in the vector that the compiled code reads.

A :class:`~iwp.models.plant.Plant` packs its parameters into one float vector
of length :data:`N_PACK` (:meth:`~iwp.models.plant.Plant.packed`); the
compiled right-hand sides of :mod:`iwp.models.equations` read it at the
indices below. The layout is internal to iwp: the public API takes
parameter objects, never vectors.

The optional terms' slots follow from their registry (:mod:`iwp.models.terms`);
the compiled code reads these constants, so this module is part of the
compiled sources' stamp (:mod:`iwp.jit`, marker: compiled-constants).

Model codes are the compiled counterpart of the model names of
:data:`iwp.models.plant.MODELS`.
"""

from __future__ import annotations

from .terms import SWITCHES, term_parameters

# --------------------------------------------------------------------------
# model codes
# --------------------------------------------------------------------------
M_EL = 0  #: Euler-Lagrange (4) with the motor (3), physical parameters
M_RAW = 1  #: state space (6), raw input v through the dead zone (5)
M_COMP = 2  #: compensated model (9), ideal input u
M_MD = 3  #: motor-disk (14) after exact compensation, input u
M_MD_RAW = 4  #: motor-disk (14), raw input v through the dead zone
M_BELT = 5  #: flexible belt (15), pendulum locked
M_BELT_FULL = 6  #: belt (15) with the pendulum free: the virtual rig's truth plant
#: model (9) compiled without its optional terms (dead zone, Coulomb, clamp),
#: for callers that have checked :func:`iwp.models.equations.optional_terms_off`
M_PLAIN = 7
M_FREE_HELD = 8  #: free pendulum, wheel held to the arm (section 5.2 on a belt-driven rig)
M_FREE_NOWHEEL = 9  #: free pendulum without a wheel, section 5.2's equation taken literally

#: models with the belt states ``delta, w`` (six states); all others have four
BELT_CODES = (M_BELT, M_BELT_FULL)

# --------------------------------------------------------------------------
# lumped layout (models (6), (9), (14), (15), free pendulum)
# --------------------------------------------------------------------------
#: model (9)'s parameters (section 4)
P1, P2, P3, RHO, SA, SV, SB = range(7)
#: the plant's options: break-away ratio and speed of the dead zone, the clamp, the dead zone on; the belt's play
#: branch, held through a step by the engine (0, as packed: decided from the state at every evaluation; see
#: :func:`iwp.models.belt.play_rate`); the disk's and the pendulum's Coulomb smoothing as packed (the fitted widths,
#: or the plant's ``coulomb_eps`` where they are 0)
BRK, WS, LOCK, DZ, PMODE, EPSC, EPSC1 = range(7, 14)
#: belt (15): k/I2, play half-width d, ratio N, b2/I2, k/gamma, kT beta/(R gamma), the motor gain for a negative net
#: input over the positive one (section 3.2 allows them to differ)
KI2, DPLAY, NB, B2I2, KG, KBRG, KNEG = range(14, 21)
#: the optional terms' parameters (:data:`iwp.models.terms.TERMS`), in the registry's order; the smoothing widths
#: eps_c1/eps_c2 are packed at EPSC1/EPSC, the plant's default in place of 0
_FIRST_TERM = 21
TERM_INDEX = {p.name: _FIRST_TERM + i for i, p in enumerate(p for p in term_parameters()
                                                              if p.name not in ("eps_c1", "eps_c2"))}
TERM_INDEX.update(eps_c1=EPSC1, eps_c2=EPSC)
VPOS, VNEG = TERM_INDEX["v_dz_pos"], TERM_INDEX["v_dz_neg"]  # the dead zone's thresholds (5)
SC2 = TERM_INDEX["sigma_c2"]  # the disk's Coulomb friction (section 5.1)
SC1 = TERM_INDEX["sigma_c1"]  # the pendulum joint's Coulomb friction
UOFF = TERM_INDEX["u_offset"]  # the input's offset
#: the slots whose non-zero value puts a term into the compiled models (:data:`iwp.models.terms.SWITCHES`)
SWITCH_SLOTS = tuple(TERM_INDEX[n] for n in SWITCHES)
N_LUMPED = max(TERM_INDEX.values()) + 1  # the last term slot (the widths sit at EPSC1, EPSC)

# --------------------------------------------------------------------------
# physical layout (model "el")
# --------------------------------------------------------------------------
(E_M1, E_M2, E_I1, E_I2, E_L, E_C, E_G, E_KT, E_KF, E_R, E_N, E_BETA, E_SV1, E_SR, E_RR, E_SV2, E_SC2,
 E_VPOS, E_VNEG, E_EPSC) = range(20)
N_PHYS = 20
#: the physical fields in the order of the layout above
PHYSICAL_FIELDS = ("m1", "m2", "I1", "I2", "l", "c", "g", "kT", "kF", "R", "N", "beta", "sigma_v1", "sigma_r", "r",
                   "sigma_v2", "sigma_c2", "V_dz_pos", "V_dz_neg")

#: length of every packed parameter vector (one size for all models)
N_PACK = max(N_LUMPED, N_PHYS)

#: lumped parameter name -> index (the fields of :class:`~iwp.models.parameters.LumpedParameters`)
LUMPED_INDEX = {"p1": P1, "p2": P2, "p3": P3, "rho": RHO, "sigma_a1": SA, "sigma_v1": SV, "sigma_b1": SB,
                **TERM_INDEX}
#: belt parameter name -> index (the fields of :class:`~iwp.models.parameters.BeltParameters`)
BELT_INDEX = {
    "k_over_I2": KI2, "d": DPLAY, "N": NB, "b2_over_I2": B2I2, "k_over_gamma": KG, "kTbeta_over_Rgamma": KBRG,
    "gain_neg": KNEG,
}
#: every model parameter name -> index (the parameters a fit can vary, and their sensitivities)
PARAMETER_INDEX = {**LUMPED_INDEX, **BELT_INDEX}

# --------------------------------------------------------------------------
# command chain (feedforward (7)-(8), then saturation)
# --------------------------------------------------------------------------
C_FF, C_FFPOS, C_FFNEG, C_SATLO, C_SATHI = range(5)
N_COMMAND = 5

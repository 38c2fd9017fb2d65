"""The optional terms of the lumped models, one object each.

Model (9) of the paper has seven parameters. Real rigs show more: Coulomb
friction at the wheel (section 5.1) and at the pendulum's joint, wider
transitions of those signs, an input offset, the dead zone (5) when the raw
command is logged, the belt (15) on a belt drive, a Stribeck rise of the
wheel's friction at low speed. Each is a :class:`Term` here, and everything
else derives from this registry (:data:`TERMS`):

* the fields of :class:`~iwp.models.parameters.LumpedParameters` and their
  :class:`~iwp.models.parameter_info.ParameterInfo` (:func:`term_parameters`);
* where the compiled code reads them (:mod:`iwp.models.layout`), and which of
  them switch model (9)'s plain compiled form off (:data:`SWITCHES`);
* which parameters each model admits (:data:`iwp.models.plant.MODELS`);
* what a fit frees and where it starts (:func:`free_parameters`,
  :func:`starting_values`), the ladder of structures ``iwp fit`` climbs
  (:mod:`iwp.ident.structure`) and its command-line flags (``iwp fit --coulomb``,
  ``--terms``).

Adding a law to the models is thus: the law (:mod:`iwp.models.friction`),
its use in the equations (:mod:`iwp.models.equations`), one :class:`Term`
below, and a test. The Stribeck term was added so.

The registry decides where the compiled code reads the terms' parameters
(:mod:`iwp.models.layout`), so an edit here recompiles the kernels (marker for
:mod:`iwp.jit`: compiled-constants).

========================  =====================  ==========================================================
term                      parameters             what
========================  =====================  ==========================================================
``dead_zone``             v_dz_pos, v_dz_neg     the dead zone (5) of a raw command ``v``: model (6)
``coulomb``               sigma_c2               Coulomb friction of the wheel (section 5.1)
``pendulum_coulomb``      sigma_c1               Coulomb friction of the pendulum joint
``input_offset``          u_offset               an offset of the input
``widths``                eps_c1, eps_c2         the smoothing widths of the Coulomb signs that are on
``belt``                  (the belt's)           the belt (15) with the play of figure 5, in place of p2, p3
``stribeck``              sigma_s2, v_s2         the Stribeck rise of the wheel's friction at low speed
========================  =====================  ==========================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from ..errors import InputError
from .parameter_info import ParameterInfo

#: a :class:`~iwp.models.parameters.LumpedParameters` (that class builds its fields from this module, so this module
#: does not import it)
Lumped = Any

__all__ = ["Term", "LadderPlace", "DriveModel", "TERMS", "SWITCHES", "term", "parse_terms", "closure",
           "term_parameters", "ladder_order", "rung_names", "free_parameters", "starting_values", "model_of",
           "drive_of", "model_parameters", "BASE_FREE", "BELT_FREE"]

#: the parameters of model (9) that every fit frees (section 4)
BASE_FREE = ("p1", "p2", "p3", "rho", "sigma_a1", "sigma_v1", "sigma_b1")


@dataclass(frozen=True)
class LadderPlace:
    """Where a term sits on the ladder of structures ``iwp fit`` climbs (:mod:`iwp.ident.structure`).

    Attributes
    ----------
    name : str
        What ``iwp fit --model`` takes for the structure with this term (``"coulomb"``, ``"offset"``, ...).
    label : str
        What the ladder's table prints.
    extends : str
        The rung whose structure this one adds the term to (``"9"``: model (9) alone).
    position : int
        Its place on the ladder, simplest first (rungs that extend the same one are tried in this order).
    default : bool
        On the ladder ``iwp fit`` climbs by default; False: only when asked (``iwp fit --try``).
    """

    name: str
    label: str
    extends: str
    position: int
    default: bool = True


@dataclass(frozen=True)
class DriveModel:
    """A model of the drive between motor and wheel in place of rigid parameters (the belt (15) in place of
    ``p2, p3``), which a term brings (:attr:`Term.replacement`).

    Attributes
    ----------
    name : str
        The drive's name (``"belt"``): the rig description's ``drive.kind`` it needs, and the
        :attr:`~iwp.models.plant.ModelInfo.drive` of the models that hold it; how a fit of it starts and is bounded
        is :mod:`iwp.ident.drives`'.
    replaces : tuple of str
        The lumped parameters it takes the place of (not freed with it).
    free : tuple of str
        Its own parameters a fit frees.
    model : str
        The model a fit with it simulates (``"belt-full"``).
    label : str
        What messages call it (``"the belt model (15)"``).
    """

    name: str
    replaces: tuple[str, ...]
    free: tuple[str, ...]
    model: str
    label: str


@dataclass(frozen=True)
class Term:
    """One optional term of the lumped models.

    Attributes
    ----------
    name : str
        Its name (``LogFitOptions`` holds a set of these; ``fit.json``'s ``options`` key).
    description : str
        What it is, for the command line's help and the reports.
    rung : LadderPlace
        Its place on ``iwp fit``'s ladder.
    parameters : tuple of ParameterInfo
        The parameters it brings to :class:`~iwp.models.parameters.LumpedParameters` (0 by default: off).
    models : tuple of str
        The models that admit it (their parameters include its own).
    switch : str or None
        The parameter whose non-zero value puts the term into the compiled models (so that model (9)'s plain
        compiled form cannot serve); None: a plant option decides (the dead zone) or it has no switch.
    shapes : tuple of str
        The terms whose shape it adjusts: it frees ``parameters[i]`` only when ``shapes[i]`` is on (the widths).
    requires, excludes : tuple of str
        Terms it needs, and terms it cannot go with.
    input : str or None
        The logged input it needs (``"v"``: the raw command), or None.
    model : str or None
        The model a fit with it simulates (``"raw"``); None: model (9), ``"compensated"``, or its drive's.
    replacement : DriveModel or None
        The drive model it puts in place of rigid parameters (the belt's), with its model and name, or None.
    start : callable or None
        ``start(params, umax, fraction)``: ``params`` with its parameters that are 0 started from what the
        logs' largest input ``umax`` and ``params`` allow, scaled by ``fraction``; None: they start at 0.
    """

    name: str
    description: str
    rung: LadderPlace
    parameters: tuple[ParameterInfo, ...] = ()
    models: tuple[str, ...] = ()
    switch: str | None = None
    shapes: tuple[str, ...] = ()
    requires: tuple[str, ...] = ()
    excludes: tuple[str, ...] = ()
    input: str | None = None
    model: str | None = None
    replacement: DriveModel | None = None
    start: Callable[[Lumped, float, float], Lumped] | None = None

    @property
    def called(self) -> str:
        """What messages call it: its drive model's label, or its description."""
        return self.replacement.label if self.replacement is not None else self.description

    @property
    def drive(self) -> str | None:
        """The drive the rig needs for it (``"belt"``: its drive model's name), or None."""
        return None if self.replacement is None else self.replacement.name

    @property
    def flag(self) -> str:
        """Its command-line flag (``--pendulum-coulomb``)."""
        return "--" + self.name.replace("_", "-")

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    def freed(self, on: frozenset[str] | set[str]) -> tuple[str, ...]:
        """The parameters a fit frees for this term when the terms ``on`` are on."""
        if self.replacement is not None:
            return self.replacement.free
        if self.shapes:
            return tuple(p for s in TERMS if s in on for p, shaped in zip(self.parameter_names, self.shapes)
                         if shaped == s)
        return self.parameter_names


def _lumped(name, unit, typical, sign, description, fit_range=None, floor=0.0) -> ParameterInfo:
    return ParameterInfo(name, "lumped", unit, typical, sign, description, fit_range, floor)


# --------------------------------------------------------------------------
# start rules: a term's parameters that are 0 started from what the logs allow
# --------------------------------------------------------------------------
def _wheel_coulomb(p: Lumped, umax: float, fraction: float) -> float:
    """A wheel's Coulomb friction of 2 % of the largest input's torque [rad/s^2] (times ``fraction``)."""
    return fraction * 0.02 * p.p3 * umax


def _start_dead_zone(p, umax, fraction):
    if p.v_dz_pos == 0 and p.v_dz_neg == 0:
        return p.replace(v_dz_pos=fraction * 0.05 * umax, v_dz_neg=fraction * 0.05 * umax)
    return p


def _start_coulomb(p, umax, fraction):
    return p.replace(sigma_c2=_wheel_coulomb(p, umax, fraction)) if p.sigma_c2 == 0 else p


def _start_pendulum_coulomb(p, umax, fraction):
    return p.replace(sigma_c1=fraction * 0.01 * p.p1) if p.sigma_c1 == 0 else p


def _start_belt(p, umax, fraction):
    # a rigid fit may have dropped the wheel's Coulomb friction for the play it could not model; started at 0 the
    # belt's fit stays there (measured: held-out fits 90/95 % against 99/99.6 %)
    return p.replace(sigma_c2=max(p.sigma_c2, _wheel_coulomb(p, umax, fraction)))


def _start_stribeck(p, umax, fraction):
    """Half the Coulomb level as the Stribeck level; as its speed a twentieth of the wheel's steady speed at the
    largest input, ``p3 umax / p2`` [rad/s] (the rise is a low-speed effect)."""
    if p.sigma_s2 != 0:
        return p
    steady = p.p3 * umax / p.p2 if p.p2 > 0 else 1.0
    return p.replace(sigma_s2=fraction * 0.5 * (p.sigma_c2 or _wheel_coulomb(p, umax, 1.0)),
                     v_s2=p.v_s2 or max(0.05 * steady, 10.0 * STRIBECK_FLOOR))


# --------------------------------------------------------------------------
# the belt's parameters (its fit's start and bounds: iwp.ident.drives)
# --------------------------------------------------------------------------
#: What a fit with the belt frees: the five of the paper's eq. (15) besides the measured ratio N.
BELT_FREE = ("k_over_I2", "d", "b2_over_I2", "k_over_gamma", "kTbeta_over_Rgamma")




#: the smallest Stribeck speed a fit may give [rad/s]: below it the rise is narrower than any logged rig resolves
#: (as the Coulomb widths' floor, :attr:`~iwp.models.parameter_info.ParameterInfo.floor`)
STRIBECK_FLOOR = 1e-2

_RIGID_LUMPED = ("raw", "compensated")
_WHEEL = ("raw", "compensated", "motor-disk", "motor-disk-raw", "belt", "belt-full")

#: The terms, by name; their order is that of the parameters' fields and of a fit's free parameters.
TERMS: dict[str, Term] = {t.name: t for t in (
    Term("dead_zone", "model (6) with the dead zone (5) (raw input v)",
         LadderPlace("dead-zone", "+ dead zone (v_dz_pos, v_dz_neg), model (6)", "widths", 5),
         (_lumped("v_dz_pos", "in", 31.0, "nonnegative", "dead-zone threshold v+ (5)"),
          _lumped("v_dz_neg", "in", 31.0, "nonnegative", "dead-zone threshold v- (5)")),
         models=("raw", "motor-disk-raw"), input="v", model="raw", start=_start_dead_zone),
    Term("coulomb", "Coulomb friction of the wheel (sigma_c2)",
         LadderPlace("coulomb", "+ wheel Coulomb (sigma_c2)", "9", 1),
         (_lumped("sigma_c2", "rad/s^2", 0.1, "nonnegative", "Coulomb friction of the disk over I1_hat (section 5.1)",
                  (1e-5, 10.0)),),
         models=_WHEEL, switch="sigma_c2", start=_start_coulomb),
    Term("pendulum_coulomb", "Coulomb friction of the pendulum joint (sigma_c1)",
         LadderPlace("pendulum-coulomb", "+ pendulum Coulomb (sigma_c1)", "coulomb", 2),
         (_lumped("sigma_c1", "rad/s^2", 0.05, "nonnegative", "Coulomb friction of the pendulum joint over I1_hat"),),
         models=("raw", "compensated", "belt-full", "free", "free-nowheel"), switch="sigma_c1",
         start=_start_pendulum_coulomb),
    Term("input_offset", "an offset of the input (u_offset)",
         LadderPlace("offset", "+ input offset (u_offset)", "widths", 4),
         (_lumped("u_offset", "in", 1.0, "signed", "offset of the input"),),
         models=("raw", "compensated", "motor-disk", "motor-disk-raw", "belt-full"), switch="u_offset"),
    Term("widths", "the smoothing widths of the Coulomb terms that are on (eps_c2, eps_c1)",
         LadderPlace("widths", "+ Coulomb widths (eps_c1, eps_c2)", "pendulum-coulomb", 3),
         (_lumped("eps_c1", "rad/s", 0.01, "nonnegative",
                  "smoothing width of the pendulum's Coulomb sign (0: the plant's)", (1e-3, 2.0), 1e-3),
          _lumped("eps_c2", "rad/s", 0.01, "nonnegative",
                  "smoothing width of the disk's Coulomb sign (0: the plant's)", (1e-3, 2.0), 1e-3)),
         shapes=("pendulum_coulomb", "coulomb")),
    Term("belt", "the belt (15) between motor and wheel in place of p2, p3 (a rig whose drive is a belt)",
         LadderPlace("belt", "+ belt (15) in place of p2, p3 (5 terms)", "widths", 6),
         excludes=("dead_zone",),
         replacement=DriveModel("belt", ("p2", "p3"), BELT_FREE, "belt-full", "the belt model (15)"),
         start=_start_belt),
    Term("stribeck", "the Stribeck rise of the wheel's friction at low speed (sigma_s2, v_s2)",
         LadderPlace("stribeck", "+ wheel Stribeck (sigma_s2, v_s2)", "coulomb", 7, default=False),
         (_lumped("sigma_s2", "rad/s^2", 0.05, "nonnegative",
                  "Stribeck level of the disk's friction over I1_hat: static friction's excess over Coulomb's"),
          _lumped("v_s2", "rad/s", 1.0, "nonnegative", "Stribeck speed of the disk's friction (0: no rise)",
                  None, STRIBECK_FLOOR)),
         models=_RIGID_LUMPED, switch="sigma_s2", requires=("coulomb",), start=_start_stribeck),
)}

#: the parameters whose non-zero value puts a term into the compiled models (model (9)'s plain form cannot serve)
SWITCHES: tuple[str, ...] = tuple(t.switch for t in TERMS.values() if t.switch is not None)


def term_parameters() -> tuple[ParameterInfo, ...]:
    """Every term's parameters, in the registry's order (the fields of ``LumpedParameters`` after model (9)'s)."""
    return tuple(p for t in TERMS.values() for p in t.parameters)


def ladder_order() -> list[Term]:
    """The terms in the order of their rungs on the ladder, simplest first (:attr:`LadderPlace.position`)."""
    return sorted(TERMS.values(), key=lambda t: t.rung.position)


def rung_names() -> tuple[str, ...]:
    """The ladder's structures by name, simplest first: ``"9"`` (model (9)) then each term's rung."""
    return ("9", *(t.rung.name for t in ladder_order()))


def term(name: str, *, argument: str = "terms") -> Term:
    """The term called ``name`` (``-`` or ``_`` alike); a clear error naming ``argument`` otherwise."""
    key = str(name).strip().replace("-", "_")
    if key not in TERMS:
        raise InputError(f"{argument}: unknown term {name!r}; choose from "
                         f"{', '.join(t.replace('_', '-') for t in TERMS)}", argument=argument)
    return TERMS[key]


def parse_terms(text: str, *, argument: str = "--terms") -> frozenset[str]:
    """The terms of a comma-separated list (``"coulomb,stribeck"``), checked (:func:`term`)."""
    names = [s for s in (x.strip() for x in str(text).split(",")) if s]
    if not names:
        raise InputError(f"{argument}: no term given; choose from {', '.join(t.replace('_', '-') for t in TERMS)}",
                         argument=argument)
    return frozenset(term(n, argument=argument).name for n in names)


def closure(names) -> frozenset[str]:
    """``names`` with the terms they require, checked against what they exclude.

    Raises
    ------
    InputError
        Two terms that exclude each other (the error names both flags).
    """
    on = {term(n).name for n in names}
    while True:
        more = {r for n in on for r in TERMS[n].requires} - on
        if not more:
            break
        on |= more
    for n in sorted(on):
        for x in TERMS[n].excludes:
            if x in on:
                raise InputError(f"{TERMS[n].flag} and {TERMS[x].flag} exclude each other ({TERMS[n].called} and "
                                 f"{TERMS[x].called}); fit one of them", argument=TERMS[n].name)
    return frozenset(on)


def drive_of(on) -> DriveModel | None:
    """The model of its own a term of ``on`` puts in place of rigid parameters (the belt's), or None."""
    return next((TERMS[n].replacement for n in TERMS if n in on and TERMS[n].replacement is not None), None)


def model_of(on) -> str:
    """The model a fit with the terms ``on`` simulates: a term's own (``"belt-full"``, ``"raw"``) or
    ``"compensated"``; a term that replaces rigid parameters comes first."""
    models = [TERMS[n].model for n in TERMS if n in on and TERMS[n].model is not None]
    drive = drive_of(on)
    return drive.model if drive is not None else (models or ["compensated"])[0]


def free_parameters(on) -> tuple[str, ...]:
    """What a fit with the terms ``on`` frees: model (9)'s (less what a drive model replaces, plus its own)
    then each term's, in the registry's order."""
    drive = drive_of(on)
    base = BASE_FREE if drive is None else tuple(n for n in BASE_FREE if n not in drive.replaces) + drive.free
    return base + tuple(p for n, t in TERMS.items() if n in on and t.replacement is None for p in t.freed(on))


def starting_values(on, start: Lumped, umax: float, *, fraction: float = 1.0) -> Lumped:
    """``start`` with the parameters of the terms ``on`` that are 0 started by each term's rule (terms a
    simpler structure fitted keep their values); ``umax``: the logs' largest input magnitude [in];
    ``fraction`` scales the starts (a start next to a simpler structure's optimum)."""
    for n, t in TERMS.items():
        if n in on and t.start is not None:
            start = t.start(start, umax, fraction)
    return start


def model_parameters(model: str, core: tuple[str, ...]) -> tuple[str, ...]:
    """The parameters of ``model``: its own ``core`` ones, then those of the terms it admits (a term that shapes
    others, the widths, brings the parameter of each shaped term the model admits)."""
    out = list(core)
    for t in TERMS.values():
        if t.shapes:
            out += [p for p, s in zip(t.parameter_names, t.shapes) if model in TERMS[s].models]
        elif model in t.models:
            out += list(t.parameter_names)
    return tuple(dict.fromkeys(out))

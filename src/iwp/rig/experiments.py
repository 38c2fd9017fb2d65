"""The paper's experiments, by name, with their settings and inputs.

``static-curve``, ``static-curve-compensated`` (figure 2), ``motor-disk-chirp``
(section 5.1), ``sine-60``, ``sine-40``, ``sine-20`` (figures 3, 4),
``free-pendulum`` (figure 8), ``full-chirp`` (figure 9) and ``closed-loop``
(figure 10), each with the paper's settings (:data:`EXPERIMENTS`,
:func:`list_experiments`). Each says how it runs (:class:`ExperimentKind`:
open loop with its input law, static curve, release, closed loop; with or
without the compensation (7)-(8); pendulum clamped or free), and the virtual
rig (:mod:`iwp.rig.virtual`) and a rig in the loop
(:mod:`iwp.device.experiments`) run it by that kind, not by its name.
:func:`law_input` builds the ideal input ``u(t)`` of an input law (the one
place that does), :func:`open_loop_input` that of an open-loop experiment;
the checks of the options that :meth:`iwp.rig.VirtualRig.run` accepts are
here too.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from ..errors import InputError

__all__ = [
    "ExperimentSpec",
    "ExperimentKind",
    "RunKind",
    "InputLaw",
    "EXPERIMENTS",
    "PAPER_V_DZ",
    "VELOCITY_FILTER_TAU",
    "list_experiments",
    "experiment_spec",
]

#: The paper's dead-zone compensation threshold ``v_dz`` (section 5.1) [input units].
PAPER_V_DZ = 31.0
#: Time constant of the first-order filter of the rig's velocity estimate [s].
VELOCITY_FILTER_TAU = 0.01


class RunKind(enum.Enum):
    """How an experiment drives the rig (:attr:`ExperimentKind.run`)."""

    #: The motor follows an input law ``u(t)`` fixed in advance (:class:`InputLaw`).
    OPEN_LOOP = "open-loop"
    #: Figure 2: each input of a grid held from rest and the steady wheel speed read; pendulum clamped.
    STATIC_CURVE = "static-curve"
    #: The pendulum let go from rest at an angle, the motor off (the free pendulum, figure 8).
    RELEASE = "release"
    #: The input computed every sample from the measured angles (the Hopf law of section 5.3).
    CLOSED_LOOP = "closed-loop"


class InputLaw(enum.Enum):
    """The input law of an open-loop experiment (:attr:`ExperimentKind.law`, :func:`law_input`)."""

    #: ``u = A sin(omega t)``.
    SINE = "sine"
    #: ``u = A sin((w0 + t/tau) t)``.
    CHIRP = "chirp"
    #: A pseudo-random binary sequence ``+-A``, each level held at least ``hold_time``.
    PRBS = "prbs"
    #: Levels each held ``step_time``, repeated.
    STEPS = "steps"


@dataclass(frozen=True)
class ExperimentKind:
    """How an experiment runs: what the virtual rig and a rig in the loop dispatch on.

    Attributes
    ----------
    run : RunKind
        Open loop, static curve, release or closed loop.
    law : InputLaw or None
        The input law of an open-loop experiment; None for the others.
    compensated : bool
        True: the rig's feedforward (7)-(8) is on (the settings' ``v_dz``) and the logged input is the ideal
        ``u``; False: the input is the raw driver command ``v`` (or none: a release). For a static curve this
        is what the curve is (``u`` or ``v`` against the wheel speed); the other experiments' ``v_dz = None``
        switches the compensation off.
    locked : bool
        The pendulum is clamped at ``q1 = 0`` (section 5.1).

    Raises
    ------
    InputError
        A ``run`` that is not a :class:`RunKind`, an input law on an experiment that is not open loop (or none
        on one that is), or a static curve with the pendulum free.
    """

    run: RunKind
    law: InputLaw | None = None
    compensated: bool = False
    locked: bool = False

    def __post_init__(self):
        if not isinstance(self.run, RunKind):
            raise InputError(f"run must be a RunKind, got {self.run!r}")
        if self.law is not None and not isinstance(self.law, InputLaw):
            raise InputError(f"law must be an InputLaw or None, got {self.law!r}")
        if (self.law is not None) != (self.run is RunKind.OPEN_LOOP):
            raise InputError(f"an open-loop experiment has an input law and no other has one, got run={self.run}, "
                             f"law={self.law}")
        if self.run is RunKind.STATIC_CURVE and not self.locked:
            raise InputError("a static curve runs with the pendulum clamped (locked=True)")


#: Ways the paper's experiments run (:attr:`ExperimentSpec.kind`).
_STATIC = ExperimentKind(RunKind.STATIC_CURVE, locked=True)
_STATIC_COMPENSATED = ExperimentKind(RunKind.STATIC_CURVE, compensated=True, locked=True)
_CLAMPED_SINE = ExperimentKind(RunKind.OPEN_LOOP, InputLaw.SINE, compensated=True, locked=True)
_CLAMPED_CHIRP = ExperimentKind(RunKind.OPEN_LOOP, InputLaw.CHIRP, compensated=True, locked=True)
_FREE_CHIRP = ExperimentKind(RunKind.OPEN_LOOP, InputLaw.CHIRP, compensated=True)
_RELEASE = ExperimentKind(RunKind.RELEASE)
_CLOSED_LOOP = ExperimentKind(RunKind.CLOSED_LOOP, compensated=True)


@dataclass(frozen=True)
class ExperimentSpec:
    """One of the paper's experiments.

    Attributes
    ----------
    name : str
        Name for :meth:`VirtualRig.run` and ``iwp rig run``.
    description : str
        One line.
    reference : str
        Where it is in the paper.
    settings : dict
        The paper's settings (defaults of the run).
    options : tuple of str
        The overrides :meth:`VirtualRig.run` accepts for it.
    session : str
        The session of the paper's experiments it belongs to: ``"5.1"`` (the
        motor-disk experiments of section 5.1) or ``"5.2"`` (the free
        pendulum, the full chirp and the closed loop of sections 5.2 and 5.3).
        The truth may differ between sessions
        (:attr:`iwp.rig.RigTruth.resistance_ratio`).
    kind : ExperimentKind
        How it runs (keyword only): the rigs dispatch on it, never on the name.

    Raises
    ------
    InputError
        A ``kind`` that is not an :class:`ExperimentKind`, or one that the settings contradict (``locked``,
        ``v_dz`` present or not).
    """

    name: str
    description: str
    reference: str
    settings: dict
    options: tuple[str, ...]
    session: str = "5.1"
    kind: ExperimentKind = field(kw_only=True)

    def __post_init__(self):
        if not isinstance(self.kind, ExperimentKind):
            raise InputError(f"experiment {self.name!r}: kind must be an ExperimentKind, got {self.kind!r}")
        if bool(self.settings.get("locked", False)) != self.kind.locked:
            raise InputError(f"experiment {self.name!r}: settings locked={self.settings.get('locked')!r} "
                             f"contradict its kind (locked={self.kind.locked})")
        if (self.settings.get("v_dz") is not None) != self.kind.compensated:
            raise InputError(f"experiment {self.name!r}: settings v_dz={self.settings.get('v_dz')!r} contradict "
                             f"its kind (compensated={self.kind.compensated})")

    def settings_text(self) -> str:
        """The settings as ``key=value`` pairs."""
        return ", ".join(f"{k}={_fmt(v)}" for k, v in self.settings.items())


def _fmt(v) -> str:
    if isinstance(v, (list, tuple)):
        return "[" + ",".join(_fmt(e) for e in v) + "]"
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


_COMMON = ("duration", "seed", "noise_std")
_STATIC_OPTS = ("amplitude", "step", "duration", "seed", "noise_std")

#: The paper's experiments by name, in the paper's order.
EXPERIMENTS: dict[str, ExperimentSpec] = {
    spec.name: spec
    for spec in [
        ExperimentSpec(
            "static-curve",
            "static curve v -> steady disk velocity, no compensation, pendulum locked",
            "section 5.1, figure 2(a)",
            {"input": "v", "amplitude": 100.0, "step": 2.0, "duration": 6.0, "locked": True, "compensated": False},
            _STATIC_OPTS,
            kind=_STATIC,
        ),
        ExperimentSpec(
            "static-curve-compensated",
            "static curve u -> steady disk velocity through the feedforward v = u + 31 sgn u, pendulum locked",
            "section 5.1, figure 2(b)",
            {"input": "u", "amplitude": 60.0, "step": 2.0, "duration": 6.0, "locked": True, "v_dz": PAPER_V_DZ},
            _STATIC_OPTS + ("v_dz",),
            kind=_STATIC_COMPENSATED,
        ),
        ExperimentSpec(
            "motor-disk-chirp",
            "chirp u = 60 sin((3.2 + t/75) t), pendulum locked, compensated",
            "section 5.1 (identification of p2(1+rho), p3(1+rho))",
            {"amplitude": 60.0, "w0": 3.2, "tau": 75.0, "duration": 300.0, "locked": True, "v_dz": PAPER_V_DZ},
            ("amplitude",) + _COMMON + ("v_dz",),
            kind=_CLAMPED_CHIRP,
        ),
        *[
            ExperimentSpec(
                f"sine-{A}",
                f"sinusoid u = {A} sin(5 t), pendulum locked, compensated",
                f"section 5.1, figure {'3(a)' if A == 60 else '3(b)' if A == 40 else '4'}",
                {"amplitude": float(A), "omega": 5.0, "duration": 20.0, "locked": True, "v_dz": PAPER_V_DZ},
                ("amplitude",) + _COMMON + ("v_dz",),
                kind=_CLAMPED_SINE,
            )
            for A in (60, 40, 20)
        ],
        ExperimentSpec(
            "free-pendulum",
            "free pendulum released from q1 = -1.422 rad at rest, u = 0",
            "section 5.2, figure 8 (the caption says -1.442 rad, ERRATA item 4)",
            {"x0": [-1.422, 0.0, 0.0, 0.0], "duration": 60.0, "locked": False},
            _COMMON + ("x0",),
            "5.2",
            kind=_RELEASE,
        ),
        ExperimentSpec(
            "full-chirp",
            "chirp u = 60 sin((3 + t/100) t), pendulum free, compensated",
            "section 5.2, eq. (16), figure 9",
            {"amplitude": 60.0, "w0": 3.0, "tau": 100.0, "duration": 300.0, "locked": False, "v_dz": PAPER_V_DZ},
            ("amplitude",) + _COMMON + ("v_dz", "x0"),
            "5.2",
            kind=_FREE_CHIRP,
        ),
        ExperimentSpec(
            "closed-loop",
            "Hopf anticontrol u = k1 q3 + k2 q3^3 on the measured q1, sampled every Ts, compensated",
            "section 5.3, figure 10 (amplitude ~2.58 rad)",
            {"k1": -10.0, "k2": 0.1, "x0": [0.3, 0.0, 0.0, 0.0], "duration": 60.0, "locked": False,
             "v_dz": PAPER_V_DZ, "filter_tau": VELOCITY_FILTER_TAU},
            _COMMON + ("k1", "k2", "x0", "v_dz", "filter_tau"),
            "5.2",
            kind=_CLOSED_LOOP,
        ),
    ]
}


def list_experiments() -> list[ExperimentSpec]:
    """The paper's experiments, in the paper's order (name, description, reference, settings).

    Examples
    --------
    >>> from iwp.rig import list_experiments
    >>> [spec.name for spec in list_experiments()]  # doctest: +NORMALIZE_WHITESPACE
    ['static-curve', 'static-curve-compensated', 'motor-disk-chirp', 'sine-60', 'sine-40', 'sine-20',
     'free-pendulum', 'full-chirp', 'closed-loop']
    >>> spec = list_experiments()[3]
    >>> spec.reference, spec.settings["amplitude"], spec.settings["duration"]  # input units, s
    ('section 5.1, figure 3(a)', 60.0, 20.0)
    """
    return list(EXPERIMENTS.values())


def experiment_spec(name: str) -> ExperimentSpec:
    """The experiment ``name``; an :class:`InputError` listing the valid names for an unknown one.

    Parameters
    ----------
    name : str
        Experiment name, a key of :data:`EXPERIMENTS`.

    Returns
    -------
    ExperimentSpec
        The experiment's description and default settings.
    """
    if not isinstance(name, str) or name not in EXPERIMENTS:
        raise InputError(f"unknown experiment {name!r}; valid: {', '.join(EXPERIMENTS)}")
    return EXPERIMENTS[name]

"""The paper's experiments, by name, with their settings and inputs.

``static-curve``, ``static-curve-compensated`` (figure 2), ``motor-disk-chirp``
(section 5.1), ``sine-60``, ``sine-40``, ``sine-20`` (figures 3, 4),
``free-pendulum`` (figure 8), ``full-chirp`` (figure 9) and ``closed-loop``
(figure 10), each with the paper's settings (:data:`EXPERIMENTS`,
:func:`list_experiments`). :func:`open_loop_input` gives the ideal input
``u(t)`` an open-loop experiment applies; the checks of the options that
:meth:`iwp.rig.VirtualRig.run` accepts are here too.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..checks import check_finite, check_nonnegative
from ..errors import InputError
from ..sim.inputs import Chirp, Input, Sine

__all__ = [
    "ExperimentSpec",
    "EXPERIMENTS",
    "PAPER_V_DZ",
    "VELOCITY_FILTER_TAU",
    "list_experiments",
    "experiment_spec",
    "open_loop_input",
]

#: The paper's dead-zone compensation threshold ``v_dz`` (section 5.1) [input units].
PAPER_V_DZ = 31.0
#: Time constant of the first-order filter of the rig's velocity estimate [s].
VELOCITY_FILTER_TAU = 0.01


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
    """

    name: str
    description: str
    reference: str
    settings: dict
    options: tuple[str, ...]
    session: str = "5.1"

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
        ),
        ExperimentSpec(
            "static-curve-compensated",
            "static curve u -> steady disk velocity through the feedforward v = u + 31 sgn u, pendulum locked",
            "section 5.1, figure 2(b)",
            {"input": "u", "amplitude": 60.0, "step": 2.0, "duration": 6.0, "locked": True, "v_dz": PAPER_V_DZ},
            _STATIC_OPTS + ("v_dz",),
        ),
        ExperimentSpec(
            "motor-disk-chirp",
            "chirp u = 60 sin((3.2 + t/75) t), pendulum locked, compensated",
            "section 5.1 (identification of p2(1+rho), p3(1+rho))",
            {"amplitude": 60.0, "w0": 3.2, "tau": 75.0, "duration": 300.0, "locked": True, "v_dz": PAPER_V_DZ},
            ("amplitude",) + _COMMON + ("v_dz",),
        ),
        *[
            ExperimentSpec(
                f"sine-{A}",
                f"sinusoid u = {A} sin(5 t), pendulum locked, compensated",
                f"section 5.1, figure {'3(a)' if A == 60 else '3(b)' if A == 40 else '4'}",
                {"amplitude": float(A), "omega": 5.0, "duration": 20.0, "locked": True, "v_dz": PAPER_V_DZ},
                ("amplitude",) + _COMMON + ("v_dz",),
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
        ),
        ExperimentSpec(
            "full-chirp",
            "chirp u = 60 sin((3 + t/100) t), pendulum free, compensated",
            "section 5.2, eq. (16), figure 9",
            {"amplitude": 60.0, "w0": 3.0, "tau": 100.0, "duration": 300.0, "locked": False, "v_dz": PAPER_V_DZ},
            ("amplitude",) + _COMMON + ("v_dz", "x0"),
            "5.2",
        ),
        ExperimentSpec(
            "closed-loop",
            "Hopf anticontrol u = k1 q3 + k2 q3^3 on the measured q1, sampled every Ts, compensated",
            "section 5.3, figure 10 (amplitude ~2.58 rad)",
            {"k1": -10.0, "k2": 0.1, "x0": [0.3, 0.0, 0.0, 0.0], "duration": 60.0, "locked": False,
             "v_dz": PAPER_V_DZ, "filter_tau": VELOCITY_FILTER_TAU},
            _COMMON + ("k1", "k2", "x0", "v_dz", "filter_tau"),
            "5.2",
        ),
    ]
}


def list_experiments() -> list[ExperimentSpec]:
    """The paper's experiments, in the paper's order (name, description, reference, settings)."""
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


def open_loop_input(name: str, settings: Mapping[str, Any]) -> Input | None:
    """The ideal input ``u(t)`` of the open-loop experiment ``name`` with ``settings``; ``None`` for the others.

    The sinusoids ``u = A sin(omega t)`` (figures 3, 4) and the chirps
    ``u = A sin((w0 + t/tau) t)`` (section 5.1 and eq. (16)).

    Parameters
    ----------
    name : str
        Experiment name.
    settings : mapping of str to object
        Its settings: ``amplitude`` [input units], and ``omega`` [rad/s] (sinusoids) or ``w0`` [rad/s] and
        ``tau`` [s^2/rad] (chirps).

    Returns
    -------
    Input or None
        :class:`Sine` for ``"sine-*"``, :class:`Chirp` for ``"*chirp"``, None otherwise.

    Raises
    ------
    InputError
        A non-finite amplitude.
    """
    if name.startswith("sine-"):
        return Sine(check_finite("amplitude", settings["amplitude"]), settings["omega"])
    if name.endswith("chirp"):
        return Chirp(check_finite("amplitude", settings["amplitude"]), settings["w0"], settings["tau"])
    return None


# --------------------------------------------------------------------------
# checks of the run options
# --------------------------------------------------------------------------
def check_seed(seed) -> int:
    """``seed`` as an int >= 0 (the noise seed of ``numpy.random.default_rng``)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be an integer >= 0, got {seed!r}")
    return int(seed)


def compensation_thresholds(v_dz) -> tuple[float, float] | None:
    """The thresholds ``(v+, v-)`` of the rig's feedforward (7)-(8) [input units].

    ``v_dz``: ``None`` (no compensation), a number (both sides) or a pair ``(v+, v-)``.
    """
    if v_dz is None:
        return None
    if isinstance(v_dz, (list, tuple, np.ndarray)):
        if len(v_dz) != 2:
            raise InputError(f"v_dz must be a number or a pair (v_dz_pos, v_dz_neg), got {list(v_dz)!r}")
        pos, neg = v_dz
    else:
        pos = neg = v_dz
    return (check_nonnegative("v_dz (positive side)", pos), check_nonnegative("v_dz (negative side)", neg))


def initial_state(x0, what: str = "x0") -> np.ndarray:
    """``x0`` (``q1`` or ``[q1, q2, q3, q4]`` [rad, rad/s]) as the 4 states of the pendulum and disk."""
    if np.isscalar(x0):
        x0 = [x0, 0.0, 0.0, 0.0]
    try:
        x = np.array(x0, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError(f"{what} must be q1 or [q1, q2, q3, q4] (numbers), got {x0!r}") from None
    if x.size == 1:
        x = np.array([x[0], 0.0, 0.0, 0.0])
    if x.size != 4:
        raise InputError(f"{what} must be q1 or [q1, q2, q3, q4], got {x.size} values")
    if not np.all(np.isfinite(x)):
        raise InputError(f"{what} must be finite, got {x.tolist()}")
    return x

"""What a controller faces on the rig (sections 5 and 5.1): dead zone, encoders, sampling, saturation."""

from __future__ import annotations

from dataclasses import dataclass

from ..checks import check_nonnegative, check_positive
from ..errors import InputError
from ..models.encoder import encoder_step
from ..models.parameters import LumpedParameters
from ..models.plant import Plant
from ..sim.options import Feedforward, SimOptions
from .closed_loop import lumped_parameters

__all__ = ["RigConditions"]


@dataclass(frozen=True)
class RigConditions:
    """What the controller faces on the rig (sections 5 and 5.1).

    The plant is the raw model (6) with an asymmetric dead zone
    ``v+ = v_dz_pos, v- = v_dz_neg``; the controller compensates it with the
    feedforward (7)-(8) using a single threshold ``v_comp`` (the paper's
    31), measures both angles with encoders of ``counts_per_rev`` counts
    (2000: 318.31 counts/rad), estimates the velocities with an observer,
    and runs every ``Ts``; the ideal input is clipped to ``|u| <= u_max``.

    Attributes
    ----------
    v_dz_pos, v_dz_neg : float
        Dead-zone thresholds of the plant [input units].
    v_comp : float
        Threshold of the feedforward compensation [input units].
    counts_per_rev : int
        Encoder resolution; 0 disables the quantisation.
    Ts : float
        Controller sample period [s].
    u_max : float
        Saturation of the ideal input ``u`` [input units]; the command is
        ``v = u +- v_comp``.
    sigma_q3, sigma_q4 : float
        Process-noise intensities of the observer's Kalman gain on the
        pendulum and disk accelerations [rad/s^2].
    """

    v_dz_pos: float = 33.0
    v_dz_neg: float = 29.0
    v_comp: float = 31.0
    counts_per_rev: int = 2000
    Ts: float = 0.005
    u_max: float = 100.0
    sigma_q3: float = 0.1
    sigma_q4: float = 3.0

    def __post_init__(self):
        check_nonnegative("v_dz_pos", self.v_dz_pos)
        check_nonnegative("v_dz_neg", self.v_dz_neg)
        check_nonnegative("v_comp", self.v_comp)
        if int(self.counts_per_rev) != self.counts_per_rev or self.counts_per_rev < 0:
            raise InputError(f"counts_per_rev must be a non-negative integer, got {self.counts_per_rev!r}")
        check_positive("Ts", self.Ts)
        check_positive("u_max", self.u_max)
        check_positive("sigma_q3", self.sigma_q3)
        check_positive("sigma_q4", self.sigma_q4)

    @property
    def quantum(self) -> float:
        """Encoder step [rad] (0: no quantisation)."""
        return encoder_step(self.counts_per_rev) if self.counts_per_rev else 0.0

    def plant_params(self, params: LumpedParameters) -> LumpedParameters:
        """``params`` with the rig's dead zone."""
        return lumped_parameters(params).replace(v_dz_pos=float(self.v_dz_pos), v_dz_neg=float(self.v_dz_neg))

    def plant(self, params: LumpedParameters) -> Plant:
        """The rig's plant: the raw model (6) with ``params`` and the rig's dead zone."""
        return Plant(self.plant_params(params), model="raw")

    @property
    def feedforward(self) -> tuple[float, float]:
        """The controller's feedforward thresholds ``(v_comp, v_comp)`` (7)-(8) [input units]."""
        return float(self.v_comp), float(self.v_comp)

    def simulate_options(self) -> SimOptions:
        """The options of :func:`iwp.sim.simulate` for this rig's plant (:meth:`plant`): its feedforward."""
        return SimOptions(feedforward=Feedforward(*self.feedforward))

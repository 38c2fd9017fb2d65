"""The belt (15) between motor and wheel: its parameters (:class:`BeltParameters`) and what iwp knows of each.

A module of its own so that the optional terms (:mod:`iwp.models.terms`), of
which the belt is one, and the parameter sets (:mod:`iwp.models.parameters`,
which re-exports these) both build on it.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from ..errors import InputError
from .parameter_info import ParameterInfo, check_fields, info_table, names_with_sign

__all__ = ["BELT_INFO", "BeltParameters"]

#: The belt (15) and figure 5, by name.
BELT_INFO: dict[str, ParameterInfo] = info_table("belt", (
    ("k_over_I2", "1/s^2", 60.0, "positive", "belt stiffness over the disk inertia", (1.0, 1e6)),
    ("d", "rad", 2.0, "nonnegative", "half-width of the belt's play (figure 5)", (1e-4, 20.0)),
    ("N", "-", 13.5, "positive", "reduction ratio (measured)"),
    ("b2_over_I2", "1/s", 10.0, "nonnegative", "viscous friction of the disk over its inertia", (1e-4, 100.0)),
    ("k_over_gamma", "1/s", 780.0, "positive", "belt stiffness over the motor's damping gamma", (1e-2, 1e9)),
    ("kTbeta_over_Rgamma", "rad/(s in)", 26.0, "positive", "motor's no-load speed per input unit", (1e-2, 1e4)),
    ("gain_neg", "-", 1.0, "positive", "motor gain for a negative over a positive input (section 3.2)", (0.3, 3.0)),
))


@dataclass(frozen=True)
class BeltParameters:
    """Flexible rubber belt of equation (15) with the hysteresis of figure 5.

    The motor inertia ``J_m`` is neglected (as in the paper), so the motor
    position ``q_m`` follows ``gamma q_m' - Psi/N = (kT beta / R) u``. The
    parameters are normalised as the paper gives them. ``Psi`` is the belt
    force: a linear spring ``k`` acting on the output of a play (backlash)
    operator of half-width ``d`` applied to the belt stretch
    ``delta = q2 - q_m / N`` (our reading of figure 5, whose drawing is not in
    the text: a parallelogram loop of slope ``k`` and width ``2 d``).

    Parameters
    ----------
    k_over_I2 : float
        Belt stiffness over the disk inertia ``k / I2`` [s^-2].
    d : float
        Half-width of the hysteresis (play) [rad of disk angle].
    N : float
        Reduction ratio [-].
    b2_over_I2 : float
        Viscous friction of the disk joint over its inertia ``b2 / I2`` [s^-1].
    k_over_gamma : float
        ``k / gamma`` with ``gamma = N^2 kT kF / R + b_m`` [s^-1].
    kTbeta_over_Rgamma : float
        ``kT beta / (R gamma)`` [rad s^-1 per input unit]: the motor's no-load
        speed per input unit (for a positive net input).
    gain_neg : float
        Ratio of the motor gain ``N kT / R`` for a negative net input to that
        for a positive one [-]; section 3.2: "a more general model may also
        use different values for coefficient ``N kT / R`` depending on the sign
        of ``V_i``". 1 (symmetric) by default. It scales the dead zone's
        torque (5) with the drive, since both are ``N kT / R`` times a voltage.
    """

    k_over_I2: float = 60.0  # [s^-2]
    d: float = 2.0  # [rad]
    N: float = 13.5  # [-]
    b2_over_I2: float = 10.0  # [s^-1]
    k_over_gamma: float = 780.0  # [s^-1]
    kTbeta_over_Rgamma: float = 26.0  # [rad s^-1 / in]
    gain_neg: float = 1.0  # [-]

    def __post_init__(self) -> None:
        check_fields(self, "BeltParameters", positive=names_with_sign(BELT_INFO, "positive"),
                     nonneg=names_with_sign(BELT_INFO, "nonnegative"))

    @property
    def rigid_p2rho(self) -> float:
        """Disk damping of the rigid limit ``(b2 + N^2 gamma) / I2`` [s^-1]."""
        gamma_over_I2 = self.k_over_I2 / self.k_over_gamma
        return self.b2_over_I2 + self.N**2 * gamma_over_I2

    @property
    def rigid_p3rho(self) -> float:
        """Input gain of the rigid limit ``N kT beta / (R I2)`` [rad s^-2 / in]."""
        gamma_over_I2 = self.k_over_I2 / self.k_over_gamma
        return self.N * self.kTbeta_over_Rgamma * gamma_over_I2

    @classmethod
    def from_rigid(
        cls,
        p2rho: float,
        p3rho: float,
        *,
        k_over_I2: float,
        d: float,
        N: float = 13.5,
        b2_over_I2: float = 0.5,
        gain_neg: float = 1.0,
    ) -> "BeltParameters":
        """A belt whose rigid limit (``k -> inf``, ``d = 0``) has the given disk dynamics.

        With the pendulum locked the rigid model is
        ``q4' = -p2rho q4 + p3rho u``; this solves
        ``p2rho = b2/I2 + N^2 gamma/I2`` and ``p3rho = N kT beta / (R I2)``
        for ``gamma`` and ``kT beta / R``.

        Parameters
        ----------
        p2rho, p3rho : float
            Rigid-limit damping [s^-1] and gain [rad s^-2 / in] (for a free
            pendulum these are ``p2 rho`` and ``p3 rho``).
        k_over_I2, d, N, b2_over_I2, gain_neg : float
            As in the class; ``b2_over_I2`` must be below ``p2rho``; ``p3rho``
            is the gain for a positive input.
        """
        if not b2_over_I2 < p2rho:
            raise InputError(
                f"b2_over_I2 = {b2_over_I2} must be below the rigid damping p2rho = {p2rho}"
            )
        gamma_over_I2 = (p2rho - b2_over_I2) / N**2
        return cls(
            k_over_I2=k_over_I2,
            d=d,
            N=N,
            b2_over_I2=b2_over_I2,
            k_over_gamma=k_over_I2 / gamma_over_I2,
            kTbeta_over_Rgamma=p3rho / N / gamma_over_I2,
            gain_neg=gain_neg,
        )

    def to_dict(self) -> dict[str, float]:
        """Field name -> value."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}

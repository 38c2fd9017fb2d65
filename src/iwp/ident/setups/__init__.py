"""The identification set-ups of section 5, one file each.

==================  ======================  ==========================================
name                class                   paper
==================  ======================  ==========================================
``full``            :class:`Full`           (10)-(12), eq. (16)
``motor-disk``      :class:`MotorDisk`      theta^a, section 5.1, eq. (14)
``motor-disk-       :class:`MotorDisk-      theta^b, section 5.1 (Coulomb)
coulomb``           Coulomb`
``free``            :class:`FreePendulum`   theta^c, section 5.2
``two-step``        :class:`TwoStep`        theta^d, section 5.2
``dead-zone``       :class:`DeadZone`       (5)/(8) from a static curve, figure 2a
==================  ======================  ==========================================
"""

from __future__ import annotations

from ...errors import InputError
from .base import PARAMETER_UNITS, PENDULUM, Derived, RefineSpec, Regression, Setup
from .dead_zone import DeadZone, StaticFit, fit_static_curve
from .free import FreePendulum, known_p2
from .full import Full
from .motor_disk import MotorDisk, MotorDiskCoulomb
from .two_step import TwoStep, pendulum_values

#: The set-ups by name, in the paper's order.
SETUPS: dict[str, Setup] = {s.name: s for s in (Full(), MotorDisk(), MotorDiskCoulomb(), FreePendulum(), TwoStep(),
                                                 DeadZone())}
#: Parameters each set-up identifies (``rho`` of "full" and "two-step" is derived).
PARAMETER_NAMES: dict[str, tuple[str, ...]] = {name: s.parameters for name, s in SETUPS.items()}


def get_setup(name: str) -> Setup:
    """The set-up called ``name``; a clear error for an unknown one.

    Parameters
    ----------
    name : str
        Set-up name, a key of :data:`SETUPS` (``"full"``, ``"free"``, ``"two-step"``, ``"dead-zone"``, ...).

    Returns
    -------
    Setup
        The set-up.

    Raises
    ------
    InputError
        Not a string, or an unknown name (the message lists the set-ups).

    Examples
    --------
    >>> from iwp.ident import get_setup
    >>> setup = get_setup("two-step")  # theta^d of section 5.2
    >>> setup.paper, setup.parameters
    ('theta^d, section 5.2', ('p2', 'p3', 'p2_1rho', 'p3_1rho', 'rho'))
    >>> setup.refine  # what its refinement by simulation error frees and compares
    RefineSpec(model='compensated', free=('p2', 'p3', 'rho'), outputs=('q1', 'q4'))
    """
    if not isinstance(name, str) or name not in SETUPS:
        raise InputError(f"unknown set-up {name!r}: setup must be one of {', '.join(SETUPS)}")
    return SETUPS[name]


__all__ = [
    "PARAMETER_NAMES", "PARAMETER_UNITS", "PENDULUM", "SETUPS", "DeadZone", "Derived", "FreePendulum", "Full",
    "MotorDisk", "MotorDiskCoulomb", "RefineSpec", "Regression", "Setup", "StaticFit", "TwoStep", "fit_static_curve",
    "get_setup", "known_p2", "pendulum_values",
]

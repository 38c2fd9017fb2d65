"""Feedback laws written once, for the simulator, the analysis and the rig.

:func:`hopf_law` is the amplitude controller of section 5.3, based on the
anticontrol of Hopf bifurcations (reference [15] of the paper).
"""

from __future__ import annotations

from ..jit import jit


@jit
def hopf_law(k1, k2, q3):
    """The Hopf anticontrol law ``u = k1 q3 + k2 q3^3`` (section 5.3) [input units].

    ``k1`` [input units s/rad], ``k2`` [input units s^3/rad^3], ``q3`` the
    pendulum velocity [rad/s]. Works element-wise on arrays too.
    """
    return k1 * q3 + k2 * q3 * q3 * q3

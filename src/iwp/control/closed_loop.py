"""Model (9) under the Hopf law, on the reduced state ``(q1, q3, q4)``.

``q2`` (the disk angle) is cyclic: it enters no right-hand side, so the
analysis of the closed loop works on ``z = (q1, q3, q4)``, the entries
:data:`REDUCED` of the state ``x = [q1, q2, q3, q4]``. The closed loop is
evaluated through :meth:`iwp.models.Plant.rhs` with
:func:`iwp.models.laws.hopf_law`: no model equation and no copy of the law
is written here.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..models.laws import hopf_law
from ..models.parameters import LumpedParameters, PhysicalParameters
from ..models.plant import Plant

__all__ = ["REDUCED", "lumped_parameters", "lift", "hopf_rate"]

#: Indices of the reduced state ``(q1, q3, q4)`` inside ``x = [q1, q2, q3, q4]``.
REDUCED = (0, 2, 3)


def lumped_parameters(params) -> LumpedParameters:
    """``params`` as :class:`LumpedParameters` (physical ones are mapped, section 4).

    Parameters
    ----------
    params : LumpedParameters or PhysicalParameters
        The plant's parameters.

    Returns
    -------
    LumpedParameters
        ``params`` itself, or the lumped parameters of physical ones.

    Raises
    ------
    InputError
        For anything else.
    """
    if isinstance(params, PhysicalParameters):
        params = params.to_lumped()
    if not isinstance(params, LumpedParameters):
        raise InputError(f"params must be LumpedParameters, got {type(params).__name__}")
    return params


def lift(z) -> np.ndarray:
    """``(q1, q3, q4) -> [q1, 0, q3, q4]`` (the cyclic ``q2`` set to 0).

    Parameters
    ----------
    z : array_like, shape (3,)
        Reduced state ``(q1, q3, q4)`` [rad, rad/s, rad/s].

    Returns
    -------
    ndarray, shape (4,)
        Full state ``[q1, q2, q3, q4]`` with ``q2 = 0`` [rad, rad, rad/s, rad/s].
    """
    z = np.asarray(z, dtype=float)
    return np.array([z[0], 0.0, z[1], z[2]])


def hopf_rate(plant: Plant, k1: float, k2: float, z) -> np.ndarray:
    """``z' = f(z, u)`` of the reduced closed loop with ``u = k1 q3 + k2 q3^3`` (section 5.3).

    Parameters
    ----------
    plant : Plant
        Model (9) (or any plant whose input is ``u``).
    k1, k2 : float
        Gains [input units s/rad, input units s^3/rad^3].
    z : array_like, shape (3,)
        ``(q1 [rad], q3 [rad/s], q4 [rad/s])``.

    Returns
    -------
    ndarray, shape (3,)
        ``(q1', q3', q4')`` [rad/s, rad/s^2, rad/s^2].
    """
    x = lift(z)
    return plant.rhs(x, hopf_law(k1, k2, x[2]))[list(REDUCED)]

"""Energy and linearisation of the models.

:func:`energy` is the kinetic and potential energy of eq. (2);
:func:`linearize` the Jacobian of model (9) at an equilibrium, and
:func:`to_statespace` the same as a python-control system.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from .parameters import LumpedParameters, PhysicalParameters


def energy(params, x) -> dict[str, np.ndarray]:
    """Kinetic and potential energy.

    For :class:`PhysicalParameters`, in joules:
    ``T = 1/2 I1_hat q3^2 + 1/2 I2 (q3 + q4)^2`` and
    ``V = (m1 c + m2 l) g (1 - cos q1)`` (eq. (2)).
    For :class:`LumpedParameters`, per unit ``I1_hat`` [s^-2]:
    ``T = 1/2 q3^2 + 1/2 (q3 + q4)^2 / rho`` and ``V = p1 (1 - cos q1)``.

    Parameters
    ----------
    params : PhysicalParameters or LumpedParameters
        The parameter set; its kind sets the unit of the result.
    x : array_like, shape (4,) or (n, 4)
        States ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s].

    Returns
    -------
    dict
        ``{"kinetic": T, "potential": V, "total": T + V}`` [J, or s^-2 per
        unit ``I1_hat`` for lumped parameters].

    Examples
    --------
    >>> import numpy as np
    >>> from iwp import energy, table1
    >>> e = energy(table1(), np.array([[np.pi, 0.0, 0.0, 0.0]]))  # at rest, upright
    >>> float(e["kinetic"][0]), float(e["potential"][0])  # 2 p1 [1/s^2]
    (0.0, 52.19)
    """
    x = np.asarray(x, dtype=float)
    q1, q3, q4 = x[..., 0], x[..., 2], x[..., 3]
    if isinstance(params, PhysicalParameters):
        T = 0.5 * params.I1_hat * q3**2 + 0.5 * params.I2 * (q3 + q4) ** 2
        V = (params.m1 * params.c + params.m2 * params.l) * params.g * (1.0 - np.cos(q1))
    else:
        T = 0.5 * q3**2 + 0.5 * (q3 + q4) ** 2 / params.rho
        V = params.p1 * (1.0 - np.cos(q1))
    return {"kinetic": T, "potential": V, "total": T + V}


def pendulum_energy(params: LumpedParameters, x) -> np.ndarray:
    """Energy of the pendulum alone per unit ``I1_hat`` [s^-2]: ``q3^2/2 + p1 (1 - cos q1)``.

    Zero hanging at rest, ``2 p1`` upright at rest (the swing-up's target).

    Parameters
    ----------
    params : LumpedParameters
        Its ``p1`` [1/s^2] (eq. (9)).
    x : array_like, shape (4,) or (n, 4)
        States ``[q1, q2, q3, q4]`` [rad, rad, rad/s, rad/s].

    Returns
    -------
    ndarray
        The energy [1/s^2], one per state.

    See Also
    --------
    energy : The energy of the whole pendulum and wheel.

    Examples
    --------
    Hanging at rest, upright at rest (``2 p1``), and swinging through the bottom at 5 rad/s:

    >>> import numpy as np
    >>> from iwp import table1
    >>> from iwp.models import pendulum_energy
    >>> pendulum_energy(table1(), [[0, 0, 0, 0], [np.pi, 0, 0, 0], [0, 0, 5.0, 0]])
    array([ 0.  , 52.19, 12.5 ])
    """
    x = np.asarray(x, dtype=float)
    return 0.5 * x[..., 2] ** 2 + params.p1 * (1.0 - np.cos(x[..., 0]))


EQUILIBRIA = {"down": 0.0, "hanging": 0.0, "up": math.pi, "upright": math.pi}


def linearize(params: LumpedParameters, equilibrium: str = "down") -> tuple[np.ndarray, np.ndarray]:
    """Linearisation ``(A, B)`` of the compensated model (9) at an equilibrium.

    At ``q1* = 0`` (``"down"``) or ``pi`` (``"up"``), ``q2`` arbitrary,
    ``q3 = q4 = 0``, ``u = 0``:

    ``A = [[0, 0, 1, 0], [0, 0, 0, 1], [-c, 0, -s, p2], [c, 0, s, -p2 (1 + rho)]]``,
    ``B = [0, 0, -p3, p3 (1 + rho)]^T`` with ``c = p1 cos q1*`` and
    ``s = sigma~_a1 + sigma~_v1`` (the ``q3^3`` term has zero slope). The
    Coulomb term is not part of (9) and is ignored.

    Parameters
    ----------
    params : LumpedParameters
        The parameters of model (9).
    equilibrium : {"down", "up"}
        The hanging (``q1* = 0``) or the upright (``q1* = pi``) equilibrium.

    Returns
    -------
    A : ndarray, shape (4, 4)
        State matrix [1/s, 1/s^2] of the state ``[q1, q2, q3, q4]``.
    B : ndarray, shape (4, 1)
        Input matrix [rad/(s^2 input unit)].

    Examples
    --------
    >>> import numpy as np
    >>> from iwp import linearize, table1
    >>> A, B = linearize(table1(), "up")
    >>> A.shape, B.shape
    ((4, 4), (4, 1))
    >>> bool(np.linalg.eigvals(A).real.max() > 0)  # the upright is unstable
    True
    """
    if equilibrium not in EQUILIBRIA:
        raise InputError(f"equilibrium must be one of {', '.join(EQUILIBRIA)}, got {equilibrium!r}")
    q1s = EQUILIBRIA[equilibrium]
    c = params.p1 * math.cos(q1s)
    s = params.sigma_a1 * abs(math.cos(q1s)) + params.sigma_v1
    r1 = 1.0 + params.rho
    A = np.array(
        [
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [-c, 0.0, -s, params.p2],
            [c, 0.0, s, -params.p2 * r1],
        ]
    )
    B = np.array([[0.0], [0.0], [-params.p3], [params.p3 * r1]])
    return A, B


def to_statespace(params: LumpedParameters, equilibrium: str = "down"):
    """The linearisation as a python-control ``StateSpace`` (outputs: the full state).

    Needs the optional extra: ``pip install iwp[control]``.

    Parameters
    ----------
    params : LumpedParameters
        The parameters of model (9).
    equilibrium : {"down", "up"}
        The equilibrium of :func:`linearize`.

    Returns
    -------
    control.StateSpace
        ``(A, B, I, 0)`` of :func:`linearize`: input ``u`` [input units],
        outputs ``q1, q2, q3, q4`` [rad, rad, rad/s, rad/s].

    See Also
    --------
    linearize : The same ``A`` and ``B`` as arrays.

    Examples
    --------
    Upright, model (9) has one unstable pole:

    >>> from iwp import table1
    >>> from iwp.models import to_statespace
    >>> sys = to_statespace(table1(), "up")
    >>> sys.output_labels
    ['q1', 'q2', 'q3', 'q4']
    >>> poles = sys.poles().real
    >>> int((poles > 1e-9).sum()), round(float(poles.max()), 3)  # [1/s]
    (1, 5.098)
    """
    try:
        import control
    except ImportError:  # pragma: no cover - exercised only without the extra
        raise InputError("to_statespace needs python-control: pip install 'iwp[control]'") from None
    A, B = linearize(params, equilibrium)
    return control.ss(A, B, np.eye(4), np.zeros((4, 1)), inputs=["u"], outputs=["q1", "q2", "q3", "q4"],
                      states=["q1", "q2", "q3", "q4"])

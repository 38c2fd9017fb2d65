"""Balance at the upright: an LQR on the linearisation of model (9) at ``q1 = pi`` (beyond the paper).

:func:`lqr_balance` designs the state feedback on the reduced state
``(q1 - pi, q3, q4)`` (``q2`` is cyclic and left free), continuous or
discrete (zero-order hold, the rig's 5 ms); :class:`LQRBalance` is the
saturated law, with the capture bound of the unstable mode.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm, solve_continuous_are, solve_discrete_are

from ..checks import check_positive
from ..errors import InputError
from ..models.analysis import linearize
from ..models.laws import balance_law
from ..models.parameters import LumpedParameters
from ..sim.inputs import BalanceController
from .closed_loop import REDUCED, lumped_parameters

__all__ = ["LQRBalance", "lqr_balance", "wrap_angle"]


def wrap_angle(theta):
    """``theta`` wrapped to ``[-pi, pi)`` [rad] (element-wise).

    Parameters
    ----------
    theta : float or ndarray
        Angle [rad].

    Returns
    -------
    float or ndarray
        The wrapped angle [rad], of ``theta``'s shape.
    """
    return (theta + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(frozen=True, eq=False)
class LQRBalance:
    """LQR state feedback at the upright, on the reduced state ``(q1 - pi, q3, q4)``.

    ``u = sat(-K [wrap(q1 - pi), q3, q4])`` with ``|u| <= u_max``.

    Attributes
    ----------
    K : ndarray, shape (3,)
        Gains on ``(q1 - pi, q3, q4)`` [input units per rad, per rad/s, per rad/s].
    S : ndarray, shape (3, 3)
        Solution of the Riccati equation.
    poles : ndarray, shape (3,)
        Closed-loop eigenvalues (continuous, or of the sampled loop when ``Ts`` is set).
    Q, R : ndarray
        Weights.
    Ts : float or None
        Sample period of a discrete design (ZOH) [s]; ``None``: continuous.
    u_max : float
        Input saturation [input units].
    unstable_eigenvalue : float
        The open-loop unstable eigenvalue ``lambda_u`` at the upright [1/s].
    unstable_direction : ndarray, shape (3,)
        Left eigenvector ``w`` of ``lambda_u``, scaled so that ``w[0] = 1``:
        ``w . x`` is the unstable mode in radians of ``q1``.
    capture_bound : float
        ``|w . B| u_max / lambda_u`` [rad]: beyond ``|w . x|`` greater than this, no input
        within ``u_max`` can stop the fall (linearised). The swing-up
        switches to the LQR well inside it.
    backend : str
        ``"python-control"`` or ``"scipy"``.
    """

    K: np.ndarray
    S: np.ndarray
    poles: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    Ts: float | None
    u_max: float
    unstable_eigenvalue: float
    unstable_direction: np.ndarray
    capture_bound: float
    backend: str

    @staticmethod
    def error_state(x) -> np.ndarray:
        """``(wrap(q1 - pi), q3, q4)`` from a state ``[q1, q2, q3, q4]``."""
        x = np.asarray(x, dtype=float)
        return np.array([wrap_angle(x[0] - math.pi), x[2], x[3]])

    def __call__(self, x) -> float:
        """The saturated input for the state ``x = [q1, q2, q3, q4]`` [input units].

        The law is :func:`iwp.models.laws.balance_law`, clipped to ``u_max``.
        """
        x = np.asarray(x, dtype=float)
        u = float(balance_law(float(self.K[0]), float(self.K[1]), float(self.K[2]), x[0], x[2], x[3]))
        return min(max(u, -self.u_max), self.u_max)

    def controller(self) -> BalanceController:
        """This feedback as a simulator input (sampled every ``Ts`` when the design is discrete).

        The saturation ``u_max`` is the simulator's ``saturation``.
        """
        return BalanceController(float(self.K[0]), float(self.K[1]), float(self.K[2]), self.Ts)

    def to_dict(self) -> dict:
        """The design as JSON-ready values: ``K``, the closed-loop ``poles`` as ``[re, im]``, ``Ts``, ``u_max``,
        the open-loop unstable eigenvalue and direction, the capture bound and the backend."""
        return {"K": self.K.tolist(), "poles": [[float(p.real), float(p.imag)] for p in self.poles], "Ts": self.Ts,
                "u_max": self.u_max, "unstable_eigenvalue": self.unstable_eigenvalue,
                "unstable_direction": self.unstable_direction.tolist(), "capture_bound": self.capture_bound,
                "backend": self.backend}

    def capture_ratio(self, x) -> float:
        """The unstable mode over the capture bound, ``abs(w @ x) / capture_bound``: below 1 the fall can be stopped."""
        return abs(float(self.unstable_direction @ self.error_state(x))) / self.capture_bound


def lqr_balance(
    params: LumpedParameters,
    *,
    Q=(1.0, 0.01, 1e-4),
    R: float = 0.1,
    u_max: float = 100.0,
    Ts: float | None = None,
    backend: str = "auto",
) -> LQRBalance:
    """LQR for the upright, designed on the linearisation of (9) at ``q1 = pi``.

    The reduced linearisation ``(q1 - pi, q3, q4)`` of
    :func:`iwp.models.linearize` (``q2`` is cyclic and left free). With
    ``Ts`` the design is discrete (zero-order hold), as the controller runs
    on the rig every 5 ms.

    Parameters
    ----------
    params : LumpedParameters
    Q : sequence of 3 floats or (3, 3) array
        State weights on ``(q1 - pi [rad], q3 [rad/s], q4 [rad/s])``.
    R : float
        Input weight [1/input unit^2].
    u_max : float
        Saturation of ``u`` [input units].
    Ts : float, optional
        Sample period [s] for a discrete design; at most the e-folding time
        of the upright's instability (``1/lambda``, about 0.2 s for Table 1).
    backend : str
        ``"auto"`` (python-control when installed, else scipy),
        ``"python-control"`` or ``"scipy"``.

    Returns
    -------
    LQRBalance

    Examples
    --------
    >>> from iwp import lqr_balance, table1
    >>> L = lqr_balance(table1())
    >>> L.K.shape, bool((L.poles.real < 0).all())  # u = -K [q1 - pi, q3, q4]: the closed loop is stable
    ((3,), True)
    """
    params = lumped_parameters(params)
    u_max = check_positive("u_max", u_max)
    R = check_positive("R", R)
    Qm = np.asarray(Q, dtype=float)
    if Qm.shape == (3,):
        Qm = np.diag(Qm)
    if Qm.shape != (3, 3) or not np.all(np.isfinite(Qm)):
        raise InputError(f"Q must be 3 weights or a 3x3 matrix on (q1 - pi, q3, q4), got shape {Qm.shape}")
    if Ts is not None:
        Ts = check_positive("Ts", Ts)
    if backend not in ("auto", "python-control", "scipy"):
        raise InputError(f"backend must be 'auto', 'python-control' or 'scipy', got {backend!r}")
    A4, B4 = linearize(params, "up")
    A = A4[np.ix_(REDUCED, REDUCED)]
    B = B4[list(REDUCED)]
    lam_max = float(np.max(np.linalg.eigvals(A).real))
    if Ts is not None and Ts * lam_max > 1.0:
        raise InputError(f"Ts = {Ts:g} s is too long for the upright's instability, which grows e-fold in "
                         f"{1.0 / lam_max:.3g} s ({lam_max:.4g} 1/s); a sampled balance needs Ts <= "
                         f"{1.0 / lam_max:.3g} s", argument="Ts")
    Rm = np.array([[R]])
    ctl = None
    if backend in ("auto", "python-control"):
        try:
            import control as ctl  # optional dependency
        except ImportError:
            if backend == "python-control":
                raise InputError("backend='python-control' needs python-control: pip install 'iwp[control]'") from None
            ctl = None
    if Ts is None:
        if ctl is not None:
            K, S, _E = ctl.lqr(A, B, Qm, Rm)
        else:
            S = solve_continuous_are(A, B, Qm, Rm)
            K = np.linalg.solve(Rm, B.T @ S)
        K = np.asarray(K, dtype=float).ravel()
        poles = np.linalg.eigvals(A - B @ K[None, :])
    else:
        M = np.zeros((4, 4))
        M[:3, :3] = A
        M[:3, 3:] = B
        Md = expm(M * Ts)
        Ad, Bd = Md[:3, :3], Md[:3, 3:]
        if ctl is not None:
            K, S, _E = ctl.dlqr(Ad, Bd, Qm * Ts, Rm * Ts)
        else:
            S = solve_discrete_are(Ad, Bd, Qm * Ts, Rm * Ts)
            K = np.linalg.solve(Rm * Ts + Bd.T @ S @ Bd, Bd.T @ S @ Ad)
        K = np.asarray(K, dtype=float).ravel()
        poles = np.linalg.eigvals(Ad - Bd @ K[None, :])
    ev, W = np.linalg.eig(A.T)
    iu = int(np.argmax(ev.real))
    lam = float(ev[iu].real)
    w = W[:, iu].real
    w = w / w[0]
    bound = abs(float(w @ B.ravel())) * u_max / lam
    return LQRBalance(K=K, S=np.asarray(S, dtype=float), poles=poles, Q=Qm, R=Rm, Ts=Ts, u_max=u_max,
                      unstable_eigenvalue=lam, unstable_direction=w, capture_bound=bound,
                      backend="python-control" if ctl is not None else "scipy")

"""A state observer from the two quantised encoder angles (beyond the paper).

Prediction with model (9) over one sample with the held input (the one
integration engine, :func:`iwp.sim.simulate.integrate_held`); correction
with the steady-state Kalman gain of the sampled linearisation at the
upright.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm, solve_discrete_are

from ..checks import check_positive
from ..errors import SimulationError
from ..models.actuator import command_vector
from ..models.analysis import linearize
from ..models.parameters import LumpedParameters
from ..models.plant import Plant
from ..sim.engine import ST_OK, STATUS_TEXT
from ..sim.simulate import integrate_held, tolerances
from .closed_loop import lumped_parameters

__all__ = ["EncoderObserver", "PREDICTION_RTOL", "PREDICTION_ATOL"]

#: Error control of the one-sample prediction (relative, absolute).
PREDICTION_RTOL = 1e-10
PREDICTION_ATOL = 1e-10


class EncoderObserver:
    """State observer from the two encoder angles (quantised), every ``Ts``.

    Prediction: the compensated model (9) over one sample with the held
    input (iwp's adaptive DOP853, :func:`iwp.sim.simulate.integrate_held`).
    Correction: the steady-state Kalman gain of the ZOH-discretised
    linearisation at the upright, with process noise ``sigma_q3, sigma_q4``
    on the accelerations and the quantisation noise ``quantum^2 / 12`` on
    the angles.

    Parameters
    ----------
    params : LumpedParameters
        The controller's model.
    Ts : float
        Sample period [s].
    quantum : float
        Encoder step [rad] (for the measurement noise; 0 allowed).
    sigma_q3, sigma_q4 : float
        Process-noise intensities [rad/s^2].
    """

    def __init__(self, params: LumpedParameters, Ts: float, quantum: float, sigma_q3: float = 0.1,
                 sigma_q4: float = 3.0):
        self.params = lumped_parameters(params)
        self.Ts = check_positive("Ts", Ts)
        self.plant = Plant(self.params)
        self._tol = tolerances(self.plant.n_states, PREDICTION_RTOL, PREDICTION_ATOL)
        self._command_params = command_vector()  # the held u acts as is (model (9): no feedforward)
        A, _B = linearize(self.params, "up")
        Ad = expm(A * self.Ts)
        C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
        G = np.zeros((4, 2))
        G[2, 0] = 1.0
        G[3, 1] = 1.0
        Qd = G @ np.diag([sigma_q3**2, sigma_q4**2]) @ G.T * self.Ts
        r = max(quantum, 1e-6) ** 2 / 12.0
        Rm = np.eye(2) * r
        Pp = solve_discrete_are(Ad.T, C.T, Qd, Rm)
        self.L = Pp @ C.T @ np.linalg.inv(C @ Pp @ C.T + Rm)
        self.xhat = None
        self._h = -1.0

    def reset(self) -> None:
        self.xhat = None
        self._h = -1.0

    def predict(self, x, u: float) -> np.ndarray:
        """The state one sample after ``x`` with ``u`` held [input units] (model (9))."""
        x = np.array(x, dtype=float)
        st = integrate_held(self.plant, x, 0.0, self.Ts, float(u), command_params=self._command_params, tol=self._tol,
                            h0=self._h)
        if st.status != ST_OK:
            raise SimulationError(f"observer prediction: {STATUS_TEXT.get(int(st.status), 'failed')}")
        self._h = st.h_next
        return x

    def update(self, y, u_prev: float) -> np.ndarray:
        """Fuse the angles ``y = (q1, q2)`` measured now; ``u_prev`` was held since the last sample."""
        y = np.asarray(y, dtype=float)
        if self.xhat is None:
            self.xhat = np.array([y[0], y[1], 0.0, 0.0])
        else:
            xp = self.predict(self.xhat, u_prev)
            self.xhat = xp + self.L @ (y - xp[:2])
        return self.xhat.copy()

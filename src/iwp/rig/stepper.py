"""The virtual rig one sample at a time: the truth plant advanced by a held command, read by its encoders.

:class:`VirtualRig` runs a whole experiment at once; a device in the loop
(the emulator of :mod:`iwp.device.emulator`) needs the same truth plant one
period at a time: :class:`TwinStepper` holds its state, reads the encoders
(whole counts, with the truth's noise), advances it over one period with the
driver command held (iwp's one engine, :func:`iwp.sim.simulate.integrate_held`,
with the virtual rig's tolerances), and takes the operator's hands: clamp
the pendulum at rest (section 5.1), hold it at an angle with the wheel at
rest, release it.

The truth's sessions (:meth:`RigTruth.for_session`): the clamped
experiments of the paper were session ``"5.1"``, the free ones ``"5.2"``;
with ``session="auto"`` the stepper's motor is that of the session of the
current set-up (clamped: 5.1, free: 5.2), so that the paper's experiments
run through a device give what :class:`VirtualRig` gives.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError, SimulationError
from ..models.actuator import command_vector
from ..sim.engine import ST_OK, STATUS_TEXT
from ..sim.simulate import integrate_held, tolerances
from .run_settings import check_seed, initial_state
from .truth import SESSIONS, RigTruth, default_truth
from .virtual import RIG_ATOL, RIG_RTOL

__all__ = ["TwinStepper", "SESSION_OF_SETUP"]

#: The session of the paper's experiments with the pendulum clamped / free (``session="auto"``).
SESSION_OF_SETUP = {True: "5.1", False: "5.2"}
#: State components smaller than this are exactly 0 [rad, rad/s] (many orders below the integrator's tolerances).
_TINY = 1e-150


class TwinStepper:
    """The truth plant of the virtual rig, advanced one held command at a time.

    Parameters
    ----------
    truth : RigTruth, optional
        Default :func:`default_truth`.
    session : {"auto", "5.1", "5.2"}
        The truth's session (:meth:`RigTruth.for_session`); ``"auto"``: that
        of the current set-up (clamped: 5.1, free: 5.2).
    x0 : float or sequence of 4 floats, optional
        Initial ``q1`` or ``[q1, q2, q3, q4]`` [rad, rad/s] (default rest).
    seed : int
        Seed of the encoders' noise (the truth's ``noise_std``).
    """

    def __init__(self, truth: RigTruth | None = None, *, session: str = "auto", x0=None, seed: int = 0):
        self.base = default_truth() if truth is None else truth
        if not isinstance(self.base, RigTruth):
            raise InputError(f"truth must be a RigTruth, got {type(self.base).__name__}")
        if session != "auto" and session not in SESSIONS:
            raise InputError(f"session must be 'auto' or one of {', '.join(SESSIONS)}, got {session!r}")
        self.session = session
        self._rng = np.random.default_rng(check_seed(seed))
        self._cp = command_vector()  # the device applies feedforward and saturation: v acts as it comes
        self.t = 0.0
        self.locked = False
        self.held = False
        self._set_plant()
        x = np.zeros(self.plant.n_states)
        x[:4] = np.zeros(4) if x0 is None else initial_state(x0)
        self.x = x
        self.v = 0.0

    # ------------------------------------------------------------------
    def _set_plant(self) -> None:
        s = SESSION_OF_SETUP[self.locked] if self.session == "auto" else self.session
        self.truth = self.base.for_session(s)
        self.plant = self.truth.plant(locked=self.locked)
        self._tol = tolerances(self.plant.n_states, RIG_RTOL, RIG_ATOL)

    @property
    def step(self) -> float:
        """Encoder step [rad]."""
        return self.truth.step

    def counts(self) -> tuple[int, int]:
        """The encoders now: ``round((q + noise) / step)`` for the pendulum and the wheel [counts]."""
        q = self.x[:2]
        if self.truth.noise_std > 0:
            q = q + self._rng.normal(0.0, self.truth.noise_std, 2)
        c = np.round(q / self.step)
        return int(c[0]), int(c[1])

    def clamp(self) -> None:
        """Clamp the pendulum at rest, ``q1 = q3 = 0`` (section 5.1); the wheel keeps turning."""
        self.x[0] = 0.0
        self.x[2] = 0.0
        self.held = False
        if not self.locked:
            self.locked = True
            self._set_plant()

    def hold(self, q1: float) -> None:
        """Hold the pendulum at ``q1`` [rad] with the wheel at rest (the belt relaxed) until :meth:`release`."""
        if not math.isfinite(q1):
            raise InputError(f"q1 must be finite, got {q1!r}")
        self.x[0] = float(q1)
        self.x[2:] = 0.0
        self.held = True
        if self.locked:
            self.locked = False
            self._set_plant()

    def release(self) -> None:
        """Let the pendulum (and the wheel) go: free from here on."""
        self.held = False
        if self.locked:
            self.locked = False
            self._set_plant()

    def warm(self) -> None:
        """Load the compiled integrator now (a copy of the state over a tiny step), not during the first period."""
        x = self.x.copy()
        integrate_held(self.plant, x, 0.0, 1e-4, 0.0, command_params=self._cp, tol=self._tol)

    def advance(self, v: float, dt: float) -> None:
        """Advance ``dt`` [s] with the driver command ``v`` [input units] held."""
        self.v = float(v)
        if self.held:
            self.t += dt
            return
        # a state decaying to rest (the wheel coasting down, clamped) underflows towards subnormal numbers, where
        # the integrator's error estimate lost its scale (0/0 at a 1 ms period): far below any tolerance, it is 0
        self.x[np.abs(self.x) < _TINY] = 0.0
        # each period starts with a step of the whole period, not the last period's step size: the plant's path
        # then depends on its state and command only, not on how many idle periods came before (a run by the
        # host's clock gives the same log whatever the load)
        st = integrate_held(self.plant, self.x, self.t, self.t + dt, self.v, command_params=self._cp, tol=self._tol,
                            h0=dt)
        if st.status != ST_OK:
            raise SimulationError(f"the twin: {STATUS_TEXT.get(int(st.status), 'failed')} at t = {self.t:.6g} s")
        self.t += dt

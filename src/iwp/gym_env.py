"""A Gymnasium environment of the inertia wheel pendulum.

``import iwp.gym_env`` registers ``"iwp/InertiaWheelPendulum-v0"``; after
that ``gymnasium.make("iwp/InertiaWheelPendulum-v0", **options)`` builds it.
Without the import, ``gymnasium.make("iwp.gym_env:iwp/InertiaWheelPendulum-v0")``
imports the module itself (Gymnasium >= 1.0 no longer loads plugin entry
points).

The plant is the identified model of the paper: the compensated model (9)
by default, or the raw model (6) with a dead zone compensated by the
feedforward (7)-(8) (``dead_zone=``); the angles can be quantised like the
rig's encoders (``counts_per_rev=2000``), the velocities are then backward
differences of the quantised angles over one sample, as on the rig. The
controller runs every ``Ts`` (5 ms) with the action held (zero-order hold);
one sample is one held segment of the integration engine of :mod:`iwp.sim`
(:func:`iwp.sim.simulate.integrate_held`, adaptive DOP853) on the compiled
right-hand side of :mod:`iwp.models`, so a rollout of the environment is
the simulation :func:`iwp.sim.simulate` does with the same held input.

Task: swing up from the bottom and balance at the upright (``q1 = pi``).

Observation (float32): ``[cos q1, sin q1, q3, q4]`` (measured), clipped to
``|q3| <= 40`` rad/s and ``|q4| <= 600`` rad/s.
Action (float32): ``a`` in ``[-1, 1]``, the ideal input ``u = u_max a``; one number (an action
of another shape, or NaN, is refused with :class:`~iwp.errors.InputError`), beyond ``[-1, 1]``
clipped to it, as the driver saturates.
Reward: ``-(theta^2 + w_v q3^2 + w_d (q4/100)^2 + w_u a^2)`` with
``theta = wrap(q1 - pi)``; weights ``reward_weights = (1, w_v, w_d, w_u)``.
Episodes are truncated after 2000 steps (10 s) by the registration.
"""

from __future__ import annotations

import math

import numpy as np

try:
    import gymnasium as gym
    from gymnasium import spaces
except ImportError as exc:  # pragma: no cover - exercised only without the extra
    raise ImportError("iwp.gym_env needs gymnasium: pip install 'iwp[gym]'") from exc

from .errors import InputError
from .models import LumpedParameters, PhysicalParameters, Plant, load_params
from .models.actuator import command_vector
from .models.encoder import encoder_step, quantize
from .sim.engine import ST_OK
from .sim.simulate import X_MAX, integrate_held, tolerances

__all__ = ["ENV_ID", "InertiaWheelPendulumEnv", "register_envs"]

#: The Gymnasium id of the environment (``gymnasium.make(ENV_ID)`` after :func:`register_envs`).
ENV_ID = "iwp/InertiaWheelPendulum-v0"

_RANDOMISED = ("p1", "p2", "p3", "rho", "sigma_a1", "sigma_v1", "sigma_b1")
_Q3_MAX = 40.0  # [rad/s]
_Q4_MAX = 600.0  # [rad/s]
#: Integration tolerances of one sample (relative, absolute [rad, rad/s]).
RTOL = 1e-9
ATOL = 1e-9


class InertiaWheelPendulumEnv(gym.Env):
    """Swing-up and balance of the inertia wheel pendulum (Gymnasium API).

    Parameters
    ----------
    params : str, path or LumpedParameters
        Parameter set (default: the paper's Table 1).
    dead_zone : bool or (float, float)
        ``False`` (default): the compensated model (9), driven by ``u``.
        ``True``: the raw model (6) with the dead zone of ``params``;
        ``(v_pos, v_neg)``: with these thresholds (the virtual rig: (33, 29)).
        The command is then the feedforward (7)-(8) of ``u``.
    compensation : float or (float, float), optional
        Thresholds of the feedforward when the dead zone is on (default:
        those of ``params``, 31 for Table 1).
    counts_per_rev : int
        Encoder resolution for the measured angles (0: exact, default; the
        rig: 2000).
    Ts : float
        Control period [s].
    u_max : float
        ``|u| <= u_max`` [input units]; the action is scaled by it.
    randomize : float
        Relative spread of the parameter randomisation at every reset:
        ``p1, p2, p3, rho`` and the friction coefficients (and the dead-zone
        thresholds) are multiplied by ``U(1 - randomize, 1 + randomize)``.
    init : str
        Initial state: ``"bottom"`` (near the hanging rest), ``"random"``
        (any angle, some velocity) or ``"top"`` (near the upright).
    reward_weights : (float, float, float, float)
        Weights of ``theta^2, q3^2, (q4/100)^2, a^2``.
    substeps : int
        At least this many integration steps per control period: the
        largest step of the adaptive integrator is ``Ts / substeps``
        (its error control, ``rtol = atol = 1e-9``, may take more).
    render_mode : str, optional
        ``"rgb_array"``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(self, params="table1", *, dead_zone=False, compensation=None, counts_per_rev: int = 0,
                 Ts: float = 0.005, u_max: float = 100.0, randomize: float = 0.0, init: str = "bottom",
                 reward_weights=(1.0, 0.01, 0.001, 0.001), substeps: int = 5, render_mode: str | None = None):
        if isinstance(params, (str,)) or hasattr(params, "__fspath__"):
            params = load_params(params)
        if isinstance(params, PhysicalParameters):
            params = params.to_lumped()
        if not isinstance(params, LumpedParameters):
            raise InputError(f"params must be a parameter-set name, a JSON path or LumpedParameters, "
                             f"got {type(params).__name__}")
        self.nominal = params
        if dead_zone is True:
            self._dz = (params.v_dz_pos, params.v_dz_neg)
        elif dead_zone is False or dead_zone is None:
            self._dz = None
        else:
            try:
                vp, vn = (float(v) for v in dead_zone)
            except (TypeError, ValueError):
                raise InputError(f"dead_zone must be True, False or (v_pos, v_neg), got {dead_zone!r}") from None
            if not (vp >= 0 and vn >= 0):
                raise InputError(f"dead_zone thresholds must be >= 0, got {dead_zone!r}")
            self._dz = (vp, vn)
        if compensation is None:
            comp = (params.v_dz_pos, params.v_dz_neg)
        elif np.ndim(compensation) == 0:
            comp = (float(compensation), float(compensation))
        else:
            comp = tuple(float(c) for c in compensation)
        self._comp = comp
        if int(counts_per_rev) != counts_per_rev or counts_per_rev < 0:
            raise InputError(f"counts_per_rev must be a non-negative integer, got {counts_per_rev!r}")
        self.quantum = encoder_step(counts_per_rev) if counts_per_rev else 0.0
        if not (Ts > 0 and math.isfinite(Ts)):
            raise InputError(f"Ts must be > 0, got {Ts!r}")
        if not (u_max > 0 and math.isfinite(u_max)):
            raise InputError(f"u_max must be > 0, got {u_max!r}")
        if not (0.0 <= randomize < 1.0):
            raise InputError(f"randomize must be in [0, 1), got {randomize!r}")
        if init not in ("bottom", "random", "top"):
            raise InputError(f"init must be 'bottom', 'random' or 'top', got {init!r}")
        if len(reward_weights) != 4 or not all(isinstance(w, (int, float, np.number)) and math.isfinite(w)
                                               for w in reward_weights):
            raise InputError("reward_weights must hold 4 finite weights (theta^2, q3^2, (q4/100)^2, a^2), got "
                             f"{tuple(reward_weights)!r}")
        if int(substeps) != substeps or substeps < 1:
            raise InputError(f"substeps must be a positive integer, got {substeps!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise InputError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.Ts = float(Ts)
        self.u_max = float(u_max)
        self.randomize = float(randomize)
        self.init = init
        self.reward_weights = tuple(float(w) for w in reward_weights)
        self.substeps = int(substeps)
        self.render_mode = render_mode
        high = np.array([1.0, 1.0, _Q3_MAX, _Q4_MAX], dtype=np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self._tol = tolerances(4, RTOL, ATOL, max_step=self.Ts / self.substeps)
        # the feedforward (7)-(8) with the compensator's thresholds, when the plant has a dead zone
        self._command_params = command_vector(None if self._dz is None else self._comp)
        self._h = -1.0  # the integrator's step size, carried from one sample to the next
        self.params = params
        self._set_plant(params)
        self.state = np.zeros(4)
        self._prev_meas = np.zeros(2)
        self._fig = None

    # ------------------------------------------------------------------
    def _set_plant(self, params: LumpedParameters) -> None:
        """The plant: model (6) with the dead zone (5) of ``self._dz``, or model (9)."""
        if self._dz is not None:
            params = params.replace(v_dz_pos=self._dz[0], v_dz_neg=self._dz[1])
            self.plant = Plant(params, model="raw")
        else:
            self.plant = Plant(params, model="compensated")
        self.params = params

    def _measure(self, x) -> np.ndarray:
        """The encoder readings of ``q1, q2`` (exact when ``counts_per_rev`` is 0)."""
        return quantize(x[:2], self.quantum)

    def _obs(self, meas, prev) -> np.ndarray:
        if self.quantum == 0:
            q3, q4 = self.state[2], self.state[3]
        else:
            q3, q4 = (meas - prev) / self.Ts
        o = np.array([math.cos(meas[0]), math.sin(meas[0]), q3, q4])
        o[2] = min(max(o[2], -_Q3_MAX), _Q3_MAX)
        o[3] = min(max(o[3], -_Q4_MAX), _Q4_MAX)
        return o.astype(np.float32)

    # ------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        rng = self.np_random
        p = self.nominal
        if self.randomize > 0:
            r = self.randomize
            changes = {name: getattr(p, name) * float(rng.uniform(1 - r, 1 + r)) for name in _RANDOMISED}
            p = p.replace(**changes)
        self._set_plant(p)
        if self._dz is not None and self.randomize > 0:
            r = self.randomize
            pr = self.params.replace(v_dz_pos=self._dz[0] * float(rng.uniform(1 - r, 1 + r)),
                                     v_dz_neg=self._dz[1] * float(rng.uniform(1 - r, 1 + r)))
            self.plant = Plant(pr, model="raw")
            self.params = pr
        x0 = None if options is None else options.get("x0")
        if x0 is not None:
            try:
                x = np.array(x0, dtype=float).ravel()
            except (TypeError, ValueError):
                x = np.full(0, np.nan)
            if x.shape != (4,) or not np.all(np.abs(x) < X_MAX):
                raise InputError(f"options['x0'] must be 4 finite numbers [q1, q2, q3, q4] below {X_MAX:g} in "
                                 f"magnitude, got {x0!r}")
        elif self.init == "bottom":
            x = np.array([rng.uniform(-0.05, 0.05), 0.0, rng.uniform(-0.05, 0.05), 0.0])
        elif self.init == "top":
            x = np.array([math.pi + rng.uniform(-0.05, 0.05), 0.0, rng.uniform(-0.05, 0.05), 0.0])
        else:
            x = np.array([rng.uniform(-math.pi, math.pi), 0.0, rng.uniform(-2.0, 2.0), rng.uniform(-20.0, 20.0)])
        self.state = x
        self._h = -1.0
        meas = self._measure(x)
        # a virtual previous sample consistent with the initial velocities
        self._prev_meas = self._measure(x - self.Ts * np.array([x[2], x[3], 0.0, 0.0]))
        obs = self._obs(meas, self._prev_meas)
        self._prev_meas = meas
        return obs, self._info(0.0)

    def step(self, action):
        try:
            arr = np.asarray(action, dtype=float)
        except (TypeError, ValueError):
            arr = np.full(0, np.nan)
        if arr.size != 1 or np.isnan(arr).any():
            shown = arr.tolist() if arr.size else action
            raise InputError(f"action must be one number in [-1, 1] (the action space's shape (1,)), got {shown!r}")
        a = float(np.clip(arr.reshape(-1)[0], -1.0, 1.0))
        u = self.u_max * a
        x = self.state.copy()
        # u held over one sample; the command is the feedforward (7)-(8) of u (dead zone on)
        stats = integrate_held(self.plant, x, 0.0, self.Ts, u, command_params=self._command_params, tol=self._tol,
                               h0=self._h)
        self._h = stats.h_next
        self.state = x
        terminated = stats.status != ST_OK or not bool(np.all(np.isfinite(x)))
        if terminated:
            self.state = np.nan_to_num(x)
        meas = self._measure(self.state)
        obs = self._obs(meas, self._prev_meas)
        self._prev_meas = meas
        th = (self.state[0] - math.pi + math.pi) % (2 * math.pi) - math.pi
        w1, w2, w3, w4 = self.reward_weights
        reward = -(w1 * th * th + w2 * self.state[2] ** 2 + w3 * (self.state[3] / 100.0) ** 2 + w4 * a * a)
        return obs, float(reward), terminated, False, self._info(u)

    def _info(self, u: float) -> dict:
        th = (self.state[0] - math.pi + math.pi) % (2 * math.pi) - math.pi
        return {"state": self.state.copy(), "u": float(u), "theta": float(th)}

    # ------------------------------------------------------------------
    def render(self):
        if self.render_mode != "rgb_array":
            return None
        # an off-screen figure of its own (matplotlib's Agg canvas, no pyplot): the user's backend is left alone
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.patches import Circle

        if self._fig is None:
            self._fig = Figure(figsize=(2.5, 2.5), dpi=64)
            FigureCanvasAgg(self._fig)
            ax = self._fig.add_subplot()
            ax.set_xlim(-1.4, 1.4)
            ax.set_ylim(-1.4, 1.4)
            ax.set_aspect("equal")
            ax.axis("off")
            ax.plot([0], [0], "ko", ms=3)
            (self._arm,) = ax.plot([], [], "-", color="0.3", lw=3)
            self._disk = Circle((0, 0), 0.25, fc="C0", ec="k", alpha=0.6)
            ax.add_patch(self._disk)
            (self._spoke,) = ax.plot([], [], "-", color="C3", lw=2)
        q1, q2 = self.state[0], self.state[1]
        x, y = math.sin(q1), -math.cos(q1)
        self._arm.set_data([0, x], [0, y])
        self._disk.center = (x, y)
        a = q1 + q2
        self._spoke.set_data([x, x + 0.25 * math.sin(a)], [y, y - 0.25 * math.cos(a)])
        self._fig.canvas.draw()
        img = np.asarray(self._fig.canvas.buffer_rgba())[..., :3].copy()
        return img

    def close(self):
        self._fig = None  # not pyplot's: nothing to close but the reference


def register_envs() -> None:
    """Register ``"iwp/InertiaWheelPendulum-v0"`` with Gymnasium (idempotent)."""
    if ENV_ID not in gym.envs.registry:
        gym.register(id=ENV_ID, entry_point="iwp.gym_env:InertiaWheelPendulumEnv", max_episode_steps=2000)


register_envs()

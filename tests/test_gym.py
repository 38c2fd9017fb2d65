"""The Gymnasium environment (iwp.gym_env)."""

import math
import subprocess
import sys

import numpy as np
import pytest

from iwp.models import Plant
from iwp.sim import Feedforward, SimOptions, Tolerances

gym = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

import iwp.gym_env  # noqa: E402,F401  (registers the id)
from iwp.errors import InputError  # noqa: E402
from iwp.gym_env import ENV_ID, InertiaWheelPendulumEnv  # noqa: E402
from iwp.models import table1  # noqa: E402
from iwp.sim import Sampled, simulate  # noqa: E402

RIG = {"dead_zone": (33.0, 29.0), "compensation": 31.0, "counts_per_rev": 2000}


@pytest.mark.parametrize("kwargs", [{}, dict(RIG, randomize=0.1, init="random"), {"init": "top"}])
def test_check_env_passes(kwargs):
    env = gym.make(ENV_ID, render_mode="rgb_array", **kwargs)
    check_env(env.unwrapped)
    env.close()


def test_make_by_id_and_time_limit():
    env = gym.make(ENV_ID)
    assert env.spec.max_episode_steps == 2000
    check_env(env.unwrapped)
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs) and set(info) == {"state", "u", "theta"}
    n = 0
    while True:
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        n += 1
        assert env.observation_space.contains(obs) and r <= 0
        if term or trunc:
            break
    assert trunc and not term and n == 2000
    env.close()


def test_make_by_module_path_without_prior_import():
    code = ("import gymnasium as g; e = g.make('iwp.gym_env:iwp/InertiaWheelPendulum-v0', counts_per_rev=2000); "
            "o, _ = e.reset(seed=0); print(o.shape)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "(4,)"


def _rollout(env, seed, n=200, action=None):
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    traj = [obs]
    for _ in range(n):
        a = rng.uniform(-1, 1, 1).astype(np.float32) if action is None else action
        obs, *_ = env.step(a)
        traj.append(obs)
    return np.array(traj), info


def test_seeding_and_parameter_randomisation():
    env = InertiaWheelPendulumEnv(**RIG, randomize=0.2, init="random")
    a, _ = _rollout(env, 7)
    pa = env.params
    b, _ = _rollout(env, 7)
    np.testing.assert_array_equal(a, b)
    assert env.params == pa
    c, _ = _rollout(env, 8)
    assert not np.array_equal(a, c) and env.params != pa
    nom = table1()
    seen = []
    for s in range(20):
        env.reset(seed=s)
        seen.append(env.params.p1 / nom.p1)
        assert 0.8 <= env.params.p1 / nom.p1 <= 1.2 and 0.8 * 33 <= env.params.v_dz_pos <= 1.2 * 33
    assert np.std(seen) > 0.05
    # no randomisation: the nominal parameters every time
    env0 = InertiaWheelPendulumEnv(**RIG)
    env0.reset(seed=1)
    assert env0.params == nom.replace(v_dz_pos=33.0, v_dz_neg=29.0)


def test_quantised_measurements():
    env = InertiaWheelPendulumEnv(counts_per_rev=2000, init="random")
    q = 2 * math.pi / 2000
    env.reset(seed=0)
    for _ in range(50):
        obs, _, _, _, info = env.step(np.array([0.5], dtype=np.float32))
        q1m = math.atan2(obs[1], obs[0])
        k = q1m / q
        # a whole number of quanta (to the observation's float32 precision), also across the wrap at +-pi:
        # 2 pi is 2000 quanta
        assert abs(k - round(k)) < 1e-3
        assert abs(q1m - math.remainder(info["state"][0], 2 * math.pi)) <= q / 2 + 1e-6
        v = obs[2] / (q / 0.005)
        assert abs(v - round(v)) < 1e-3 * max(1, abs(v))


def test_env_matches_the_simulator():
    # the same plant as iwp.simulate: raw model, dead zone 33/29, feedforward 31, held input
    env = InertiaWheelPendulumEnv(dead_zone=(33.0, 29.0), compensation=31.0, substeps=20)
    env.reset(seed=0, options={"x0": [0.3, 0.0, 0.0, 0.0]})
    actions = np.sin(np.arange(400) * 0.03) * 0.8
    states = [env.state.copy()]
    for a in actions:
        env.step(np.array([a], dtype=np.float32))
        states.append(env.state.copy())
    states = np.array(states)
    u = 100.0 * actions.astype(np.float32).astype(float)
    r = simulate(Plant(table1().replace(v_dz_pos=33.0, v_dz_neg=29.0), model="raw"), x0=[0.3, 0, 0, 0], t_end=2.0,
                 input=Sampled(u, 0.005),
                 options=SimOptions(feedforward=Feedforward(31.0, 31.0), tolerances=Tolerances(rtol=1e-11, atol=1e-11)))
    np.testing.assert_allclose(states[:, [0, 2]], r.x[:, [0, 2]], atol=1e-6)
    np.testing.assert_allclose(states[:, 3], r.x[:, 3], atol=1e-4)


def test_vector_api():
    envs = gym.make_vec(ENV_ID, num_envs=3, vectorization_mode="sync", randomize=0.1)
    obs, info = envs.reset(seed=11)
    assert obs.shape == (3, 4) and obs.dtype == np.float32
    assert not np.allclose(obs[0], obs[1])
    for _ in range(5):
        obs, rew, term, trunc, info = envs.step(envs.action_space.sample())
    assert obs.shape == (3, 4) and rew.shape == (3,) and term.shape == (3,)
    envs.close()
    envs2 = gym.vector.SyncVectorEnv([lambda: gym.make(ENV_ID, **RIG) for _ in range(2)])
    obs, _ = envs2.reset(seed=[1, 2])
    obs, *_ = envs2.step(np.zeros((2, 1), dtype=np.float32))
    assert obs.shape == (2, 4)
    envs2.close()


def test_balance_controller_in_the_env():
    # the LQR of iwp.control keeps the pendulum up in the environment with the rig's imperfections
    from iwp.control import lqr_balance

    L = lqr_balance(table1(), Ts=0.005)
    env = InertiaWheelPendulumEnv(dead_zone=(33.0, 29.0), compensation=31.0, init="top")
    env.reset(seed=0)
    for _ in range(600):
        a = np.array([L(env.state) / 100.0], dtype=np.float32)
        _, r, term, _, info = env.step(a)
    assert abs(info["theta"]) < 0.02 and r > -0.01


@pytest.mark.parametrize(
    "kwargs,match",
    [({"dead_zone": "x"}, "dead_zone"), ({"counts_per_rev": -1}, "counts_per_rev"), ({"Ts": 0}, "Ts"),
     ({"randomize": 1.5}, "randomize"), ({"init": "side"}, "init"), ({"render_mode": "human"}, "render_mode"),
     ({"reward_weights": (float("nan"), 1, 1, 1)}, "reward_weights must hold 4 finite weights")],
)
def test_bad_options(kwargs, match):
    with pytest.raises(InputError, match=match):
        InertiaWheelPendulumEnv(**kwargs)


def test_render_rgb_array():
    env = InertiaWheelPendulumEnv(render_mode="rgb_array")
    env.reset(seed=0)
    img = env.render()
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8
    env.close()


@pytest.mark.parametrize("action", [np.array([np.nan], dtype=np.float32), np.array([0.3, -0.9]), [], "up"],
                         ids=["nan", "two", "none", "text"])
def test_an_action_that_is_not_one_number_is_refused_and_the_state_kept(action):
    env = InertiaWheelPendulumEnv()
    env.reset(seed=0)
    before = env.state.copy()
    with pytest.raises(InputError, match=r"action must be one number in \[-1, 1\]"):
        env.step(action)
    np.testing.assert_array_equal(env.state, before)
    _, reward, terminated, _, info = env.step(np.array([2.0], dtype=np.float32))  # beyond [-1, 1]: saturated
    assert info["u"] == env.u_max and np.isfinite(reward) and not terminated


@pytest.mark.parametrize("x0", ["abc", [0.0, 0.0, 0.0, 1e9], [0.0, np.nan, 0.0, 0.0], [1.0, 2.0]])
def test_a_bad_initial_state_is_refused(x0):
    env = InertiaWheelPendulumEnv()
    with pytest.raises(InputError, match=r"options\['x0'\] must be 4 finite numbers"):
        env.reset(options={"x0": x0})

"""Contract tests, parametrised over every registered environment.

API checkers (Gymnasium, Stable-Baselines3), observations inside their spaces and not
sharing memory, randomised and seeded resets, resets that do not rebuild the world,
rendering.
"""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pybullet as p
import pytest
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

from pyflyt_engine.envs.wrappers import FlattenWaypointEnv
from tests.envs.conftest import ENV_IDS, PROFILES


def _positions(env, obs):
    attitude = obs["attitude"] if isinstance(obs, dict) else obs
    offset = 10 if env.config.angle_representation == "quaternion" else 9
    return attitude[offset : offset + 3]


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("sparse", [False, True])
@pytest.mark.parametrize("angles", ["euler", "quaternion"])
def test_gymnasium_env_checker(env_id, sparse, angles):
    # made outside the checker's filter: once pyflyt_engine.compat registers the reference's
    # -v4 ids under the same names, Gymnasium's make warns that -v0 is "out of date"
    env = gymnasium.make(env_id, sparse_reward=sparse, angle_representation=angles)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # anything the checker says is a failure, except:
        # the action Box is the paper's (rates in rad/s, thrust in [0, 1]), not [-1, 1];
        # the attitude is genuinely unbounded
        warnings.filterwarnings("ignore", message=".*symmetric and normalized.*")
        warnings.filterwarnings("ignore", message=".*infinity.*")
        try:
            check_env(env.unwrapped, skip_render_check=True)
        finally:
            env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("sparse", [False, True])
@pytest.mark.parametrize("angles", ["euler", "quaternion"])
def test_stable_baselines3_env_checker(env_id, sparse, angles, make):
    env = make(env_id, sparse_reward=sparse, angle_representation=angles)
    if isinstance(env.observation_space, spaces.Dict) and isinstance(
        env.observation_space.spaces.get("target_deltas"), spaces.Sequence
    ):  # a variable-length list of targets: SB3 takes the flattened next ones; other Dicts as they are
        env = FlattenWaypointEnv(env, context_length=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*(symmetric|float32|float64).*")
        sb3_check_env(env, warn=True)


def test_every_registered_env_has_a_profile():
    assert set(PROFILES) == set(ENV_IDS)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_observations_in_space_with_documented_layout(env_id, make):
    profile = PROFILES[env_id]
    env = make(env_id, angle_representation="quaternion")
    n_act = env.action_space.shape[0]
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs)
    assert {"collision", "out_of_bounds", "env_complete", "success"} <= set(info)
    attitude = obs["attitude"] if isinstance(obs, dict) else obs
    # 3 + 4 + 3 + 3 + previous action + aux state (+ task extras): QuadX 21
    assert attitude.shape == (13 + n_act + profile.aux + profile.extra,)
    state = env.state
    np.testing.assert_array_equal(attitude[0:3], state.ang_vel)
    np.testing.assert_array_equal(attitude[3:7], state.quaternion)
    np.testing.assert_array_equal(attitude[7:10], state.lin_vel)
    np.testing.assert_array_equal(attitude[10:13], state.lin_pos)
    np.testing.assert_array_equal(attitude[13 : 13 + n_act], 0.0)  # no previous action yet
    low, high = env.action_space.low, env.action_space.high
    action = low + (high - low) * np.linspace(0.3, 0.7, n_act)  # inside the box
    for _ in range(3):
        obs, reward, terminated, truncated, info = env.step(action)
        assert env.observation_space.contains(obs)
        assert isinstance(reward, float)
    attitude = obs["attitude"] if isinstance(obs, dict) else obs
    np.testing.assert_allclose(attitude[13 : 13 + n_act], action)
    aux = attitude[13 + n_act : 13 + n_act + profile.aux]
    np.testing.assert_allclose(aux, env.vehicle.aux_state)
    if env_id.startswith("PyFlyt/QuadX"):
        np.testing.assert_allclose(aux, env.vehicle.motor_throttle)
    euler = make(env_id, angle_representation="euler")
    obs, _ = euler.reset(seed=3)
    attitude = obs["attitude"] if isinstance(obs, dict) else obs
    assert attitude.shape == (12 + n_act + profile.aux + profile.extra,)
    np.testing.assert_array_equal(attitude[3:6], euler.state.ang_pos)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_actions_outside_the_box_are_clipped(env_id, make):
    env = make(env_id)
    env.reset(seed=0)
    low, high = env.action_space.low, env.action_space.high
    n_act = low.size
    wild = np.where(np.arange(n_act) % 2 == 0, high + 10.0, low - 10.0)
    wild[-1] = 0.5 * (low[-1] + high[-1])  # one entry inside: left alone
    obs, *_ = env.step(wild)
    attitude = obs["attitude"] if isinstance(obs, dict) else obs
    np.testing.assert_allclose(attitude[13 : 13 + n_act], np.clip(wild, low, high))
    if env_id.startswith("PyFlyt/QuadX") and env.config.action.mode == "rates_thrust":
        np.testing.assert_allclose(attitude[13:17], [np.pi, -np.pi, np.pi, 0.5])
    with pytest.raises(ValueError, match=f"{n_act} values"):
        env.step(np.zeros(n_act - 1))


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_observations_do_not_share_memory(env_id, make):
    env = make(env_id)
    first, _ = env.reset(seed=0)
    second, *_ = env.step(env.action_space.sample())
    third, *_ = env.step(env.action_space.sample())
    leaves = lambda o: list(o.values()) if isinstance(o, dict) else [o]  # noqa: E731
    for a in leaves(first) + leaves(second):
        for b in leaves(third):
            assert not np.shares_memory(a, b)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_reset_does_not_rebuild_the_world(env_id, make):
    env = make(env_id, render_mode="rgb_array")  # with markers: they must not be re-added either
    env.reset(seed=0)
    client, body, world = env.world.client, env.vehicle.body_id, env.world
    bodies = p.getNumBodies(physicsClientId=client)
    for seed in (1, None, 2):
        for _ in range(5):
            env.step(env.action_space.sample())
        env.reset(seed=seed)
        assert env.world is world and env.world.client == client and env.vehicle.body_id == body
        assert p.getNumBodies(physicsClientId=client) == bodies
        assert env.elapsed_steps == 0 and env.world.physics_steps == 0


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_resets_are_randomised_and_reproducible(env_id, make):
    env = make(env_id)
    starts = []
    for seed in (0, 1, 2):
        obs, _ = env.reset(seed=seed)
        starts.append(_positions(env, obs).copy())
    assert not np.allclose(starts[0], starts[1]) and not np.allclose(starts[1], starts[2])
    # spawn within the documented noise (QuadX: (0, 0, 1) +- 0.1 m per axis)
    profile = PROFILES[env_id]
    for start in starts:
        assert np.all(np.abs(start - profile.spawn_centre) <= np.add(profile.spawn_halfwidth, 1e-9))
    again, _ = env.reset(seed=0)
    np.testing.assert_array_equal(_positions(env, again), starts[0])
    # seed=None continues the stream: a new start, not a replay of seed 0
    following, _ = env.reset()
    assert not np.allclose(_positions(env, following), starts[0])


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_same_trajectory_in_one_process(env_id, make):
    policy = PROFILES[env_id].policy

    def rollout(env, seed):
        obs, _ = env.reset(seed=seed)
        rng = np.random.default_rng(42)
        out = [_positions(env, obs).copy()]
        for _ in range(40):
            action = policy(rng)
            obs, reward, terminated, truncated, _ = env.step(action)
            out.append(np.append(_positions(env, obs), reward))
            if terminated or truncated:
                break
        return np.concatenate(out)

    env = make(env_id)
    a = rollout(env, 7)
    rollout(env, 8)  # something else in between
    b = rollout(env, 7)
    np.testing.assert_array_equal(a, b)
    other = make(env_id)  # a second instance agrees too
    np.testing.assert_array_equal(a, rollout(other, 7))


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_rgb_array_render(env_id, make):
    env = make(env_id, render_mode="rgb_array", render={"resolution": (48, 64)})
    env.reset(seed=0)
    env.step(env.action_space.sample())
    image = env.render()
    assert image.shape == (48, 64, 3) and image.dtype == np.uint8
    assert image.std() > 0  # not a blank frame
    assert env.metadata["render_fps"] == env.config.agent_hz


def test_registered_ids_and_make_kwargs(make):
    assert {"PyFlyt/QuadX-Hover-v0", "PyFlyt/QuadX-Waypoints-v0"} <= set(gymnasium.registry)
    env = make("PyFlyt/QuadX-Waypoints-v0", num_targets=2, agent_hz=60, flight_dome_size=4.0)
    obs, _ = env.reset(seed=0)
    assert obs["target_deltas"].shape == (2, 3)
    assert env.world.physics_per_agent == 4
    assert env.config.flight_dome_size == 4.0
    assert np.all(np.linalg.norm(env.task.targets, axis=1) <= 0.9 * 4.0 + 1e-9)

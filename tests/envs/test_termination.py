"""Episode end: crashes, dome exits, completing every waypoint, the time limit."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from tests.envs.conftest import ENV_IDS, PROFILES

HOVER = "PyFlyt/QuadX-Hover-v0"
WAYPOINTS = "PyFlyt/QuadX-Waypoints-v0"
QUADX_IDS = [i for i in ENV_IDS if i in ("PyFlyt/QuadX-Hover-v0", "PyFlyt/QuadX-Waypoints-v0")]  # others: own tests


def _teleport(env, position, velocity=(0.0, 0.0, 0.0)):
    cid, body = env.world.client, env.vehicle.body_id
    p.resetBasePositionAndOrientation(body, list(position), (0.0, 0.0, 0.0, 1.0), physicsClientId=cid)
    p.resetBaseVelocity(body, list(velocity), [0.0, 0.0, 0.0], physicsClientId=cid)
    if env.payloads is not None:  # carried payloads move with the vehicle
        env.vehicle.state_changed()
        env.payloads.place()


@pytest.mark.parametrize("env_id", QUADX_IDS)
@pytest.mark.parametrize("sparse", [False, True])
def test_zero_thrust_falls_and_crashes_into_the_ground(make, env_id, sparse):
    env = make(env_id, sparse_reward=sparse)
    env.reset(seed=0)
    for step in range(60):  # 1 m free fall takes ~0.45 s = 14 agent steps
        obs, reward, terminated, truncated, info = env.step(np.zeros(4))
        if terminated:
            break
        assert not info["collision"] and not truncated
    assert terminated and not truncated and 8 <= step <= 30
    assert info["collision"] and not info["out_of_bounds"] and not info["success"] and not info["env_complete"]
    assert reward == -100.0 and info["reward_terms"]["crash"] == -100.0
    contacts = p.getContactPoints(bodyA=env.vehicle.body_id, physicsClientId=env.world.client)
    assert any(c[2] == env.world.ground_id for c in contacts)  # it really is on the ground
    assert env.state.lin_pos[2] < 0.05


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("sparse", [False, True])
def test_leaving_the_flight_dome_terminates(make, env_id, sparse):
    env = make(env_id, sparse_reward=sparse)
    neutral = np.array(PROFILES[env_id].neutral)
    env.reset(seed=0)
    dome = env.config.flight_dome_size
    obs, reward, terminated, truncated, info = env.step(neutral)
    assert not terminated and not info["out_of_bounds"]
    _teleport(env, (0.0, 0.0, dome + 0.5))
    obs, reward, terminated, truncated, info = env.step(neutral)
    assert terminated and not truncated
    assert info["out_of_bounds"] and not info["collision"] and not info["success"]
    terms = info["reward_terms"]
    assert -100.0 in terms.values() and list(terms.values()).count(-100.0) == 1
    if env_id.startswith("PyFlyt/QuadX") or sparse or "Waypoints" in env_id:
        assert reward == -100.0  # the dome penalty alone (the rocket's dense reward adds r_d + r_v)
    # just inside the dome is fine
    env.reset(seed=0)
    _teleport(env, (0.94 * dome, 0.0, 0.3 * dome))
    obs, reward, terminated, truncated, info = env.step(neutral)
    assert not terminated and not info["out_of_bounds"]


@pytest.mark.parametrize("sparse", [False, True])
def test_reaching_every_waypoint_completes_the_episode(make, sparse):
    env = make(WAYPOINTS, sparse_reward=sparse, num_targets=4)
    obs, info = env.reset(seed=5)
    targets = env.task.targets
    assert targets.shape == (4, 3) and info["num_targets_reached"] == 0
    hover = np.array([0.0, 0.0, 0.0, 0.125])
    # a step away from the waypoint: nothing reached, the dense reward is c_a / delta (+ approach)
    obs, reward, terminated, truncated, info = env.step(hover)
    assert info["num_targets_reached"] == 0 and not terminated
    for i, target in enumerate(targets):
        assert obs["target_deltas"].shape == (4 - i, 3)
        _teleport(env, target)
        obs, reward, terminated, truncated, info = env.step(hover)
        assert reward == 100.0 and info["reward_terms"]["waypoint_bonus"] == 100.0
        assert info["num_targets_reached"] == i + 1
        last = i == len(targets) - 1
        assert terminated == last and not truncated
        assert info["env_complete"] == last and info["success"] == last
        assert not info["collision"] and not info["out_of_bounds"]
    assert obs["target_deltas"].shape == (0, 3)
    assert env.observation_space.contains(obs)


def test_target_deltas_are_body_frame_vectors_to_the_remaining_waypoints(make):
    env = make(WAYPOINTS)
    env.reset(seed=9)
    target = env.task.targets[0]
    yaw = 0.7
    cid, body = env.world.client, env.vehicle.body_id
    # place the vehicle 1 m "behind" the first waypoint along its own heading, level
    position = target - np.array([np.cos(yaw), np.sin(yaw), 0.0])
    p.resetBasePositionAndOrientation(body, list(position), p.getQuaternionFromEuler([0, 0, yaw]), physicsClientId=cid)
    p.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0], physicsClientId=cid)
    obs, *_ = env.step(np.array([0.0, 0.0, 0.0, 0.125]))
    # the waypoint is ~1 m straight ahead: body x forward
    np.testing.assert_allclose(obs["target_deltas"][0], [1.0, 0.0, 0.0], atol=0.02)


def test_time_limit_truncates(make):
    env = make(HOVER, max_duration_seconds=0.5)  # 15 agent steps at 30 Hz
    env.reset(seed=0)
    for step in range(1, 16):
        obs, reward, terminated, truncated, info = env.step(np.array([0.0, 0.0, 0.0, 0.125]))
        assert not terminated
        assert truncated == (step == 15)
    assert info["success"]  # hover: surviving to the time limit is the task
    assert not info["env_complete"]
    waypoints = make(WAYPOINTS, max_duration_seconds=0.2, agent_hz=60)  # 12 steps at 60 Hz
    waypoints.reset(seed=0)
    results = [waypoints.step(np.array([0.0, 0.0, 0.0, 0.125])) for _ in range(12)]
    assert [r[3] for r in results] == [False] * 11 + [True]
    assert not results[-1][4]["success"]  # waypoints: running out of time is no success

"""PyFlyt/Fixedwing-Waypoints-v0: the paper's waypoint reward with c_a = 1, c_b = 3, d = 2 by
hand, the 20x waypoint scale, an in-flight spawn, crashes and dome exits.

The oracle never calls the env's reward code: it reads positions from observations and
the sampled waypoints from the task, and applies the paper's piecewise formula.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from tests.envs.test_rewards import WaypointOracle

FIXEDWING = "PyFlyt/Fixedwing-Waypoints-v0"
C_A, C_B, REACH, DOME = 1.0, 3.0, 2.0, 100.0


def _place(env, position, rpy=(0.0, 0.0, 0.0), lin_vel=(0.0, 0.0, 0.0), ang_vel=(0.0, 0.0, 0.0)):
    """Set the aircraft's pose and ground-frame velocities directly in PyBullet."""
    cid, body = env.world.client, env.vehicle.body_id
    p.resetBasePositionAndOrientation(body, list(position), p.getQuaternionFromEuler(list(rpy)), physicsClientId=cid)
    p.resetBaseVelocity(body, list(lin_vel), list(ang_vel), physicsClientId=cid)


def FixedwingWaypointOracle(targets, position, sparse):
    """The paper's waypoint reward with the Fixedwing's d = 2, c_a = 1, c_b = 3."""
    return WaypointOracle(targets, position, sparse, dome=DOME, c_a=C_A, c_b=C_B, reach=REACH)


def _policy(rng):
    return np.array([*rng.uniform(-0.3, 0.3, 3), rng.uniform(0.3, 0.7)])


@pytest.mark.parametrize("sparse", [False, True])
def test_reward_matches_the_paper_on_flights_and_set_states(make, sparse):
    env = make(FIXEDWING, sparse_reward=sparse)
    rng = np.random.default_rng(0)
    checked, seen = 0, set()
    for episode in range(10):
        obs, _ = env.reset(seed=episode)
        oracle = FixedwingWaypointOracle(env.task.targets, obs["attitude"][10:13], sparse)
        for step in range(90):
            if episode % 2 and step % 10 == 5:
                # fly at the next waypoint from a few metres away, sometimes straight through it
                target = oracle.targets[oracle.index]
                offset = rng.normal(size=3)
                offset *= rng.choice([3.0, 8.0]) / np.linalg.norm(offset)
                heading = -offset / np.linalg.norm(offset) * rng.choice([-1.0, 1.0, 1.0])
                _place(env, target + offset, (0.0, 0.0, math.atan2(heading[1], heading[0])), 14.0 * heading)
            elif episode == 8 and step == 30:
                _place(env, (0.0, 0.0, 1.0), (0.0, 0.4, 0.0), (10.0, 0.0, -4.0))  # into the ground
            elif episode == 6 and step == 30:
                _place(env, (99.0, 0.0, 5.0), lin_vel=(14.0, 0.0, 0.0))  # out of the dome
            obs, reward, terminated, truncated, info = env.step(_policy(rng))
            assert reward == pytest.approx(oracle(obs, info), rel=1e-12, abs=1e-9)
            assert reward == pytest.approx(sum(info["reward_terms"].values()), abs=1e-12)
            checked += 1
            if terminated or truncated:
                break
        seen |= oracle.branches
    assert checked > 400
    assert ({"crash", "reached", "nothing"} if sparse else {"crash", "reached", "approaching", "receding"}) <= seen


def test_waypoints_are_20_times_the_quadx_scale(make):
    env = make(FIXEDWING)
    firsts = []
    for seed in range(8):
        env.reset(seed=seed)
        targets = env.task.targets
        assert targets.shape == (5, 3)
        distance = np.linalg.norm(targets, axis=1)
        assert np.all(distance >= 20.0 - 1e-9) and np.all(distance <= 90.0 + 1e-9)  # QuadX: 1 to 4.5 m
        assert np.all(targets[:, 2] >= 2.0)  # QuadX: 0.1 m
        firsts.append(targets[0])
    assert len({tuple(t) for t in firsts}) == 8
    assert env.config.flight_dome_size == 100.0 and env.task.options.goal_reach_distance == 2.0


def test_spawns_in_flight_and_glides_with_neutral_controls(make):
    env = make(FIXEDWING)
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        s = env.state
        assert np.all(np.abs(np.subtract(s.lin_pos, (0.0, 0.0, 20.0))) <= 2.0 + 1e-9)
        np.testing.assert_allclose(s.lin_vel, (14.0, 0.0, 0.0), atol=1e-9)  # along the nose
        assert np.linalg.norm(s.ang_vel) < 1e-9
        # neither stalls nor crashes right away: power off, it glides for seconds
        for step in range(150):  # 5 s
            _obs, _reward, terminated, _truncated, _info = env.step(np.zeros(4))
            assert not terminated, f"seed {seed}: crashed after {step} steps"
        assert 10.0 < np.linalg.norm(env.state.lin_vel) < 20.0 and env.state.lin_pos[2] > 3.0
    # with cruise thrust it holds its height for a while
    env.reset(seed=0)
    z0 = env.state.lin_pos[2]
    for _ in range(90):
        env.step(np.array([0.0, 0.0, 0.0, 0.45]))
    assert abs(env.state.lin_pos[2] - z0) < 5.0


@pytest.mark.parametrize("sparse", [False, True])
def test_flying_out_of_the_dome_terminates(make, sparse):
    env = make(FIXEDWING, sparse_reward=sparse)
    env.reset(seed=0)
    _place(env, (math.sqrt(95.0**2 - 10.0**2), 0.0, 10.0), lin_vel=(14.0, 0.0, 0.0))  # 95 m out, heading out
    for step in range(30):
        _obs, reward, terminated, _truncated, info = env.step(np.array([0.0, 0.0, 0.0, 0.45]))
        if terminated:
            break
    assert terminated and info["out_of_bounds"] and not info["collision"] and not info["success"]
    assert 8 <= step <= 13  # 5 m to the dome at 14 m/s: 10.8 steps
    assert reward == -100.0 and info["reward_terms"]["crash"] == -100.0
    assert np.linalg.norm(env.state.lin_pos) > DOME


@pytest.mark.parametrize("sparse", [False, True])
def test_flying_into_the_ground_is_a_crash(make, sparse):
    env = make(FIXEDWING, sparse_reward=sparse)
    env.reset(seed=1)
    _place(env, (0.0, 0.0, 3.0), (0.0, 0.5, 0.0), (12.0, 0.0, -6.0))  # nose down (positive pitch), diving
    for step in range(30):
        _obs, reward, terminated, _truncated, info = env.step(np.array([0.0, 0.0, 0.0, 0.5]))
        if terminated:
            break
    assert terminated and info["collision"] and not info["out_of_bounds"] and not info["success"]
    assert reward == -100.0 and info["reward_terms"]["crash"] == -100.0
    contacts = p.getContactPoints(bodyA=env.vehicle.body_id, physicsClientId=env.world.client)
    assert any(c[2] == env.world.ground_id for c in contacts)


def test_a_fast_pass_through_a_waypoint_counts_and_the_last_completes(make):
    env = make(FIXEDWING, num_targets=2)
    env.reset(seed=3)
    for i, target in enumerate(env.task.targets):
        # 0.9 m to the side of the line through the waypoint (inside d = 2 m), 20 m/s
        start = target + np.array([-1.0, 0.9, 0.0])
        _place(env, start, lin_vel=(20.0, 0.0, 0.0))
        obs, reward, terminated, _truncated, info = env.step(np.array([0.0, 0.0, 0.0, 0.5]))
        assert info["num_targets_reached"] == i + 1 and reward == 100.0
        assert terminated == (i == 1) and info["success"] == (i == 1)
    assert obs["target_deltas"].shape == (0, 3)


def test_target_deltas_are_in_the_body_frame(make):
    env = make(FIXEDWING)
    env.reset(seed=9)
    target = env.task.targets[0]
    yaw = -2.0
    _place(env, target - 10.0 * np.array([math.cos(yaw), math.sin(yaw), 0.0]), (0.0, 0.0, yaw))
    obs, *_ = env.step(np.array([0.0, 0.0, 0.0, 0.0]))
    # ~10 m straight ahead (body x): from rest it barely moves in 1/30 s
    np.testing.assert_allclose(obs["target_deltas"][0], [10.0, 0.0, 0.0], atol=0.1)

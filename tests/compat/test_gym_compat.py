"""The reference-shaped Gymnasium ids: spaces, defaults and arguments as PyFlyt 0.29.0 documents them."""

from __future__ import annotations

import math

import gymnasium
import numpy as np
import pytest
from gymnasium import spaces

import pyflyt_engine.compat.gym_envs as compat_gym
from pyflyt_engine.compat.gym_envs import FlattenWaypointEnv

PI = math.pi
RATES_THRUST_LOW = [-PI, -PI, -PI, 0.0]
RATES_THRUST_HIGH = [PI, PI, PI, 0.8]

# id -> (euler observation size, action low, action high, agent_hz, max_duration_seconds,
#        flight_dome_size, target-delta bound or None); PyFlyt 0.29.0 envs' defaults
REFERENCE = {
    "PyFlyt/QuadX-Hover-v4": (20, RATES_THRUST_LOW, RATES_THRUST_HIGH, 40, 10.0, 3.0, None),
    "PyFlyt/QuadX-Waypoints-v4": (20, RATES_THRUST_LOW, RATES_THRUST_HIGH, 30, 10.0, 5.0, 10.0),
    "PyFlyt/QuadX-Pole-Balance-v4": (32, [0.0] * 4, [0.8] * 4, 40, 20.0, 3.0, None),
    "PyFlyt/QuadX-Pole-Waypoints-v4": (32, [0.0] * 4, [0.8] * 4, 40, 20.0, 10.0, 20.0),
    "PyFlyt/QuadX-Ball-In-Cup-v4": (26, RATES_THRUST_LOW, RATES_THRUST_HIGH, 30, 10.0, 30.0, None),
    "PyFlyt/Fixedwing-Waypoints-v3": (22, [-1.0] * 4, [1.0] * 4, 30, 120.0, 100.0, 200.0),
    "PyFlyt/Rocket-Landing-v4": (29, [-1, -1, -1, 0, 0, -1, -1], [1.0] * 7, 40, 30.0, None, None),
}


def _make(env_id: str, **kwargs):
    return gymnasium.make(env_id, **kwargs).unwrapped


@pytest.mark.parametrize("env_id", sorted(REFERENCE))
def test_spaces_and_defaults_are_the_references(env_id):
    size, low, high, hz, duration, dome, bound = REFERENCE[env_id]
    for angles, extra in (("euler", 0), ("quaternion", 1)):
        env = _make(env_id, angle_representation=angles)
        try:
            space = env.observation_space
            attitude = space["attitude"] if isinstance(space, spaces.Dict) else space
            assert attitude.shape == (size + extra,) and attitude.dtype == np.float64
            assert env.action_space.dtype == np.float64
            np.testing.assert_allclose(env.action_space.low, low)
            np.testing.assert_allclose(env.action_space.high, high)
            assert env.config.agent_hz == hz and env.config.max_duration_seconds == duration
            if dome is not None:
                assert env.config.flight_dome_size == dome
            if bound is not None:
                feature = space["target_deltas"].feature_space
                assert feature.shape == (3,)
                np.testing.assert_allclose(feature.low, -bound)
                np.testing.assert_allclose(feature.high, bound)
        finally:
            env.close()


def test_every_reference_id_is_registered_and_native_ids_keep_theirs():
    for env_id in compat_gym.REFERENCE_IDS:
        assert env_id in gymnasium.registry
    native = gymnasium.make("PyFlyt/QuadX-Hover-v0").unwrapped
    try:  # the native id keeps its own bounds and rate
        assert native.action_space.high[3] == 1.0 and native.config.agent_hz == 30
    finally:
        native.close()


def test_the_references_constructor_arguments_are_accepted():
    cases = {
        "PyFlyt/QuadX-Hover-v4": dict(flight_mode=7, render_resolution=(64, 48), flight_dome_size=4.0),
        "PyFlyt/QuadX-Waypoints-v4": dict(use_yaw_targets=False, goal_reach_angle=0.3, num_targets=2, flight_mode=-1),
        "PyFlyt/Rocket-Landing-v4": dict(ceiling=300.0, max_displacement=100.0, agent_hz=30),
        "PyFlyt/QuadX-Ball-In-Cup-v4": dict(goal_reach_velocity=0.5, goal_reach_distance=0.5),
    }
    for env_id, kwargs in cases.items():
        env = _make(env_id, **kwargs)
        try:
            env.reset(seed=1)
            env.step(env.action_space.sample())
        finally:
            env.close()
    rocket = _make("PyFlyt/Rocket-Landing-v4", ceiling=300.0, max_displacement=100.0)
    try:
        for seed in range(3):
            rocket.reset(seed=seed)
            x, y, z = rocket.vehicle.state.lin_pos  # `state` is the last observation, as in the reference
            # spawn z in U(0.8, 0.9) x ceiling, then 1/12 s of settling at ~100 m/s down
            assert 240.0 - 9.0 <= z <= 270.0 - 8.0 and abs(x) <= 10.5 and abs(y) <= 10.5
    finally:
        rocket.close()


def test_flight_mode_sets_the_action_layout():
    env = _make("PyFlyt/QuadX-Hover-v4", flight_mode=-1)
    try:
        np.testing.assert_allclose(env.action_space.low, [0.0] * 4)
        np.testing.assert_allclose(env.action_space.high, [0.8] * 4)
        assert env.config.action.mode == "motors"
    finally:
        env.close()
    with pytest.raises(ValueError, match="flight_mode"):
        _make("PyFlyt/QuadX-Hover-v4", flight_mode=9)


def test_agent_hz_must_divide_120_as_in_the_reference():
    with pytest.raises(ValueError, match="120"):
        _make("PyFlyt/QuadX-Hover-v4", agent_hz=50)


def test_rgb_array_frames_have_four_channels_at_the_asked_resolution():
    env = _make("PyFlyt/QuadX-Hover-v4", render_mode="rgb_array", render_resolution=(48, 64))
    try:
        env.reset(seed=0)
        frame = env.render()
        assert frame.shape == (48, 64, 4) and frame.dtype == np.uint8
        assert (frame[:, :, 3] == 255).all()
    finally:
        env.close()


def test_info_keys_are_the_references():
    rocket = _make("PyFlyt/Rocket-Landing-v4")
    hover = _make("PyFlyt/QuadX-Hover-v4")
    waypoints = _make("PyFlyt/QuadX-Waypoints-v4")
    try:
        for env, keys in (
            (rocket, {"out_of_bounds", "fatal_collision", "env_complete"}),
            (hover, {"out_of_bounds", "collision", "env_complete"}),
            (waypoints, {"out_of_bounds", "collision", "env_complete", "num_targets_reached"}),
        ):
            _, info = env.reset(seed=0)
            assert keys <= set(info)
            *_, info = env.step(env.action_space.sample())
            assert keys <= set(info) and "reward_terms" not in info
    finally:
        rocket.close()
        hover.close()
        waypoints.close()


def test_mode_0_thrust_is_a_motor_command_matched_at_hover():
    # PyFlyt 0.29.0 QuadX mode 0: the thrust entry is a motor command, thrust ~ command**2;
    # its cf2x hovers at 0.300 (measured), which must be this airframe's hover
    from pyflyt_engine.compat.gym_envs._base import REFERENCE_QUADX_HOVER_COMMAND

    env = _make("PyFlyt/QuadX-Hover-v4")
    try:
        env.reset(seed=0)
        hover = env.vehicle.hover_throttle() ** 2  # thrust fraction at hover
        env.step(np.array([0.0, 0.0, 0.0, REFERENCE_QUADX_HOVER_COMMAND]))
        assert env.vehicle.setpoint[3] == pytest.approx(hover)
        env.step(np.array([0.0, 0.0, 0.0, 2 * REFERENCE_QUADX_HOVER_COMMAND]))
        assert env.vehicle.setpoint[3] == pytest.approx(4 * hover)  # quadratic
        assert env.last_action[3] == pytest.approx(2 * REFERENCE_QUADX_HOVER_COMMAND)  # observed as given
    finally:
        env.close()


def test_flatten_waypoint_env_has_the_references_layout():
    base = gymnasium.make("PyFlyt/QuadX-Waypoints-v4", angle_representation="euler")
    env = FlattenWaypointEnv(base, context_length=2)
    try:
        assert env.observation_space.shape == (20 + 3 * 2,)
        assert env.observation_space.dtype == np.float32
        obs, _ = env.reset(seed=0)
        assert env.observation_space.contains(obs)
    finally:
        env.close()


def test_hover_spawns_at_the_start_point_and_settles_as_the_reference():
    # PyFlyt 0.29.0 QuadXBaseEnv: spawn exactly at (0, 0, 1), then 10 steps of 1/120 s with
    # idle motors before the first observation: 1/12 s of free fall
    env = _make("PyFlyt/QuadX-Hover-v4", angle_representation="euler")
    try:
        obs, _ = env.reset(seed=3)
        fall = 0.5 * 9.81 * (1 / 12) ** 2
        np.testing.assert_allclose(obs[9:12], [0.0, 0.0, 1.0 - fall], atol=2e-3)
        assert obs[8] == pytest.approx(-9.81 / 12, abs=0.02)  # body w (level): falling
        assert env.elapsed_steps == 0
    finally:
        env.close()

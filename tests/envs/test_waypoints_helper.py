"""The shared waypoint logic (no physics) and the flattening wrapper."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pyflyt_engine.envs.waypoints import (
    WaypointTracker,
    body_frame_deltas,
    sample_waypoints,
    segment_point_distance,
)
from pyflyt_engine.envs.wrappers import FlattenWaypointEnv


def test_sampled_waypoints_respect_the_distance_and_height_bounds():
    rng = np.random.default_rng(0)
    targets = sample_waypoints(rng, 2000, 1.0, 4.5, 0.1)
    distance = np.linalg.norm(targets, axis=1)
    raised = targets[:, 2] == 0.1  # heights below the floor were raised to it
    assert targets.shape == (2000, 3)
    assert np.all(targets[:, 2] >= 0.1)
    assert np.all(distance[~raised] >= 1.0 - 1e-9) and np.all(distance <= np.hypot(4.5, 0.1) + 1e-9)
    assert distance.max() > 4.3 and distance.min() < 1.2  # the range is used
    # directions cover the upper hemisphere evenly: mean unit vector ~ (0, 0, 0.5)
    unit = targets[~raised] / distance[~raised, None]
    np.testing.assert_allclose(unit.mean(axis=0), [0, 0, 0.5], atol=0.05)
    again = sample_waypoints(np.random.default_rng(0), 2000, 1.0, 4.5, 0.1)
    np.testing.assert_array_equal(targets, again)


def test_body_frame_deltas_against_scipy_rotations():
    rng = np.random.default_rng(1)
    for _ in range(20):
        rotation = Rotation.from_euler("xyz", rng.uniform(-np.pi, np.pi, 3))  # extrinsic = PyBullet's convention
        position = rng.uniform(-3, 3, 3)
        targets = rng.uniform(-5, 5, (4, 3))
        expected = rotation.inv().apply(targets - position)
        np.testing.assert_allclose(body_frame_deltas(targets, position, rotation.as_quat()), expected, atol=1e-12)
    # a level vehicle yawed 90 degrees left sees a point to the north (+y) straight ahead (+x body)
    quarter = Rotation.from_euler("z", 90, degrees=True).as_quat()
    np.testing.assert_allclose(body_frame_deltas([[0, 2, 1]], [0, 0, 1], quarter), [[2, 0, 0]], atol=1e-12)


def test_segment_distance():
    assert segment_point_distance((0, 0, 0), (2, 0, 0), (1, 1, 0)) == pytest.approx(1.0)
    assert segment_point_distance((0, 0, 0), (2, 0, 0), (3, 0, 0)) == pytest.approx(1.0)  # beyond the end
    assert segment_point_distance((0, 0, 0), (2, 0, 0), (-1, 0, 0)) == pytest.approx(1.0)  # before the start
    assert segment_point_distance((1, 1, 1), (1, 1, 1), (1, 1, 2)) == pytest.approx(1.0)  # no motion


def test_tracker_distance_rate_and_segment_reach():
    tracker = WaypointTracker(reach_distance=0.2)
    tracker.reset(np.array([[3.0, 0.0, 1.0], [3.0, 3.0, 1.0]]), (0.0, 0.0, 1.0))
    delta, rate, reached = tracker.step((1.0, 0.0, 1.0), dt=0.5)
    assert (delta, rate, reached) == (pytest.approx(2.0), pytest.approx(-2.0), False)
    # fly straight through the first waypoint within one step: the sampled points miss it
    delta, rate, reached = tracker.step((5.0, 0.0, 1.0), dt=0.5)
    assert reached and delta == pytest.approx(2.0) and rate == pytest.approx(0.0)
    assert tracker.num_reached == 1 and len(tracker.remaining) == 1
    # the rate to the new waypoint is measured from where the vehicle was when it switched
    delta, rate, reached = tracker.step((3.0, 1.0, 1.0), dt=0.5)
    assert delta == pytest.approx(2.0) and rate == pytest.approx((2.0 - np.hypot(2.0, 3.0)) / 0.5)
    assert not reached
    _, _, reached = tracker.step((3.0, 2.85, 1.0), dt=0.5)
    assert reached and tracker.all_reached
    assert tracker.step((0.0, 0.0, 1.0), dt=0.5) == (0.0, 0.0, False)


def test_flatten_wrapper_pads_and_masks(make):
    env = FlattenWaypointEnv(make("PyFlyt/QuadX-Waypoints-v0", num_targets=3), context_length=4)
    assert env.observation_space.shape == (21 + 4 * 3 + 4,)
    obs, _ = env.reset(seed=0)
    raw = env.unwrapped.task
    deltas = obs[21:33].reshape(4, 3)
    np.testing.assert_array_equal(obs[33:], [1, 1, 1, 0])
    np.testing.assert_array_equal(deltas[3], 0.0)
    state = env.unwrapped.state
    np.testing.assert_allclose(deltas[:3], body_frame_deltas(raw.targets, state.lin_pos, state.quaternion))
    short = FlattenWaypointEnv(make("PyFlyt/QuadX-Waypoints-v0", num_targets=3), context_length=1)
    obs, _ = short.reset(seed=0)
    assert obs.shape == (21 + 3 + 1,) and obs[-1] == 1.0
    with pytest.raises(TypeError, match="Dict"):
        FlattenWaypointEnv(make("PyFlyt/QuadX-Hover-v0"))

"""Per-episode task options: ``env.reset(options={"task": {...}})`` (what a training curriculum sets).

Oracle: the reach test with a reach distance wider than the flight dome's diameter is
passed at the first step for every waypoint still to come, one per step; the configured
0.2 m is not.  The option holds for that episode only.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pyflyt_engine.envs import make_env
from pyflyt_engine.errors import ConfigError

CONFIG = Path(__file__).resolve().parents[2] / "conf" / "env" / "quadx_waypoints.yaml"


@pytest.fixture(scope="module")
def env():
    env = make_env(CONFIG)
    yield env
    env.close()


def _hover(env) -> np.ndarray:
    return np.array([0.0, 0.0, 0.0, 0.35])


def test_a_reach_distance_set_for_one_episode_holds_for_that_episode_only(env):
    _, info = env.reset(seed=4, options={"task": {"goal_reach_distance": 20.0}})
    assert env.task.options.goal_reach_distance == 20.0
    assert env.task.configured.goal_reach_distance == 0.2
    reached = []
    for _ in range(5):
        _, _, terminated, _, info = env.step(_hover(env))
        reached.append(info["num_targets_reached"])
    assert reached == [1, 2, 3, 4, 5]  # every waypoint is within 20 m: one reached per step
    assert terminated and info["env_complete"]

    _, info = env.reset(seed=4)  # no options: the configured task again
    assert env.task.options.goal_reach_distance == 0.2 and env.task.tracker.reach_distance == 0.2
    _, _, _, _, info = env.step(_hover(env))
    assert info["num_targets_reached"] == 0


def test_the_same_seed_with_and_without_options_samples_the_same_waypoints(env):
    env.reset(seed=11, options={"task": {"goal_reach_distance": 1.0}})
    wide = env.task.targets
    env.reset(seed=11)
    np.testing.assert_array_equal(env.task.targets, wide)


@pytest.mark.parametrize(
    ("options", "error", "names"),
    [
        ({"task": {"num_targets": 3}}, ValueError, ["num_targets", "goal_reach_distance"]),
        ({"task": {"goal_reach_distance": -1.0}}, ValueError, ["goal_reach_distance", "greater than 0"]),
        ({"task": {"min_target_distance": 9.0}}, ConfigError, ["min_target_distance", "widen the dome"]),
        ({"wind": "gust"}, ValueError, ['{"task"', "wind"]),
    ],
)
def test_bad_episode_options_are_refused_with_the_option_named(env, options, error, names):
    with pytest.raises(error) as exc:
        env.reset(seed=0, options=options)
    for name in names:
        assert name in str(exc.value)
    env.reset(seed=0)  # the env is still usable, as configured
    assert env.task.options == env.task.configured


def test_a_task_without_episode_options_refuses_any():
    env = make_env(CONFIG.with_name("quadx_hover.yaml"))
    try:
        with pytest.raises(ValueError, match="options an episode may set: none"):
            env.reset(seed=0, options={"task": {"start_position_noise": 0.0}})
    finally:
        env.close()


def test_the_landing_task_drops_from_an_episode_height_and_refreshes_its_thresholds():
    env = make_env(CONFIG.with_name("rocket_landing.yaml"))
    try:
        env.reset(seed=2, options={"task": {"start_position": [0.0, 0.0, 40.0], "tip_over_angle_deg": 60.0}})
        assert env.vehicle.state.lin_pos[2] == pytest.approx(40.0)  # start_height_noise is 0
        assert env.task._tip_over == pytest.approx(np.radians(60.0))
        env.reset(seed=2)
        assert env.vehicle.state.lin_pos[2] == pytest.approx(450.0)
        assert env.task._tip_over == pytest.approx(np.radians(30.0))
        with pytest.raises(ValueError, match="pad_radius"):
            env.reset(seed=2, options={"task": {"pad_radius": 5.0}})  # the pad is built once
    finally:
        env.close()

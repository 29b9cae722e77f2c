"""QuadX-Waypoints flown through the velocity flight mode (conf/env/quadx_waypoints_velocity.yaml).

Oracle: the task is solvable within its limits.  A proportional controller that only
steers the velocity setpoint towards the next waypoint (v = 2 x delta, clipped to the
action bounds) reaches all five waypoints well inside the 20 s episode, in the shipped
config, on several seeds: what a policy in this action space has to learn is that map.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pyflyt_engine.envs import make_env

CONFIG = Path(__file__).resolve().parents[2] / "conf" / "env" / "quadx_waypoints_velocity.yaml"


@pytest.mark.parametrize("seed", [0, 10_000, 10_004])
def test_steering_the_velocity_at_the_next_waypoint_reaches_all_five(seed):
    env = make_env(CONFIG, angle_representation="euler")
    try:
        assert env.config.action.mode == "velocity_yawrate"
        obs, _ = env.reset(seed=seed)
        low, high = env.action_space.low, env.action_space.high
        total, steps = 0.0, 0
        for steps in range(1, env.config.max_steps + 1):
            delta = env.task.tracker.remaining[0] - obs["attitude"][9:12]  # euler: position 9-11
            action = np.clip([2.0 * delta[0], 2.0 * delta[1], 0.0, 2.0 * delta[2]], low, high)
            obs, reward, terminated, truncated, info = env.step(action)
            total += reward
            if terminated or truncated:
                break
        assert info["num_targets_reached"] == 5 and info["env_complete"] and not info["collision"]
        assert steps < 0.75 * env.config.max_steps  # all five within 15 of the 20 s
        assert total > 500.0  # five +100 bonuses plus the approach and proximity terms
    finally:
        env.close()

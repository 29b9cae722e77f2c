"""A new task and a new reward term slot in without touching the env (the Rocket-Landing path)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from pyflyt_engine.envs import rewards
from pyflyt_engine.envs.config import env_config_data
from pyflyt_engine.envs.env import UAVEnv
from pyflyt_engine.envs.tasks import TASKS, Task, TaskSignals, register_task


class TouchdownTask(Task):
    """Touch the ground: contact is the goal, not a crash; too fast is a task failure."""

    name = "test_touchdown"
    provides = frozenset({"touchdown_speed"})
    crash_on_contact = False

    def setup(self, world):
        self.world = world  # scenery would be added here, before the reset snapshot

    def update(self, state):
        touching = self.world.collided_with_ground(0)
        speed = float(np.linalg.norm(state.lin_vel))
        return TaskSignals(
            complete=touching and speed < 5.0, failed=touching and speed >= 5.0, extras={"touchdown_speed": speed}
        )


def touchdown_speed(ctx):
    """Speed at the step [m/s] as reported by the task."""
    return ctx.extras["touchdown_speed"]


@pytest.fixture
def touchdown():
    register_task(TouchdownTask)
    rewards.TERMS["touchdown_speed"] = rewards.RewardTerm(touchdown_speed, "m/s", ("touchdown_speed",))
    yield
    del TASKS["test_touchdown"]
    del rewards.TERMS["touchdown_speed"]


def test_custom_task_and_term_through_the_generic_env(touchdown):
    data = copy.deepcopy(
        env_config_data("quadx_hover")
    )  # its bases' keys too: the task below replaces the whole section
    data["id"] = None
    data["task"] = {"name": "test_touchdown", "start_position": [0, 0, 0.3], "start_position_noise": 0.0}
    data["reward"] = {
        "terms": {
            "landed": {"term": "constant", "weight": 10.0, "when": "task_complete"},
            "speed": {"term": "touchdown_speed", "weight": -1.0, "when": "not_crash"},
            "crash": {"term": "constant", "weight": -100.0, "when": "crash"},
        }
    }
    env = UAVEnv(data)
    try:
        env.reset(seed=0)
        for _ in range(30):
            obs, reward, terminated, truncated, info = env.step(np.zeros(4))
            if terminated:
                break
        assert terminated and info["collision"] and info["env_complete"] and info["success"]
        assert info["reward_terms"]["crash"] == 0.0 and info["reward_terms"]["landed"] == 10.0
        assert reward == pytest.approx(10.0 - np.linalg.norm(env.state.lin_vel))
    finally:
        env.close()
    # the hover task does not provide the new signal: the preset is refused at build time
    data["task"] = {"name": "hover"}
    with pytest.raises(Exception, match="needs the signal 'touchdown_speed'"):
        UAVEnv(data)

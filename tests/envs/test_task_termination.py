"""The loop asks the task how a step ends the episode (``Task.termination``)."""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np
import pytest

from pyflyt_engine.envs.env import UAVEnv
from pyflyt_engine.envs.tasks import TASKS, HoverOptions, HoverTask, register_task
from pyflyt_engine.envs.tasks.base import termination


class _RoamOptions(HoverOptions):
    name: Literal["test_roam"] = "test_roam"  # type: ignore[assignment]


class RoamTask(HoverTask):
    """Hover whose episode never ends early: leaving the dome is no crash."""

    name: ClassVar[str] = "test_roam"
    Options = _RoamOptions

    def termination(self, collision, out_of_bounds, signals):
        return False, False


@pytest.fixture
def roam():
    register_task(RoamTask)
    yield
    del TASKS[RoamTask.name]


def test_the_default_rule():
    assert termination(False, True, False, False, True) == (True, True)  # out of the dome
    assert termination(True, False, False, False, False) == (False, False)  # contact is no crash here
    assert termination(True, False, False, False, True) == (True, True)
    assert termination(False, False, False, True, True) == (False, True)  # complete


def test_a_task_that_overrides_termination_decides_alone(roam):
    from pyflyt_engine.envs.config import load_env_config

    data = load_env_config("quadx_hover").model_dump(exclude={"source"})
    data["task"]["name"] = "test_roam"
    ends = {}
    for name in ("hover", "test_roam"):
        data["task"]["name"] = name
        env = UAVEnv({**data, "flight_dome_size": 0.5})  # the spawn at 1 m is outside the dome
        try:
            env.reset(seed=0)
            _, _, terminated, _, info = env.step(np.zeros(4))
            ends[name] = (terminated, info["out_of_bounds"])
        finally:
            env.close()
    assert ends == {"hover": (True, True), "test_roam": (False, True)}

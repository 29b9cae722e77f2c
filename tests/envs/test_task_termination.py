"""How a step ends the episode is the env config's termination terms, not the task's own hook."""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np
import pytest

from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.env import UAVEnv
from pyflyt_engine.envs.tasks import TASKS, HoverOptions, HoverTask, register_task
from pyflyt_engine.envs.tasks.base import termination
from pyflyt_engine.errors import ConfigError


class _RoamOptions(HoverOptions):
    name: Literal["test_roam"] = "test_roam"  # type: ignore[assignment]


class RoamTask(HoverTask):
    """Hover with the retired hook: a task deciding the episode's end on its own."""

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


def _first_step(**changes):
    data = load_env_config("quadx_hover").model_dump(exclude={"source"})
    env = UAVEnv({**data, "flight_dome_size": 0.5, **changes})  # the spawn at 1 m is outside the dome
    try:
        env.reset(seed=0)
        _, _, terminated, _, info = env.step(np.zeros(4))
        return terminated, info["out_of_bounds"]
    finally:
        env.close()


def test_the_config_decides_whether_leaving_the_dome_ends_the_episode():
    assert _first_step() == (True, True)
    off = {**load_env_config("quadx_hover").model_dump()["terminations"], "out_of_dome": None}
    assert _first_step(terminations=off) == (False, True)  # still measured, no longer an end


def test_a_task_that_still_defines_termination_is_refused_naming_the_fix(roam):
    data = load_env_config("quadx_hover").model_dump(exclude={"source"})
    data["task"]["name"] = "test_roam"
    with pytest.raises(ConfigError, match="defines termination.*register_termination"):
        UAVEnv(data)

"""Task registry: task name (``task.name`` in an env YAML) -> :class:`Task` subclass.

Built-in tasks are listed here; add your own from Python with :func:`register_task`
(config files name tasks, they never import code).
"""

from __future__ import annotations


from pyflyt_engine.envs.tasks.ball_in_cup import BallInCupOptions, BallInCupTask
from pyflyt_engine.envs.tasks.base import Spawn, Task, TaskOptions, TaskSignals
from pyflyt_engine.envs.tasks.gates import GatesOptions, GatesTask
from pyflyt_engine.envs.tasks.goal import GoalOptions, GoalTask
from pyflyt_engine.envs.tasks.hover import HoverOptions, HoverTask
from pyflyt_engine.envs.tasks.landing import LandingOptions, LandingTask
from pyflyt_engine.envs.tasks.pole import PoleBalanceOptions, PoleBalanceTask, PoleWaypointsOptions, PoleWaypointsTask
from pyflyt_engine.envs.tasks.waypoints import WaypointsOptions, WaypointsTask
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.suggest import did_you_mean

TASKS: dict[str, type[Task]] = {
    HoverTask.name: HoverTask,
    WaypointsTask.name: WaypointsTask,
    LandingTask.name: LandingTask,
    PoleBalanceTask.name: PoleBalanceTask,
    PoleWaypointsTask.name: PoleWaypointsTask,
    BallInCupTask.name: BallInCupTask,
    GatesTask.name: GatesTask,
    GoalTask.name: GoalTask,
}


def register_task(task: type[Task]) -> None:
    """Make ``task`` available to env configs as ``task: {name: <task.name>, ...}``."""
    if not (isinstance(task, type) and issubclass(task, Task)):
        raise TypeError(f"register_task needs a Task subclass, got {task!r}")
    TASKS[task.name] = task


def get_task(name: str) -> type[Task]:
    """The task class registered as ``name``. Raises ConfigError listing the valid ones."""
    try:
        return TASKS[name]
    except KeyError:
        hint = did_you_mean(str(name), list(TASKS))
        raise ConfigError(f"unknown task '{name}'.{hint} Valid: {', '.join(TASKS)}") from None


__all__ = [
    "TASKS",
    "BallInCupOptions",
    "BallInCupTask",
    "GatesOptions",
    "GatesTask",
    "GoalOptions",
    "GoalTask",
    "HoverOptions",
    "HoverTask",
    "LandingOptions",
    "LandingTask",
    "PoleBalanceOptions",
    "PoleBalanceTask",
    "PoleWaypointsOptions",
    "PoleWaypointsTask",
    "Spawn",
    "Task",
    "TaskOptions",
    "TaskSignals",
    "WaypointsOptions",
    "WaypointsTask",
    "get_task",
    "register_task",
]

"""The tasks: one module per task, each holding its Task, its options, its reward terms,
its oracles and its registration (:func:`~pyflyt_engine.envs.task_registry.register_task` at
the end of the module).

Single-agent tasks subclass :class:`~pyflyt_engine.envs.tasks.base.Task` (one vehicle,
run by :class:`~pyflyt_engine.envs.env.UAVEnv`); multi-agent tasks subclass
:class:`~pyflyt_engine.envs.tasks.multi.MultiAgentTask` (``ma_hover``, ``ma_formation``,
``dogfight``: N agents in one world, run by the env class each registers).

Importing this package imports every shipped task module, which fills the one task
registry (:mod:`pyflyt_engine.envs.task_registry`).  :data:`TASKS` is its view of the
single-agent tasks (task name, ``task.name`` in an env YAML -> :class:`Task` subclass);
add your own from Python with :func:`register_task` (config files name tasks, they never
import code).
"""

from __future__ import annotations

from typing import Any

# the shipped task modules, single-agent then multi-agent, in the order the tasks are listed
# (each registers itself): a new task adds its module here
from pyflyt_engine.envs.tasks import hover, waypoints, landing, pole, ball_in_cup, gates, goal  # noqa: F401
from pyflyt_engine.envs.tasks import ma_hover, ma_formation, dogfight  # noqa: F401
from pyflyt_engine.envs import task_registry
from pyflyt_engine.envs.task_registry import TaskTable
from pyflyt_engine.envs.tasks.ball_in_cup import BallInCupOptions, BallInCupTask
from pyflyt_engine.envs.tasks.base import Spawn, Task, TaskOptions, TaskSignals
from pyflyt_engine.envs.tasks.gates import GatesOptions, GatesTask
from pyflyt_engine.envs.tasks.goal import GoalOptions, GoalTask
from pyflyt_engine.envs.tasks.hover import HoverOptions, HoverTask
from pyflyt_engine.envs.tasks.landing import LandingOptions, LandingTask
from pyflyt_engine.envs.tasks.pole import PoleBalanceOptions, PoleBalanceTask, PoleWaypointsOptions, PoleWaypointsTask
from pyflyt_engine.envs.tasks.waypoints import WaypointsOptions, WaypointsTask

#: single-agent task name -> Task subclass: a live view of the task registry
#: (``TASKS[name] = cls`` registers, ``del TASKS[name]`` unregisters)
TASKS: TaskTable[type[Task]] = TaskTable("single", "task")


def register_task(task: type[Task], **kwargs: Any) -> type[Task]:
    """Make ``task`` available to env configs as ``task: {name: <task.name>, ...}``; returns it.

    :func:`pyflyt_engine.envs.task_registry.register_task` for a single-agent task (keywords as
    there: ``oracles``, ``name``).

    Raises:
        TypeError: ``task`` is not a :class:`Task` subclass.
    """
    if not (isinstance(task, type) and issubclass(task, Task)):
        raise TypeError(f"register_task needs a Task subclass, got {task!r}")
    return task_registry.register_task(task, **kwargs)


def get_task(name: str) -> type[Task]:
    """The task class registered as ``name``. Raises ConfigError listing the valid ones."""
    return task_registry.task_entry(name, "single").task


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

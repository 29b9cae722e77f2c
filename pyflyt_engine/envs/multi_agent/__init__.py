"""Multi-agent environments (PettingZoo): several vehicles in one World.

One module per environment, in PettingZoo's layout (``parallel_env(**kwargs)``,
``env(**kwargs)`` for the AEC form, ``raw_env``):

* :mod:`.ma_quadx_hover_v0` -- N quadrotors, each holding its own hover point
  (:class:`~.hover.MAQuadXHoverEnv`);
* :mod:`.ma_quadx_formation_v0` -- a swarm of 2 to 128 quadrotors keeping a moving grid
  formation (:class:`~.formation.MAQuadXFormationEnv`);
* :mod:`.ma_fixedwing_dogfight_v0` -- two teams of fixed-wings with forward guns
  (:class:`~.dogfight.MAFixedwingDogfightEnv`).

Configs are declared in ``conf/env/ma_*.yaml`` (the agents, their airframes, teams and
spawn regions); rewards are named terms in ``conf/reward/`` as for every env.  Each
env runs a task object (a :class:`~pyflyt_engine.envs.tasks.multi.MultiAgentTask`), over
one loop (:class:`~.base.MultiAgentUAVEnv`).  The tasks are modules of
:mod:`pyflyt_engine.envs.tasks` (``ma_hover``, ``ma_formation``, ``dogfight``: options,
task, reward terms), each registered in the one task registry with the env class that
runs it (:mod:`pyflyt_engine.envs.task_registry`).
:class:`~.shared.SharedPolicyEnv` presents a parallel env to one policy shared by all
agents (training with ``pyflyt train env=ma_quadx_hover``).  The package is imported on
demand: ``import pyflyt_engine`` does not import PettingZoo.
"""

from __future__ import annotations

from dataclasses import dataclass

from pyflyt_engine.envs import task_registry
from pyflyt_engine.envs import tasks as _tasks  # noqa: F401  (the shipped tasks: the registry TASK_CLASSES views)
from pyflyt_engine.envs.task_registry import TaskTable


@dataclass(frozen=True)
class MultiAgentEntry:
    """A multi-agent environment: its module (PettingZoo layout), class and shipped config."""

    module: str
    entry_point: str
    config: str


#: environment name -> registration.  Behaviour changes get a new version.
MA_ENVS: dict[str, MultiAgentEntry] = {
    "ma_quadx_hover_v0": MultiAgentEntry(
        "pyflyt_engine.envs.multi_agent.ma_quadx_hover_v0",
        "pyflyt_engine.envs.multi_agent.hover:MAQuadXHoverEnv",
        "ma_quadx_hover",
    ),
    "ma_quadx_formation_v0": MultiAgentEntry(
        "pyflyt_engine.envs.multi_agent.ma_quadx_formation_v0",
        "pyflyt_engine.envs.multi_agent.formation:MAQuadXFormationEnv",
        "ma_quadx_formation",
    ),
    "ma_fixedwing_dogfight_v0": MultiAgentEntry(
        "pyflyt_engine.envs.multi_agent.ma_fixedwing_dogfight_v0",
        "pyflyt_engine.envs.multi_agent.dogfight:MAFixedwingDogfightEnv",
        "ma_fixedwing_dogfight",
    ),
}

#: multi-agent task name -> the class running it (``module:Class``): a live view of the task
#: registry, where each task module registers its env class
TASK_CLASSES: TaskTable[str | None] = TaskTable("multi", "env")

#: the env class of a multi-agent task registered without one: the generic loop, running the
#: task the config names
GENERIC_ENV = "pyflyt_engine.envs.multi_agent.base:MultiAgentUAVEnv"


def env_class(task_name: str) -> type:
    """The parallel env class that runs multi-agent task ``task_name``.

    Raises:
        ConfigError: no multi-agent task of that name (the message names the valid ones).
    """
    import importlib

    module, _, name = (task_registry.task_entry(task_name, "multi").env or GENERIC_ENV).partition(":")
    return getattr(importlib.import_module(module), name)


__all__ = ["GENERIC_ENV", "MA_ENVS", "TASK_CLASSES", "MultiAgentEntry", "env_class"]

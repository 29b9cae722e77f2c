"""The check of a multi-agent config's references, and the lookup of its task class.

The multi-agent config models (:class:`~pyflyt_engine.envs.config.MultiAgentEnvConfig`,
its agents) live with the other env configs in :mod:`pyflyt_engine.envs.config`, whose
loaders accept both kinds; each multi-agent task (its options, task class, reward terms
and registration) is a module of :mod:`pyflyt_engine.envs.tasks`, in the one task
registry (:mod:`pyflyt_engine.envs.task_registry`).  This module has :func:`get_ma_task`
and :func:`check_references`.  It imports no PettingZoo.
"""

from __future__ import annotations

from pyflyt_engine.envs import task_registry
from pyflyt_engine.envs.config import MultiAgentEnvConfig, load_reward_preset
from pyflyt_engine.envs.tasks.multi import MA_TASK_CLASSES, MultiAgentTask, register_ma_task
from pyflyt_engine.spec import load_uav_spec


def get_ma_task(name: str) -> type[MultiAgentTask]:
    """The task class registered as ``name``. Raises ConfigError listing the valid ones."""
    return task_registry.task_entry(name, "multi").task


def check_references(config: MultiAgentEnvConfig) -> None:
    """Load the reward preset and every airframe the config names, so a wrong name fails now."""
    load_reward_preset(config.reward_preset_name()).compile(get_ma_task(config.task.name).provides, config.task.name)
    for uav in dict.fromkeys(a.uav for a in config.resolved_agents()):
        load_uav_spec(uav)


__all__ = ["MA_TASK_CLASSES", "check_references", "get_ma_task", "register_ma_task"]

"""The shipped multi-agent tasks, registered, and the check of a config's references.

The multi-agent config models (:class:`~pyflyt_engine.envs.config.MultiAgentEnvConfig`,
its agents, spawns and task options) live with the other env configs in
:mod:`pyflyt_engine.envs.config`, whose loaders accept both kinds.  This module registers
the task objects that run the shipped multi-agent tasks (each declares the reward
signals it provides and registers its own reward terms) and has :func:`check_references`.
It imports no PettingZoo.
"""

from __future__ import annotations


from pyflyt_engine.envs.config import MultiAgentEnvConfig, load_reward_preset
from pyflyt_engine.envs.multi_agent.dogfight_task import DogfightTask
from pyflyt_engine.envs.multi_agent.formation_task import MAFormationTask
from pyflyt_engine.envs.multi_agent.hover_task import MAHoverTask
from pyflyt_engine.envs.multi_agent.task import MA_TASK_CLASSES, MultiAgentTask, register_ma_task
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.suggest import did_you_mean

for _task in (MAHoverTask, MAFormationTask, DogfightTask):
    register_ma_task(_task)


def get_ma_task(name: str) -> type[MultiAgentTask]:
    """The task class registered as ``name``. Raises ConfigError listing the valid ones."""
    try:
        return MA_TASK_CLASSES[name]
    except KeyError:
        hint = did_you_mean(str(name), list(MA_TASK_CLASSES))
        raise ConfigError(f"unknown multi-agent task '{name}'.{hint} Valid: {', '.join(MA_TASK_CLASSES)}") from None


def check_references(config: MultiAgentEnvConfig) -> None:
    """Load the reward preset and every airframe the config names, so a wrong name fails now."""
    load_reward_preset(config.reward_preset_name()).compile(get_ma_task(config.task.name).provides, config.task.name)
    for uav in dict.fromkeys(a.uav for a in config.resolved_agents()):
        load_uav_spec(uav)

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
env runs a task object (:mod:`.task`: :class:`~.task.MultiAgentTask`; the shipped ones in
:mod:`.hover_task`, :mod:`.formation_task`, :mod:`.dogfight_task`, registered by
:mod:`.config`), over one loop (:class:`~.base.MultiAgentUAVEnv`).
:class:`~.shared.SharedPolicyEnv` presents a parallel env to one policy shared by all
agents (training with ``pyflyt train env=ma_quadx_hover``).  The package is imported on
demand: ``import pyflyt_engine`` does not import PettingZoo.
"""

from __future__ import annotations

from dataclasses import dataclass


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

#: multi-agent task name -> the class running it
TASK_CLASSES: dict[str, str] = {
    "ma_hover": "pyflyt_engine.envs.multi_agent.hover:MAQuadXHoverEnv",
    "ma_formation": "pyflyt_engine.envs.multi_agent.formation:MAQuadXFormationEnv",
    "dogfight": "pyflyt_engine.envs.multi_agent.dogfight:MAFixedwingDogfightEnv",
}


def env_class(task_name: str) -> type:
    """The parallel env class that runs multi-agent task ``task_name``."""
    import importlib

    module, _, name = TASK_CLASSES[task_name].partition(":")
    return getattr(importlib.import_module(module), name)


__all__ = ["MA_ENVS", "TASK_CLASSES", "MultiAgentEntry", "env_class"]

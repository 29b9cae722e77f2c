"""What the multi-agent tasks provide beyond their configs, and the check of a config's references.

The multi-agent config models (:class:`~pyflyt_engine.envs.config.MultiAgentEnvConfig`,
its agents, spawns and task options) live with the other env configs in
:mod:`pyflyt_engine.envs.config`, whose loaders accept both kinds; this module adds the
reward signals each multi-agent task provides (:data:`PROVIDES`) and
:func:`check_references`.
"""

from __future__ import annotations

from pyflyt_engine.envs.config import MultiAgentEnvConfig, load_reward_preset
from pyflyt_engine.spec import load_uav_spec

#: reward signals each multi-agent task provides (checked against the reward preset)
PROVIDES: dict[str, frozenset[str]] = {
    "ma_hover": frozenset({"target_distance", "target_distance_rate"}),
    "ma_formation": frozenset({"target_distance", "target_distance_rate", "formation"}),
    "dogfight": frozenset({"dogfight"}),
}


def check_references(config: MultiAgentEnvConfig) -> None:
    """Load the reward preset and every airframe the config names, so a wrong name fails now."""
    load_reward_preset(config.reward_preset_name()).compile(PROVIDES[config.task.name], config.task.name)
    for uav in dict.fromkeys(a.uav for a in config.resolved_agents()):
        load_uav_spec(uav)

"""A task's own reward terms and conditions live in its module; the global module keeps the generic ones."""

from __future__ import annotations

import pytest

from pyflyt_engine.envs import rewards
from pyflyt_engine.envs.config import load_reward_preset

#: signals any task may provide through the StepContext's own fields
GENERIC = {"target_distance", "target_distance_rate", "waypoints"}
OWNERS = {
    "pole": "pyflyt_engine.envs.tasks.pole",
    "ball_in_cup": "pyflyt_engine.envs.tasks.ball_in_cup",
    "landing": "pyflyt_engine.envs.tasks.landing",
    "dogfight": "pyflyt_engine.envs.tasks.dogfight",
    "formation": "pyflyt_engine.envs.tasks.ma_formation",
}


def test_task_signals_are_read_only_by_the_tasks_own_module():
    entries = [*rewards.TERMS.items(), *rewards.CONDITIONS.items()]
    for name, entry in entries:
        own = set(entry.requires) - GENERIC
        if entry.fn.__module__ == rewards.__name__:
            assert not own, f"'{name}' reads {sorted(own)} but is defined in the global rewards module"
        for signal in own:
            assert entry.fn.__module__ == OWNERS[signal], f"'{name}' reads {signal} from {entry.fn.__module__}"
    assert {"pole_lean", "ball_height", "hits_dealt"} <= set(rewards.TERMS)
    assert {"safe_landing", "ball_in_cup", "team_win"} <= set(rewards.CONDITIONS)


def test_registering_a_name_twice_with_another_function_is_refused():
    term = rewards.TERMS["pole_lean"]
    rewards.register_term("pole_lean", term)  # the same entry again (a module imported twice): fine
    with pytest.raises(ValueError, match="registered already"):
        rewards.register_term("pole_lean", rewards.RewardTerm(rewards.constant, "1"))
    with pytest.raises(ValueError, match="reserved"):
        rewards.register_condition("not_x", rewards.Condition(rewards.always))


@pytest.mark.parametrize(
    "preset",
    ["quadx_pole_balance_dense", "quadx_ball_in_cup_dense", "rocket_landing_dense", "ma_fixedwing_dogfight_dense"],
)
def test_shipped_presets_name_the_task_terms(preset):
    assert load_reward_preset(preset).compile() is not None

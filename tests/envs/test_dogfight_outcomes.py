"""Dogfight outcomes (docs/multi_agent.md): each agent's ``info["outcome"]`` on its last step,
``success`` only for a win by kill, never for a crash (one's own or the opponent's)."""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.envs.multi_agent import ma_fixedwing_dogfight_v0

STILL = {"position_noise": 0.0, "orientation_noise": 0.0, "lin_vel": [14.0, 0.0, 0.0]}
CRUISE = np.array([0.0, 0.0, 0.0, 0.45])
DIVE = np.array([0.0, 1.0, 0.0, 1.0])  # full nose-down elevator (+1 on this airframe), full thrust


def _fight(agents, policy, steps=300, **kwargs):
    """Step until every agent is out; each agent's last info, and the env's episode success."""
    env = ma_fixedwing_dogfight_v0.parallel_env(agents=agents, **kwargs)
    _, infos = env.reset(seed=0)
    assert all(info["outcome"] is None for info in infos.values())
    last = {}
    for _ in range(steps):
        _, _, terms, truncs, infos = env.step({a: policy(a) for a in env.agents})
        for name, info in infos.items():
            if terms[name] or truncs[name]:
                last[name] = info
            else:
                assert info["outcome"] is None and not info["success"]
        if not env.agents:
            break
    assert not env.agents
    decided = env.episode_success(np.array([last[a]["success"] for a in env.possible_agents]))
    env.close()
    return last, decided


def test_a_kill_wins_and_is_the_only_success():
    agents = [
        {"team": 0, "spawn": {"position": [0.0, 0.0, 40.0], **STILL}},
        {"team": 1, "spawn": {"position": [10.0, 0.0, 40.0], **STILL}},
    ]
    last, decided = _fight(agents, lambda a: CRUISE, damage_per_second=3.0)
    assert last["uav_0"]["outcome"] == "win_by_kill" and last["uav_0"]["success"]
    assert last["uav_1"]["outcome"] == "loss" and not last["uav_1"]["success"]
    assert decided


def test_a_crash_is_never_a_success_and_the_opponents_crash_is_no_win_by_kill():
    # uav_1 dives into the ground from 6 m; uav_0, 300 m away, never fires a shot
    agents = [
        {"team": 0, "spawn": {"position": [0.0, 0.0, 40.0], **STILL}},
        {"team": 1, "spawn": {"position": [0.0, 300.0, 6.0], **STILL}},
    ]
    last, decided = _fight(agents, lambda a: DIVE if a == "uav_1" else CRUISE)
    assert last["uav_1"]["outcome"] == "crash" and last["uav_1"]["collision"] and not last["uav_1"]["success"]
    assert last["uav_0"]["outcome"] == "win_by_default" and last["uav_0"]["team_win"]
    assert not last["uav_0"]["success"] and not decided


def test_leaving_the_dome_and_the_time_limit():
    agents = [
        {"team": 0, "spawn": {"position": [0.0, 0.0, 40.0], **STILL}},
        {"team": 1, "spawn": {"position": [0.0, 300.0, 40.0], **STILL}},
    ]
    # a 60 m dome: uav_1 starts outside it
    last, decided = _fight(agents, lambda a: CRUISE, flight_dome_size=100.0)
    assert last["uav_1"]["outcome"] == "out_of_bounds" and last["uav_1"]["out_of_bounds"]
    assert last["uav_0"]["outcome"] == "win_by_default" and not decided
    # 2 s and nobody in range: both are alive at the time limit
    last, decided = _fight(agents, lambda a: CRUISE, max_duration_seconds=2.0)
    assert [last[a]["outcome"] for a in ("uav_0", "uav_1")] == ["time_limit", "time_limit"]
    assert not any(info["success"] for info in last.values()) and not decided


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        ((True, True, True, True, False), "loss"),  # shot down while crashing: shot down
        ((False, True, True, True, False), "crash"),
        ((False, False, True, True, False), "out_of_bounds"),
        ((False, False, False, False, True), "time_limit"),
        ((False, False, False, False, False), None),
    ],
)
def test_outcome_precedence(args, expected):
    env = ma_fixedwing_dogfight_v0.parallel_env()
    env.reset(seed=0)
    shot_down, crashed, out, won, time_up = args
    assert env.task._outcome(shot_down, crashed, out, won, 0, time_up) == expected
    env.task._team_kills = [0, 0]
    assert env.task._outcome(False, False, False, True, 0, False) == "win_by_default"
    env.task._team_kills = [1, 0]
    assert env.task._outcome(False, False, False, True, 0, False) == "win_by_kill"
    assert env.task._outcome(False, False, False, True, 1, False) == "win_by_default"
    env.close()

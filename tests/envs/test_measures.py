"""The tasks' success measures: ``info["measures"]`` on the step that ends an episode, and
the same values in the recording's end record.

Oracles: the distance held, computed by hand from the recorded trajectory (the hover
point minus every recorded position after the reset); the waypoint and gate counts the
step infos already carry; the landing task's own outcome flags; a multi-agent episode's
per-agent values averaged by hand.  Computing the measures must not change an episode:
the returns with and without them (a recording) are the same floats.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.tasks.measures import DISTANCE_HELD, Measure, describe, summarize_measures
from pyflyt_engine.telemetry import RecordEpisode, load_episode


def _fly(env, seed: int, action) -> tuple[list[dict], float]:
    _, info = env.reset(seed=seed)
    infos, total, done = [info], 0.0, False
    while not done:
        _, reward, terminated, truncated, info = env.step(action(env))
        infos.append(info)
        total += float(reward)
        done = terminated or truncated
    return infos, total


def _hover_thrust(env):
    # a little under hover thrust with a slight roll: the quad drifts off the point and stays up a while
    return np.array([0.1, 0.0, 0.0, 0.55])


def test_hover_distance_held_is_the_recorded_trajectorys_distance_to_the_point(tmp_path):
    env = RecordEpisode(make_env("quadx_hover", max_duration_seconds=2), tmp_path, prefix="ep")
    infos, _ = _fly(env, 4, _hover_thrust)
    path = env.paths[-1]
    env.close()
    measures = infos[-1]["measures"]
    assert all("measures" not in info for info in infos[:-1])  # only the step that ends the episode
    recorded = load_episode(path)
    positions = recorded.vehicles[0].states["lin_pos"][1:]  # after the reset: the policy's steps
    assert len(positions) == len(infos) - 1 > 5
    by_hand = np.linalg.norm(positions - np.array([0.0, 0.0, 1.0]), axis=1)
    assert measures["distance_mean"] == pytest.approx(by_hand.mean(), rel=1e-12)
    assert measures["distance_max"] == pytest.approx(by_hand.max(), rel=1e-12)
    assert recorded.end["measures"] == pytest.approx(measures, rel=1e-12)  # the MCAP end record holds them


def test_measures_do_not_change_the_episode(tmp_path):
    plain = make_env("quadx_hover", max_duration_seconds=1)
    recorded = RecordEpisode(make_env("quadx_hover", max_duration_seconds=1), tmp_path, prefix="ep")
    _, a = _fly(plain, 9, _hover_thrust)
    _, b = _fly(recorded, 9, _hover_thrust)
    _, c = _fly(plain, 9, _hover_thrust)
    plain.close()
    recorded.close()
    assert a == b == c


def test_waypoint_measures_count_the_waypoints_the_infos_report():
    env = make_env("quadx_waypoints", max_duration_seconds=2)
    infos, _ = _fly(env, 1, lambda e: np.zeros(4))
    env.close()
    end = infos[-1]
    assert end["measures"] == {
        "waypoints_reached": float(end["num_targets_reached"]),
        "all_reached": float(end["num_targets_reached"] == env.config.task.num_targets),
    }
    assert [m.key for m in env.measures] == ["waypoints_reached", "all_reached"]


def test_the_rocket_lander_lands_and_its_measures_say_so():
    from pyflyt_engine.envs.oracles import make_oracle

    env = make_env("rocket_landing")
    oracle = make_oracle("rocket_lander", env)
    obs, info = env.reset(seed=3)
    done, speeds = False, []
    while not done:
        before = float(np.linalg.norm(env.state.lin_vel))
        obs, _, terminated, truncated, info = env.step(oracle(obs.astype(np.float32)))
        speeds.append((before, float(np.linalg.norm(env.state.lin_vel)), info["pad_contact"]))
        done = terminated or truncated
    env.close()
    m = info["measures"]
    assert info["safe_landing"] and m["landed"] == 1.0 and m["fatal_landing"] == 0.0 and m["ground_contact"] == 0.0
    # the touchdown: the first step touching the pad; its speed the larger of the speeds before and after it
    first = next(i for i, (_, _, pad) in enumerate(speeds) if pad)
    assert m["touchdown_speed"] == pytest.approx(max(speeds[first][:2]), rel=1e-12)


def test_an_episode_without_a_touchdown_has_no_touchdown_speed():
    env = make_env("rocket_landing")
    infos, _ = _fly(env, 0, lambda e: np.zeros(env.action_space.shape))
    env.close()
    m = infos[-1]["measures"]
    assert not any(i.get("pad_contact") for i in infos)
    assert m["landed"] == 0.0 and math.isnan(m["touchdown_speed"])
    assert m["ground_contact"] == float(infos[-1]["ground_contact"])


def test_a_multi_agent_episode_reports_each_agent_and_their_mean():
    env = make_env("ma_quadx_hover", max_duration_seconds=1)
    n = env.num_agents
    _, info = env.reset(seed=2)
    done, ends = False, {}
    while not done:
        _, _, terminated, truncated, info = env.step(np.tile([0.0, 0.0, 0.0, 0.6], (n, 1)))
        for name, agent_info in info["agent_infos"].items():
            if "measures" in agent_info:
                ends[name] = agent_info["measures"]
        done = terminated or truncated
    names = env.agent_names
    env.close()
    m = info["measures"]
    assert set(ends) == set(names)
    for name in names:
        assert m[f"{name}/distance_mean"] == ends[name]["distance_mean"]
    assert m["distance_mean"] == pytest.approx(np.mean([ends[a]["distance_mean"] for a in names]), rel=1e-12)
    assert m["agents_succeeded"] == info["success_rate"]
    combined = summarize_measures(env.measures, [m, m])
    assert combined[f"{names[0]}/distance_max"] == m[f"{names[0]}/distance_max"]
    text = "\n".join(describe(env.measures, combined))
    assert "per agent: " + names[0] in text


def test_episodes_combine_by_mean_or_max_and_leave_out_what_did_not_apply():
    speed = Measure("touchdown_speed", "touchdown speed", "m/s")
    episodes = [
        {"distance_mean": 0.1, "distance_max": 0.3, "touchdown_speed": math.nan},
        {"distance_mean": 0.3, "distance_max": 0.2, "touchdown_speed": 0.5},
    ]
    out = summarize_measures((*DISTANCE_HELD, speed), episodes)
    assert out == {"distance_mean": pytest.approx(0.2), "distance_max": 0.3, "touchdown_speed": 0.5}
    assert math.isnan(summarize_measures((speed,), episodes[:1])["touchdown_speed"])
    assert speed.format(math.nan) == "n/a" and speed.format(0.5) == "0.50 m/s"

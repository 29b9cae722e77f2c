"""Multi-agent environments: PettingZoo API, seeding, early retirement, rewards, configs, guns."""

from __future__ import annotations

import hashlib
import json
import math
import subprocess
import sys
import warnings

import numpy as np
import pytest

from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.multi_agent import ma_fixedwing_dogfight_v0, ma_quadx_formation_v0, ma_quadx_hover_v0
from pyflyt_engine.errors import ConfigError

HOVER_ACTION = np.array([0.0, 0.0, 0.0, 0.125])  # level, thrust = weight for the 8:1 cf2x


def _close(env) -> None:
    env.close()


@pytest.mark.parametrize(
    ("module", "kwargs"),
    [(ma_quadx_hover_v0, {}), (ma_fixedwing_dogfight_v0, {"agents": 4}), (ma_quadx_formation_v0, {"agents": 5})],
    ids=["hover", "dogfight2v2", "formation5"],
)
def test_pettingzoo_api(module, kwargs):
    from pettingzoo.test import api_test, parallel_api_test

    env = module.parallel_env(**kwargs)
    parallel_api_test(env, num_cycles=120)
    env.close()
    aec = module.env(**kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # api_test warns about unbounded observation spaces
        api_test(aec, num_cycles=30)
    aec.close()


def _trajectory_digest(module_name: str, kwargs: dict, seed: int, steps: int) -> str:
    import importlib

    module = importlib.import_module(module_name)
    env = module.parallel_env(**kwargs)
    digest = hashlib.sha256()
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        for name in sorted(obs):
            digest.update(np.asarray(obs[name], dtype=np.float64).tobytes())
        if not env.agents:
            break
        actions = {
            a: env.action_space(a).low + rng.random(4) * (env.action_space(a).high - env.action_space(a).low) * 0.3
            for a in env.agents
        }
        obs, rewards, *_ = env.step(actions)
        digest.update(json.dumps(rewards, sort_keys=True).encode())
    env.close()
    return digest.hexdigest()


@pytest.mark.parametrize(
    ("module", "kwargs"),
    [
        ("pyflyt_engine.envs.multi_agent.ma_quadx_hover_v0", {}),
        ("pyflyt_engine.envs.multi_agent.ma_fixedwing_dogfight_v0", {}),
        ("pyflyt_engine.envs.multi_agent.ma_quadx_formation_v0", {"agents": 6}),
    ],
    ids=["hover", "dogfight", "formation"],
)
def test_same_seed_same_trajectory_across_processes(module, kwargs):
    here = _trajectory_digest(module, kwargs, 7, 40)
    assert here == _trajectory_digest(module, kwargs, 7, 40)
    assert here != _trajectory_digest(module, kwargs, 8, 40)
    code = (
        "from tests.envs.test_multi_agent import _trajectory_digest;"
        f"print(_trajectory_digest({module!r}, {kwargs!r}, 7, 40))"
    )
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()[-1]
    assert other == here


def _two_touching_and_one_apart():
    return [
        {"spawn": {"position": [0.0, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
        {"spawn": {"position": [0.05, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
        {"spawn": {"position": [2.0, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
    ]


def test_colliders_retire_and_the_others_fly_on():
    env = ma_quadx_hover_v0.parallel_env(agents=_two_touching_and_one_apart())
    obs, infos = env.reset(seed=0)
    assert set(obs) == set(infos) == {"uav_0", "uav_1", "uav_2"}
    obs, rewards, terms, truncs, infos = env.step({a: HOVER_ACTION for a in env.agents})
    # both colliders are out, with the crash penalty; the third flies on
    assert terms == {"uav_0": True, "uav_1": True, "uav_2": False}
    assert infos["uav_0"]["collision"] and infos["uav_1"]["collision"]
    assert rewards["uav_0"] == rewards["uav_1"] == -100.0
    assert env.agents == ["uav_2"]
    assert env.world.vehicles[0].armed is False
    # only the live agent acts and is reported from now on
    obs, rewards, terms, truncs, infos = env.step({"uav_2": HOVER_ACTION})
    assert set(obs) == set(rewards) == set(terms) == set(truncs) == set(infos) == {"uav_2"}
    with pytest.raises(ValueError, match="no action for live agent 'uav_2'"):
        env.step({})
    env.close()


def test_time_limit_truncates_every_live_agent_as_success():
    env = ma_quadx_hover_v0.parallel_env(agents=2, max_duration_seconds=0.2)  # 6 steps
    env.reset(seed=1)
    for _ in range(6):
        _obs, _rewards, terms, truncs, infos = env.step({a: HOVER_ACTION for a in env.agents})
    assert truncs == {"uav_0": True, "uav_1": True} and not any(terms.values())
    assert all(info["success"] for info in infos.values())
    assert env.agents == []
    env.close()


def test_hover_reward_is_the_reference_formula_per_agent():
    env = ma_quadx_hover_v0.parallel_env(agents=3)
    env.reset(seed=2)
    obs, rewards, _terms, _truncs, infos = env.step({a: HOVER_ACTION for a in env.agents})
    for name, info in infos.items():
        i = env.agent_index[name]
        s = env.world.vehicles[i].state
        point = np.array(env.agent_list[i].hover_point)
        distance = float(np.linalg.norm(np.array(s.lin_pos) - point))
        tilt = math.hypot(s.ang_pos[0], s.ang_pos[1])
        assert rewards[name] == pytest.approx(1.0 - distance - 0.1 * tilt, abs=1e-12)
        assert sum(info["reward_terms"].values()) == pytest.approx(rewards[name], abs=1e-12)
        # the observation ends with the hover point minus the position (ground frame)
        np.testing.assert_allclose(obs[name][-3:], point - np.array(s.lin_pos), atol=1e-12)
    env.close()


def test_mixed_airframes_hover_together_and_replay_verifies(tmp_path):
    from pyflyt_engine.telemetry import RecordEpisode, load_episode
    from pyflyt_engine.telemetry.replay import verify

    agents = [
        {"uav": "quadx_f450", "spawn": {"position": [-1.0, 0.0, 1.0]}},
        {"uav": "quadx_cf2x", "spawn": {"position": [1.0, 0.0, 1.0]}, "hover_point": [1.0, 0.0, 1.5]},
    ]
    env = RecordEpisode(make_env("ma_quadx_hover", agents=agents), tmp_path)
    assert [v.spec.name for v in env.unwrapped.world.vehicles] == ["quadx_f450", "quadx_cf2x"]
    obs, _ = env.reset(seed=4)
    assert obs.shape == (2, 24)
    rng = np.random.default_rng(0)
    for _ in range(30):
        obs, reward, terminated, truncated, info = env.step(HOVER_ACTION + rng.normal(0.0, 0.02, (2, 4)))
        assert sum(info["reward_terms"].values()) == pytest.approx(reward, abs=1e-12)
        if terminated or truncated:
            break
    env.close()
    episode = load_episode(env.paths[0])
    assert len(episode.vehicles) == 2 and episode.actions.shape[1] == 8
    result = verify(episode)
    assert result.ok and result.max_deviation == 0.0


def test_dogfight_gun_geometry_health_and_kill():
    # uav_0 flies 10 m behind uav_1, same heading and speed: uav_1 sits on uav_0's nose
    still = {"position_noise": 0.0, "orientation_noise": 0.0, "lin_vel": [14.0, 0.0, 0.0]}
    agents = [
        {"team": 0, "spawn": {"position": [0.0, 0.0, 40.0], **still}},
        {"team": 1, "spawn": {"position": [10.0, 0.0, 40.0], **still}},
    ]
    env = ma_fixedwing_dogfight_v0.parallel_env(agents=agents, damage_per_second=3.0)
    env.reset(seed=0)
    action = np.array([0.0, 0.0, 0.0, 0.45])
    obs, rewards, terms, _truncs, infos = env.step({a: action for a in env.agents})
    assert infos["uav_0"]["hits_dealt"] == 1 and infos["uav_0"]["hits_taken"] == 0
    assert infos["uav_1"]["hits_taken"] == 1 and infos["uav_1"]["hits_dealt"] == 0
    assert infos["uav_1"]["health"] == pytest.approx(1.0 - 3.0 / 30.0)
    assert infos["uav_0"]["reward_terms"]["hit"] == 20.0
    assert infos["uav_1"]["reward_terms"]["hit_taken"] == -10.0
    # the opponent's block in uav_0's observation: it is ~10 m straight ahead (body x)
    block = obs["uav_0"][23 + 1 : 23 + 1 + 12]
    assert block[0] == pytest.approx(10.0, abs=0.5) and abs(block[1]) < 0.5 and abs(block[2]) < 0.5
    assert block[9] == pytest.approx(1.0 - 3.0 / 30.0) and block[10] == 0.0 and block[11] == 1.0
    # 10 steps of sustained fire at 3/s shoot it down; uav_0 scores the kill and wins
    for _ in range(20):
        obs, rewards, terms, _truncs, infos = env.step({a: action for a in env.agents})
        if not env.agents:
            break
    assert infos["uav_1"]["shot_down"] and terms["uav_1"] and not infos["uav_1"]["success"]
    assert infos["uav_0"]["kills"] == 1 and infos["uav_0"]["team_win"] and infos["uav_0"]["success"]
    assert rewards["uav_0"] == 300.0  # a win replaces the step's other terms (reference)
    assert env.agents == []
    env.close()


def test_teammates_never_hit_each_other():
    still = {"position_noise": 0.0, "orientation_noise": 0.0, "lin_vel": [14.0, 0.0, 0.0]}
    agents = [
        {"team": 0, "spawn": {"position": [0.0, 0.0, 40.0], **still}},
        {"team": 0, "spawn": {"position": [10.0, 0.0, 40.0], **still}},
        {"team": 1, "spawn": {"position": [0.0, 200.0, 40.0], **still}},
    ]
    env = ma_fixedwing_dogfight_v0.parallel_env(agents=agents)
    env.reset(seed=0)
    _, _, _, _, infos = env.step({a: np.array([0.0, 0.0, 0.0, 0.45]) for a in env.agents})
    assert all(info["hits_dealt"] == 0 and info["hits_taken"] == 0 for info in infos.values())
    env.close()


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"agents": 0}, "agents must be a count >= 1"),
        ({"agents": [{"uav": "quadx_cf2x", "colour": "red"}]}, "unknown key 'colour'"),
        ({"agents": [{"name": "a"}, {"name": "a"}]}, "names must be unique, repeated: a"),
        (
            {"agents": [{"uav": "quadx_cf2x"}, {"uav": "fixedwing"}]},
            "unknown mode .rates_thrust. for vehicle .fixedwing.",
        ),
        ({"task": {"name": "hover"}}, "needs task.name one of: ma_hover, ma_formation, dogfight"),
        ({"layout_radius": -1.0}, "task.layout_radius"),
        (
            {"agents": [{"spawn": {"position": [0.0, 0.0, float("nan")]}}]},
            "agents.0.spawn.position.2: Input should be a finite number",
        ),
    ],
)
def test_bad_hover_configs_fail_with_one_clear_message(overrides, message):
    with pytest.raises(ConfigError, match=message):
        env = ma_quadx_hover_v0.parallel_env(**overrides)
        env.close()


def test_bad_dogfight_teams():
    with pytest.raises(ConfigError, match="cannot form two equal teams"):
        load_env_config("ma_fixedwing_dogfight").with_overrides(agents=3)
    with pytest.raises(ConfigError, match="needs agents in both teams"):
        load_env_config("ma_fixedwing_dogfight").with_overrides(agents=[{"team": 0}, {"team": 0}])


def test_supersuit_vector_env_interop():
    """The parallel env plugs into SuperSuit's PettingZoo-to-vector-env wrappers (one slot per agent)."""
    import supersuit as ss

    env = ss.black_death_v3(ma_quadx_hover_v0.parallel_env(agents=2))
    vec = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(env), 2, num_cpus=0, base_class="gymnasium")
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (4, 24)
    for _ in range(5):
        obs, rewards, terminations, _truncations, _ = vec.step(np.tile(HOVER_ACTION, (4, 1)))
    assert obs.shape == (4, 24) and rewards.shape == (4,) and not terminations.any()
    vec.close()


def test_pyflyt_envs_lists_the_multi_agent_envs():
    from pyflyt_cli.catalog import list_envs

    table = list_envs()
    for name in ("ma_quadx_hover_v0", "ma_fixedwing_dogfight_v0"):
        assert f"pyflyt_engine.envs.multi_agent.{name}" in table
    assert "observation: Box(24,) per agent" in table and "teams [0, 1]" in table


def test_rgb_array_render_follows_a_live_agent():
    env = make_env("ma_quadx_hover", agents=2, render_mode="rgb_array")
    env.reset(seed=0)
    image = env.render()
    assert image.shape == (480, 480, 3) and image.dtype == np.uint8 and image.std() > 0
    env.close()


def test_the_generic_front_runs_the_task_the_config_names():
    """A registered env class only names its task: the base class given the same config
    flies the same task object and the same episode, bit for bit."""
    from pyflyt_engine.envs.multi_agent.base import MultiAgentUAVEnv
    from pyflyt_engine.envs.multi_agent.config import get_ma_task
    from pyflyt_engine.envs.tasks.ma_formation import MAFormationTask
    from pyflyt_engine.errors import ConfigError

    assert get_ma_task("ma_formation") is MAFormationTask
    with pytest.raises(ConfigError, match="ma_formation"):
        get_ma_task("ma_formaton")
    runs = []
    builds = (
        lambda: ma_quadx_formation_v0.parallel_env(agents=4),
        lambda: MultiAgentUAVEnv("ma_quadx_formation", agents=4),
    )
    for build in builds:
        env = build()
        try:
            assert isinstance(env.task, MAFormationTask)
            obs, _ = env.reset(seed=5)
            out = [np.concatenate([obs[a] for a in env.possible_agents])]
            for _ in range(5):
                obs, rewards, *_ = env.step({a: np.array([0.1, 0.0, -0.1, 0.5]) for a in env.agents})
                out.append(np.concatenate([obs[a] for a in env.agents] + [np.array(list(rewards.values()))]))
            runs.append(out)
        finally:
            env.close()
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)

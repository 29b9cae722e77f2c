"""Training a shared policy on the multi-agent envs: slots, exact resume, eval, replay, self-play."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pyflyt_cli.training import evaluate_run, resume, train
from pyflyt_engine.telemetry import load_episode, read_metrics
from pyflyt_engine.telemetry.replay import verify

from .conftest import load, pyflyt
from .test_resume import SignalAt, _assert_same, _outcome

MA_PPO = [
    "env=ma_quadx_hover",
    "algo=ppo",
    "env.agents=2",
    "train.n_envs=2",
    "train.total_timesteps=1000",  # rollout 2 envs x 2 agents x 64 steps = 256: ends at 1024
    "algo.n_steps=64",
    "algo.batch_size=64",
    "algo.n_epochs=2",
    "train.eval_freq=256",
    "train.eval_episodes=1",
    "train.checkpoint_freq=256",
    "train.progress_bar=false",
]


def test_slots_follow_agents_through_retirement_and_reset():
    from pyflyt_cli.training.envs import make_vec_env
    from pyflyt_engine.envs.config import load_env_config

    agents = [
        {"spawn": {"position": [0.0, 0.0, 1.0], "position_noise": 0.0}},
        {"spawn": {"position": [0.05, 0.0, 1.0], "position_noise": 0.0}},  # touches uav_0 at once
        {"spawn": {"position": [2.0, 0.0, 1.0], "position_noise": 0.0}},
    ]
    config = load_env_config("ma_quadx_hover").with_overrides(agents=agents, max_duration_seconds=0.2)
    vec = make_vec_env(config, 2)
    assert vec.num_envs == 6
    vec.seed(3)
    obs = vec.reset()
    assert obs.shape == (6, 24) and obs.dtype == np.float32
    hover = np.tile([0.0, 0.0, 0.0, -0.75], (6, 1))  # thrust 0.125 in the [-1, 1] rescaled units
    obs, rewards, dones, infos = vec.step(hover)
    # the colliders of both envs are done with their episode statistics; their slots pad
    assert dones.tolist() == [True, True, False] * 2
    for slot in (0, 1, 3, 4):
        assert infos[slot]["episode"]["r"] == rewards[slot] == -100.0 and infos[slot]["episode"]["l"] == 1
        assert infos[slot]["terminal_observation"].shape == (24,)
        assert not obs[slot].any()
    for _ in range(5):  # the third agent reaches the time limit (6 steps): every slot restarts
        obs, rewards, dones, infos = vec.step(hover)
        assert rewards[[0, 1, 3, 4]].tolist() == [0.0] * 4  # padding
    assert dones.all()
    assert infos[2]["TimeLimit.truncated"] and infos[2]["episode"]["success"] and infos[2]["episode"]["l"] == 6
    assert "episode" not in infos[0] and not infos[0]["TimeLimit.truncated"]
    assert obs.any(axis=1).all()  # every slot observes the next episode
    vec.close()


def test_a_stop_then_resume_is_bit_identical_to_the_uninterrupted_run(tmp_path, tmp_path_factory):
    reference = _outcome(train(load(MA_PPO, tmp_path_factory.mktemp("reference"))).run_dir)
    first = train(load(MA_PPO, tmp_path), callbacks=[SignalAt(301)])
    assert first.interrupted
    resumed = resume(first.run_dir)
    assert not resumed.interrupted
    _assert_same(_outcome(first.run_dir), reference)
    assert len(reference["episodes"]) > 0  # per-agent training episodes were logged


@pytest.mark.slow  # the training test below covers the same in the default suite
def test_envs_in_subprocesses_step_exactly_as_in_this_process():
    """train.vec_env=subproc for a multi-agent env: the same seed gives the same slots
    (observations, rewards, dones, episode statistics) as the envs in this process."""
    from pyflyt_cli.training.envs import make_vec_env
    from pyflyt_engine.envs.config import load_env_config

    config = load_env_config("ma_quadx_hover").with_overrides(agents=2, max_duration_seconds=0.5)
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1.0, 1.0, (40, 4, 4))
    runs = []
    for kind in ("dummy", "subproc"):
        vec = make_vec_env(config, 2, kind)
        try:
            assert vec.num_envs == 4 and vec.subprocess == (kind == "subproc")
            vec.seed(11)
            steps = [vec.reset()]
            for a in actions:
                obs, rewards, dones, infos = vec.step(a)
                episodes = [
                    (i, info["episode"]["r"], info["episode"]["l"]) for i, info in enumerate(infos) if "episode" in info
                ]
                steps.append((obs, rewards, dones, episodes))
            states = vec.env_method("episode_state")
        finally:
            vec.close()
        runs.append((steps, states))
    (dummy, dummy_states), (subproc, subproc_states) = runs
    assert np.array_equal(dummy[0], subproc[0])
    for a, b in zip(dummy[1:], subproc[1:]):
        assert all(np.array_equal(x, y) for x, y in zip(a[:3], b[:3])) and a[3] == b[3]
    assert sum(len(step[3]) for step in dummy[1:]) >= 4  # episodes ended (and restarted) on the way
    assert repr(dummy_states) == repr(subproc_states)


def test_envs_in_subprocesses_train_the_same_run_and_resume_exactly(tmp_path, tmp_path_factory):
    """train.vec_env=subproc: each env in its own process, the same numbers as in this process
    under a seed (first rollout, updates, evaluations), and a stop + resume through the pipes
    (episode state saved and re-simulated in the workers) still bit-identical."""
    budget = ["train.total_timesteps=512"]
    reference = _outcome(train(load([*MA_PPO, *budget, "train.vec_env=dummy"], tmp_path_factory.mktemp("ref"))).run_dir)
    first = train(load([*MA_PPO, *budget, "train.vec_env=subproc"], tmp_path), callbacks=[SignalAt(45)])
    assert first.interrupted
    resumed = resume(first.run_dir)
    assert not resumed.interrupted and resumed.num_timesteps == 512
    _assert_same(_outcome(first.run_dir), reference)


def test_eval_and_replay_verify_from_the_command_line(tmp_path):
    """Also: airframe files the listed agents name are copied into the run (one copy per
    distinct file), so eval and replay work from the run directory alone."""
    from pyflyt_cli.training.rundir import config_digest, load_run_config
    from pyflyt_engine.paths import conf_dir

    small, big = tmp_path / "small.yaml", tmp_path / "big.yaml"
    small.write_text((conf_dir() / "uav" / "quadx_cf2x.yaml").read_text())
    big.write_text((conf_dir() / "uav" / "quadx_f450.yaml").read_text())
    agents = (
        f"[{{uav: {small}, spawn: {{position: [-1, 0, 1]}}}}, {{uav: {big}, spawn: {{position: [1, 0, 1]}}}},"
        f" {{uav: {small}, spawn: {{position: [0, 1, 1]}}}}]"
    )
    # `pyflyt train` is this library call (the command's own path is tested with bad input below)
    args = [
        *MA_PPO,
        f"env.agents={agents}",
        "train.n_envs=1",
        "train.total_timesteps=192",
        "train.eval_freq=192",
        "env.max_duration_seconds=2",
    ]
    cfg = load(args, tmp_path / "runs")
    digest = config_digest(cfg)
    run = train(cfg).run_dir
    assert (run / "model.pt").is_file() and list((run / "checkpoints").glob("*.pt"))
    assert len(list(run.glob("airframe-*.yaml"))) == 2
    small.unlink()
    big.unlink()
    loaded = load_run_config(run)
    uavs = [agent.uav for agent in loaded.env.agents]
    assert {Path(u).parent for u in uavs} == {run} and uavs[0] == uavs[2] != uavs[1]
    assert config_digest(loaded, run) == digest  # the copies identify as the files they copy
    metrics = read_metrics(run)
    assert metrics["/eval"] and metrics["/train/episode"]
    shown = pyflyt(["eval", str(run), "episodes=2"], cwd=tmp_path)
    assert shown.returncode == 0, shown.stderr
    report = json.loads((run / "eval.json").read_text())
    assert len(report["episodes"]) == 2 and len(report["recordings"]) == 2
    recording = run / "episodes" / report["recordings"][0]
    episode = load_episode(recording)
    assert len(episode.vehicles) == 3  # every agent has its frame in the scene
    replay = pyflyt(["replay", str(recording), "--verify"], cwd=tmp_path)
    assert replay.returncode == 0 and "verify    OK" in replay.stdout, replay.stdout + replay.stderr


def test_dogfight_trains_by_self_play(tmp_path):
    overrides = [
        "env=ma_fixedwing_dogfight",
        "algo=ppo",
        "env.agents=4",
        "train.total_timesteps=512",
        "algo.n_steps=64",
        "algo.batch_size=64",
        "algo.n_epochs=1",
        "train.eval_freq=256",
        "train.eval_episodes=1",
        "env.max_duration_seconds=3",
        "train.progress_bar=false",
    ]
    result = train(load(overrides, tmp_path))
    assert result.num_timesteps == 512 and result.last_eval is not None
    report = evaluate_run(result.run_dir, {"episodes": 1})
    assert report.episodes[0].length == 90  # 3 s at 30 Hz unless decided earlier
    assert verify(load_episode(report.recordings[0])).ok


def test_a_bad_multi_agent_config_is_one_message_exit_2(tmp_path):
    done = pyflyt(["train", "env=ma_quadx_hover", "env.agents=[{uav: quadx_cf2x, wings: 3}]"], cwd=tmp_path)
    assert done.returncode == 2
    assert "unknown key 'wings'" in done.stderr and "Traceback" not in done.stderr
    done = pyflyt(["train", "env=ma_fixedwing_dogfight", "env.agents=3"], cwd=tmp_path)
    assert done.returncode == 2 and "cannot form two equal teams" in done.stderr
    done = pyflyt(["train", "env=ma_quadx_hover", "+env.range_sensors=[{name: lidar, type: lidar}]"], cwd=tmp_path)
    assert done.returncode == 2 and "env.range_sensors" in done.stderr and "Traceback" not in done.stderr


def test_a_swarm_trains_one_shared_policy_evaluates_and_replays_exactly(tmp_path):
    overrides = [
        "env=ma_quadx_formation",
        "algo=ppo",
        "env.agents=9",
        "env.task.layout_spacing=0.8",
        "train.total_timesteps=576",  # 9 agents x 64 steps
        "algo.n_steps=64",
        "algo.batch_size=64",
        "algo.n_epochs=1",
        "train.eval_freq=576",
        "train.eval_episodes=1",
        "env.max_duration_seconds=1",
        "train.progress_bar=false",
    ]
    result = train(load(overrides, tmp_path))
    assert result.num_timesteps == 576 and result.last_eval is not None
    report = evaluate_run(result.run_dir, {"episodes": 1})
    episode = load_episode(report.recordings[0])
    assert verify(episode).ok  # nine vehicles with downwash re-simulated exactly


@pytest.mark.parametrize("name", ["ma_quadx_hover", "ma_fixedwing_dogfight", "ma_quadx_formation"])
def test_the_shipped_configs_compose(name, tmp_path):
    cfg = load([f"env={name}", "algo=ppo"], tmp_path)
    assert cfg.env.multi_agent and cfg.env_name == name

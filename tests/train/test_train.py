"""Training and evaluation as plain functions, with tiny budgets (seconds each)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml

from pyflyt_cli.training import evaluate_run, resume, train
from pyflyt_cli.training.models import read_policy
from pyflyt_cli.training.rundir import config_digest, load_run_config, read_state
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.paths import conf_dir
from pyflyt_engine.loading import available
from pyflyt_engine.telemetry import read_metrics

from .conftest import TINY_PPO, TINY_SAC, initial_policy_probe, load


def _metrics(run_dir: Path) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a truncated file would warn
        return read_metrics(run_dir)


def _system_temp(tmp_path, monkeypatch) -> Path:
    """An empty stand-in for the system's temporary directory."""
    import tempfile

    temp = tmp_path / "system-temp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    return temp


def test_tiny_ppo_run_leaves_a_complete_run_directory(tmp_path, monkeypatch):
    temp = _system_temp(tmp_path, monkeypatch)
    result = train(load(TINY_PPO, tmp_path / "runs"), command=["pyflyt", "train"], overrides=TINY_PPO)
    run = result.run_dir
    assert run.parent == (tmp_path / "runs" / "quadx_hover" / "ppo").resolve()
    assert run.name.endswith("-seed0") and not result.interrupted
    assert result.num_timesteps == 512 and result.steps_per_second > 0

    for name in ("config.yaml", "run.yaml", "state.json", "model.pt", "best_model.pt", "metrics.mcap"):
        assert (run / name).is_file(), name
    assert not list(run.rglob("*.pkl")) and not list(run.rglob("*.zip"))  # nothing pickled
    final = read_policy(run / "model.pt")
    assert final.algo == "ppo" and final.step == 512
    assert final.normalizer is not None and final.normalizer["norm_obs"]  # the hover tuning normalises observations
    assert sorted(p.name for p in (run / "checkpoints").glob("model_*")) == [
        "model_256_steps.pt",
        "model_512_steps.pt",
    ]

    record = yaml.safe_load((run / "run.yaml").read_text())
    assert record["seed"] == 0 and record["command"] == ["pyflyt", "train"] and record["overrides"] == TINY_PPO
    assert {"python", "stable-baselines3", "torch", "gymnasium", "pyflyt-toolkit"} <= set(record["versions"])
    assert record["config_digest"] == config_digest(load_run_config(run), run)  # the run's identity
    if (Path(__file__).resolve().parents[2] / ".git").exists():  # the code's commit, from a checkout
        assert len(record["versions"]["pyflyt-toolkit revision"].split("+")[0]) == 40
    state = read_state(run)
    assert state["status"] == "complete" and state["num_timesteps"] == 512 and state["checkpoint"] == 512
    assert load_run_config(run) == load_run_config(run)  # config.yaml reloads and validates

    metrics = _metrics(run)
    episodes = metrics["/train/episode"]
    assert episodes and {"step", "wall_time", "return", "length", "success"} <= set(episodes[0])
    assert [e["step"] for e in episodes] == sorted(e["step"] for e in episodes)
    evals = metrics["/eval"]
    assert [e["step"] for e in evals] == [256, 512]
    assert {"mean_return", "std_return", "success_rate", "mean_length"} <= set(evals[0])
    assert result.last_eval == {k: evals[-1][k] for k in result.last_eval}
    assert not list(temp.glob("SB3-*"))  # no logger folder left outside the run directory


def test_eval_of_a_run_records_episodes_and_summarises(tmp_path):
    run = train(load(TINY_PPO, tmp_path / "runs")).run_dir
    report = evaluate_run(run, {"episodes": 3, "seed": 5, "model": "final"})
    assert [e.seed for e in report.episodes] == [5, 6, 7] and report.which == "final"
    assert len(report.recordings) == 3 and all(p.parent == run / "episodes" for p in report.recordings)
    assert all(p.stat().st_size > 0 for p in report.recordings)
    assert report.summary["mean_return"] == pytest.approx(np.mean([e.ret for e in report.episodes]))
    table = report.table()
    assert "± " in table and "success rate" in table and "length" in table
    saved = json.loads((run / "eval.json").read_text())
    assert saved["seed"] == 5 and len(saved["episodes"]) == 3
    again = evaluate_run(run, {"episodes": 3, "seed": 5, "model": "final", "record": False})
    assert [e.ret for e in again.episodes] == [e.ret for e in report.episodes]
    assert len(list((run / "episodes").glob("*.mcap"))) == 3  # record=false writes none; none overwritten


@pytest.mark.long
def test_eval_writes_a_gif(tmp_path):
    pytest.importorskip("imageio")
    run = train(load(TINY_PPO, tmp_path / "runs")).run_dir
    gif = tmp_path / "flight.gif"
    report = evaluate_run(run, {"episodes": 1, "video": str(gif), "record": False})
    assert report.video == gif and gif.stat().st_size > 1000
    import imageio.v2 as imageio

    frames = imageio.mimread(gif)
    assert len(frames) >= 2 and not report.recordings  # record=false: filmed from a temporary recording
    assert not (run / "episodes").exists()
    # the film is `pyflyt replay --video` of the episode's recording, frame for frame
    recorded = evaluate_run(run, {"episodes": 1, "video": str(tmp_path / "again.gif"), "record": True})
    from pyflyt_engine.telemetry import load_episode
    from pyflyt_engine.telemetry.video import render_video

    replayed = render_video(load_episode(recorded.recordings[0]), tmp_path / "replayed.gif")
    assert replayed.read_bytes() == (tmp_path / "again.gif").read_bytes() == gif.read_bytes()


def test_eval_errors(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        evaluate_run(tmp_path / "missing")
    with pytest.raises(ConfigError, match="not a run directory"):
        evaluate_run(tmp_path)
    with pytest.raises(ConfigError, match="video: must end in .gif or .mp4"):
        evaluate_run(tmp_path, {"video": "out.avi"})


def _eval_returns(run_dir: Path) -> list[float]:
    return [e["mean_return"] for e in _metrics(run_dir)["/eval"]]


def test_same_seed_gives_identical_evaluations(tmp_path):
    first = train(load(TINY_PPO, tmp_path / "a"))
    second = train(load(TINY_PPO, tmp_path / "b"))
    other = train(load([*TINY_PPO, "seed=1"], tmp_path / "c"))
    assert _eval_returns(first.run_dir) == _eval_returns(second.run_dir)
    assert [e["return"] for e in _metrics(first.run_dir)["/train/episode"]] == [
        e["return"] for e in _metrics(second.run_dir)["/train/episode"]
    ]
    assert _eval_returns(first.run_dir) != _eval_returns(other.run_dir)
    a = evaluate_run(first.run_dir, {"episodes": 2, "record": False})
    b = evaluate_run(second.run_dir, {"episodes": 2, "record": False})
    assert [e.ret for e in a.episodes] == [e.ret for e in b.episodes]


def test_off_policy_run_checkpoints_its_replay_buffer_and_extends(tmp_path):
    result = train(load(TINY_SAC, tmp_path / "runs"))
    run = result.run_dir
    assert result.num_timesteps == 400
    buffers = sorted(p.name for p in (run / "checkpoints").glob("replay_buffer_*"))
    assert buffers == ["replay_buffer_400_steps.npz"]  # only the newest buffer is kept
    with pytest.raises(ConfigError, match="is complete"):
        resume(run)
    more = resume(run, total_timesteps=600)
    assert more.num_timesteps == 600 and read_state(run)["status"] == "complete"
    steps = [e["step"] for e in _metrics(run)["/eval"]]
    assert steps == [200, 400, 600]
    assert read_policy(run / "model.pt").step == 600
    with np.load(run / "checkpoints" / "replay_buffer_600_steps.npz", allow_pickle=False) as buffer:
        assert int(buffer["pos"]) == 600 and buffer["observations"].shape[0] == 600


@pytest.mark.parametrize("algo", ["td3", "a2c", "ddpg"])
def test_other_algorithms_train(tmp_path, monkeypatch, algo):
    temp = _system_temp(tmp_path, monkeypatch)
    overrides = [
        f"algo={algo}",
        "train.total_timesteps=300",
        "train.eval_freq=300",
        "train.eval_episodes=1",
        "train.checkpoint_freq=0",
        "train.progress_bar=false",
    ]
    if algo in ("td3", "ddpg"):
        overrides += ["algo.buffer_size=1000", "algo.learning_starts=100", "algo.batch_size=32"]
    result = train(load(overrides, tmp_path / "runs"))
    assert result.num_timesteps >= 300 and read_policy(result.run_dir / "model.pt").algo == algo
    assert not list(temp.glob("SB3-*"))


def test_parallel_environments(tmp_path):
    overrides = [*TINY_PPO, "train.n_envs=2", "train.vec_env=subproc", "algo.n_steps=128"]
    result = train(load(overrides, tmp_path / "runs"))
    assert result.num_timesteps == 512
    evals = _metrics(result.run_dir)["/eval"]
    assert [e["step"] for e in evals] == [256, 512]


def test_init_from_copies_the_policy(tmp_path):
    import torch

    source = train(load(TINY_PPO, tmp_path / "runs")).run_dir
    src_params = read_policy(source / "best_model.pt").policy

    probe, seen = initial_policy_probe()

    overrides = [*TINY_PPO, f"init_from={source}", "env.reward=sparse", "seed=3"]
    result = train(load(overrides, tmp_path / "runs"), callbacks=[probe])
    assert all(torch.equal(seen[k], v) for k, v in src_params.items())
    record = yaml.safe_load((result.run_dir / "run.yaml").read_text())
    assert record["init_from"]["run"] == str(source)

    with pytest.raises(ConfigError, match="trained by ppo, this run uses sac"):
        train(load([*TINY_SAC, f"init_from={source}"], tmp_path / "runs"))
    with pytest.raises(ConfigError, match="does not fit"):
        train(load([*TINY_PPO, f"init_from={source}", "algo.policy_kwargs.net_arch=[8,8]"], tmp_path / "runs"))


def test_airframe_and_reward_files_are_kept_in_the_run(tmp_path):
    airframe = tmp_path / "my_quad.yaml"
    airframe.write_text((conf_dir() / "uav" / "quadx_cf2x.yaml").read_text())
    reward = tmp_path / "my_reward.yaml"
    reward.write_text("description: stay alive\nterms:\n  alive: {term: constant, weight: 1.0, when: not_crash}\n")
    overrides = [
        *TINY_PPO,
        f"env.uav={airframe}",
        f"env.reward={reward}",
        "train.eval_freq=0",
        "train.total_timesteps=256",
    ]
    run = train(load(overrides, tmp_path / "runs")).run_dir
    airframe.unlink()
    reward.unlink()
    cfg = load_run_config(run)
    assert Path(cfg.env.uav) == run / "airframe.yaml" and cfg.env.reward["terms"]["alive"]["weight"] == 1.0
    report = evaluate_run(run, {"episodes": 1, "record": False})
    episode = report.episodes[0]  # +1 per step survived (the crash step pays 0)
    assert episode.ret == pytest.approx(episode.length - (0 if episode.success else 1))


def test_callbacks_from_config_stop_training(tmp_path):
    overrides = [
        *TINY_PPO,
        "train.total_timesteps=5000",
        "callbacks=[{name:stop_on_reward,reward_threshold:-1000}]",
    ]
    result = train(load(overrides, tmp_path / "runs"))
    assert result.num_timesteps == 256  # stopped after the first evaluation


def test_tensorboard_logs_when_asked(tmp_path):
    pytest.importorskip("tensorboard")
    overrides = [*TINY_PPO, "train.tensorboard=true", "train.total_timesteps=256", "train.eval_freq=0"]
    run = train(load(overrides, tmp_path / "runs")).run_dir
    assert list((run / "tensorboard").rglob("events.out.tfevents.*"))


def test_multirun_from_the_command_line(tmp_path):
    from typer.testing import CliRunner

    from pyflyt_cli.main import app

    args = [
        "train",
        "-m",
        "seed=0,1",
        *TINY_PPO,
        "train.total_timesteps=256",
        "train.eval_freq=0",
        f"train.output_dir={tmp_path}",
    ]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    runs = sorted((tmp_path / "quadx_hover" / "ppo").iterdir())
    assert [r.name.split("-seed")[1] for r in runs] == ["0", "1"]
    assert "multirun summary" in result.output


def test_a_run_being_trained_cannot_be_resumed_twice(tmp_path):
    import os

    run = train(load([*TINY_PPO, "train.total_timesteps=256", "train.eval_freq=0"], tmp_path / "runs")).run_dir
    assert not (run / "run.lock").exists()
    (run / "run.lock").write_text(f"{os.getppid()}\n")  # a live process holds it
    with pytest.raises(ConfigError, match="is being trained by process"):
        resume(run, total_timesteps=512)
    (run / "run.lock").write_text("999999999\n")  # stale: no such process
    assert resume(run, total_timesteps=512).num_timesteps == 512
    assert not (run / "run.lock").exists()


@pytest.mark.parametrize("env", available("env"))  # every shipped env config; its bases are no envs
def test_every_env_config_trains_and_evaluates(tmp_path, env):
    overrides = [
        f"env={env}",
        "algo=ppo",
        "train.n_envs=1",
        "algo.n_steps=128",
        "algo.batch_size=64",
        "algo.n_epochs=1",
    ]
    overrides += [
        "train.total_timesteps=128",
        "train.eval_freq=0",
        "train.checkpoint_freq=0",
        "train.progress_bar=false",
        # a tuning that imitates an oracle first (rocket_landing_descent, quadx_obstacles,
        # quadx_gates_state): the oracle's own round of one episode, not 21 x 10 episodes
        "train.imitation.rounds=0",
        "train.imitation.episodes=1",
        # a tuning's curriculum (the waypoint tasks') would outlast 128 steps, which is refused
        # (tests/train/test_curriculum.py trains with one)
        "train.curriculum=null",
    ]
    run = train(load(overrides, tmp_path / "runs")).run_dir
    assert run.parent.parent.name == env
    report = evaluate_run(run, {"episodes": 1, "record": True})
    assert report.episodes[0].length > 0 and len(report.recordings) == 1


@pytest.mark.parametrize(("best_by", "best_step"), [("return", 256), ("success", 768)])
def test_best_by_picks_the_evaluation_best_model_keeps(tmp_path, monkeypatch, best_by, best_step):
    """``train.best_by=success`` ranks evaluations by success rate, ties by return; the default
    by return.  The evaluations' outcomes are scripted: 256 the best return, 512 and 768 the
    best success rate, 768 the better return of the two."""
    from pyflyt_cli.training import callbacks

    scripted = iter([(0.0, 900.0), (0.5, 100.0), (0.5, 200.0)])
    real = callbacks.summarize

    def summarize(episodes):
        summary = real(episodes)
        summary["success_rate"], summary["mean_return"] = next(scripted)
        return summary

    monkeypatch.setattr(callbacks, "summarize", summarize)
    overrides = [*TINY_PPO, "train.total_timesteps=768", f"train.best_by={best_by}"]
    result = train(load(overrides, tmp_path / "runs"))
    assert [e["step"] for e in _metrics(result.run_dir)["/eval"]] == [256, 512, 768]
    state = read_state(result.run_dir)
    assert state["best_step"] == best_step and read_policy(result.run_dir / "best_model.pt").step == best_step
    assert state["best_mean_return"] == {256: 900.0, 768: 200.0}[best_step]


def test_best_by_is_checked_resumes_and_leaves_older_runs_their_identity(tmp_path):
    from pyflyt_cli.training.callbacks import PeriodicEvaluation

    with pytest.raises(ConfigError, match="train.best_by"):
        load([*TINY_PPO, "train.best_by=waypoints"], tmp_path)
    default = load(TINY_PPO, tmp_path)
    assert default.train.best_by == "return"
    older = default.model_dump(mode="json")
    del older["train"]["best_by"]  # a config.yaml written before the key existed
    assert config_digest(older) == config_digest(default)
    assert config_digest(type(default).model_validate(older)) == config_digest(default)  # read back: None
    assert config_digest(load([*TINY_PPO, "train.best_by=success"], tmp_path)) != config_digest(default)

    def evaluation(**kwargs):
        return PeriodicEvaluation(None, tmp_path, "ppo", None, 256, 1, 0, True, next_eval=256, **kwargs)

    saved = evaluation(best_by="success", best_mean_reward=3.0, best_step=512, best_success_rate=0.4).state_dict()
    resumed = evaluation(best_by="success")
    resumed.load_state_dict(saved)
    assert (resumed.best_success_rate, resumed.best_mean_reward, resumed.best_step) == (0.4, 3.0, 512)
    del saved["best_success_rate"]  # a checkpoint from before the key
    resumed.load_state_dict(saved)
    assert resumed.best_success_rate is None


def test_a_run_from_before_the_termination_terms_keeps_its_identity_and_another_declaration_counts(tmp_path):
    default = load(TINY_PPO, tmp_path)
    older = default.model_dump(mode="json")
    del older["env"]["terminations"]  # a config.yaml written before the key existed
    assert config_digest(older) == config_digest(default)
    assert config_digest(type(default).model_validate(older)) == config_digest(default)  # read back: the defaults
    off = load([*TINY_PPO, "env.terminations.out_of_dome=null"], tmp_path)
    assert off.env.terminations["out_of_dome"] is None
    fewer = default.model_dump(mode="json")
    fewer["env"]["terminations"] = {"time_limit": {"term": None, "params": {}}}
    digests = {config_digest(default), config_digest(off), config_digest(fewer)}
    assert len(digests) == 3  # switching terms off is another run, however it is written

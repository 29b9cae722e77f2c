"""Interrupted runs (Ctrl-C to the whole process group, SIGKILL) resume to the same end.

Each test starts `pyflyt train` in a subprocess, interrupts it once a checkpoint exists,
resumes it with `pyflyt train resume=<run>`, and compares with an uninterrupted run.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

from pyflyt_cli.training import train
from pyflyt_engine.telemetry import read_metrics

from .conftest import ROOT, cli_env, load, pyflyt

PPO_RUN = [
    "env=quadx_hover",
    "algo=ppo",
    "train.total_timesteps=2000",  # not a multiple of the 128-step rollout: PPO ends at 2048
    "train.n_envs=2",
    "algo.n_steps=64",
    "algo.batch_size=64",
    "algo.n_epochs=2",
    "train.eval_freq=512",
    "train.eval_episodes=1",
    "train.checkpoint_freq=256",
    "train.progress_bar=false",
]

SAC_RUN = [
    "env=quadx_hover",
    "algo=sac",
    "train.total_timesteps=900",
    "train.n_envs=1",
    "algo.buffer_size=5000",
    "algo.learning_starts=100",
    "algo.batch_size=32",
    "algo.policy_kwargs.net_arch=[32,32]",
    "train.eval_freq=300",
    "train.eval_episodes=1",
    "train.checkpoint_freq=300",
    "train.progress_bar=false",
]


def _start(overrides: list[str], cwd: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "pyflyt_cli.main", "train", *overrides],
        cwd=cwd,
        env=cli_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, like a job in a terminal
    )


def _wait_for_checkpoint(root: Path, proc: subprocess.Popen, at_least: int, timeout: float = 240) -> Path:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for state_file in root.glob("*/*/*/state.json"):
            try:
                state = json.loads(state_file.read_text())
            except ValueError:
                continue
            if (state.get("checkpoint") or 0) >= at_least and state.get("status") == "running":
                return state_file.parent
        if proc.poll() is not None:
            raise AssertionError(f"training ended before a checkpoint: {proc.communicate()}")
        time.sleep(0.05)
    proc.kill()
    raise AssertionError("no checkpoint in time")


def _metrics(run_dir: Path) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_metrics(run_dir)


def _state(run_dir: Path) -> dict:
    return json.loads((run_dir / "state.json").read_text())


def test_ctrl_c_saves_a_checkpoint_and_resume_reaches_the_same_end(tmp_path):
    root = tmp_path / "runs"
    proc = _start([*PPO_RUN, f"train.output_dir={root}"], tmp_path)
    run = _wait_for_checkpoint(root, proc, 512)
    os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does: trainer and env workers
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "SIGINT received" in err and "interrupted at step" in err and "Traceback" not in err
    state = _state(run)
    stopped = state["num_timesteps"]
    assert state["status"] == "interrupted" and state["checkpoint"] == stopped and stopped % 128 == 0
    assert (run / "checkpoints" / f"model_{stopped}_steps.zip").is_file()
    assert stopped < 2048

    resumed = pyflyt(["train", f"resume={run}"], cwd=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming {run} from step {stopped}" in resumed.stderr
    final = _state(run)
    assert final["status"] == "complete"

    reference = train(load(PPO_RUN, tmp_path / "reference"))
    assert final["num_timesteps"] == reference.num_timesteps == 2048

    from stable_baselines3 import PPO

    assert PPO.load(run / "model.zip").num_timesteps == 2048
    metrics = _metrics(run)
    assert [e["step"] for e in metrics["/eval"]] == [512, 1024, 1536, 2048]  # no gap, no repeat
    steps = [e["step"] for e in metrics["/train/episode"]]
    assert steps == sorted(steps) and steps[-1] <= 2048
    assert any(s <= stopped for s in steps) and any(s > stopped for s in steps)
    assert sorted(p.name for p in run.glob("metrics*.mcap")) == ["metrics-1.mcap", "metrics.mcap"]


def test_sigkill_after_a_checkpoint_resumes_with_the_replay_buffer(tmp_path):
    root = tmp_path / "runs"
    proc = _start([*SAC_RUN, f"train.output_dir={root}"], tmp_path)
    run = _wait_for_checkpoint(root, proc, 300)
    proc.kill()  # SIGKILL: no handler, no last checkpoint
    proc.communicate(timeout=60)
    state = _state(run)
    assert state["status"] == "running"
    checkpoint = state["checkpoint"]
    assert (run / "checkpoints" / f"replay_buffer_{checkpoint}_steps.pkl").is_file()

    resumed = pyflyt(["train", f"resume={run}"], cwd=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert f"from step {checkpoint}" in resumed.stderr
    # the hover SAC tuning collects 8 steps per update (train_freq=8): an uninterrupted run
    # also stops at the first multiple of 8 from 900
    assert _state(run)["num_timesteps"] == 904

    from stable_baselines3 import SAC

    model = SAC.load(run / "model.zip")
    model.load_replay_buffer(run / "checkpoints" / "replay_buffer_904_steps.pkl")
    # every step since the start is in the buffer: the checkpoint's transitions were restored
    assert model.num_timesteps == 904 and model.replay_buffer.size() == 904
    evals = [e["step"] for e in _metrics(run)["/eval"]]
    assert evals == [300, 600, 900, 904]  # the last one: the final evaluation


def test_resume_of_a_run_killed_before_its_first_checkpoint_starts_over(tmp_path):
    cfg = load([*PPO_RUN, "train.total_timesteps=256", "train.n_envs=1"], tmp_path / "runs")
    run = train(cfg).run_dir
    # simulate a kill before any checkpoint: drop everything the run wrote after starting
    for p in (run / "checkpoints").iterdir():
        p.unlink()
    (run / "state.json").write_text(json.dumps({"status": "running", "num_timesteps": 0, "checkpoint": None}))
    result = pyflyt(["train", f"resume={run}"], cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "from the start" in result.stderr and _state(run)["status"] == "complete"
    assert ROOT.is_dir()

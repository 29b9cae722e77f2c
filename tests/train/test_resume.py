"""Exact resume: a run interrupted and resumed ends bit-identical to the same run uninterrupted.

Every test compares with a reference run trained in one go: same evaluation returns,
same training episodes, bit-identical final weights.  Interruptions: a stop request at an
arbitrary step (in process), Ctrl-C to the process group, SIGTERM, SIGKILL after a
checkpoint, and a kill at each step of the checkpoint commit (fault injection).
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

import numpy as np
import pytest
import torch
from stable_baselines3.common.callbacks import BaseCallback

from pyflyt_cli.training import artifacts, resume, train
from pyflyt_cli.training.models import read_policy
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.telemetry import read_metrics

from tests.conftest import default_subset

from .conftest import cli_env, load, pyflyt

PPO = [
    "env=quadx_hover",
    "algo=ppo",
    "train.total_timesteps=1000",  # not a multiple of the rollout: PPO ends at 1024
    "algo.n_steps=128",
    "algo.batch_size=64",
    "algo.n_epochs=2",
    "algo.use_sde=true",  # gSDE: exploration noise resampled at every rollout start
    "train.eval_freq=256",
    "train.eval_episodes=1",
    "train.checkpoint_freq=256",
    "train.progress_bar=false",
]

SAC = [
    "env=quadx_hover",
    "algo=sac",
    "train.total_timesteps=600",
    "algo.buffer_size=5000",
    "algo.learning_starts=100",
    "algo.batch_size=32",
    "algo.policy_kwargs.net_arch=[32,32]",
    "train.eval_freq=100",
    "train.eval_episodes=1",
    "train.checkpoint_freq=100",
    "train.progress_bar=false",
]

RUNS = {"ppo": PPO, "sac": SAC}
_REFERENCES: dict[tuple[str, ...], dict] = {}


def _outcome(run_dir: Path) -> dict:
    """What must not change: final weights, evaluations, training episodes, the end step."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        metrics = read_metrics(run_dir)
    final = read_policy(run_dir / "model.pt")
    return {
        "step": final.step,
        "policy": final.policy,
        "normalizer": final.normalizer,
        "evals": [(r["step"], r["mean_return"], r["std_return"]) for r in metrics["/eval"]],
        "episodes": [(r["step"], r["return"], r["length"]) for r in metrics["/train/episode"]],
    }


def _reference(overrides: list[str], tmp_path_factory) -> dict:
    key = tuple(overrides)
    if key not in _REFERENCES:
        root = tmp_path_factory.mktemp("reference")
        _REFERENCES[key] = _outcome(train(load(overrides, root)).run_dir)
    return _REFERENCES[key]


def _assert_same(resumed: dict, reference: dict) -> None:
    assert resumed["step"] == reference["step"]
    assert resumed["evals"] == reference["evals"]  # no gap, no repeat, same returns
    assert resumed["episodes"] == reference["episodes"]
    assert resumed["policy"].keys() == reference["policy"].keys()
    for key, value in reference["policy"].items():
        assert torch.equal(resumed["policy"][key], value), key
    if reference["normalizer"] is not None:
        for part in ("obs_rms", "ret_rms"):
            for stat in ("mean", "var"):
                assert torch.equal(resumed["normalizer"][part][stat], reference["normalizer"][part][stat])


class SignalAt(BaseCallback):
    """Send this process a signal once the run passes ``step`` (Ctrl-C at an arbitrary moment)."""

    def __init__(self, step: int, signum: int = signal.SIGINT) -> None:
        super().__init__()
        self.step, self.signum, self.sent = step, signum, False

    def _on_step(self) -> bool:
        if not self.sent and self.num_timesteps >= self.step:
            self.sent = True
            os.kill(os.getpid(), self.signum)
        return True


@pytest.mark.parametrize("algo", default_subset(["ppo", "sac"], lambda algo: algo == "ppo"))
def test_a_stop_anywhere_then_resume_is_bit_identical_to_the_uninterrupted_run(tmp_path, tmp_path_factory, algo):
    # the shipped hover tunings: PPO normalises observations and rewards; SAC explores with
    # gSDE and collects 8 steps per update.  Two envs: the command-line tests below.
    overrides = [*RUNS[algo], "train.n_envs=1"]
    reference = _reference(overrides, tmp_path_factory)
    stop_at = 301 if algo == "ppo" else 333  # mid-rollout, between checkpoints
    first = train(load(overrides, tmp_path), callbacks=[SignalAt(stop_at)])
    assert first.interrupted and first.num_timesteps > stop_at
    state = json.loads((first.run_dir / "state.json").read_text())
    assert state["status"] == "interrupted" and state["checkpoint"] == first.num_timesteps
    resumed = resume(first.run_dir)
    assert not resumed.interrupted
    _assert_same(_outcome(first.run_dir), reference)


# ---------------------------------------------------------------- real signals


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


def _wait(root: Path, proc: subprocess.Popen, ready) -> Path:
    """Poll the run directory until ``ready(run_dir, state)``; fails if training ends first."""
    while True:
        for state_file in root.glob("*/*/*/state.json"):
            try:
                state = json.loads(state_file.read_text())
            except ValueError:
                continue
            if state.get("status") == "running" and ready(state_file.parent, state):
                return state_file.parent
        if proc.poll() is not None:
            raise AssertionError(f"training ended before the moment to interrupt it: {proc.communicate()}")
        time.sleep(0.05)


def _checkpoint_at_least(step: int):
    return lambda run, state: (state.get("checkpoint") or 0) >= step


@pytest.mark.parametrize(
    ("algo", "n_envs", "how"),
    default_subset(
        [("ppo", 2, "ctrl-c"), ("sac", 1, "sigterm"), ("sac", 2, "sigkill"), ("ppo", 1, "sigkill")],
        lambda case: case == ("sac", 1, "sigterm"),
    ),
)
def test_a_signal_then_resume_from_the_command_line_is_bit_identical(tmp_path, tmp_path_factory, algo, n_envs, how):
    overrides = [*RUNS[algo], f"train.n_envs={n_envs}"]
    reference = _reference(overrides, tmp_path_factory)
    root = tmp_path / "runs"
    proc = _start([*overrides, f"train.output_dir={root}"], tmp_path)
    run = _wait(root, proc, _checkpoint_at_least(256 if algo == "ppo" else 100))
    if how == "sigkill":
        proc.kill()  # no handler runs, no last checkpoint: the newest one counts (records logged
        proc.communicate()  # after it are superseded: the fault-injection tests below pin that down)
        assert proc.returncode == -signal.SIGKILL
    else:
        if how == "ctrl-c":
            os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does: trainer and env workers
        else:
            proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate()
        assert proc.returncode == 130, err
        name = "SIGINT" if how == "ctrl-c" else "SIGTERM"
        assert f"{name} received" in err and "interrupted at step" in err and "Traceback" not in err
        assert "time in training: collect " in err  # where the interrupted session's time went
        state = json.loads((run / "state.json").read_text())
        assert state["status"] == "interrupted" and state["checkpoint"] == state["num_timesteps"]
    resumed = pyflyt(["train", f"resume={run}"], cwd=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert "resuming" in resumed.stderr and "warning" not in resumed.stderr
    _assert_same(_outcome(run), reference)


# ------------------------------------------------------------ fault injection

#: the steps of a checkpoint commit (``_Run.save_checkpoint`` in the training loop), in order
COMMIT_STEPS = [
    "metrics flushed",
    "written replay_buffer",
    "renamed replay_buffer",
    "written model",
    "renamed model",
    "state written",
    "pruned replay_buffer",
]


class Killed(BaseException):
    """A kill: nothing after it runs (no ``except Exception`` catches it)."""


@pytest.mark.parametrize("step", default_subset(COMMIT_STEPS, lambda step: step == COMMIT_STEPS[0]))
def test_a_kill_at_any_step_of_a_checkpoint_commit_resumes_exactly(tmp_path, tmp_path_factory, monkeypatch, step):
    overrides = [*SAC, "train.n_envs=1"]
    reference = _reference(overrides, tmp_path_factory)
    seen = []

    def fault(name: str) -> None:
        if name.startswith(step):
            seen.append(name)
            if len(seen) == 2:  # during the second checkpoint: the first one is complete
                raise Killed(name)

    monkeypatch.setattr(artifacts, "fault_point", fault)
    with pytest.raises(Killed):
        train(load(overrides, tmp_path))
    monkeypatch.undo()
    run = next(tmp_path.glob("*/*/*/config.yaml")).parent
    resumed = resume(run)
    assert not resumed.interrupted
    _assert_same(_outcome(run), reference)
    leftovers = [p.name for p in (run / "checkpoints").iterdir() if p.name.startswith(".")]
    assert leftovers == []  # what the kill left of the unfinished commit was cleared


# ------------------------------------------------------------------- others


def test_resume_of_a_run_killed_before_its_first_checkpoint_starts_over(tmp_path):
    cfg = load([*PPO, "train.total_timesteps=256", "train.n_envs=1"], tmp_path / "runs")
    run = train(cfg).run_dir
    reference = _outcome(run)
    # a kill before any checkpoint: only what the run wrote before training is left
    for p in (run / "checkpoints").iterdir():
        p.unlink()
    (run / "model.pt").unlink()
    (run / "state.json").write_text(json.dumps({"status": "running", "num_timesteps": 0, "checkpoint": None}))
    result = pyflyt(["train", f"resume={run}"], cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "from the start" in result.stderr and json.loads((run / "state.json").read_text())["status"] == "complete"
    assert _outcome(run)["evals"] == reference["evals"]  # the first attempt's records are superseded
    assert torch.equal(
        _outcome(run)["policy"]["mlp_extractor.policy_net.0.weight"],
        reference["policy"]["mlp_extractor.policy_net.0.weight"],
    )


def test_a_checkpoint_holds_tensors_and_plain_data_only(tmp_path):
    run = train(load([*SAC, "train.total_timesteps=250"], tmp_path)).run_dir
    checkpoint = sorted((run / "checkpoints").glob("model_*_steps.pt"))[-1]
    data = torch.load(checkpoint, weights_only=True)  # would raise on anything but tensors and primitives
    assert data["format"] == "pyflyt.checkpoint" and data["algo"] == "sac"
    assert {"policy", "optimizers", "variables", "state", "tensors", "normalizer"} <= set(data)
    state = json.loads(data["state"])
    assert {"counters", "rng", "envs", "callbacks"} <= set(state)
    with np.load(sorted((run / "checkpoints").glob("replay_buffer_*.npz"))[-1], allow_pickle=False) as buffer:
        assert {"observations", "actions", "rewards", "dones", "pos", "full"} <= set(buffer.files)


def test_a_legacy_pickled_run_is_refused_for_resume(tmp_path):
    run = train(load([*PPO, "train.total_timesteps=256", "train.eval_freq=0"], tmp_path)).run_dir
    for p in (run / "checkpoints").iterdir():
        p.rename(p.with_name(p.name.replace(".pt", ".zip")))
    (run / "state.json").write_text(json.dumps({"status": "interrupted", "num_timesteps": 0, "checkpoint": 256}))
    with pytest.raises(ConfigError, match="older version in a pickled format"):
        resume(run)


def test_a_resume_under_another_numeric_platform_says_so_in_one_line_and_records_where_it_ran(tmp_path):
    from pyflyt_cli.training import rundir

    run = train(load([*PPO, "train.total_timesteps=128", "train.eval_freq=0", "train.n_envs=1"], tmp_path)).run_dir
    record = rundir.read_yaml(run / rundir.RUN_FILE)
    here = record["numerics"]
    assert here == rundir.numeric_platform()  # the CPU, the kernels in force, the key
    for made, expected in (
        ({**here, "cpu": "Intel(R) Xeon(R) Gold 6338"},
         "note: this run was made on another CPU (Intel(R) Xeon(R) Gold 6338; here "),
        ({**here, "key": {**here["key"], "numerics": "native", "cpu": "Intel(R) Xeon(R) Gold 6338"}},
         "note: this run was made under another numeric platform (cpu Intel(R) Xeon(R) Gold 6338 -> -; "
         "numerics native -> pinned): what is computed here may round differently"),
    ):  # fmt: skip
        rundir.write_yaml(run / rundir.RUN_FILE, {**record, "numerics": made})
        lines: list[str] = []
        steps = rundir.read_state(run)["num_timesteps"] + 128
        resume(run, total_timesteps=steps, log=lines.append)
        assert [line for line in lines if line.startswith("note:")] == [
            next(x for x in lines if x.startswith(expected))
        ]
        resumes = rundir.read_yaml(run / rundir.RUN_FILE)["resumes"]
        assert resumes[-1]["cpu"] == here["cpu"] and resumes[-1]["numerics"] == here["key"]

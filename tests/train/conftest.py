"""Helpers for the training tests: tiny budgets, composed configs, subprocess CLI runs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def experiment(name: str):
    """The script ``experiments/<name>.py`` as a module, for tests of a study's own code (what
    the studies share lives in :mod:`pyflyt_cli.studies`; no script imports another)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, ROOT / "experiments" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


#: a PPO run that finishes in a few seconds: 2 rollouts of 256 steps, evaluation and
#: checkpoints at every rollout, 2 short evaluation episodes
TINY_PPO = [
    "env=quadx_hover",
    "algo=ppo",
    "env.backend=pybullet",  # the PyBullet training path (hover PPO's default auto would train batched: tests/batched)
    "train.total_timesteps=512",
    "train.n_envs=1",
    "algo.n_steps=256",
    "algo.batch_size=64",
    "algo.n_epochs=2",
    "train.eval_freq=256",
    "train.eval_episodes=2",
    "train.checkpoint_freq=256",
    "train.progress_bar=false",
]

#: a SAC run with a small replay buffer, learning from step 100
TINY_SAC = [
    "env=quadx_hover",
    "algo=sac",
    "train.total_timesteps=400",
    "train.n_envs=1",
    "algo.buffer_size=2000",
    "algo.learning_starts=100",
    "algo.batch_size=32",
    "algo.policy_kwargs.net_arch=[32,32]",
    "train.eval_freq=200",
    "train.eval_episodes=2",
    "train.checkpoint_freq=200",
    "train.progress_bar=false",
]

#: an AWAC run on quadx_hover that updates from step 100 and evaluates twice
TINY_AWAC = [
    "env=quadx_hover",
    "algo=awac",
    "train.total_timesteps=300",
    "algo.buffer_size=2000",
    "algo.learning_starts=100",
    "algo.batch_size=32",
    "algo.policy_kwargs.net_arch=[32,32]",
    "train.eval_freq=150",
    "train.eval_episodes=1",
    "train.checkpoint_freq=150",
    "train.progress_bar=false",
]


def load(overrides: list[str], output_dir: Path):
    """The validated TrainConfig `pyflyt train <overrides>` would run, writing under output_dir."""
    from pyflyt_cli.training.compose import compose_config

    return compose_config(overrides=[*overrides, f"train.output_dir={output_dir}"])


def cli_env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def pyflyt(args: list[str], cwd: Path, timeout: float = 300, **kwargs) -> subprocess.CompletedProcess:
    """Run ``python -m pyflyt_cli.main <args>`` from the checkout."""
    return subprocess.run(  # noqa: PLW1510 - the caller checks returncode
        [sys.executable, "-m", "pyflyt_cli.main", *args],
        cwd=cwd,
        env=cli_env(),
        capture_output=True,
        text=True,
        timeout=timeout,
        **kwargs,
    )


@pytest.fixture
def runs(tmp_path: Path) -> Path:
    path = tmp_path / "runs"
    return path


def initial_policy_probe() -> tuple[object, dict]:
    """An SB3 callback and the dict it fills with the policy's weights when training starts
    (after ``init_from`` has loaded them, before the first update)."""
    from stable_baselines3.common.callbacks import BaseCallback

    seen: dict = {}

    class Capture(BaseCallback):
        def _on_training_start(self) -> None:
            seen.update({k: v.clone() for k, v in self.model.policy.state_dict().items()})

        def _on_step(self) -> bool:
            return True

    return Capture(), seen


class FixedAction:
    """A policy that always returns ``action`` (in the agent's [-1, 1] units): what the
    experiments' probes fly, without training."""

    def __init__(self, action):
        self.action = np.asarray(action, dtype=np.float32)

    def get_vec_normalize_env(self):
        return None

    def predict(self, obs, deterministic=True):
        return self.action, None

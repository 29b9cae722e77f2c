"""n-step returns for the off-policy algorithms (``algo.n_steps``, SB3's ``NStepReplayBuffer``).

The default (1) builds exactly the one-step algorithm with SB3's plain replay buffer, so every
earlier run computes what it did and keeps its digest; n > 1 reaches SB3's n-step buffer with the
run's own discount, trains, evaluates and resumes bit for bit, and counts in the run's identity.
"""

from __future__ import annotations

import pytest
from stable_baselines3.common.buffers import NStepReplayBuffer, ReplayBuffer

from pyflyt_cli.training import resume, train
from pyflyt_cli.training.compose import compose_config
from pyflyt_cli.training.rundir import identity

from .conftest import load
from .test_resume import SignalAt, _assert_same, _outcome

TINY_SAC = [
    "env=quadx_hover",
    "algo=sac",
    "train.total_timesteps=300",
    "train.eval_freq=128",
    "train.eval_episodes=1",
    "train.checkpoint_freq=128",
    "train.save_replay_buffer=true",
    "train.progress_bar=false",
    "algo.buffer_size=2000",
    "algo.learning_starts=64",
    "algo.batch_size=32",
    "algo.policy_kwargs.net_arch=[32,32]",
]


def _model(overrides: list[str]):
    from pyflyt_cli.training.envs import make_vec_env
    from pyflyt_cli.training.models import build_model

    cfg = compose_config(overrides=overrides)
    vec = make_vec_env(cfg.env, 1, "dummy")
    try:
        return cfg, build_model(cfg, vec)
    finally:
        vec.close()


@pytest.mark.parametrize("algo", ["sac", "td3", "tqc", "crossq", "awac"])
def test_one_step_is_the_default_and_builds_the_plain_replay_buffer(algo):
    cfg, model = _model([f"algo={algo}", "algo.buffer_size=100", "env.backend=pybullet"])
    assert cfg.algo.n_steps == 1 and "n_steps" not in cfg.algo.constructor_kwargs()
    assert type(model.replay_buffer) is ReplayBuffer
    assert "algo.n_steps" not in identity(cfg)  # runs recorded before the key keep their identity


def test_n_steps_reach_sbs_n_step_buffer_with_the_runs_discount():
    cfg, model = _model(["algo=sac", "algo.n_steps=3", "algo.gamma=0.97", "algo.buffer_size=100"])
    assert isinstance(model.replay_buffer, NStepReplayBuffer)
    assert model.replay_buffer.n_steps == 3 and model.replay_buffer.gamma == pytest.approx(0.97)
    assert identity(cfg)["algo.n_steps"] == 3
    assert identity(cfg) != identity(compose_config(overrides=["algo=sac", "algo.gamma=0.97", "algo.buffer_size=100"]))


def test_an_n_step_run_trains_and_resumes_bit_for_bit(tmp_path):
    overrides = [*TINY_SAC, "algo.n_steps=3"]
    reference_run = train(load(overrides, tmp_path / "reference")).run_dir
    reference = _outcome(reference_run)
    first = train(load(overrides, tmp_path / "interrupted"), callbacks=[SignalAt(150)])
    assert first.interrupted
    assert not resume(first.run_dir).interrupted
    _assert_same(_outcome(first.run_dir), reference)

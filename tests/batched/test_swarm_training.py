"""Training the multi-agent hover on the batched backend: worlds x agents as the VecEnv's
slots, the run's record, evaluation in the PyBullet engine, exact resume, determinism."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import yaml

from pyflyt_cli.training import resume, train
from pyflyt_cli.training.envs import make_vec_env
from pyflyt_engine.envs.config import load_env_config
from tests.train.conftest import load
from tests.train.test_resume import SignalAt, _assert_same, _outcome, _reference

PPO_SWARM = [
    "env=ma_quadx_hover",
    "algo=ppo",
    "env.backend=batched",
    "env.agents=4",
    "env.downwash=true",
    "train.n_envs=2",
    "train.total_timesteps=2048",
    "algo.n_steps=64",
    "algo.batch_size=128",
    "algo.n_epochs=2",
    "train.eval_freq=512",
    "train.eval_episodes=1",
    "train.checkpoint_freq=512",
    "train.progress_bar=false",
]


def test_the_slots_are_worlds_times_agents():
    cfg = load_env_config("ma_quadx_hover").with_overrides(backend="batched", agents=4)
    vec = make_vec_env(cfg, 3)
    assert vec.num_envs == 12 and vec.env.worlds == 3
    obs = vec.reset()
    assert obs.shape == (12, 24) and obs.dtype == np.float32
    # slot k A + i is agent i of world k: every world's agents start on the ring, in order
    ring = np.array([a.hover_point for a in cfg.resolved_agents()])
    assert np.abs(vec.env.pos.reshape(3, 4, 3) - ring).max() <= 0.1 + 1e-12
    _, rewards, dones, _ = vec.step(np.zeros((12, 4), dtype=np.float32))  # mid thrust
    assert rewards.shape == (12,) and not dones.any()


def test_a_run_records_its_backend_and_evaluates_in_the_pybullet_engine(tmp_path):
    result = train(load(PPO_SWARM, tmp_path))
    config = yaml.safe_load((result.run_dir / "config.yaml").read_text())
    assert config["env"]["backend"] == "batched" and config["env"]["downwash"] is True
    assert yaml.safe_load((result.run_dir / "run.yaml").read_text())["backend"] == "batched"
    assert result.num_timesteps == 2048
    from pyflyt_cli.training.evaluate import evaluate_run

    report = evaluate_run(result.run_dir, {"episodes": 2})
    assert len(report.episodes) == 2  # flown on the PyBullet engine's shared-policy env
    assert isinstance(report.batched, dict) and report.batched["episodes"] == 2.0  # and on the batched worlds


@pytest.mark.parametrize(
    "lines",
    [
        PPO_SWARM,
        # the worlds' turbulence state and streams travel in the checkpoint too
        pytest.param(
            [*PPO_SWARM, "env.wind=dryden_light", "env.ground_effect=true"], marks=pytest.mark.long, id="turbulence"
        ),
        # the formation's task objects (one per world) resume from the env's arrays
        pytest.param(["env=ma_quadx_formation", *PPO_SWARM[1:]], marks=pytest.mark.long, id="formation"),
    ],
)
def test_a_stop_anywhere_then_resume_is_bit_identical(tmp_path, tmp_path_factory, lines):
    """Stopped mid-rollout, with retired agents padding their slots, then resumed: the same
    weights, evaluations and episodes as the uninterrupted run."""
    reference = _reference(lines, tmp_path_factory)
    assert len(reference["episodes"]) > 8  # agents did retire and worlds did restart along the way
    first = train(load(lines, tmp_path), callbacks=[SignalAt(700)])
    assert first.interrupted
    resumed = resume(first.run_dir)
    assert not resumed.interrupted
    _assert_same(_outcome(first.run_dir), reference)


def test_same_seed_same_numbers_in_another_process():
    code = (
        "import numpy as np\n"
        "from pyflyt_engine.envs import make_batched_env\n"
        "env = make_batched_env('ma_quadx_hover', n_envs=3, seed=11, downwash=True)\n"
        "obs, _ = env.reset(seed=11)\n"
        "rng = np.random.default_rng(0)\n"
        "out = [obs]\n"
        "for _ in range(120):\n"
        "    o, r, t, tr, _ = env.step(np.c_[rng.uniform(-1, 1, (12, 3)), rng.uniform(0.1, 0.16, (12, 1))])\n"
        "    out += [o, r[:, None]]\n"
        "print(np.concatenate([x.ravel() for x in out]).tobytes().hex())\n"
    )
    runs = [
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
        for _ in range(2)
    ]
    assert runs[0] == runs[1] and len(runs[0]) > 1000


def test_the_eta_counts_an_evaluation_step_of_the_pybullet_env_once(tmp_path):
    """The evaluation cost measured for a batched run is per step of the PyBullet env, all
    its agents at once: the estimate does not multiply it by the agent count again."""
    from pyflyt_cli.training.timing import Costs, estimate_seconds

    cfg = load([*PPO_SWARM, "env.agents=8"], tmp_path)
    base = estimate_seconds(cfg, Costs(1e-5, 2e-5, None))
    with_eval = estimate_seconds(cfg, Costs(1e-5, 2e-5, 0.01))
    evals = cfg.train.total_timesteps // cfg.train.eval_freq
    expected = 2048 * 3e-5 + evals * cfg.train.eval_episodes * cfg.env.max_steps * 0.01
    assert abs(with_eval - expected) < 1e-9
    assert abs(base - (2048 * 3e-5 + evals * cfg.train.eval_episodes * cfg.env.max_steps * 8 * 1e-5)) < 1e-9

"""AWAC (Nair et al. 2020): losses against hand computations, save/load, `pyflyt train` runs.

Tiny networks and budgets: every test takes a few seconds on one core.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import torch
import yaml

from pyflyt_cli.training import train
from pyflyt_cli.training.artifacts import save_replay_buffer
from pyflyt_cli.training.awac import AWAC, advantage_weights
from pyflyt_cli.training.models import read_policy
from pyflyt_engine.errors import ConfigError

from .conftest import TINY_AWAC, TINY_SAC, initial_policy_probe, load

SMALL = {"net_arch": [16, 16]}


@pytest.fixture(autouse=True)
def _one_thread():
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


def _pendulum(**kwargs) -> AWAC:
    args = {"learning_starts": 50, "batch_size": 32, "buffer_size": 2000, "policy_kwargs": SMALL, "seed": 0}
    return AWAC("MlpPolicy", gym.make("Pendulum-v1"), device="cpu", **{**args, **kwargs})


def test_a_few_hundred_pendulum_steps_train_with_finite_losses():
    model = _pendulum().learn(300)
    logged = model.logger.name_to_value
    assert model.num_timesteps == 300 and model._n_updates == 250
    assert math.isfinite(logged["train/actor_loss"]) and math.isfinite(logged["train/critic_loss"])
    assert 0 < logged["train/adv_weight_mean"] <= model.max_weight


def test_advantage_weights_are_exp_a_over_lambda_clipped_at_max_weight():
    a = torch.tensor([-2.0, 0.0, 0.5, 3.0, 1e6])
    w = advantage_weights(a, beta=0.5, max_weight=20.0)
    expected = [math.exp(-4.0), 1.0, math.e, 20.0, 20.0]  # exp(6) > 20 is clipped; 1e6 does not overflow
    assert w.tolist() == pytest.approx(expected, rel=1e-6)


def test_actor_loss_equals_a_hand_computation_on_a_fixed_batch():
    model = _pendulum(beta=0.05, max_weight=3.0, n_value_samples=2)
    rng = np.random.default_rng(1)
    obs = torch.as_tensor(rng.uniform(-1, 1, (8, 3)), dtype=torch.float32)
    actions = torch.as_tensor(rng.uniform(-0.9, 0.9, (8, 1)), dtype=torch.float32)
    # make the critics disagree with the policy's own samples: a wide spread of advantages
    with torch.no_grad():
        for q in model.critic.q_networks:
            q[-1].weight.mul_(40.0)

    torch.manual_seed(123)
    loss, parts = model.actor_loss(obs, actions)

    # by hand: same random draws for the two policy samples that estimate V(s)
    torch.manual_seed(123)
    with torch.no_grad():
        q_sa = torch.minimum(*model.critic(obs, actions)).numpy()
        v = np.mean(
            [torch.minimum(*model.critic(obs, model.actor.action_log_prob(obs)[0])).numpy() for _ in range(2)], axis=0
        )
        mean, log_std, _ = model.actor.get_action_dist_params(obs)
        mean, std = mean.numpy().astype(np.float64), np.exp(log_std.numpy().astype(np.float64))
    a = actions.numpy().astype(np.float64)
    u = np.arctanh(a)  # pre-squash Gaussian sample
    gauss = -0.5 * ((u - mean) / std) ** 2 - np.log(std) - 0.5 * np.log(2 * np.pi)
    log_prob = gauss.sum(axis=1, keepdims=True) - np.log(1 - a**2 + 1e-6).sum(axis=1, keepdims=True)
    adv = q_sa - v
    weights = np.minimum(np.exp(adv / 0.05), 3.0)
    expected = -np.mean(weights * log_prob)

    assert np.allclose(parts["advantages"].numpy(), adv, atol=1e-5)
    assert np.allclose(parts["weights"].numpy(), weights, rtol=1e-4)
    assert (weights == 3.0).any() and (weights < 3.0).any(), "the batch should exercise the clip"
    assert np.allclose(parts["log_prob"].numpy(), log_prob, atol=1e-4)
    assert loss.item() == pytest.approx(expected, rel=1e-4)

    # the gradient reaches the actor only
    loss.backward()
    assert all(p.grad is not None for p in model.actor.parameters() if p.requires_grad)
    assert all(p.grad is None for p in model.critic.parameters())


def test_save_and_load_round_trip(tmp_path):
    model = _pendulum(beta=0.3, max_weight=7.0).learn(120)
    model.save(tmp_path / "awac.zip")
    again = AWAC.load(tmp_path / "awac.zip", device="cpu")
    assert (again.beta, again.max_weight, again.num_timesteps) == (0.3, 7.0, 120)
    for key, value in model.policy.state_dict().items():
        assert torch.equal(value, again.policy.state_dict()[key]), key
    obs = np.array([[0.5, -0.5, 0.1]], dtype=np.float32)
    assert np.array_equal(model.predict(obs, deterministic=True)[0], again.predict(obs, deterministic=True)[0])
    assert again.critic is again.policy.critic and again.actor is again.policy.actor


def test_offline_pretraining_on_a_saved_buffer(tmp_path):
    source = _pendulum(learning_starts=1000).learn(200)  # collects only
    save_replay_buffer(tmp_path / "buffer.npz", source.replay_buffer)
    model = _pendulum(offline_buffer=tmp_path / "buffer.npz", offline_steps=15, learning_starts=0)
    assert model.replay_buffer.size() == 200
    size = 200
    for name in ("observations", "actions", "rewards", "dones"):
        assert np.array_equal(getattr(model.replay_buffer, name)[:size], getattr(source.replay_buffer, name)[:size])
    before = {k: v.clone() for k, v in model.actor.state_dict().items()}
    assert model.pretrain() == 15 and model._n_updates == 15 and model.offline_steps_done == 15
    assert any(not torch.equal(v, model.actor.state_dict()[k]) for k, v in before.items())
    model.learn(10)  # the offline phase is not repeated; online data joins the same buffer
    assert model.offline_steps_done == 15 and model.replay_buffer.size() == 210


def test_a_pickled_offline_buffer_loads_only_when_trusted(tmp_path):
    source = _pendulum(learning_starts=1000).learn(50)
    source.save_replay_buffer(tmp_path / "buffer.pkl")
    with pytest.raises(ConfigError, match="trust_pickle=true"):
        _pendulum(offline_buffer=tmp_path / "buffer.pkl")
    assert _pendulum(offline_buffer=tmp_path / "buffer.pkl", trust_pickle=True).replay_buffer.size() == 50


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="offline_steps > 0 needs offline_buffer"):
        _pendulum(offline_steps=5)
    with pytest.raises(ValueError, match="beta must be > 0"):
        _pendulum(beta=0.0)


def test_awac_through_train_on_quadx_hover(tmp_path):
    result = train(load(TINY_AWAC, tmp_path / "runs"))
    run = result.run_dir
    assert run.parent.name == "awac" and result.num_timesteps == 300 and not result.interrupted
    assert (run / "metrics.mcap").is_file() and read_policy(run / "model.pt").algo == "awac"
    assert list((run / "checkpoints").glob("replay_buffer_*.npz")), "off-policy: the buffer is checkpointed"
    assert result.last_eval is not None and math.isfinite(result.last_eval["mean_return"])


def test_awac_config_is_checked_at_load(tmp_path):
    cfg = load(["algo=awac"], tmp_path)
    assert cfg.algo.beta == 1.0 and cfg.algo.max_weight == 20.0 and cfg.algo.batch_size == 1024
    with pytest.raises(ConfigError, match="offline_steps > 0 needs offline_buffer"):
        load(["algo=awac", "algo.offline_steps=10"], tmp_path)
    with pytest.raises(ConfigError, match="offline_buffer: no such file"):
        load(["algo=awac", f"algo.offline_buffer={tmp_path / 'none.pkl'}"], tmp_path)
    with pytest.raises(ConfigError, match="beta"):
        load(["algo=awac", "algo.beta=0"], tmp_path)


def test_init_from_a_sac_run_loads_its_policy(tmp_path):
    sac_run = [*TINY_SAC[:2], "train.total_timesteps=150", *TINY_SAC[3:]]
    source = train(load(sac_run, tmp_path / "runs")).run_dir
    src = read_policy(source / "model.pt").policy
    probe, seen = initial_policy_probe()

    # the shipped quadx_hover SAC tuning explores with gSDE: AWAC must too, for the shapes to match
    assert load(sac_run, tmp_path).algo.use_sde
    sde = ["algo.use_sde=true", "algo.policy_kwargs.log_std_init=-3"]
    overrides = [*TINY_AWAC, *sde, "train.total_timesteps=50", "train.eval_freq=0", f"init_from={source}"]
    result = train(load(overrides, tmp_path / "runs"), callbacks=[probe])
    assert set(seen) == set(src)
    assert all(torch.equal(seen[k], v) for k, v in src.items())
    assert yaml.safe_load((result.run_dir / "run.yaml").read_text())["init_from"]["run"] == str(source)


def test_init_from_a_sac_run_with_another_exploration_says_what_to_match(tmp_path):
    source = train(load([*TINY_SAC[:2], "train.total_timesteps=20", *TINY_SAC[3:]], tmp_path / "runs")).run_dir
    overrides = [*TINY_AWAC, "train.total_timesteps=20", "train.eval_freq=0", f"init_from={source}"]
    with pytest.raises(ConfigError, match="algo.use_sde"):
        train(load(overrides, tmp_path / "runs"))


def test_gsde_exploration_trains():
    model = _pendulum(use_sde=True, sde_sample_freq=4).learn(120)
    assert model._n_updates == 70 and math.isfinite(model.logger.name_to_value["train/actor_loss"])


def test_init_from_an_unrelated_algorithm_is_refused(tmp_path):
    source = train(load([*TINY_AWAC, "train.total_timesteps=20", "train.eval_freq=0"], tmp_path / "runs")).run_dir
    overrides = [*TINY_SAC, "train.total_timesteps=20", "train.eval_freq=0", f"init_from={source}"]
    with pytest.raises(ConfigError, match="sac can start from the policy weights of: sac"):
        train(load(overrides, tmp_path / "runs"))

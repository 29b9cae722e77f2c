"""CCGE (Tai et al. 2022): the exploration rule on constructed critics, SAC equivalence when the
oracle is never used, bootstrapping from a SAC run, exact resume."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch
from stable_baselines3 import SAC

from pyflyt_cli.training import resume, train
from pyflyt_cli.training.ccge import CCGE, oracle_switch
from pyflyt_cli.training.models import read_policy

from .conftest import TINY_SAC, load
from .test_resume import SignalAt, _assert_same, _outcome


@pytest.fixture(autouse=True)
def _one_thread():
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


def test_the_switch_is_the_normalised_gap_between_oracle_upper_and_policy_lower_values():
    q_policy = torch.tensor([[1.0, 3.0], [10.0, 10.0], [-2.0, -2.0], [0.0, 0.0]])
    q_oracle = torch.tensor([[2.0, 5.0], [10.5, 11.0], [-1.0, 0.0], [0.0, 1e-3]])
    switch, u = oracle_switch(q_policy, q_oracle, confidence_lambda=1.0)
    # (max oracle - min policy) / |mean policy|: (5-1)/2, (11-10)/10, (0+2)/2, (1e-3 - 0)/tiny
    assert u[:3, 0].tolist() == pytest.approx([2.0, 0.1, 1.0])
    assert switch[:, 0].tolist() == [1.0, 0.0, 0.0, 1.0]  # 1.0 is not above lambda = 1


def _pendulum(**kwargs) -> CCGE:
    args = {"learning_starts": 0, "batch_size": 16, "buffer_size": 500, "seed": 0, "device": "cpu"}
    policy_kwargs = {"net_arch": {"pi": [8], "qf": []}}  # linear critics: Q_j(s, a) = w_j . [s, a] + b_j
    return CCGE("MlpPolicy", gym.make("Pendulum-v1"), policy_kwargs=policy_kwargs, **{**args, **kwargs})


def _set_critic(model: CCGE, slopes: list[float], offset: float | list[float]) -> None:
    """Q_j(s, a) = offset_j + slopes[j] * a (observations ignored)."""
    offsets = offset if isinstance(offset, list) else [offset] * len(slopes)
    with torch.no_grad():
        for q, slope, b in zip(model.critic.q_networks, slopes, offsets):
            layer = q[0]
            layer.weight.zero_()
            layer.weight[0, -1] = slope
            layer.bias.fill_(b)


def _set_oracle(model: CCGE, action: float) -> None:
    """An oracle whose deterministic action is ``action`` everywhere (tanh of a constant mean)."""
    with torch.no_grad():
        model.policy.oracle.mu.weight.zero_()
        model.policy.oracle.mu.bias.fill_(float(np.arctanh(action)))


def _explore(model: CCGE) -> tuple[np.ndarray, np.ndarray]:
    env = model.get_env()
    model._last_obs = env.reset()
    return model._sample_action(learning_starts=0, n_envs=1)


def test_the_oracle_acts_only_where_the_critic_ensemble_is_unsure():
    model = _pendulum(confidence_lambda=0.5)
    _set_oracle(model, 0.8)
    # critics agree everywhere (Q = 10 at every action): confident, the policy acts
    _set_critic(model, [0.0, 0.0], offset=10.0)
    action, buffer_action = _explore(model)
    assert not np.allclose(buffer_action, 0.8, atol=1e-5)
    # critics disagree about actions: at the oracle's 0.8 one says 10 + 20 * 0.8 = 26, while the
    # policy's a in [-1, 1] has min_j Q_j(s, a) <= 10 and mean ~ 10: the gap (>= 16) / 10 > 0.5
    _set_critic(model, [20.0, -20.0], offset=10.0)
    action, buffer_action = _explore(model)
    assert buffer_action == pytest.approx(np.array([[0.8]]), abs=1e-6)
    assert action == pytest.approx(2.0 * buffer_action, abs=1e-5)  # Pendulum's torque range is [-2, 2]
    assert model.oracle_actions == 1 and model.policy_actions == 1
    # the same disagreement with a large lambda: the policy acts again
    model.confidence_lambda = 100.0
    _, buffer_action = _explore(model)
    assert not np.allclose(buffer_action, 0.8, atol=1e-5)


def test_the_warm_up_takes_random_actions_as_sac():
    model = _pendulum(confidence_lambda=0.0)
    _set_oracle(model, 0.8)
    _set_critic(model, [20.0, -20.0], offset=10.0)
    model._last_obs = model.get_env().reset()
    _, buffer_action = model._sample_action(learning_starts=100, n_envs=1)
    assert not np.allclose(buffer_action, 0.8) and model.oracle_actions == 0


def test_ccge_whose_oracle_never_acts_is_sac_bit_for_bit():
    env_id, kwargs = (
        "Pendulum-v1",
        {"learning_starts": 50, "batch_size": 16, "seed": 3, "device": "cpu", "policy_kwargs": {"net_arch": [16]}},
    )
    sac = SAC("MlpPolicy", gym.make(env_id), **kwargs).learn(200)
    ccge = CCGE("MlpPolicy", gym.make(env_id), confidence_lambda=1e30, **kwargs).learn(200)
    assert ccge.oracle_actions == 0 and ccge.policy_actions == 150
    ours = ccge.policy.state_dict()
    for key, value in sac.policy.state_dict().items():
        assert torch.equal(ours[key], value), key


@pytest.mark.parametrize("supervise", [True, False])
def test_supervision_pulls_the_actor_to_the_oracle_where_the_critic_is_unsure(supervise):
    model = _pendulum(confidence_lambda=0.0, supervise=supervise)
    _set_oracle(model, 0.8)
    model.learn(64)  # fills the buffer
    # min_j Q_j(s, a) = 10 - 20 |a + 0.8|: the critic's best action is -0.8, the oracle says +0.8,
    # and the ensemble's gap there (max_j Q_j(s, 0.8) = 42 against <= 10) makes it unsure everywhere
    _set_critic(model, [20.0, -20.0], offset=[26.0, -6.0])
    model._update_learning_rate = lambda optimizers: None  # critic frozen, actor at 1e-2
    for group in model.critic.optimizer.param_groups:
        group["lr"] = 0.0
    for group in model.actor.optimizer.param_groups:
        group["lr"] = 1e-2
    model.train(gradient_steps=300, batch_size=32)
    obs = torch.as_tensor(model.replay_buffer.observations[:64, 0])
    mean_action = model.actor(obs, deterministic=True).mean().item()
    # imitated: towards the oracle's 0.8; without supervision SAC's loss takes it towards -0.8
    assert mean_action > 0.5 if supervise else mean_action < -0.5


@pytest.mark.long
def test_pyflyt_train_ccge_bootstraps_from_a_sac_run_and_resumes_exactly(tmp_path):
    sac_run = train(load(TINY_SAC, tmp_path / "sac")).run_dir
    sac_policy = read_policy(sac_run / "best_model.pt").policy
    overrides = [
        "env=quadx_hover",
        "algo=ccge",
        "train.total_timesteps=300",
        "algo.buffer_size=2000",
        "algo.learning_starts=50",
        "algo.batch_size=32",
        "algo.policy_kwargs.net_arch=[32,32]",
        "train.eval_freq=150",
        "train.eval_episodes=1",
        "train.checkpoint_freq=150",
        "train.progress_bar=false",
        f"init_from={sac_run}",
    ]
    reference_run = train(load(overrides, tmp_path / "reference")).run_dir
    final = read_policy(reference_run / "model.pt")
    assert final.algo == "ccge"
    for key, value in sac_policy.items():  # the oracle is the SAC actor, frozen
        if key.startswith("actor."):
            assert torch.equal(final.policy["oracle." + key[len("actor.") :]], value), key
    first = train(load(overrides, tmp_path / "interrupted"), callbacks=[SignalAt(170)])
    assert first.interrupted
    assert not resume(first.run_dir).interrupted
    _assert_same(_outcome(first.run_dir), _outcome(reference_run))


def test_pyflyt_train_refuses_ccge_without_an_oracle_naming_init_from():
    from typer.testing import CliRunner

    from pyflyt_cli.main import app

    result = CliRunner().invoke(app, ["train", "env=quadx_hover", "algo=ccge", "train.total_timesteps=10"])
    assert result.exit_code == 2, result.output
    assert "algo=ccge needs init_from=" in result.output and "random initial actor" in result.output

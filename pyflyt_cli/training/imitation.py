"""Imitation before reinforcement learning: DAgger from a scripted oracle (``train.imitation``).

A new run with ``train.imitation`` first fits its policy's deterministic action to a
scripted oracle's (:mod:`pyflyt_engine.envs.oracles`) by DAgger (Ross, Gordon & Bagnell
2011, "A Reduction of Imitation Learning and Structured Prediction to No-Regret Online
Learning", AISTATS): round 0 flies ``episodes`` episodes with the oracle in control;
each later round k = 1..``rounds`` flies ``episodes`` episodes in which, at every step,
the oracle acts with probability ``beta_k = mixing * (1 - (k - 1) / rounds)`` and the
policy (its deterministic action) otherwise.  Every state visited is labelled with the
oracle's action and added to one data set, and after every round the policy is fitted
to the whole set for ``epochs`` passes (mean squared error between the policy's
deterministic action and the oracle's, in the policy's own action units: the env's for
PPO/A2C/TRPO, [-1, 1] for the squashed off-policy actors).  Reinforcement learning then
starts from the fitted policy; the value functions and critics start untrained, unless
``value_warmup`` (PPO, A2C) gives the value function that many learning steps to fit the
fitted policy's returns before the policy itself is updated
(:class:`pyflyt_cli.training.callbacks.ValueWarmup`): an
untrained critic's advantages are noise, and updating a good policy on them can unlearn it.

With ``algo.normalize.observation``, the normaliser's statistics are updated with every
round's observations before the fit, so the policy learns on the inputs it will see.

Episodes are seeded ``seed + IMITATION_SEED_OFFSET + i`` (episode i of the stage), the
mixing draws and the minibatches from ``seed``: the stage is deterministic, and a rerun
of the same configuration fits the same weights.  It runs once, when a run starts; a
resumed run continues from its checkpoint (which holds the fitted and since trained
weights).  Per round, ``/imitation`` in ``metrics.mcap`` records the data set size, the
oracle's share of the actions, the episodes' mean return and success rate and the fit's
final loss.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from stable_baselines3.common.running_mean_std import RunningMeanStd

#: episode i of the imitation stage is reset with seed + IMITATION_SEED_OFFSET + i (away from
#: the training envs' seed + i and the evaluations' seed + 1000 + i)
IMITATION_SEED_OFFSET = 2_000_000

#: the fields of a :class:`Round` logged on ``/imitation`` (the round's index is the step)
IMITATION_RECORD = ("oracle_share", "episodes", "steps", "samples", "mean_return", "success_rate", "loss", "seconds")


@dataclass
class Round:
    """One DAgger round: what was flown and how well the policy fits the data set after it."""

    index: int
    oracle_share: float  # beta: probability the oracle acted at a step
    episodes: int
    steps: int  # environment steps flown this round
    samples: int  # size of the aggregated data set after the round
    mean_return: float
    success_rate: float
    loss: float  # mean squared error over the last epoch
    seconds: float


def oracle_share(round_index: int, rounds: int, mixing: float) -> float:
    """beta of a round: 1 for round 0 (the oracle alone), then ``mixing`` falling linearly to
    ``mixing / rounds`` at the last round."""
    if round_index == 0:
        return 1.0
    return mixing * (1.0 - (round_index - 1) / rounds)


def imitate(
    model: Any,
    env: Any,
    options: Any,
    seed: int,
    log: Callable[[str], None],
    on_round: Callable[[Round], None] | None = None,
) -> list[Round]:
    """Fit ``model``'s policy to the oracle ``options.oracle`` by DAgger on ``env``.

    Args:
        model: a new SB3 model (its normaliser, if any, from ``model.get_vec_normalize_env()``).
        env: one environment wrapped for the agent (:func:`pyflyt_cli.training.envs.wrap_for_agent`).
        options: ``train.imitation`` (:class:`pyflyt_cli.training.schema.ImitationOptions`).
        seed: the run's seed.
        log: progress lines.
        on_round: called with every finished round (the metrics record).
    """
    import torch as th

    from pyflyt_engine.envs.oracles import make_oracle

    oracle = make_oracle(options.oracle, env)
    to_agent = agent_units(env)
    policy = model.policy
    normalizer = model.get_vec_normalize_env()
    if normalizer is not None and not normalizer.norm_obs:
        normalizer = None
    rng = np.random.default_rng([seed, IMITATION_SEED_OFFSET])
    generator = th.Generator().manual_seed(seed + IMITATION_SEED_OFFSET)
    optimizer = th.optim.Adam([p for p in policy.parameters() if p.requires_grad], lr=options.learning_rate)
    observations: list[np.ndarray] = []
    actions: list[np.ndarray] = []
    rounds: list[Round] = []
    episode = 0
    for k in range(options.rounds + 1):
        started = time.perf_counter()
        beta = oracle_share(k, options.rounds, options.mixing)
        returns, successes, steps, new = [], [], 0, []
        for _ in range(options.episodes):
            obs, _ = env.reset(seed=seed + IMITATION_SEED_OFFSET + episode)
            episode += 1
            total, done, info = 0.0, False, {}
            while not done:
                target = to_agent(oracle(obs))  # flown as computed; stored as float32
                new.append(np.asarray(obs, dtype=np.float32))
                actions.append(target.astype(np.float32))
                if rng.random() < beta:
                    act = target
                else:
                    x = normalizer.normalize_obs(obs) if normalizer is not None else obs
                    act, _ = policy.predict(x, deterministic=True)
                obs, reward, terminated, truncated, info = env.step(act)
                total += float(reward)
                steps += 1
                done = terminated or truncated
            returns.append(total)
            successes.append(bool(info.get("success", False)))
        batch = np.stack(new)
        if normalizer is not None:
            normalizer.obs_rms.update(batch)
        observations.append(batch)
        loss = _fit(policy, normalizer, np.concatenate(observations), np.stack(actions), options, optimizer, generator)
        done_round = Round(
            index=k,
            oracle_share=beta,
            episodes=options.episodes,
            steps=steps,
            samples=len(actions),
            mean_return=float(np.mean(returns)),
            success_rate=float(np.mean(successes)),
            loss=loss,
            seconds=time.perf_counter() - started,
        )
        rounds.append(done_round)
        log(
            f"imitation round {k}/{options.rounds}: oracle acts {beta:.0%} of the steps, {options.episodes} episodes "
            f"(mean return {done_round.mean_return:.1f}, success {done_round.success_rate:.0%}), "
            f"{done_round.samples} samples, fit loss {loss:.4g}, {done_round.seconds:.0f} s"
        )
        if on_round is not None:
            on_round(done_round)
    return rounds


def agent_units(env: Any) -> Callable[[np.ndarray], np.ndarray]:
    """The oracle's action (in the env's own action space) in the agent's: the wrappers rescale a
    bounded Box to [-1, 1] (:func:`pyflyt_cli.training.envs.wrap_for_agent`)."""
    inner, outer = env.unwrapped.action_space, env.action_space
    if np.array_equal(inner.low, outer.low) and np.array_equal(inner.high, outer.high):
        return lambda action: np.asarray(action, dtype=np.float64)
    low, span = inner.low.astype(np.float64), (inner.high - inner.low).astype(np.float64)
    out_low, out_span = outer.low.astype(np.float64), (outer.high - outer.low).astype(np.float64)
    return lambda action: out_low + out_span * (np.asarray(action, dtype=np.float64) - low) / span


def _fit(
    policy: Any,
    normalizer: Any,
    observations: np.ndarray,
    targets: np.ndarray,
    options: Any,
    optimizer: Any,
    generator: Any,
) -> float:
    """``options.epochs`` passes of minibatch MSE between the policy's deterministic action and
    the oracle's; returns the mean loss of the last pass."""
    import torch as th

    x = normalizer.normalize_obs(observations) if normalizer is not None else observations
    if policy.squash_output:  # the actor's tanh output is the action space scaled to [-1, 1]
        targets = policy.scale_action(targets)
    x_t = th.as_tensor(np.asarray(x, dtype=np.float32), device=policy.device)
    y_t = th.as_tensor(np.asarray(targets, dtype=np.float32), device=policy.device)
    policy.set_training_mode(True)
    last = 0.0
    for _ in range(options.epochs):
        order = th.randperm(len(x_t), generator=generator)
        total, batches = 0.0, 0
        for start in range(0, len(order), options.batch_size):
            idx = order[start : start + options.batch_size]
            predicted = policy._predict(x_t[idx], deterministic=True)
            loss = th.nn.functional.mse_loss(predicted, y_t[idx])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            total += float(loss.item())
            batches += 1
        last = total / batches
    policy.set_training_mode(False)
    return last


def hold_observation_statistics(normalizer: Any) -> bool:
    """``train.imitation.hold_normalizer``: from now on the observation normaliser's running
    statistics stay as they are (the reward's still update).

    The imitation stage fits the policy on observations scaled by the statistics of the
    states it flew; statistics that go on moving with the learner's own (noisier) states
    change what the same weights do: in a QuadX-Obstacles pilot the policy, held by
    ``value_warmup``, went from 9 of 10 probe episodes at the goal to 2 of 10 in 100k steps.  Each running mean/std of
    ``normalizer.obs_rms`` becomes a :class:`HeldStatistics` with the same values; returns
    whether there was one to hold."""
    if normalizer is None or not normalizer.norm_obs:
        return False
    rms = normalizer.obs_rms
    if isinstance(rms, dict):
        normalizer.obs_rms = {key: HeldStatistics.of(value) for key, value in rms.items()}
    else:
        normalizer.obs_rms = HeldStatistics.of(rms)
    return True


class HeldStatistics(RunningMeanStd):
    """An SB3 ``RunningMeanStd`` whose ``update`` leaves it unchanged (saved and restored as any)."""

    @classmethod
    def of(cls, rms: Any) -> HeldStatistics:
        held = cls(shape=rms.mean.shape)
        held.mean, held.var, held.count = rms.mean.copy(), rms.var.copy(), rms.count
        return held

    def update(self, arr: np.ndarray) -> None:
        return None

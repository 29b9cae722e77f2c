"""Advantage-Weighted Actor-Critic (AWAC) as a Stable-Baselines3 off-policy algorithm.

Nair, Gupta, Dalal & Levine (2020), "AWAC: Accelerating Online Reinforcement Learning
with Offline Datasets", arXiv:2006.09359.  Stable-Baselines3 has no AWAC; this one reuses
SB3's SAC policy unchanged (squashed-Gaussian actor, twin Q critics, polyak-averaged
target critics), so a SAC run's ``policy`` state dict loads into an AWAC model as is: the
paper's "bootstrapped from a partially trained SAC policy" is ``init_from=<sac run>``.

One gradient step on a batch ``(s, a, r, s', d)`` drawn from the replay buffer:

* **Critic** (TD, as SAC's, with policy-sampled next actions)::

      y = r + γ (1 − d) [ min_j Q̄_j(s', a') − α log π(a'|s') ],   a' ~ π(·|s')
      L_Q = ½ Σ_j mean (Q_j(s, a) − y)²

  with α = ``ent_coef`` (0 by default: the paper's plain TD backup; > 0 gives SAC's soft
  backup).

* **Actor** (the paper's eq. 13, the normaliser Z(s) dropped as in the paper)::

      A(s, a) = min_j Q_j(s, a) − V(s),   V(s) = 1/n Σ_k min_j Q_j(s, a_k),  a_k ~ π(·|s)
      w(s, a) = min(exp(A(s, a) / λ), max_weight)            (no gradient through w)
      L_π = − mean[ w(s, a) · log π(a | s) ]

  over the *buffer* actions ``a``: the policy is pulled towards the actions in the data
  that beat its own average, never towards actions the critic merely extrapolates to.
  λ is ``beta`` (the paper's Lagrange multiplier / temperature); ``max_weight`` bounds the
  exponential weights so one over-estimated advantage cannot dominate a batch.

* **Targets**: ``Q̄ ← τ Q + (1 − τ) Q̄`` every ``target_update_interval`` gradient steps.

**Offline pretraining** (the paper's first phase): pass ``offline_buffer`` (a replay
buffer saved by ``model.save_replay_buffer`` or an SB3 ``ReplayBuffer`` pickle) and
``offline_steps``; the buffer is loaded when the model is built and the first call to
:meth:`AWAC.learn` runs ``offline_steps`` gradient steps on it before collecting any
online data (:meth:`AWAC.pretrain` does the same on demand).  Online transitions are then
appended to the same buffer, as in the paper.

The actions stored in SB3's replay buffer are already rescaled to ``[-1, 1]``; their
log-probability under the tanh-squashed Gaussian is computed by SB3's
``SquashedDiagGaussianDistribution.log_prob`` (which clips ±1 by float epsilon).
"""

from __future__ import annotations

import io
import pathlib
from typing import Any, ClassVar, TypeVar

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import ReplayBuffer
from stable_baselines3.common.noise import ActionNoise
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.policies import BasePolicy, ContinuousCritic
from stable_baselines3.common.type_aliases import GymEnv, MaybeCallback, Schedule
from stable_baselines3.common.utils import get_parameters_by_name, polyak_update
from stable_baselines3.sac.policies import Actor, CnnPolicy, MlpPolicy, MultiInputPolicy, SACPolicy
from torch.nn import functional as F

SelfAWAC = TypeVar("SelfAWAC", bound="AWAC")

#: default temperature λ: the paper's value for its MuJoCo locomotion tasks (Nair et al.
#: 2020, appendix, hyper-parameters; also d3rlpy's ``AWACConfig.lam``)
DEFAULT_BETA = 1.0
#: default upper bound of exp(A/λ): d3rlpy's ``AWACConfig.max_weight`` (CORL uses 100)
DEFAULT_MAX_WEIGHT = 20.0


def advantage_weights(advantages: th.Tensor, beta: float, max_weight: float) -> th.Tensor:
    """``min(exp(A / beta), max_weight)``, computed without overflow (A/beta is clipped first)."""
    limit = float(np.log(max_weight))
    return th.exp(th.clamp(advantages / beta, max=limit))


class AWAC(OffPolicyAlgorithm):
    """Advantage-Weighted Actor-Critic (Nair et al. 2020) on SB3's SAC policy.

    Args (beyond :class:`~stable_baselines3.common.off_policy_algorithm.OffPolicyAlgorithm`'s):
        beta: temperature λ of the advantage weights exp(A/λ); smaller is greedier.
        max_weight: clip of the advantage weights (> 0).
        n_value_samples: policy samples per state averaged into V(s).
        ent_coef: α of the soft TD backup (0: plain TD, as in the paper).
        target_update_interval: gradient steps between target-critic updates.
        use_sde, sde_sample_freq: generalised state-dependent exploration, as SAC's (needed
            to start from a SAC run trained with gSDE: the policies must have the same shape).
        offline_buffer: a replay buffer to pretrain on and keep filling: a ``.npz`` written
            with a pyflyt checkpoint (``checkpoints/replay_buffer_<N>_steps.npz``), or an
            SB3 ``.pkl`` (``save_replay_buffer``) only with ``trust_pickle``.
        offline_steps: gradient steps on ``offline_buffer`` before the first online step.
        trust_pickle: allow a pickled ``offline_buffer`` (unpickling can run any code it names).
    """

    policy_aliases: ClassVar[dict[str, type[BasePolicy]]] = {
        "MlpPolicy": MlpPolicy,
        "CnnPolicy": CnnPolicy,
        "MultiInputPolicy": MultiInputPolicy,
    }
    policy: SACPolicy
    actor: Actor
    critic: ContinuousCritic
    critic_target: ContinuousCritic

    def __init__(
        self,
        policy: str | type[SACPolicy],
        env: GymEnv | str,
        learning_rate: float | Schedule = 3e-4,
        buffer_size: int = 1_000_000,
        learning_starts: int = 100,
        batch_size: int = 1024,
        tau: float = 0.005,
        gamma: float = 0.99,
        train_freq: int | tuple[int, str] = 1,
        gradient_steps: int = 1,
        action_noise: ActionNoise | None = None,
        replay_buffer_class: type[ReplayBuffer] | None = None,
        replay_buffer_kwargs: dict[str, Any] | None = None,
        optimize_memory_usage: bool = False,
        beta: float = DEFAULT_BETA,
        max_weight: float = DEFAULT_MAX_WEIGHT,
        n_value_samples: int = 1,
        ent_coef: float = 0.0,
        target_update_interval: int = 1,
        use_sde: bool = False,
        sde_sample_freq: int = -1,
        offline_buffer: str | pathlib.Path | None = None,
        offline_steps: int = 0,
        n_steps: int = 1,
        trust_pickle: bool = False,
        stats_window_size: int = 100,
        tensorboard_log: str | None = None,
        policy_kwargs: dict[str, Any] | None = None,
        verbose: int = 0,
        seed: int | None = None,
        device: th.device | str = "auto",
        _init_setup_model: bool = True,
    ) -> None:
        if beta <= 0:
            raise ValueError(f"beta must be > 0, got {beta}")
        if max_weight <= 0:
            raise ValueError(f"max_weight must be > 0, got {max_weight}")
        if n_value_samples < 1:
            raise ValueError(f"n_value_samples must be >= 1, got {n_value_samples}")
        if ent_coef < 0:
            raise ValueError(f"ent_coef must be >= 0, got {ent_coef}")
        if offline_steps < 0:
            raise ValueError(f"offline_steps must be >= 0, got {offline_steps}")
        if offline_steps > 0 and offline_buffer is None:
            raise ValueError("offline_steps > 0 needs offline_buffer (a saved replay buffer to pretrain on)")
        super().__init__(
            policy,
            env,
            learning_rate,
            buffer_size,
            learning_starts,
            batch_size,
            tau,
            gamma,
            train_freq,
            gradient_steps,
            action_noise,
            replay_buffer_class=replay_buffer_class,
            replay_buffer_kwargs=replay_buffer_kwargs,
            n_steps=n_steps,
            optimize_memory_usage=optimize_memory_usage,
            policy_kwargs=policy_kwargs,
            stats_window_size=stats_window_size,
            tensorboard_log=tensorboard_log,
            verbose=verbose,
            device=device,
            seed=seed,
            use_sde=use_sde,
            sde_sample_freq=sde_sample_freq,
            supported_action_spaces=(spaces.Box,),
            support_multi_env=True,
        )
        self.beta = float(beta)
        self.max_weight = float(max_weight)
        self.n_value_samples = int(n_value_samples)
        self.ent_coef = float(ent_coef)
        self.target_update_interval = int(target_update_interval)
        self.offline_buffer = None if offline_buffer is None else str(offline_buffer)
        self.offline_steps = int(offline_steps)
        self.trust_pickle = bool(trust_pickle)
        #: gradient steps already taken on the offline buffer (saved: a resume does not redo them)
        self.offline_steps_done = 0
        if _init_setup_model:
            self._setup_model()

    # ---------------------------------------------------------------- setup

    def _setup_model(self) -> None:
        super()._setup_model()
        self.actor = self.policy.actor
        self.critic = self.policy.critic
        self.critic_target = self.policy.critic_target
        self.batch_norm_stats = get_parameters_by_name(self.critic, ["running_"])
        self.batch_norm_stats_target = get_parameters_by_name(self.critic_target, ["running_"])
        if self.offline_buffer is not None:
            self.load_offline_buffer(self.offline_buffer)

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "actor", "critic", "critic_target"]

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        return ["policy", "actor.optimizer", "critic.optimizer"], []

    # ---------------------------------------------------------------- losses

    def _min_q(self, critic: th.nn.Module, obs: th.Tensor, actions: th.Tensor) -> th.Tensor:
        return th.min(th.cat(critic(obs, actions), dim=1), dim=1, keepdim=True)[0]

    def actor_loss(self, observations: th.Tensor, actions: th.Tensor) -> tuple[th.Tensor, dict[str, th.Tensor]]:
        """``−mean[min(exp(A/λ), max_weight) · log π(a|s)]`` over buffer actions, and its parts.

        Returns the loss (differentiable in the actor only) and ``{"advantages", "weights",
        "log_prob", "q", "v"}``, each of shape ``(batch, 1)``.
        """
        with th.no_grad():
            q = self._min_q(self.critic, observations, actions)
            values = []
            for _ in range(self.n_value_samples):
                pi_actions, _ = self.actor.action_log_prob(observations)
                values.append(self._min_q(self.critic, observations, pi_actions))
            v = th.stack(values).mean(dim=0)
            advantages = q - v
            weights = advantage_weights(advantages, self.beta, self.max_weight)
        mean_actions, log_std, kwargs = self.actor.get_action_dist_params(observations)
        distribution = self.actor.action_dist.proba_distribution(mean_actions, log_std, **kwargs)
        log_prob = distribution.log_prob(actions).reshape(-1, 1)
        loss = -(weights * log_prob).mean()
        return loss, {"advantages": advantages, "weights": weights, "log_prob": log_prob.detach(), "q": q, "v": v}

    def critic_loss(self, replay_data: Any) -> th.Tensor:
        """½ Σ_j mean (Q_j(s, a) − y)², y the (soft) TD target with a' ~ π(·|s')."""
        discounts = getattr(replay_data, "discounts", None)
        discounts = self.gamma if discounts is None else discounts
        with th.no_grad():
            next_actions, next_log_prob = self.actor.action_log_prob(replay_data.next_observations)
            next_q = self._min_q(self.critic_target, replay_data.next_observations, next_actions)
            if self.ent_coef > 0:
                next_q = next_q - self.ent_coef * next_log_prob.reshape(-1, 1)
            target = replay_data.rewards + (1 - replay_data.dones) * discounts * next_q
        current = self.critic(replay_data.observations, replay_data.actions)
        loss = 0.5 * sum(F.mse_loss(q, target) for q in current)
        assert isinstance(loss, th.Tensor)  # a sum over at least one critic
        return loss

    # -------------------------------------------------------------- training

    def train(self, gradient_steps: int, batch_size: int = 64) -> None:
        self.policy.set_training_mode(True)
        self._update_learning_rate([self.actor.optimizer, self.critic.optimizer])
        actor_losses, critic_losses, weights_mean, weights_clipped = [], [], [], []
        for gradient_step in range(gradient_steps):
            replay_data = self.replay_buffer.sample(batch_size, env=self._vec_normalize_env)  # type: ignore[union-attr]
            if self.use_sde:  # fresh exploration matrix for the policy samples, as SAC
                self.actor.reset_noise()

            critic_loss = self.critic_loss(replay_data)
            self.critic.optimizer.zero_grad()
            critic_loss.backward()
            self.critic.optimizer.step()

            actor_loss, parts = self.actor_loss(replay_data.observations, replay_data.actions)
            self.actor.optimizer.zero_grad()
            actor_loss.backward()
            self.actor.optimizer.step()

            if gradient_step % self.target_update_interval == 0:
                polyak_update(self.critic.parameters(), self.critic_target.parameters(), self.tau)
                polyak_update(self.batch_norm_stats, self.batch_norm_stats_target, 1.0)

            critic_losses.append(float(critic_loss.item()))
            actor_losses.append(float(actor_loss.item()))
            weights_mean.append(float(parts["weights"].mean().item()))
            weights_clipped.append(float((parts["weights"] >= self.max_weight * (1 - 1e-6)).float().mean().item()))
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.record("train/actor_loss", np.mean(actor_losses))
        self.logger.record("train/critic_loss", np.mean(critic_losses))
        self.logger.record("train/adv_weight_mean", np.mean(weights_mean))
        self.logger.record("train/adv_weight_clipped_fraction", np.mean(weights_clipped))

    def pretrain(self, gradient_steps: int | None = None) -> int:
        """Gradient steps on the replay buffer alone (offline phase); returns how many ran.

        Without ``gradient_steps``: whatever of ``offline_steps`` is not done yet.
        """
        steps = self.offline_steps - self.offline_steps_done if gradient_steps is None else int(gradient_steps)
        if steps <= 0:
            return 0
        if self.replay_buffer is None or self.replay_buffer.size() == 0:
            raise ValueError(
                "offline pretraining needs a non-empty replay buffer (offline_buffer or load_replay_buffer)"
            )
        if not hasattr(self, "_logger"):  # before the first learn(): a logger that learn() will replace
            from stable_baselines3.common.utils import configure_logger

            self._logger = configure_logger(self.verbose, None, "AWAC", True)
        self.train(steps, batch_size=self.batch_size)
        self.offline_steps_done += steps if gradient_steps is None else 0
        return steps

    def learn(
        self: SelfAWAC,
        total_timesteps: int,
        callback: MaybeCallback = None,
        log_interval: int = 4,
        tb_log_name: str = "AWAC",
        reset_num_timesteps: bool = True,
        progress_bar: bool = False,
    ) -> SelfAWAC:
        if self.offline_steps_done < self.offline_steps:
            self.pretrain()
        return super().learn(
            total_timesteps=total_timesteps,
            callback=callback,
            log_interval=log_interval,
            tb_log_name=tb_log_name,
            reset_num_timesteps=reset_num_timesteps,
            progress_bar=progress_bar,
        )

    #: attributes a checkpoint carries across a resume besides SB3's counters
    resume_attributes: ClassVar[tuple[str, ...]] = ("offline_steps_done",)

    def load_offline_buffer(self, path: str | pathlib.Path) -> None:
        """Fill the replay buffer from ``path``: a pyflyt ``.npz`` (data only), or a pickle with ``trust_pickle``."""
        path = pathlib.Path(path)
        if path.suffix == ".npz":
            from pyflyt_cli.training.artifacts import load_replay_buffer

            load_replay_buffer(path, self.replay_buffer, exact=False)
            return
        if not self.trust_pickle:
            from pyflyt_cli.training.artifacts import PICKLE_RISK, ArtifactError

            raise ArtifactError(f"offline_buffer {path}: {PICKLE_RISK}")
        self.load_replay_buffer(path)

    def load_replay_buffer(self, path: str | pathlib.Path | io.BufferedIOBase, truncate_last_traj: bool = True) -> None:
        """SB3's (pickle) loader, with a clear error when the buffer does not match this env's spaces."""
        super().load_replay_buffer(path, truncate_last_traj)
        assert isinstance(self.action_space, spaces.Box)  # the one action space AWAC supports
        buffer = self.replay_buffer
        if buffer is not None and (
            buffer.obs_shape != self.observation_space.shape
            or buffer.action_dim != int(np.prod(self.action_space.shape))
        ):
            raise ValueError(
                f"replay buffer {path}: observations {buffer.obs_shape} / actions ({buffer.action_dim},) do not fit "
                f"this env's {self.observation_space.shape} / {self.action_space.shape}"
            )

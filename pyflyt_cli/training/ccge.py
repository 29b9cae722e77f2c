"""Critic Confidence Guided Exploration (CCGE) as a Stable-Baselines3 off-policy algorithm.

Tai, Terry, Innocente, Brusey & Horri (2022), "Some Supervision Required: Incorporating
Oracle Policies in Reinforcement Learning via Epistemic Uncertainty Metrics",
arXiv:2208.10533 (TMLR) — the algorithm the PyFlyt paper trains its sparse-reward tasks
with, "bootstrapping off a policy partially trained using SAC".

CCGE is SAC with an **oracle** policy π̄ whose actions are taken as suggestions where the
critic is unsure of the learning policy's:

* **Exploration rule.**  In state s, with the learning policy's action a ~ π(·|s) and the
  oracle's ā = π̄(s), the critic ensemble {Q_j} gives the normalised gap::

      u(s, a, ā) = ( max_j Q_j(s, ā) − min_j Q_j(s, a) ) / | mean_j Q_j(s, a) |

  (the *implicit* uncertainty of the paper: the ensemble's spread bounds how much better
  the oracle's action might be).  If u > λ (``confidence_lambda``) the oracle's action is
  executed (and stored), else the policy's.  :func:`oracle_switch` is this rule.
* **Learning.**  The critics learn as SAC's (soft TD with clipped double Q).  The actor
  minimises SAC's loss where the critic is confident and imitates the oracle where it is
  not (``supervise``)::

      L_π = mean[ (1 − w) (α log π(a|s) − min_j Q_j(s, a)) ] + mean[ w (a − ā)² ],
      w = 1[u(s, a, ā) > λ]   (no gradient through w),  a ~ π(·|s) reparameterised

**Bootstrapping** (the paper's setting): ``init_from=<a SAC run>`` loads that run's SAC
policy; its actor becomes both the oracle (frozen) and the learning actor's start, its
critics the critics' start (:meth:`CCGEPolicy.load_state_dict`).  ``pyflyt train``
refuses ``algo=ccge`` without ``init_from`` (:class:`~pyflyt_cli.training.schema.TrainConfig`):
the oracle would be the randomly initialised actor's copy, a pull towards a fixed random
policy where the critic is unsure, which CCGE is not meant for.  (Built directly from
Python without a loaded oracle, the class still behaves so.)

The oracle is part of the policy's state (``oracle.*`` tensors), so policy files and
checkpoints carry it and a resume is exact.  The explicit variant of the paper (a
learned uncertainty head trained by an uncertainty Bellman target) is not implemented.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
import torch as th
from stable_baselines3 import SAC
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.utils import polyak_update
from stable_baselines3.sac.policies import SACPolicy
from torch.nn import functional as F

#: default λ: the threshold of the normalised gap above which the oracle acts (the paper's
#: ``confidence_lambda`` default, 1.0)
DEFAULT_CONFIDENCE_LAMBDA = 1.0


def oracle_switch(q_policy: th.Tensor, q_oracle: th.Tensor, confidence_lambda: float) -> tuple[th.Tensor, th.Tensor]:
    """(switch, u): 1.0 where the oracle's action is to be used, and the normalised gap u.

    ``q_policy``, ``q_oracle``: (batch, n_critics) values of the critic ensemble at the
    learning policy's and the oracle's actions.  u = (max_j Q_j(s, ā) − min_j Q_j(s, a)) /
    |mean_j Q_j(s, a)| (a zero mean counts as tiny: the oracle acts), switch = 1[u > λ].
    """
    gap = q_oracle.max(dim=1, keepdim=True)[0] - q_policy.min(dim=1, keepdim=True)[0]
    scale = q_policy.mean(dim=1, keepdim=True).abs().clamp_min(th.finfo(q_policy.dtype).tiny)
    u = gap / scale
    return (u > confidence_lambda).to(q_policy.dtype), u


class CCGEPolicy(SACPolicy):
    """SAC's policy plus a frozen ``oracle`` actor of the same shape."""

    def _build(self, lr_schedule: Any) -> None:
        super()._build(lr_schedule)
        with th.random.fork_rng(devices=[]):  # its weights are copied: the streams stay SAC's
            self.oracle = self.make_actor(features_extractor=None)
        self.oracle.load_state_dict(self.actor.state_dict())
        self.oracle.requires_grad_(False)
        self.oracle.set_training_mode(False)

    def set_training_mode(self, mode: bool) -> None:
        self.actor.set_training_mode(mode)
        self.critic.set_training_mode(mode)
        self.training = mode

    def load_state_dict(self, state_dict: Any, strict: bool = True, assign: bool = False) -> Any:
        """A CCGE policy's state, or a SAC policy's: its actor then also becomes the oracle."""
        state = dict(state_dict)
        if not any(k.startswith("oracle.") for k in state):
            state.update({"oracle." + k[len("actor.") :]: v for k, v in state_dict.items() if k.startswith("actor.")})
        return super().load_state_dict(state, strict=strict, assign=assign)

    def oracle_action(self, observation: th.Tensor) -> th.Tensor:
        """The oracle's deterministic action (in the [-1, 1] units of the buffer)."""
        with th.no_grad():
            return self.oracle(observation, deterministic=True)


class CCGE(SAC):
    """Critic Confidence Guided Exploration (Tai et al. 2022) on SB3's SAC.

    Args (beyond :class:`~stable_baselines3.SAC`'s):
        confidence_lambda: λ; the oracle acts (and is imitated) where the critic ensemble's
            normalised gap u exceeds it.  Larger: the oracle is used less.
        supervise: add the imitation term on the oracle's actions to the actor loss where
            u > λ (the paper); false: the oracle only steers exploration.
    """

    policy_aliases: ClassVar[dict[str, type[BasePolicy]]] = {"MlpPolicy": CCGEPolicy}
    policy: CCGEPolicy

    def __init__(
        self,
        policy: Any,
        env: Any,
        confidence_lambda: float = DEFAULT_CONFIDENCE_LAMBDA,
        supervise: bool = True,
        **kwargs: Any,
    ) -> None:
        if not np.isfinite(confidence_lambda) or confidence_lambda < 0:
            raise ValueError(f"confidence_lambda must be a finite number >= 0, got {confidence_lambda}")
        self.confidence_lambda = float(confidence_lambda)
        self.supervise = bool(supervise)
        #: executed actions that were the oracle's, since the model was built (for the logs)
        self.oracle_actions = 0
        self.policy_actions = 0
        super().__init__(policy, env, **kwargs)

    #: attributes a checkpoint carries across a resume besides SB3's counters
    resume_attributes: ClassVar[tuple[str, ...]] = ("oracle_actions", "policy_actions")

    def _critic_values(self, obs: th.Tensor, actions: th.Tensor) -> th.Tensor:
        return th.cat(self.critic(obs, actions), dim=1)

    def switch(self, obs: th.Tensor, actions: th.Tensor, oracle: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """:func:`oracle_switch` with this model's critic ensemble and λ."""
        with th.no_grad():
            return oracle_switch(
                self._critic_values(obs, actions), self._critic_values(obs, oracle), self.confidence_lambda
            )

    def _sample_action(
        self, learning_starts: int, action_noise: Any = None, n_envs: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        """SAC's action, replaced by the oracle's where the critic is unsure (after the warm-up)."""
        warmup = self.num_timesteps < learning_starts
        action, buffer_action = super()._sample_action(learning_starts, action_noise, n_envs)
        if warmup:
            return action, buffer_action
        assert self._last_obs is not None  # set by the rollout collection that samples
        obs, _ = self.policy.obs_to_tensor(self._last_obs)
        assert isinstance(obs, th.Tensor)  # CCGE's one policy, MlpPolicy, sees a Box observation
        oracle = self.policy.oracle_action(obs)
        use, _ = self.switch(obs, th.as_tensor(buffer_action, dtype=oracle.dtype), oracle)
        chosen = use.cpu().numpy().astype(bool).reshape(-1)
        if chosen.any():
            buffer_action = buffer_action.copy()
            buffer_action[chosen] = oracle.cpu().numpy()[chosen]
            action = self.policy.unscale_action(buffer_action)
        self.oracle_actions += int(chosen.sum())
        self.policy_actions += int((~chosen).sum())
        return action, buffer_action

    def train(self, gradient_steps: int, batch_size: int = 64) -> None:
        """SAC's update with the actor loss of CCGE (see the module docstring)."""
        self.policy.set_training_mode(True)
        optimizers = [self.actor.optimizer, self.critic.optimizer]
        if self.ent_coef_optimizer is not None:
            optimizers.append(self.ent_coef_optimizer)
        self._update_learning_rate(optimizers)
        actor_losses, critic_losses, ent_coefs, switched = [], [], [], []
        for gradient_step in range(gradient_steps):
            data = self.replay_buffer.sample(batch_size, env=self._vec_normalize_env)  # type: ignore[union-attr]
            discounts = getattr(data, "discounts", None)
            discounts = self.gamma if discounts is None else discounts
            if self.use_sde:
                self.actor.reset_noise()
            actions_pi, log_prob = self.actor.action_log_prob(data.observations)
            log_prob = log_prob.reshape(-1, 1)

            if self.ent_coef_optimizer is not None and self.log_ent_coef is not None:
                ent_coef = th.exp(self.log_ent_coef.detach())
                assert isinstance(self.target_entropy, float)  # made a number by SAC's _setup_model
                ent_loss = -(self.log_ent_coef * (log_prob + self.target_entropy).detach()).mean()
                self.ent_coef_optimizer.zero_grad()
                ent_loss.backward()
                self.ent_coef_optimizer.step()
            else:
                ent_coef = self.ent_coef_tensor
            ent_coefs.append(float(ent_coef.item()))

            with th.no_grad():
                next_actions, next_log_prob = self.actor.action_log_prob(data.next_observations)
                next_q = th.cat(self.critic_target(data.next_observations, next_actions), dim=1).min(
                    dim=1, keepdim=True
                )[0]
                next_q = next_q - ent_coef * next_log_prob.reshape(-1, 1)
                target_q = data.rewards + (1 - data.dones) * discounts * next_q
            current = self.critic(data.observations, data.actions)
            critic_loss = 0.5 * sum(F.mse_loss(q, target_q) for q in current)
            self.critic.optimizer.zero_grad()
            critic_loss.backward()  # type: ignore[union-attr]
            self.critic.optimizer.step()

            q_pi = self._critic_values(data.observations, actions_pi)
            rl_loss = ent_coef * log_prob - q_pi.min(dim=1, keepdim=True)[0]
            if self.supervise:
                oracle = self.policy.oracle_action(data.observations)
                weight, _ = self.switch(data.observations, actions_pi.detach(), oracle)
                imitation = (actions_pi - oracle).pow(2).mean(dim=1, keepdim=True)
                actor_loss = ((1 - weight) * rl_loss).mean() + (weight * imitation).mean()
                switched.append(float(weight.mean().item()))
            else:
                actor_loss = rl_loss.mean()
            self.actor.optimizer.zero_grad()
            actor_loss.backward()
            self.actor.optimizer.step()

            if gradient_step % self.target_update_interval == 0:
                polyak_update(self.critic.parameters(), self.critic_target.parameters(), self.tau)
                polyak_update(self.batch_norm_stats, self.batch_norm_stats_target, 1.0)
            actor_losses.append(float(actor_loss.item()))
            critic_losses.append(float(critic_loss.item()))  # type: ignore[union-attr]
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.record("train/ent_coef", np.mean(ent_coefs))
        self.logger.record("train/actor_loss", np.mean(actor_losses))
        self.logger.record("train/critic_loss", np.mean(critic_losses))
        if switched:
            self.logger.record("train/oracle_supervised_fraction", np.mean(switched))
        total = self.oracle_actions + self.policy_actions
        if total:
            self.logger.record("rollout/oracle_action_fraction", self.oracle_actions / total)

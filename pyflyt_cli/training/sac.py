"""Soft Actor-Critic as Stable-Baselines3 computes it, with cheaper gradient steps.

``algo=sac`` trains this class: SB3's :class:`~stable_baselines3.SAC` (Haarnoja et al. 2018,
arXiv:1801.01290, with the automatic entropy tuning of arXiv:1812.05905) whose
:meth:`SAC.train` performs the same operations as SB3's (version 2.x), in the same order, on
the same tensors, drawing the same random numbers: the same seed and configuration give the
same weights, optimiser states and logged losses bit for bit
(``tests/train/test_sac_updates.py`` compares it with SB3's class and with a run recorded
before it existed).  On SAC's small networks an update's time is the matrix products of the
networks' forward and backward passes and the Python around them
(``experiments/sac_update_cost.py``); what this class leaves out is work whose result
nothing reads:

* **The critics' weight gradients of the actor's loss.**  The actor's loss evaluates the
  critics at the policy's actions.  Its backward pass needs the critics' gradient with
  respect to those actions only; SB3 also lets it accumulate the critics' weight gradients,
  which the next critic update throws away (``zero_grad`` before its own backward).  Here
  the critics' parameters do not require gradients while that loss is built, so autograd
  skips those products; the action gradients are the same kernels on the same operands.
* **The Polyak update's Python.**  The target critics move towards the critics with one
  ``_foreach_mul_`` and one ``_foreach_add_`` over parameter lists built once per call of
  :meth:`train`, instead of two operations per tensor over ``parameters()`` generators
  rebuilt at every gradient step: per tensor, the same multiply and the same add with
  ``alpha``.

What stays as SB3 has it: sampling (SB3's ``ReplayBuffer`` / ``NStepReplayBuffer``, whose
n-step returns are already vectorised), the losses, the optimisers (Adam, one tensor at a
time), the logged means of the per-step losses.  The pinned kernels
(``pyflyt_engine/numerics.py``) are untouched: they are what makes these numbers the same
on every AVX2 CPU, and their matrix products are most of what an update costs.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence

import numpy as np
import torch as th
from stable_baselines3 import SAC as _SB3SAC
from stable_baselines3.common.utils import polyak_update
from torch.nn import functional as F


@contextlib.contextmanager
def _frozen(params: Sequence[th.Tensor]) -> Iterator[None]:
    """``params`` (tensors that require gradients) do not inside the block: a graph built
    there computes no gradient for them."""
    for p in params:
        p.requires_grad_(False)
    try:
        yield
    finally:
        for p in params:
            p.requires_grad_(True)


def _polyak(params: list[th.Tensor], targets: list[th.Tensor], tau: float) -> None:
    """``target <- (1 - tau) target + tau param`` for each pair, in place: SB3's ``polyak_update``
    (an in-place multiply, then an add with ``alpha=tau`` into the target) over all tensors at once."""
    if not params:
        return
    with th.no_grad():
        th._foreach_mul_(targets, 1 - tau)
        th._foreach_add_(targets, params, alpha=tau)


class SAC(_SB3SAC):
    """SB3's SAC with cheaper gradient steps and the same numbers (see the module docstring)."""

    def train(self, gradient_steps: int, batch_size: int = 64) -> None:
        self.policy.set_training_mode(True)  # batch norm / dropout, where a policy has them
        optimizers = [self.actor.optimizer, self.critic.optimizer]
        if self.ent_coef_optimizer is not None:
            optimizers.append(self.ent_coef_optimizer)
        self._update_learning_rate(optimizers)

        critic_params: list[th.Tensor] = list(self.critic.parameters())
        trained = [p for p in critic_params if p.requires_grad]
        target_params: list[th.Tensor] = list(self.critic_target.parameters())
        if len(target_params) != len(critic_params):  # SB3's polyak_update refuses it too (zip strict)
            raise ValueError(f"the critic has {len(critic_params)} parameter tensors, its target {len(target_params)}")

        ent_coef_losses: list[float] = []
        ent_coefs: list[float] = []
        actor_losses: list[float] = []
        critic_losses: list[float] = []
        for gradient_step in range(gradient_steps):
            data = self.replay_buffer.sample(batch_size, env=self._vec_normalize_env)  # type: ignore[union-attr]
            # n-step returns: the buffer gives each sample's discount (gamma ** steps taken)
            discounts = data.discounts if data.discounts is not None else self.gamma
            if self.use_sde:  # log_std may have changed since the last noise
                self.actor.reset_noise()

            actions_pi, log_prob = self.actor.action_log_prob(data.observations)
            log_prob = log_prob.reshape(-1, 1)

            ent_coef_loss = None
            if self.ent_coef_optimizer is not None and self.log_ent_coef is not None:
                ent_coef = th.exp(self.log_ent_coef.detach())  # no gradient into the other losses
                assert isinstance(self.target_entropy, float)
                ent_coef_loss = -(self.log_ent_coef * (log_prob + self.target_entropy).detach()).mean()
                ent_coef_losses.append(ent_coef_loss.item())
            else:
                ent_coef = self.ent_coef_tensor
            ent_coefs.append(ent_coef.item())
            if ent_coef_loss is not None and self.ent_coef_optimizer is not None:
                self.ent_coef_optimizer.zero_grad()
                ent_coef_loss.backward()
                self.ent_coef_optimizer.step()

            with th.no_grad():  # the soft TD target: clipped double Q at the next state's action
                next_actions, next_log_prob = self.actor.action_log_prob(data.next_observations)
                next_q = th.cat(self.critic_target(data.next_observations, next_actions), dim=1)
                next_q, _ = th.min(next_q, dim=1, keepdim=True)
                next_q = next_q - ent_coef * next_log_prob.reshape(-1, 1)
                target_q = data.rewards + (1 - data.dones) * discounts * next_q

            current_q = self.critic(data.observations, data.actions)
            critic_loss = 0.5 * sum(F.mse_loss(q, target_q) for q in current_q)
            assert isinstance(critic_loss, th.Tensor)
            critic_losses.append(critic_loss.item())
            self.critic.optimizer.zero_grad()
            critic_loss.backward()
            self.critic.optimizer.step()

            with _frozen(trained):  # the actor's loss needs the critics' action gradients only
                q_pi = th.cat(self.critic(data.observations, actions_pi), dim=1)
            min_q_pi, _ = th.min(q_pi, dim=1, keepdim=True)
            actor_loss = (ent_coef * log_prob - min_q_pi).mean()
            actor_losses.append(actor_loss.item())
            self.actor.optimizer.zero_grad()
            actor_loss.backward()
            self.actor.optimizer.step()

            if gradient_step % self.target_update_interval == 0:
                _polyak(critic_params, target_params, self.tau)
                # batch norm's running statistics are copied, as SB3 does (its issue #996)
                polyak_update(self.batch_norm_stats, self.batch_norm_stats_target, 1.0)

        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.record("train/ent_coef", np.mean(ent_coefs))
        self.logger.record("train/actor_loss", np.mean(actor_losses))
        self.logger.record("train/critic_loss", np.mean(critic_losses))
        if ent_coef_losses:
            self.logger.record("train/ent_coef_loss", np.mean(ent_coef_losses))

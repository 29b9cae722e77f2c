"""Running a trained policy for whole episodes: returns, lengths, success.

Shared by the periodic evaluation during training and by ``pyflyt eval``, so both report
the same numbers for the same seeds.  Episode ``i`` starts from ``reset(seed=seed + i)``:
each episode can be reproduced on its own.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: evaluation episodes use seeds ``run seed + EVAL_SEED_OFFSET + i`` unless told otherwise
EVAL_SEED_OFFSET = 1000


@dataclass(frozen=True)
class Episode:
    """One evaluation episode."""

    seed: int
    #: undiscounted sum of rewards
    ret: float
    #: agent steps
    length: int
    #: the env's ``info["success"]`` at the last step
    success: bool
    #: the last step's ``info`` (reward terms, collision, ...)
    final_info: dict[str, Any] = field(default_factory=dict, repr=False)


def run_episodes(
    predict: Callable[[np.ndarray, bool], np.ndarray],
    env: Any,
    episodes: int,
    seed: int,
    deterministic: bool = True,
    normalize_obs: Callable[[np.ndarray], np.ndarray] | None = None,
    on_step: Callable[[Any, int], None] | None = None,
    on_reset: Callable[[Any, int], None] | None = None,
) -> list[Episode]:
    """Run ``episodes`` episodes of ``env`` (a Gymnasium env wrapped for the agent).

    Args:
        predict: ``(observation, deterministic) -> action``, e.g. a bound ``model.predict``
            that drops the state.
        env: the environment (see :func:`pyflyt_cli.training.envs.wrap_for_agent`).
        episodes: number of episodes.
        seed: episode ``i`` is reset with ``seed + i``.
        deterministic: pass to ``predict``.
        normalize_obs: observation normalisation the policy was trained with (``VecNormalize``).
        on_step: called as ``on_step(env, episode_index)`` after every step (video frames,
            custom measurements).
        on_reset: called as ``on_reset(env, episode_index)`` after every reset.
    """
    results = []
    for i in range(episodes):
        obs, info = env.reset(seed=seed + i)
        if hasattr(predict, "reset"):  # a recurrent policy starts each episode from a blank memory
            predict.reset()
        total, length, done = 0.0, 0, False
        if on_reset is not None:
            on_reset(env, i)
        while not done:
            x = normalize_obs(obs) if normalize_obs is not None else obs
            action = predict(x, deterministic)
            obs, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            length += 1
            done = terminated or truncated
            if on_step is not None:
                on_step(env, i)
        results.append(Episode(seed + i, total, length, bool(info.get("success", False)), dict(info)))
    return results


def summarize(episodes: list[Episode]) -> dict[str, float]:
    """``mean_return``, ``std_return``, ``success_rate``, ``mean_length`` (the ``/eval`` record)."""
    returns = np.array([e.ret for e in episodes], dtype=np.float64)
    return {
        "mean_return": float(returns.mean()),
        "std_return": float(returns.std()),
        "success_rate": float(np.mean([e.success for e in episodes])),
        "mean_length": float(np.mean([e.length for e in episodes])),
    }


def policy_predict(model: Any) -> Callable[[np.ndarray, bool], np.ndarray]:
    """``(obs, deterministic) -> action`` of an SB3 model.

    A recurrent policy (sb3-contrib ``RecurrentPPO``) carries its LSTM state from step to
    step; the returned callable then has a ``reset()`` that :func:`run_episodes` calls at
    every episode start.
    """
    if getattr(model, "_last_lstm_states", None) is not None or hasattr(model.policy, "lstm_actor"):
        return _RecurrentPredict(model)

    def predict(obs: np.ndarray, deterministic: bool) -> np.ndarray:
        action, _ = model.predict(obs, deterministic=deterministic)
        return action

    return predict


class _RecurrentPredict:
    """A recurrent policy's actions along one episode: its state carried, reset per episode."""

    def __init__(self, model: Any) -> None:
        self.model = model
        self.state: Any = None
        self.episode_start = np.ones((1,), dtype=bool)

    def reset(self) -> None:
        self.state = None
        self.episode_start = np.ones((1,), dtype=bool)

    def __call__(self, obs: np.ndarray, deterministic: bool) -> np.ndarray:
        action, self.state = self.model.predict(
            obs, state=self.state, episode_start=self.episode_start, deterministic=deterministic
        )
        self.episode_start = np.zeros((1,), dtype=bool)
        return action

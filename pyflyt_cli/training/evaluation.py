"""Running a trained policy for whole episodes: returns, lengths, success, the task's measures.

Shared by the periodic evaluation during training and by ``pyflyt eval``, so both report
the same numbers for the same seeds.  Episode ``i`` starts from ``reset(seed=seed + i)``:
each episode can be reproduced on its own.

Beside the return, every episode carries the task's success measures (``info["measures"]``
of its last step, declared by the task: :mod:`pyflyt_engine.envs.tasks.measures`) and why
it ended; :func:`summarize_measures` combines the measures over the episodes and
:func:`disagreement` says where the return and the success verdict rank episodes
differently.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeAlias

import numpy as np

from pyflyt_engine.envs.tasks.measures import INFO_KEY as MEASURES
from pyflyt_engine.envs.tasks.measures import Measure
from pyflyt_engine.envs.tasks.measures import summarize_measures as combine_measures

#: an observation: one array, or the entries of a Dict observation space
Observation: TypeAlias = np.ndarray | dict[str, np.ndarray]
#: ``obs -> normalised obs``: the observation normalisation a policy was trained with
ObsNormalizer: TypeAlias = Callable[[Observation], Observation]

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
    #: the task's success measures of the episode (``info["measures"]`` of its last step)
    measures: dict[str, float] = field(default_factory=dict)
    #: why it ended: ``complete``, ``time_limit``, ``collision``, ``out_of_bounds``, ``failed``
    end: str = ""


def run_episodes(
    predict: Callable[[Any, bool], np.ndarray],
    env: Any,
    episodes: int,
    seed: int,
    deterministic: bool = True,
    normalize_obs: ObsNormalizer | None = None,
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
    from pyflyt_engine.telemetry.recorder import end_reason

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
        measures = {str(k): float(v) for k, v in (info.get(MEASURES) or {}).items()}
        reason = end_reason(bool(terminated), bool(truncated), info)
        results.append(Episode(seed + i, total, length, bool(info.get("success", False)), dict(info), measures, reason))
    return results


def env_measures(env: Any) -> tuple[Measure, ...]:
    """The success measures the env's task declares (none for an env without them)."""
    return tuple(getattr(getattr(env, "unwrapped", env), "measures", ()) or ())


def summarize_measures(measures: tuple[Measure, ...], episodes: list[Episode]) -> dict[str, float]:
    """The declared ``measures`` combined over ``episodes`` (see
    :func:`pyflyt_engine.envs.tasks.measures.summarize_measures`)."""
    return combine_measures(measures, [e.measures for e in episodes])


#: what an episode's end reason is called in the printed report
END_WORDS = {
    "complete": "task complete",
    "time_limit": "time limit",
    "collision": "crashed (contact)",
    "out_of_bounds": "left the flight dome",
    "failed": "failed (the task's verdict)",
    "": "-",
}


def disagreement(episodes: list[Episode]) -> str | None:
    """A sentence when the return ranks a failed episode above a successful one (the
    return pays for more than the outcome, e.g. a proximity term over a longer episode);
    None when the two agree."""
    wins = [e for e in episodes if e.success]
    fails = [e for e in episodes if not e.success]
    if not wins or not fails:
        return None
    best_fail = max(fails, key=lambda e: e.ret)
    worst_win = min(wins, key=lambda e: e.ret)
    if best_fail.ret <= worst_win.ret:
        return None
    index = episodes.index(best_fail)
    top = max(episodes, key=lambda e: e.ret)
    lead = "the highest return" if top is best_fail else "a higher return than a success"
    successes = f"{worst_win.ret:.2f}" if len(wins) == 1 else f"{worst_win.ret:.2f} to {max(e.ret for e in wins):.2f}"
    longest_win = max(e.length for e in wins)
    why = (
        f"it flew longer ({best_fail.length} steps, successes {min(e.length for e in wins)}-{longest_win}) and "
        "the return adds reward up over the steps flown"
        if best_fail.length > longest_win
        else "the return pays for more than the outcome (e.g. for approaching the targets along the way)"
    )
    return (
        f"return and success disagree: episode {index} has {lead} ({best_fail.ret:.2f}) but is not a success "
        f"({END_WORDS.get(best_fail.end, best_fail.end)}), while the successes score {successes}: {why}; "
        "the success is the task's verdict on the outcome"
    )


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

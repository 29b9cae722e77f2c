"""The cross-cutting parts of a training run, as Stable-Baselines3 callbacks.

* :class:`StopOnRequest` — Ctrl-C / SIGTERM end ``learn()`` at the next step boundary.
* :class:`EpisodeMetrics` — every finished training episode → ``/train/episode``.
* :class:`PeriodicEvaluation` — every ``eval_freq`` steps: N episodes on a separate env →
  ``/eval``, ``best_model.zip``; runs child callbacks (stop on reward ...) after each.
* :class:`Checkpointer` — every ``checkpoint_freq`` steps, at a rollout boundary: model,
  replay buffer, normalisation statistics, then ``state.json``.
* :class:`ProgressBar` — tqdm with steps/s and ETA.

Checkpoints are taken at the start of a rollout (right after the previous update), where
the step counter, the weights, the optimiser and the replay buffer agree: a run resumed
from one ends at the same step count as a run never interrupted.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, EventCallback

from pyflyt_cli.training import rundir
from pyflyt_cli.training.evaluation import policy_predict, run_episodes, summarize


class StopRequest:
    """A flag set by a signal handler; checked by :class:`StopOnRequest` at every step."""

    def __init__(self) -> None:
        self.requested = False
        self.signal_name = ""

    def request(self, name: str) -> None:
        self.requested = True
        self.signal_name = name


class StopOnRequest(BaseCallback):
    """End ``learn()`` cleanly once a stop is requested; remembers where the rollout started."""

    def __init__(self, stop: StopRequest) -> None:
        super().__init__()
        self.stop = stop
        self.rollout_start_step = 0

    def _on_training_start(self) -> None:
        self.rollout_start_step = self.model.num_timesteps

    def _on_rollout_start(self) -> None:
        self.rollout_start_step = self.model.num_timesteps

    def _on_step(self) -> bool:
        return not self.stop.requested


class EpisodeMetrics(BaseCallback):
    """Log ``/train/episode`` {return, length, success} for every finished training episode."""

    def __init__(self, writer: Any) -> None:
        super().__init__()
        self.writer = writer
        self.recent: list[float] = []

    def _on_step(self) -> bool:
        for info in self.locals.get("infos", ()):
            episode = info.get("episode")
            if episode is not None:
                values = {"return": float(episode["r"]), "length": int(episode["l"])}
                if "success" in episode:
                    values["success"] = bool(episode["success"])
                self.writer.log("/train/episode", self.model.num_timesteps, values)
                self.recent = (self.recent + [values["return"]])[-20:]
        return True


def save_model_files(model: Any, model_path: Path, vecnorm_path: Path | None, buffer_path: Path | None = None) -> None:
    """Save the model (and VecNormalize statistics, replay buffer) through temporary names."""
    tmp = model_path.with_name(f".tmp{os.getpid()}.{model_path.name}")
    model.save(tmp)
    os.replace(tmp, model_path)
    env = model.get_vec_normalize_env()
    if vecnorm_path is not None and env is not None:
        tmp = vecnorm_path.with_name(f".tmp{os.getpid()}.{vecnorm_path.name}")
        env.save(tmp)
        os.replace(tmp, vecnorm_path)
    if buffer_path is not None:
        tmp = buffer_path.with_name(f".tmp{os.getpid()}.{buffer_path.name}")
        model.save_replay_buffer(tmp)
        os.replace(tmp, buffer_path)


class PeriodicEvaluation(EventCallback):
    """Evaluate every ``eval_freq`` environment steps; keep the best model.

    Attributes ``best_mean_reward`` and ``last_mean_reward`` follow SB3's ``EvalCallback``,
    so SB3's ``StopTrainingOnRewardThreshold`` and ``StopTrainingOnNoModelImprovement`` work
    as child callbacks.
    """

    def __init__(
        self,
        env: Any,
        run_dir: Path,
        writer: Any,
        eval_freq: int,
        episodes: int,
        seed: int,
        deterministic: bool,
        next_eval: int,
        best_mean_reward: float = -np.inf,
        best_step: int | None = None,
        callback_after_eval: BaseCallback | None = None,
        log: Any = None,
        total: int | None = None,
    ) -> None:
        super().__init__(callback_after_eval, verbose=0)
        self.log = log
        self.total = total
        self.env = env
        self.run_dir = run_dir
        self.writer = writer
        self.eval_freq = eval_freq
        self.episodes = episodes
        self.seed = seed
        self.deterministic = deterministic
        self.next_eval = next_eval
        self.best_mean_reward = best_mean_reward
        self.best_step = best_step
        self.last_mean_reward = -np.inf
        self.last: dict[str, float] | None = None
        self.last_step: int | None = None
        self._started = time.perf_counter()
        self._start_steps = 0

    def _on_training_start(self) -> None:
        super()._on_training_start()
        self._started = time.perf_counter()
        self._start_steps = self.model.num_timesteps

    def _on_step(self) -> bool:
        if self.eval_freq > 0 and self.num_timesteps >= self.next_eval:
            while self.next_eval <= self.num_timesteps:
                self.next_eval += self.eval_freq
            return self.evaluate()
        return True

    def evaluate(self) -> bool:
        """Run the evaluation now; returns False if a child callback asks to stop."""
        step = self.model.num_timesteps
        vec = self.model.get_vec_normalize_env()
        episodes = run_episodes(
            policy_predict(self.model),
            self.env,
            self.episodes,
            self.seed,
            self.deterministic,
            normalize_obs=vec.normalize_obs if vec is not None and vec.norm_obs else None,
        )
        summary = summarize(episodes)
        self.writer.log("/eval", step, summary)
        elapsed = time.perf_counter() - self._started
        trained = step - self._start_steps
        self.writer.log(
            "/train/progress",
            step,
            {"elapsed": elapsed, "steps_per_second": trained / elapsed if elapsed > 0 else 0.0},
        )
        self.last, self.last_step = summary, step
        self.last_mean_reward = summary["mean_return"]
        if self.log is not None:
            of = f"/{self.total}" if self.total else ""
            self.log(
                f"step {step}{of}: eval return {summary['mean_return']:.2f} ± {summary['std_return']:.2f}, "
                f"success {100 * summary['success_rate']:.0f} %, length {summary['mean_length']:.0f} "
                f"({trained / elapsed if elapsed > 0 else 0:.0f} steps/s)"
            )
        if summary["mean_return"] > self.best_mean_reward:
            self.best_mean_reward = summary["mean_return"]
            self.best_step = step
            save_model_files(self.model, self.run_dir / rundir.BEST_MODEL, self.run_dir / rundir.BEST_VECNORM)
        if self.callback is not None:
            return self.callback.on_step()
        return True


class Checkpointer(BaseCallback):
    """Save a checkpoint at the first rollout start at or after every ``checkpoint_freq`` steps."""

    def __init__(self, run: Any, freq: int, next_checkpoint: int) -> None:
        super().__init__()
        self.run = run
        self.freq = freq
        self.next_checkpoint = next_checkpoint

    def _on_rollout_start(self) -> None:
        if self.freq > 0 and self.model.num_timesteps >= self.next_checkpoint:
            while self.next_checkpoint <= self.model.num_timesteps:
                self.next_checkpoint += self.freq
            self.run.save_checkpoint(self.model)

    def _on_step(self) -> bool:
        return True


class ProgressBar(BaseCallback):
    """A tqdm bar over the run's total steps: steps/s, elapsed, ETA, recent mean return."""

    def __init__(self, total: int, episode_metrics: EpisodeMetrics | None = None) -> None:
        super().__init__()
        self.total = total
        self.episode_metrics = episode_metrics
        self.bar: Any = None
        self._shown = 0
        self._last_postfix = 0.0

    def _on_training_start(self) -> None:
        from tqdm import tqdm

        self._shown = self.model.num_timesteps
        self.bar = tqdm(
            total=self.total, initial=self._shown, unit="step", unit_scale=True, dynamic_ncols=True, smoothing=0.05
        )

    def _on_step(self) -> bool:
        now = self.model.num_timesteps
        if now > self._shown:
            self.bar.update(now - self._shown)
            self._shown = now
        if (
            self.episode_metrics is not None
            and self.episode_metrics.recent
            and time.monotonic() - self._last_postfix > 1
        ):
            self._last_postfix = time.monotonic()
            self.bar.set_postfix_str(f"return {np.mean(self.episode_metrics.recent):.1f}", refresh=False)
        return True

    def _on_training_end(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

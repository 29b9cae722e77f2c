"""The cross-cutting parts of a training run, as Stable-Baselines3 callbacks.

* :class:`RunCallbacks` — the run's callbacks; ends ``learn()`` right after the
  checkpoint a stop request (Ctrl-C / SIGTERM) asked for.
* :class:`ResumeStreams` — after a resume, puts the random streams back at the first
  rollout start (where they were captured).
* :class:`EpisodeMetrics` — every finished training episode → ``/train/episode``.
* :class:`TaskCurriculum` — ``train.curriculum``: the task option values training
  episodes start with, moved towards the configured ones → ``/train/curriculum``.
* :class:`PeriodicEvaluation` — every ``eval_freq`` steps: N episodes on a separate env →
  ``/eval``, ``best_model.pt``; runs child callbacks (stop on reward ...) after each.
* :class:`Checkpointer` — every ``checkpoint_freq`` steps and on a stop request, at a
  rollout start: a checkpoint (see :mod:`pyflyt_cli.training.continuity`).
* :class:`ProgressBar` — tqdm with steps/s and ETA (on a terminal; elsewhere
  :class:`~pyflyt_cli.training.timing.ProgressLines`).

Checkpoints are taken at the start of a rollout (right after the previous update, before
the next action is chosen), where everything the continuation depends on can be
captured: a run resumed from one continues exactly as the uninterrupted run did.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, EventCallback

from pyflyt_cli.training import rundir
from pyflyt_cli.training.artifacts import save_policy
from pyflyt_cli.training.evaluation import env_measures, policy_predict, run_episodes, summarize, summarize_measures
from pyflyt_engine.errors import ConfigError


class StopRequest:
    """A request to end the run: the next rollout start saves a checkpoint, then ``learn()`` ends.

    ``final``: the run is complete there (an after-evaluation callback such as
    ``stop_on_reward`` decided it); otherwise (a signal) it is interrupted, to be resumed.
    """

    def __init__(self) -> None:
        self.requested = False
        self.final = False
        self.reason = ""
        #: the step of the checkpoint saved for the request, once saved
        self.saved_at: int | None = None

    def request(self, reason: str, *, final: bool = False) -> None:
        self.requested = True
        self.final = self.final or final
        self.reason = self.reason or reason


class RunCallbacks(CallbackList):
    """A run's callbacks; once the checkpoint a stop request asked for is saved, ``learn()`` ends
    at the next step and no callback runs again (nothing is logged past the checkpoint)."""

    def __init__(self, callbacks: list[BaseCallback], stop: StopRequest) -> None:
        super().__init__(callbacks)
        self.stop = stop

    def _on_step(self) -> bool:
        if self.stop.saved_at is not None:
            return False
        return super()._on_step()


class ResumeStreams(BaseCallback):
    """After a resume: put the random streams, action noise and gSDE noise back at the first
    rollout start, where the checkpoint captured them (first in the callback list)."""

    def __init__(self, state: dict[str, Any], tensors: dict[str, Any]) -> None:
        super().__init__()
        self.pending: tuple[dict[str, Any], dict[str, Any]] | None = (state, tensors)

    def _on_rollout_start(self) -> None:
        if self.pending is not None:
            from pyflyt_cli.training.continuity import restore_streams

            restore_streams(self.model, *self.pending)
            self.pending = None

    def _on_step(self) -> bool:
        return True


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


class TaskCurriculum(BaseCallback):
    """Move task options from a start value to the configured one as training goes on.

    For each option of ``train.curriculum`` the value at schedule step ``t`` is
    ``start + (configured - start) * stage / 100`` with ``stage = min(100, 100 * t // steps)``
    (a vector option element by element):
    100 equal stages, so the training envs are told (``set_task_changes`` of
    :class:`~pyflyt_cli.training.envs.EpisodeTaskOptions`) at most 100 times, and only
    episodes that start afterwards fly the new value.  Evaluation envs are not touched:
    they always fly the configured task.

    Without a ``gate`` the schedule step is the environment step count: the value is a
    function of the step count alone, and a resumed run continues the same schedule.  With
    ``gate: g`` the option's schedule counts the environment steps of a vector step only
    while at least ``g`` of the last ``gate_episodes`` finished training episodes succeeded
    (their ``info["episode"]["success"]``, at the values they flew; fewer finished episodes
    than that: closed).  At step 0 it is closed, so the option holds its start value until
    the agents succeed with it, and it pauses wherever they stop succeeding.  That count and
    the latest outcomes are part of every checkpoint (:meth:`state_dict`), so a resumed run
    continues exactly where the uninterrupted one was.

    Args:
        curriculum: option -> :class:`~pyflyt_cli.training.schema.CurriculumOption`.
        configured: option -> the env config's value (where the schedule ends).
        writer: the run's metrics writer (``/train/curriculum`` at every change), or None.
    """

    STAGES = 100

    def __init__(self, curriculum: dict[str, Any], configured: dict[str, Any], writer: Any = None) -> None:
        super().__init__()
        self.curriculum = curriculum
        self.configured = configured
        self.writer = writer
        self._stages: tuple[int, ...] | None = None
        #: gated option -> environment steps its schedule has counted
        self.progress: dict[str, int] = {n: 0 for n, c in curriculum.items() if getattr(c, "gate", None) is not None}
        #: the latest finished training episodes' successes, oldest first (as many as the widest gate looks at)
        self.outcomes: list[bool] = []
        self._window = max((curriculum[n].gate_episodes for n in self.progress), default=0)
        self._last_step = 0

    def schedule_steps(self, step: int) -> tuple[int, ...]:
        """Each option's position on its schedule at environment step ``step``."""
        return tuple(self.progress.get(name, int(step)) for name in self.curriculum)

    def stages(self, step: int) -> tuple[int, ...]:
        return tuple(
            min(self.STAGES, self.STAGES * t // c.steps)
            for t, c in zip(self.schedule_steps(step), self.curriculum.values())
        )

    def finished(self, step: int) -> bool:
        """Whether every option has reached its configured value at ``step``."""
        return all(stage == self.STAGES for stage in self.stages(step))

    def changes_at(self, step: int) -> dict[str, Any]:
        """The option values of the episodes that start at ``step`` (configured ones left out)."""
        changes: dict[str, Any] = {}
        for (name, c), stage in zip(self.curriculum.items(), self.stages(step)):
            if stage < self.STAGES:
                end, f = self.configured[name], stage / self.STAGES
                if isinstance(c.start, list):
                    changes[name] = [a + (float(b) - a) * f for a, b in zip(c.start, end)]
                else:
                    changes[name] = c.start + (float(end) - c.start) * f
        return changes

    def apply(self, vec_env: Any, step: int) -> None:
        """Tell the training envs the values of ``step`` (before ``learn()``: its first resets use them)."""
        self._stages = self.stages(step)
        self._last_step = int(step)
        changes = self.changes_at(step)
        vec_env.env_method("set_task_changes", changes)
        if self.writer is not None:
            values: dict[str, float] = {}
            for name in self.curriculum:
                value = changes.get(name, self.configured[name])
                if isinstance(value, (list, tuple)):
                    values.update({f"{name}[{i}]": float(v) for i, v in enumerate(value)})
                else:
                    values[name] = float(value)
            self.writer.log("/train/curriculum", int(step), values)

    def gate_open(self, name: str) -> bool:
        """Whether option ``name``'s gate counts steps now."""
        c = self.curriculum[name]
        recent = self.outcomes[-c.gate_episodes :]
        return len(recent) >= c.gate_episodes and sum(recent) >= c.gate * c.gate_episodes

    def _count(self) -> None:
        """A vector step of the gated schedules: its finished episodes recorded, then its steps counted."""
        for info in self.locals.get("infos", ()):
            episode = info.get("episode")
            if episode is None:
                continue
            if "success" not in episode:
                raise ConfigError(
                    "train.curriculum: a gated option (gate:) needs the training episodes' success, and this "
                    "env's episodes do not report one; remove gate: to follow the step count"
                )
            self.outcomes.append(bool(episode["success"]))
        del self.outcomes[: -self._window]
        steps = int(self.model.num_timesteps) - self._last_step
        for name in self.progress:
            if self.gate_open(name):
                self.progress[name] += steps

    def _on_step(self) -> bool:
        if self.progress:
            self._count()
        self._last_step = int(self.model.num_timesteps)
        if self.stages(self.model.num_timesteps) != self._stages:
            self.apply(self.training_env, self.model.num_timesteps)
        return True

    def state_dict(self) -> dict[str, Any]:
        """What a checkpoint keeps of the gated schedules (empty without a gate)."""
        if not self.progress:
            return {}
        return {"progress": dict(self.progress), "outcomes": [int(o) for o in self.outcomes]}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """The gated schedules as a checkpoint's :meth:`state_dict` left them."""
        for name in self.progress:
            if name not in state.get("progress", {}):
                raise ConfigError(
                    f"train.curriculum.{name}: the checkpoint holds no gated schedule for it (gate: was added "
                    "after the run started); resume with the configuration the run started with"
                )
            self.progress[name] = int(state["progress"][name])
        self.outcomes = [bool(o) for o in state.get("outcomes", [])][-self._window :] if self.progress else []


#: ``train.best_by``: what ranks evaluations for ``best_model.pt``
BEST_BY = ("return", "success")


def better_evaluation(summary: dict[str, float], best_return: float, best_success: float | None, best_by: str) -> bool:
    """Whether the evaluation ``summary`` beats the best so far (its mean return and success
    rate; ``-inf`` and None before the first) under ``best_by``: ``return``, a higher mean
    return; ``success``, a higher success rate, or an equal one and a higher return."""
    if best_by == "success":
        best = -np.inf if best_success is None else best_success
        if summary["success_rate"] != best:
            return summary["success_rate"] > best
    return summary["mean_return"] > best_return


class PeriodicEvaluation(EventCallback):
    """Evaluate at the first rollout start at or after every ``eval_freq`` steps; keep the best model.

    At a rollout start the update from the data collected so far is done, so the ``/eval``
    record at step N describes the weights trained on the first N steps (and the record
    at the end of the run, :meth:`evaluate` called by the loop, the final model).
    Attributes ``best_mean_reward`` and ``last_mean_reward`` follow SB3's ``EvalCallback``,
    so SB3's ``StopTrainingOnRewardThreshold`` and ``StopTrainingOnNoModelImprovement`` work
    as child callbacks: their verdict ends the run at this rollout start (through ``stop``).

    ``best_by`` says which evaluation is the best (kept as ``best_model.pt``): ``"return"``
    the highest mean return; ``"success"`` the highest success rate, ties broken by the
    mean return (for tasks whose return pays for more than the outcome, e.g. a waypoint
    task's proximity term).  ``best_mean_reward`` is the best evaluation's mean return.
    """

    def __init__(
        self,
        env: Any,
        run_dir: Path,
        algo: str,
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
        stop: StopRequest | None = None,
        best_by: str = "return",
        best_success_rate: float | None = None,
    ) -> None:
        super().__init__(callback_after_eval, verbose=0)
        if best_by not in BEST_BY:
            raise ValueError(f"best_by must be one of {', '.join(BEST_BY)}, not {best_by!r}")
        self.best_by = best_by
        #: the best evaluation's success rate (None before the first)
        self.best_success_rate = best_success_rate
        self.stop = stop
        self.log = log
        #: what the steps count in the log line (``agent-steps`` for a multi-agent env)
        self.unit = "steps"
        self.total = total
        self.env = env
        self.run_dir = run_dir
        self.algo = algo
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
        #: the model's update count at the last evaluation (the weights it evaluated)
        self.last_updates: int | None = None
        self._started = time.perf_counter()
        self._start_steps = 0
        #: the task's success measures (what the evaluation reports beside the return)
        self.measures = env_measures(env)

    def _on_training_start(self) -> None:
        super()._on_training_start()
        self._started = time.perf_counter()
        self._start_steps = self.model.num_timesteps

    #: a :class:`~pyflyt_cli.training.timing.PhaseClock` told the seconds evaluations take (or None)
    phases: Any = None
    #: the run's :class:`~pyflyt_cli.training.timing.RunEta` (None: the rate since training started)
    eta: Any = None

    def _on_rollout_start(self) -> None:
        if self.eval_freq > 0 and self.num_timesteps >= self.next_eval:
            clock = self.phases.clock if self.phases is not None else time.perf_counter
            started = clock()
            go_on = self.evaluate()
            if self.phases is not None:
                self.phases.add("eval", clock() - started)
            if not go_on and self.stop is not None:  # a child callback ends the run here
                self.stop.request("an after-evaluation callback", final=True)

    def _on_step(self) -> bool:
        return True

    @property
    def current(self) -> bool:
        """Whether the last evaluation saw the model's current weights (no update since)."""
        return self.last_updates is not None and self.last_updates == self.model._n_updates

    #: a :class:`~pyflyt_cli.training.timing.CostLedger` told each evaluation's seconds (or None)
    ledger: Any = None

    def evaluate(self) -> bool:
        """Run the evaluation now; returns False if a child callback asks to stop.

        The next scheduled evaluation is the first multiple of ``eval_freq`` after this step.
        """
        if self.ledger is None:
            return self._evaluate()
        with self.ledger.timed(self.ledger.evaluations):
            return self._evaluate()

    def _evaluate(self) -> bool:
        step = self.model.num_timesteps
        while self.eval_freq > 0 and self.next_eval <= step:
            self.next_eval += self.eval_freq
        vec = self.model.get_vec_normalize_env()
        episodes = run_episodes(
            policy_predict(self.model),
            self.env,
            self.episodes,
            self.seed,
            self.deterministic,
            normalize_obs=vec.normalize_obs if vec is not None and vec.norm_obs else None,
        )
        # the task's success measures ride along in the /eval record (NaN stored as null)
        summary = {**summarize(episodes), **summarize_measures(self.measures, episodes)}
        self.writer.log("/eval", step, summary)
        elapsed = time.perf_counter() - self._started
        trained = step - self._start_steps
        self.writer.log(
            "/train/progress",
            step,
            {"elapsed": elapsed, "steps_per_second": trained / elapsed if elapsed > 0 else 0.0},
        )
        self.last, self.last_step, self.last_updates = summary, step, int(self.model._n_updates)
        self.last_mean_reward = summary["mean_return"]
        if self.log is not None:
            of = f"/{self.total}" if self.total else ""
            label = "step" if self.unit == "steps" else self.unit
            rate = trained / elapsed if elapsed > 0 else 0.0
            eta = ""
            if self.eta is not None and self.total and step < self.total:  # the run's one ETA
                eta = f", ETA {self.eta.text(step)}"
            elif self.total and step < self.total and rate > 0:
                from pyflyt_cli.training.timing import format_duration

                eta = f", ETA {format_duration((self.total - step) / rate)}"
            from pyflyt_engine.envs.tasks.measures import brief

            measured = brief(self.measures, summary)
            self.log(
                f"{label} {step}{of}: eval return {summary['mean_return']:.2f} ± {summary['std_return']:.2f}, "
                f"success {100 * summary['success_rate']:.0f} %, length {summary['mean_length']:.0f}"
                + (f", {measured}" if measured else "")
                + f" ({rate:.0f} {self.unit}/s{eta})"
            )
        if better_evaluation(summary, self.best_mean_reward, self.best_success_rate, self.best_by):
            self.best_mean_reward = summary["mean_return"]
            self.best_success_rate = float(summary["success_rate"])
            self.best_step = step
            save_policy(self.run_dir / rundir.BEST_MODEL, self.model, self.algo, step)
        if self.callback is not None:
            return self.callback.on_step()
        return True

    #: the counters of SB3's after-evaluation callbacks that a resume carries on
    _CHILD_STATE = ("no_improvement_evals", "last_best_mean_reward")

    def state_dict(self) -> dict[str, Any]:
        """What a checkpoint keeps of the evaluation schedule and results (plain data)."""
        children = self.callback.callbacks if isinstance(self.callback, CallbackList) else [self.callback]
        return {
            "next_eval": self.next_eval,
            "best_mean_reward": None if not np.isfinite(self.best_mean_reward) else float(self.best_mean_reward),
            "best_step": self.best_step,
            "best_success_rate": self.best_success_rate,
            # NaN (a measure that applied to no episode) as null: checkpoint state is JSON
            "last": None if self.last is None else {k: None if v != v else v for k, v in self.last.items()},
            "last_step": self.last_step,
            "last_updates": self.last_updates,
            "last_mean_reward": None if not np.isfinite(self.last_mean_reward) else float(self.last_mean_reward),
            "children": [
                {
                    k: float(getattr(c, k)) if k == "last_best_mean_reward" else getattr(c, k)
                    for k in self._CHILD_STATE
                    if hasattr(c, k)
                }
                for c in children
                if c is not None
            ],
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Continue from :meth:`state_dict`."""
        self.next_eval = int(state["next_eval"])
        self.best_mean_reward = -np.inf if state["best_mean_reward"] is None else float(state["best_mean_reward"])
        self.best_step = state["best_step"]
        self.best_success_rate = state.get("best_success_rate")  # absent from older checkpoints
        self.last = (
            None if state["last"] is None else {k: math.nan if v is None else v for k, v in state["last"].items()}
        )
        self.last_step = state["last_step"]
        self.last_updates = state["last_updates"]
        self.last_mean_reward = -np.inf if state["last_mean_reward"] is None else float(state["last_mean_reward"])
        children = self.callback.callbacks if isinstance(self.callback, CallbackList) else [self.callback]
        for child, saved in zip([c for c in children if c is not None], state["children"]):
            for key, value in saved.items():
                setattr(child, key, value)


class Checkpointer(BaseCallback):
    """Save a checkpoint at the first rollout start at or after every ``checkpoint_freq`` steps,
    and at the first rollout start after a stop request (then ``learn()`` ends; it runs after
    the evaluation in the same rollout start, whose verdict may be the request)."""

    def __init__(self, run: Any, freq: int, next_checkpoint: int, stop: StopRequest) -> None:
        super().__init__()
        self.run = run
        self.freq = freq
        self.next_checkpoint = next_checkpoint
        self.stop = stop

    #: a :class:`~pyflyt_cli.training.timing.PhaseClock` told the seconds checkpoints take (or None)
    phases: Any = None

    def _on_rollout_start(self) -> None:
        step = self.model.num_timesteps
        due = self.freq > 0 and step >= self.next_checkpoint
        if due:
            while self.next_checkpoint <= step:
                self.next_checkpoint += self.freq
        if due or self.stop.requested:
            clock = self.phases.clock if self.phases is not None else time.perf_counter
            started = clock()
            self.run.save_checkpoint(self.model)
            if self.phases is not None:
                self.phases.add("checkpoint", clock() - started)
            if self.stop.requested:
                self.stop.saved_at = step

    def _on_step(self) -> bool:
        return True


class ProgressBar(BaseCallback):
    """A tqdm bar over the run's total steps: steps/s, elapsed, recent mean return and the
    run's ETA (``eta``, :class:`~pyflyt_cli.training.timing.RunEta`; tqdm's own, from its
    smoothed recent rate, is not shown when there is one)."""

    #: the bar without tqdm's remaining-time estimate (the run's ETA goes in the postfix)
    BAR_FORMAT = "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}, {rate_fmt}{postfix}]"

    def __init__(
        self, total: int, episode_metrics: EpisodeMetrics | None = None, unit: str = "steps", eta: Any = None
    ) -> None:
        super().__init__()
        self.eta = eta
        self.total = total
        self.unit = unit[:-1]  # tqdm's unit is singular
        self.episode_metrics = episode_metrics
        self.bar: Any = None
        self._shown = 0
        self._last_postfix = 0.0

    def _on_training_start(self) -> None:
        from tqdm import tqdm

        self._shown = self.model.num_timesteps
        self.bar = tqdm(
            total=self.total,
            initial=self._shown,
            unit=self.unit,
            unit_scale=True,
            dynamic_ncols=True,
            smoothing=0.05,
            **({"bar_format": self.BAR_FORMAT} if self.eta is not None else {}),
        )

    def _on_step(self) -> bool:
        now = self.model.num_timesteps
        if now > self._shown:
            self.bar.update(now - self._shown)
            self._shown = now
        if time.monotonic() - self._last_postfix > 1:
            self._last_postfix = time.monotonic()
            self.bar.set_postfix_str(self.postfix(now), refresh=False)
        return True

    def postfix(self, step: int) -> str:
        """What follows the rate: the run's ETA, the recent mean training return."""
        parts = [f"ETA {self.eta.text(step)}"] if self.eta is not None else []
        if self.episode_metrics is not None and self.episode_metrics.recent:
            parts.append(f"return {np.mean(self.episode_metrics.recent):.1f}")
        return ", ".join(parts)

    def _on_training_end(self) -> None:
        if self.bar is not None:
            # the postfix is refreshed at most once a second: the bar's last state shows the end's
            self.bar.set_postfix_str(self.postfix(self.model.num_timesteps), refresh=False)
            self.bar.close()
            self.bar = None


class ValueWarmup(BaseCallback):
    """``train.imitation.value_warmup``: hold the imitated policy while the value function learns.

    Until the run has collected ``steps`` learning steps, every update (the one after each
    rollout) leaves the actor's parameters -- its network, action head and log standard
    deviation -- as they are: they take no gradient (``requires_grad`` off), so the
    optimiser skips them, and the probability ratio and the KL stay at 1 and 0.  The value
    network (and a features extractor the two share) learns.  After the first rollout
    that ends past ``steps``, the actor learns too.  Whether it is held follows from the
    step count alone, so a resumed run holds it exactly as the uninterrupted one did.
    (PPO and A2C: one optimiser over an SB3 ``ActorCriticPolicy``.)
    """

    def __init__(self, steps: int, log) -> None:
        super().__init__()
        self.steps, self.log = steps, log
        self.holding: bool | None = None

    @staticmethod
    def actor_parameters(policy: Any) -> list[Any]:
        """The parameters that decide the action and nothing else: the actor's network, its
        action head, its own features extractor and the log standard deviation."""
        import torch as th

        parts = [policy.mlp_extractor.policy_net, policy.action_net]
        if not policy.share_features_extractor:
            parts.append(policy.pi_features_extractor)
        params = [p for part in parts for p in part.parameters()]
        if isinstance(getattr(policy, "log_std", None), th.nn.Parameter):
            params.append(policy.log_std)
        return params

    def hold(self, hold: bool) -> None:
        if hold == self.holding:
            return
        for p in self.actor_parameters(self.model.policy):
            p.requires_grad_(not hold)
        if hold:
            self.log(f"value warm-up: the policy is held until step {self.steps}; the value function learns")
        elif self.holding:
            self.log(f"value warm-up done at step {self.num_timesteps}: the policy learns too")
        self.holding = hold

    def _on_training_start(self) -> None:
        self.hold(self.num_timesteps < self.steps)

    def _on_rollout_end(self) -> None:  # before the update of the rollout just collected
        self.hold(self.num_timesteps <= self.steps)

    def _on_step(self) -> bool:
        return True

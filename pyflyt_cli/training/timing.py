"""Where a run's time goes, how long it will take, and a progress line for logs.

* :class:`PhaseClock` — an SB3 callback splitting ``learn()``'s wall-clock time into
  *collect* (the envs stepping and the policy choosing actions: from a rollout start to
  its end), *update* (gradient steps: from a rollout end to the next rollout start,
  less what evaluations and checkpoints took there) and *eval* / *checkpoint*.
* :class:`StepTimer` — a vector-env wrapper around every run's training envs, adding up
  the seconds their ``step`` takes (the envs alone, without the policy's part of *collect*).
* :func:`measure_costs` — the cost of one collected step and of the updates per
  step, measured before a run starts on a throw-away copy of its model (same
  configuration, one env, random streams left untouched), from which
  :func:`estimate_seconds` gives the run's expected duration.
* :class:`RunEta` — the run's one ETA, computed one way for every place that shows it
  (the start line, the evaluation lines, the progress bar, the progress lines): the
  measured cost model's seconds left (:func:`estimate_seconds`), scaled by how the run's
  actual time so far compares with what the model predicted for it.
* :class:`ProgressLines` — when stdout/stderr is not a terminal (a log file, a batch
  job), one line at least every :data:`PROGRESS_INTERVAL` seconds: step, rate, elapsed,
  ETA and the split of the time so far.

The clock is a parameter everywhere (``time.perf_counter`` by default) so the tests
drive these classes with a fake one.
"""

from __future__ import annotations

import contextlib
import math
import random
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnvWrapper

Clock = Callable[[], float]

#: seconds between two progress lines when no progress bar is shown (log files, batch jobs)
PROGRESS_INTERVAL = 30.0
#: wall-clock time spent measuring the update cost before a run (a few updates of a copy)
MEASURE_SECONDS = 0.4


def format_duration(seconds: float) -> str:
    """``1:02:03`` / ``4:05`` / ``?`` for an unknown duration."""
    if not math.isfinite(seconds) or seconds < 0:
        return "?"
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


class PhaseClock(BaseCallback):
    """Accumulate wall-clock seconds per phase of ``learn()``: collect, update, eval, checkpoint.

    ``eval`` and ``checkpoint`` time is reported by the callbacks that spend it
    (:meth:`add`); it happens at rollout starts, between an update and the next
    collection, and is taken out of the update phase.  Put this callback after them.
    """

    PHASES = ("collect", "update", "eval", "checkpoint")

    def __init__(self, clock: Clock = time.perf_counter) -> None:
        super().__init__()
        self.clock = clock
        self.seconds = dict.fromkeys(self.PHASES, 0.0)
        self.collected = 0  # steps collected since training started
        self._mark: float | None = None
        self._phase: str | None = None
        self._others = 0.0  # eval + checkpoint seconds reported since the mark
        self._rollout_steps = 0

    def add(self, phase: str, seconds: float) -> None:
        self.seconds[phase] += seconds
        self._others += seconds

    def _switch(self, phase: str | None) -> None:
        now = self.clock()
        if self._mark is not None and self._phase is not None:
            spent = now - self._mark
            if self._phase == "update":
                spent = max(0.0, spent - self._others)
            self.seconds[self._phase] += spent
        self._mark, self._phase, self._others = now, phase, 0.0

    def _on_training_start(self) -> None:
        self._mark, self._phase, self._others = self.clock(), "update", 0.0

    def _on_rollout_start(self) -> None:
        self._rollout_steps = self.model.num_timesteps
        self._switch("collect")

    def _on_rollout_end(self) -> None:
        self.collected += self.model.num_timesteps - self._rollout_steps
        self._switch("update")

    def _on_training_end(self) -> None:
        if self._phase == "collect":  # learn() ended inside a rollout (a callback stopped it)
            self.collected += self.model.num_timesteps - self._rollout_steps
        self._switch(None)

    def _on_step(self) -> bool:
        return True

    def split(self) -> dict[str, float]:
        """Seconds per phase so far, the phase in progress included."""
        out = dict(self.seconds)
        if self._mark is not None and self._phase is not None:
            spent = self.clock() - self._mark
            if self._phase == "update":
                spent = max(0.0, spent - self._others)
            out[self._phase] += spent
        return out


class StepTimer(VecEnvWrapper):
    """The training envs, unchanged, with the seconds their steps took: :attr:`seconds` adds up
    ``step_wait`` (the envs stepping; with ``step_async``'s hand-over for subprocesses) on
    ``clock``.  The loop puts it innermost (under ``VecNormalize``); find it with SB3's
    ``unwrap_vec_wrapper(model.get_env(), StepTimer)``."""

    def __init__(self, venv: Any, clock: Clock = time.perf_counter) -> None:
        super().__init__(venv)
        self.clock = clock
        self.seconds = 0.0

    def reset(self) -> Any:
        return self.venv.reset()

    def step_async(self, actions: np.ndarray) -> None:
        started = self.clock()
        self.venv.step_async(actions)
        self.seconds += self.clock() - started

    def step_wait(self) -> Any:
        started = self.clock()
        try:
            return self.venv.step_wait()
        finally:
            self.seconds += self.clock() - started


def describe_split(split: dict[str, float]) -> str:
    """``collect 31 %, update 62 %, eval 6 %, checkpoint 1 %``."""
    total = sum(split.values())
    if total <= 0:
        return ""
    return ", ".join(f"{k} {100 * v / total:.0f} %" for k, v in split.items())


@dataclass(frozen=True)
class Costs:
    """Measured costs: seconds per collected step, and seconds of updates per collected step
    once updates run (off-policy: after ``learning_starts``)."""

    collect: float
    update: float
    #: seconds per evaluation step when evaluations fly another engine than training does
    #: (``env.backend: batched``: they fly PyBullet); None: a collected step's
    evaluate: float | None = None


def estimate_seconds(cfg: Any, costs: Costs, done: int = 0) -> float:
    """Expected seconds of ``learn()`` for ``cfg`` from step ``done`` on: collection, updates and
    evaluations (an evaluation step costs a collected step per agent; episodes counted at full
    length).  Steps are what ``train.total_timesteps`` counts: agent-steps for a multi-agent env,
    and ``costs`` are per such step (:func:`measure_costs`)."""
    total = cfg.train.total_timesteps
    remaining = max(0, total - done)
    starts = int(getattr(cfg.algo, "learning_starts", 0) or 0)
    updating = max(0, total - max(done, starts))
    seconds = remaining * costs.collect + updating * costs.update
    if cfg.train.eval_freq > 0:
        from pyflyt_cli.training.multi_agent import agents_per_env

        # an evaluation step moves every agent of the env: as many collected (agent-)steps, or
        # the measured step of the PyBullet env the evaluations fly (all its agents at once)
        evals = total // cfg.train.eval_freq - done // cfg.train.eval_freq
        per_step = agents_per_env(cfg.env) * costs.collect if costs.evaluate is None else costs.evaluate
        seconds += max(0, evals) * cfg.train.eval_episodes * _episode_steps(cfg) * per_step
    return seconds


def _episode_steps(cfg: Any) -> int:
    steps = getattr(cfg.env, "max_steps", 0)
    return int(steps() if callable(steps) else steps)


@contextlib.contextmanager
def _streams_kept() -> Iterator[None]:
    """Python's, NumPy's and torch's global random streams are as before, whatever runs inside."""
    import torch

    py, np_state, torch_state = random.getstate(), np.random.get_state(), torch.get_rng_state()
    try:
        yield
    finally:
        random.setstate(py)
        np.random.set_state(np_state)
        torch.set_rng_state(torch_state)


class _StopAfter(BaseCallback):
    """End a measuring ``learn()`` once it has seen ``updates`` update phases and ``seconds`` of time."""

    def __init__(self, phases: PhaseClock, updates: int, seconds: float, clock: Clock) -> None:
        super().__init__()
        self.phases, self.updates, self.seconds, self.clock = phases, updates, seconds, clock
        self.seen = 0
        self.started = 0.0
        self.stop = False

    def _on_training_start(self) -> None:
        self.started = self.clock()

    def _on_rollout_start(self) -> None:
        if self.phases.collected > 0:
            self.seen += 1
        self.stop = self.seen >= self.updates and self.clock() - self.started >= self.seconds

    def _on_step(self) -> bool:
        return not self.stop


def measure_costs(cfg: Any, *, seconds: float = MEASURE_SECONDS) -> Costs | None:
    """Time a throw-away copy of ``cfg``'s model: collected steps and updates.

    Costs are per step ``train.total_timesteps`` counts: per agent-step for a multi-agent env
    (each env fills a slot per agent, as in training).

    The copy runs the run's envs when they live in this process (``train.vec_env`` dummy,
    one env, a multi-agent env under ``auto``, or the batched backend, whose evaluations'
    PyBullet steps are timed apart): a batch of envs shares one policy forward
    pass per step, so one env alone would overstate the cost of a step.  Subprocess envs are
    measured on one env in this process instead (on-policy: with the run's rollout size,
    ``n_steps x n_envs`` steps).  The copy learns with ``learning_starts`` 0 (off-policy)
    until it has done a few updates and ``seconds`` have passed (an on-policy copy: one
    rollout and its update).  The global random streams are restored afterwards, so the run
    itself is unchanged.  None if the algorithm cannot be measured this way.
    """
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from pyflyt_cli.training.envs import EnvFactory
    from pyflyt_cli.training.models import build_model
    from pyflyt_cli.training.schema import parse_train_config

    data = cfg.model_dump(mode="json")
    algo = data["algo"]
    on_policy = not cfg.algo.off_policy
    n_envs = cfg.train.n_envs
    multi_agent = bool(getattr(cfg.env, "multi_agent", False))
    in_process = cfg.train.vec_env == "dummy" or n_envs == 1 or (multi_agent and cfg.train.vec_env == "auto")
    if not in_process:
        if on_policy:
            algo["n_steps"] = algo["n_steps"] * n_envs
        n_envs = 1
    if "buffer_size" in algo:
        algo["buffer_size"] = 10_000
        algo["learning_starts"] = 0
    for key in ("offline_buffer", "offline_steps"):
        if key in algo:
            algo[key] = None if key == "offline_buffer" else 0
    data["train"] = {**data["train"], "n_envs": n_envs}
    probe_cfg = parse_train_config(data)
    with _streams_kept():
        batched = getattr(probe_cfg.env, "backend", "pybullet") == "batched"  # (auto is resolved by the config)
        if multi_agent or batched:  # a slot per agent (costs per agent-step); the batched envs as trained
            from pyflyt_cli.training.envs import make_vec_env

            vec: Any = make_vec_env(probe_cfg.env, n_envs, "dummy")
        else:
            vec = DummyVecEnv([EnvFactory(probe_cfg.env, resumable=False) for _ in range(n_envs)])
        try:
            _warm_up(vec)
            norm = probe_cfg.algo.normalize
            if norm.enabled:
                vec = VecNormalize(vec, norm_obs=norm.observation, norm_reward=norm.reward, gamma=probe_cfg.algo.gamma)
            model = build_model(probe_cfg, vec)
            phases = PhaseClock()
            stop = _StopAfter(phases, 1 if on_policy else 3, 0.0 if on_policy else seconds, time.perf_counter)
            budget = algo["n_steps"] * vec.num_envs + 1 if on_policy else 100_000
            model.learn(budget, callback=[phases, stop], progress_bar=False)
        finally:
            vec.close()
        evaluate = _evaluation_step(probe_cfg) if batched else None
    split = phases.split()
    if phases.collected <= 0 or split["update"] <= 0:
        return None
    return Costs(split["collect"] / phases.collected, split["update"] / phases.collected, evaluate)


def _warm_up(vec: Any, steps: int = 2) -> None:
    """Step the measuring copy's envs a little before anything is timed: their first calls do
    one-time work that no later step repeats (the batched backend compiles its laws on the first
    call after a fresh install, which takes tens of seconds, then loads them from numba's cache;
    a PyBullet env loads its meshes), which would otherwise be charged to each collected step."""
    vec.reset()
    space = vec.action_space
    for _ in range(steps):
        vec.step(np.stack([space.sample() for _ in range(vec.num_envs)]))


def _evaluation_step(cfg: Any, steps: int = 60) -> float:
    """Seconds per step of the PyBullet env the evaluations fly (random actions, resets inside)."""
    from pyflyt_cli.training.envs import EnvFactory

    env = EnvFactory(cfg.env, monitor=False)()
    try:
        env.reset(seed=0)
        env.action_space.seed(0)
        agents = int(getattr(env.unwrapped, "num_agents", 1))  # a multi-agent env takes one action per agent
        started = time.perf_counter()
        for _ in range(steps):
            action = env.action_space.sample() if agents == 1 else [env.action_space.sample() for _ in range(agents)]
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        return (time.perf_counter() - started) / steps
    finally:
        env.close()


class RunEta(BaseCallback):
    """The run's ETA: one computation behind every place that prints one.

    With measured ``costs`` (:func:`measure_costs`) the seconds left from step ``s`` are the
    cost model's (:func:`estimate_seconds`, which knows that an off-policy run updates only
    after ``learning_starts`` and that evaluations cost episodes), times the ratio of the
    actual seconds since training started to the model's seconds for the same steps: at
    the start the model alone, later the model calibrated on this machine under its
    present load.  Without costs: the steps left at the mean rate since training started.
    Either way a run that keeps going as it went so far ends when the ETA said.

    Put it first among the callbacks: its training start is the clock's zero.
    """

    def __init__(self, cfg: Any, costs: Costs | None, clock: Clock = time.perf_counter) -> None:
        super().__init__()
        self.cfg = cfg
        self.costs = costs
        self.clock = clock
        self.total = int(cfg.train.total_timesteps)
        self.started: float | None = None
        self.start_step = 0

    def _on_training_start(self) -> None:
        self.started = self.clock()
        self.start_step = int(self.model.num_timesteps)

    def _on_step(self) -> bool:
        return True

    def seconds_left(self, step: int, start_step: int | None = None) -> float:
        """Seconds until the budget is trained, seen at ``step`` now (inf: not known yet).
        Before training starts (``start_step`` given): the cost model's estimate."""
        start = self.start_step if start_step is None else start_step
        elapsed = 0.0 if self.started is None else max(0.0, self.clock() - self.started)
        if step >= self.total:
            return 0.0
        if self.costs is not None:
            left = estimate_seconds(self.cfg, self.costs, step)
            predicted = estimate_seconds(self.cfg, self.costs, start) - left  # the model's seconds for start..step
            return left * elapsed / predicted if predicted > 0 and elapsed > 0 else left
        done = step - start
        return (self.total - step) * elapsed / done if done > 0 and elapsed > 0 else math.inf

    def text(self, step: int) -> str:
        """The ETA as printed (``1:02:03``; ``?`` while unknown)."""
        return format_duration(self.seconds_left(step))


class ProgressLines(BaseCallback):
    """A progress line at least every ``interval`` seconds (at the first step after it passed).

    ``step 12000/60000 (20 %) | 410 steps/s | elapsed 0:29 | ETA 1:57 | collect 35 %, update 60 %, eval 5 %``;
    the ETA is the run's (``eta``, :class:`RunEta`; without one: from the rate since
    training started).  ``unit`` names what the steps
    count (``agent-steps`` for a multi-agent env: every agent's step is one).
    """

    def __init__(
        self,
        total: int,
        log: Callable[[str], None],
        phases: PhaseClock | None = None,
        interval: float = PROGRESS_INTERVAL,
        clock: Clock = time.perf_counter,
        episode_returns: Callable[[], list[float]] | None = None,
        unit: str = "steps",
        eta: RunEta | None = None,
    ) -> None:
        super().__init__()
        #: the run's ETA (None: from the rate since training started, as :class:`RunEta` without costs)
        self.eta = eta
        self.total = total
        self.unit = unit
        self.log = log
        self.phases = phases
        self.interval = interval
        self.clock = clock
        self.episode_returns = episode_returns
        self.started = 0.0
        self.start_step = 0
        self.next_line = 0.0
        self.lines = 0

    def _on_training_start(self) -> None:
        self.started = self.clock()
        self.start_step = int(self.model.num_timesteps)
        self.next_line = self.started + self.interval

    def _on_step(self) -> bool:
        now = self.clock()
        if now >= self.next_line:
            self.log(self.line(now))
            self.lines += 1
            while self.next_line <= now:
                self.next_line += self.interval
        return True

    def line(self, now: float) -> str:
        step = int(self.model.num_timesteps)
        elapsed = now - self.started
        done = step - self.start_step
        rate = done / elapsed if elapsed > 0 else 0.0
        left = (
            self.eta.seconds_left(step)
            if self.eta is not None
            else ((self.total - step) / rate if rate > 0 else float("inf"))
        )
        parts = [
            f"{'step' if self.unit == 'steps' else self.unit} {step}/{self.total} ({100 * step / self.total:.0f} %)",
            f"{rate:.0f} {self.unit}/s",
            f"elapsed {format_duration(elapsed)}",
            f"ETA {format_duration(left)}",
        ]
        if self.episode_returns is not None:
            recent = self.episode_returns()
            if recent:
                parts.append(f"train return {np.mean(recent):.1f}")
        if self.phases is not None:
            split = describe_split(self.phases.split())
            if split:
                parts.append(split)
        return " | ".join(parts)

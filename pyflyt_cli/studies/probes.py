"""Probes: a policy flown on seeded episodes of its task, scored by the task's own measures.

The learning studies under ``experiments/`` measure progress with these, not with the
training return (a dense reward pays for approaching a waypoint whether or not it is ever
reached): every ``every`` steps a probe callback flies the current policy, deterministic,
on ``episodes`` episodes from seed :data:`PROBE_SEED` (the same episodes for every run and
probe), and remembers the first probe that meets the study's target.

- :func:`hover_probe`, :class:`HoverProbe`: crash-free fraction and distance to the hover point;
- :func:`waypoint_probe`, :class:`WaypointProbe`: waypoints (or gates) reached and how episodes ended;
- :func:`obstacle_probe`, :class:`ObstacleProbe`: the goal reached without contact, under a CPU-time budget;
- :func:`gates_probe`, :class:`GatesProbe`: gates passed in a row.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from pyflyt_cli.training.envs import EnvFactory

#: the first probe episode's seed (then seed + 1, ...): the same episodes for every run
PROBE_SEED = 10_000
#: [m] hovering: every probe episode survives with a mean distance to the hover point below this
HOVER_DISTANCE = 0.1
#: gates in a row that count as a QuadX-Gates success (:func:`gates_probe`)
GATES = 3


def hover_probe(model, env, episodes: int, seed: int) -> dict[str, float]:
    """Fly ``episodes`` episodes; crash-free fraction, mean distance to the hover point, return."""
    vec = model.get_vec_normalize_env()
    base = env.unwrapped
    point = np.asarray(base.task.options.hover_point)
    survived, distances, returns = [], [], []
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i)
        done, total, dist = False, 0.0, []
        while not done:
            x = vec.normalize_obs(obs) if vec is not None and vec.norm_obs else obs
            action, _ = model.predict(x, deterministic=True)
            obs, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            dist.append(float(np.linalg.norm(base.state.lin_pos - point)))
            done = terminated or truncated
        survived.append(truncated and not terminated)
        distances.append(float(np.mean(dist)))
        returns.append(total)
    return {
        "survived": float(np.mean(survived)),
        "worst_distance": float(np.max(distances)),
        "mean_distance": float(np.mean(distances)),
        "mean_return": float(np.mean(returns)),
    }


class HoverProbe(BaseCallback):
    """Every ``every`` steps: fly ``probe_fn`` (default :func:`hover_probe`) on a fresh env of
    ``cfg`` (or of ``probe_env``, an env config, when the policy is probed on another env than
    it trains on); remember the first step whose probe hovers (every episode survived, worst mean
    distance below ``max_distance``).  ``unit`` names the steps in the printed lines
    (``experiments/learn_ma_hover_ppo.py`` probes all agents and counts agent-steps)."""

    def __init__(
        self,
        cfg,
        every: int,
        episodes: int,
        stop_on_hover: bool = False,
        *,
        max_distance: float = HOVER_DISTANCE,
        probe_fn=hover_probe,
        unit: str = "steps",
        probe_env=None,
    ) -> None:
        super().__init__()
        self.stop_on_hover = stop_on_hover
        self.max_distance, self.probe_fn, self.unit = max_distance, probe_fn, unit
        self.env = EnvFactory(cfg.env if probe_env is None else probe_env, monitor=False)()
        self.every, self.episodes = every, episodes
        self.next = every
        self.started = time.perf_counter()
        self.cpu_started = time.process_time()
        self.probe_time = 0.0
        self.probe_cpu = 0.0
        self.history: list[tuple[int, float, dict[str, float]]] = []
        #: (steps, wall-clock, wall-clock without the probes, CPU time of this process without the probes)
        self.hover_at: tuple[float, ...] | None = None

    def _on_training_start(self) -> None:
        self.started = time.perf_counter()
        self.cpu_started = time.process_time()

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next:
            self.next += self.every
            self.probe()
            if self.stop_on_hover and self.hover_at is not None:
                return False
        return True

    def _on_training_end(self) -> None:
        if not self.history or self.history[-1][0] != self.num_timesteps:
            self.probe()  # the final policy

    def probe(self) -> None:
        t0, c0 = time.perf_counter(), time.process_time()
        probe = self.probe_fn(self.model, self.env, self.episodes, seed=PROBE_SEED)
        self.probe_time += time.perf_counter() - t0
        self.probe_cpu += time.process_time() - c0
        wall = time.perf_counter() - self.started
        self.history.append((self.num_timesteps, wall, probe))
        print(
            f"  {self.num_timesteps:>7} {self.unit}  {wall:6.1f} s  survived {100 * probe['survived']:3.0f} %  "
            f"distance mean {probe['mean_distance']:.3f} / worst {probe['worst_distance']:.3f} m  "
            f"return {probe['mean_return']:8.2f}",
            flush=True,
        )
        if self.hover_at is None and probe["survived"] == 1.0 and probe["worst_distance"] < self.max_distance:
            cpu = time.process_time() - self.cpu_started - self.probe_cpu
            self.hover_at = (self.num_timesteps, wall, wall - self.probe_time, cpu)


def waypoint_ending(info: dict, truncated: bool) -> str:
    """How a waypoint (or gates) episode ended, from its last ``info``: complete, crash, out (of the dome) or time."""
    if info.get("env_complete"):
        return "complete"
    if info.get("out_of_bounds"):
        return "out"
    if truncated and not info.get("collision"):
        return "time"
    return "crash"


def summarize_probe(reached: list[int], endings: list[str], returns: list[float], num_targets: int) -> dict:
    """Fractions of the episodes reaching at least 1..``num_targets`` waypoints, and the rest."""
    counts = np.asarray(reached, dtype=int)
    return {
        "reached": [int(c) for c in counts],
        "at_least": [float(np.mean(counts >= k)) for k in range(1, num_targets + 1)],
        "mean_reached": float(counts.mean()),
        "all": float(np.mean(counts >= num_targets)),
        "endings": {e: endings.count(e) for e in ("complete", "time", "out", "crash") if e in endings},
        "mean_return": float(np.mean(returns)),
    }


def waypoint_probe(model, env, episodes: int, seed: int) -> dict:
    """Fly ``episodes`` deterministic episodes (seeds ``seed``, ``seed + 1``, ...); see :func:`summarize_probe`
    (waypoints reached, or gates passed, in order: ``info["num_targets_reached"]``)."""
    vec = model.get_vec_normalize_env()
    options = env.unwrapped.task.options
    num_targets = options.num_targets if hasattr(options, "num_targets") else len(options.gates)  # waypoints or gates
    reached, endings, returns = [], [], []
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i)
        done, total, info, truncated = False, 0.0, {}, False
        while not done:
            x = vec.normalize_obs(obs) if vec is not None and vec.norm_obs else obs
            action, _ = model.predict(x, deterministic=True)
            obs, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            done = terminated or truncated
        reached.append(int(info["num_targets_reached"]))
        endings.append(waypoint_ending(info, truncated))
        returns.append(total)
    return summarize_probe(reached, endings, returns, num_targets)


class WaypointProbe(HoverProbe):
    """:class:`HoverProbe`'s schedule with :func:`waypoint_probe`; remembers the first
    probe at which ``target`` of the episodes reach every waypoint, and times the env stepping."""

    def __init__(self, cfg, every: int, episodes: int, target: float) -> None:
        super().__init__(cfg, every, episodes, probe_fn=waypoint_probe)
        self.target = target
        self.loads: list[float] = []

    @property
    def env_time(self) -> float:
        """Seconds the run's envs took to step so far (the training loop's :class:`StepTimer`)."""
        from stable_baselines3.common.vec_env import unwrap_vec_wrapper

        from pyflyt_cli.training.timing import StepTimer

        model = getattr(self, "model", None)  # set when learn() starts
        timer = unwrap_vec_wrapper(model.get_env(), StepTimer) if model is not None else None
        return timer.seconds if isinstance(timer, StepTimer) else 0.0

    def probe(self) -> None:
        t0, c0 = time.perf_counter(), time.process_time()
        probe = self.probe_fn(self.model, self.env, self.episodes, seed=PROBE_SEED)
        self.probe_time += time.perf_counter() - t0
        self.probe_cpu += time.process_time() - c0
        wall = time.perf_counter() - self.started
        # CPU time of this process (every thread) in training, the probes taken out: what a
        # machine shared with other jobs inflates far less than the wall-clock
        cpu = time.process_time() - self.cpu_started - self.probe_cpu
        probe = {**probe, "cpu": cpu}
        load = os.getloadavg()[0]
        self.loads.append(load)
        self.history.append((self.num_timesteps, wall, probe))
        at_least = " ".join(f"{100 * f:3.0f}" for f in probe["at_least"])
        print(
            f"  {self.num_timesteps:>8} steps  {wall:7.1f} s  (train {wall - self.probe_time:7.1f} s, CPU {cpu:7.1f} s, "
            f"load {load:.1f})  "
            f">=k reached [%]: {at_least}  mean {probe['mean_reached']:.1f}  endings {probe['endings']}  "
            f"return {probe['mean_return']:8.1f}",
            flush=True,
        )
        if self.hover_at is None and probe["all"] >= self.target:
            self.hover_at = (self.num_timesteps, wall, wall - self.probe_time, cpu)


OBSTACLE_ENDINGS = ("reached", "trunk", "ground", "out", "time")


def obstacle_ending(info: dict, truncated: bool) -> str:
    """How an obstacle-course episode ended, from its last ``info``: reached (success), trunk, ground, out (of the dome) or time."""
    if info.get("success"):
        return "reached"
    if info.get("obstacle_contact"):
        return "trunk"
    if info.get("collision"):
        return "ground"
    if info.get("out_of_bounds"):
        return "out"
    return "time" if truncated else "ground"


def obstacle_probe(model, env, episodes: int, seed: int, task: dict | None = None, deterministic: bool = True) -> dict:
    """Fly ``episodes`` episodes (seeds ``seed``, ``seed + 1``, ...; deterministic actions unless told;
    the configured task, or other values of its episode options ``task``): success fraction,
    endings, closest approach to the goal [m], mean speed [m/s], episode length [s] and return."""
    vec = model.get_vec_normalize_env()
    base = env.unwrapped
    successes, endings, closest, speeds, lengths, returns = [], [], [], [], [], []
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i, options={"task": task} if task else None)
        goal = [float(v) for v in base.task.goal]
        done, total, info, truncated, steps = False, 0.0, {}, False, 0
        nearest, speed_sum = math.inf, 0.0
        while not done:
            x = vec.normalize_obs(obs) if vec is not None and vec.norm_obs else obs
            action, _ = model.predict(x, deterministic=deterministic)
            obs, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            steps += 1
            nearest = min(nearest, math.dist([float(v) for v in base.state.lin_pos], goal))
            speed_sum += math.hypot(*(float(v) for v in base.state.lin_vel))
            done = terminated or truncated
        successes.append(bool(info.get("success")))
        endings.append(obstacle_ending(info, truncated))
        closest.append(0.0 if info.get("success") else nearest)
        speeds.append(speed_sum / steps)
        lengths.append(steps / base.config.agent_hz)
        returns.append(total)
    return {
        "success": float(np.mean(successes)),
        "successes": successes,
        "endings": {e: endings.count(e) for e in OBSTACLE_ENDINGS if e in endings},
        "episode_endings": endings,
        "closest": [round(c, 3) for c in closest],
        "mean_closest": float(np.mean(closest)),
        "mean_speed": float(np.mean(speeds)),
        "mean_length": float(np.mean(lengths)),
        "mean_return": float(np.mean(returns)),
    }


class ObstacleProbe(WaypointProbe):
    """:class:`WaypointProbe` (schedule, env timing, load) with :func:`obstacle_probe`,
    a CPU-time budget (``cpu_budget`` seconds of training, the probes' CPU time excluded) and a
    ``save`` hook called after every probe (the partial results on disk)."""

    def __init__(self, cfg, every: int, episodes: int, target: float, cpu_budget: float | None, save=None) -> None:
        super().__init__(cfg, every, episodes, target)
        self.probe_fn = obstacle_probe
        self.cpu_budget, self.save = cpu_budget, save
        self.env_name = cfg.env_name
        self.imitates = cfg.train.imitation is not None and cfg.train.imitation.oracle is not None
        # the clocks start here, just before `train`: a tuning's imitation stage (DAgger, run
        # before learning starts) is part of the budget and of the wall-clock
        self.cpu_started = time.process_time()
        self.started = time.perf_counter()
        self.probe_cpu = 0.0
        self.stopped_by_budget = False

    def _on_training_start(self) -> None:
        started = self.started
        super()._on_training_start()
        self.started = started
        if self.imitates:
            self.probe()  # the policy the imitation stage left, before reinforcement learning

    def training_cpu(self) -> float:
        """CPU seconds of this process since learning started, without the probes'."""
        return time.process_time() - self.cpu_started - self.probe_cpu

    def _on_step(self) -> bool:
        if not super()._on_step():
            return False
        if self.cpu_budget is not None and self.training_cpu() >= self.cpu_budget:
            self.stopped_by_budget = True
            return False
        return True

    def describe(self, probe: dict) -> str:
        """The task's measures of one probe, for its progress line."""
        return (
            f"success {100 * probe['success']:3.0f} %  endings {probe['endings']}  "
            f"closest {probe['mean_closest']:.2f} m  speed {probe['mean_speed']:.2f} m/s  "
            f"length {probe['mean_length']:.1f} s  return {probe['mean_return']:8.1f}"
        )

    def probe(self) -> None:
        t0, c0 = time.perf_counter(), time.process_time()
        probe = self.probe_fn(self.model, self.env, self.episodes, seed=PROBE_SEED)
        self.probe_time += time.perf_counter() - t0
        self.probe_cpu += time.process_time() - c0
        wall = time.perf_counter() - self.started
        cpu = self.training_cpu()
        load = os.getloadavg()[0]
        self.loads.append(load)
        probe.update(cpu=cpu, load=load)
        self.history.append((self.num_timesteps, wall, probe))
        print(
            f"  {self.num_timesteps:>8} steps  CPU {cpu / 60:5.1f} min  wall {wall / 60:5.1f} min (load {load:.1f})  "
            + self.describe(probe),
            flush=True,
        )
        if self.hover_at is None and probe["success"] >= self.target:
            self.hover_at = (self.num_timesteps, wall, cpu)
        if self.save is not None:
            self.save(self)


def gates_probe(model, env, episodes: int, seed: int, gates: int = GATES) -> dict:
    """Fly ``episodes`` deterministic episodes (seeds ``seed``, ``seed + 1``, ...):
    :func:`waypoint_probe`'s counts (gates passed per episode, the fractions
    passing at least 1..n, their mean, the endings, the return), and ``success``, the fraction
    passing at least ``gates``."""
    out = waypoint_probe(model, env, episodes, seed)
    out["success"] = out["at_least"][gates - 1]
    return out


class GatesProbe(ObstacleProbe):
    """:class:`ObstacleProbe` (CPU budget, saves, schedule) flying :func:`gates_probe`."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.probe_fn = gates_probe

    def describe(self, probe: dict) -> str:
        at_least = " ".join(f"{100 * f:3.0f}" for f in probe["at_least"])
        return (
            f">= k gates [%]: {at_least}  mean {probe['mean_reached']:.2f}  endings {probe['endings']}  "
            f"return {probe['mean_return']:8.1f}"
        )

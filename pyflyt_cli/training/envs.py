"""Environments as an agent sees them: flattened observations, actions in [-1, 1].

Every registered environment (any env config) goes through the same wrappers, in
training, in evaluation and in ``pyflyt eval``, so a saved policy always meets the
observation and action layout it was trained on:

1. the pyflyt env, built from its :class:`~pyflyt_engine.envs.config.EnvConfig`;
2. optionally :class:`~pyflyt_engine.telemetry.RecordEpisode` (innermost: it records the
   actions the vehicle receives, in the env's own units);
3. a ``Dict`` observation becomes one ``Box``: waypoint envs by
   :class:`~pyflyt_engine.envs.wrappers.FlattenWaypointEnv`, any other ``Dict`` by
   Gymnasium's ``FlattenObservation``; except that a camera image (a uint8 ``Box`` of
   rank 3) stays a separate entry: ``Dict(attitude=Box, image=Box)``, trained with SB3's
   ``MultiInputPolicy``;
   observations are cast to float32 (the networks' type; halves replay buffers);
4. a bounded ``Box`` action space is rescaled to ``[-1, 1]`` (what SB3's squashed and
   clipped Gaussian policies assume; the paper's units stay in the env);
5. SB3's ``Monitor`` (episode return, length and ``success``) for training envs;
6. :class:`ResumableEpisode` (outermost, training envs): remembers how the episode in
   progress started and the actions since, so a checkpoint can rebuild it exactly.

A multi-agent config (one with ``agents``) goes through the same steps: its env is the
parallel env seen by one shared policy
(:class:`~pyflyt_engine.envs.multi_agent.shared.SharedPolicyEnv`: one agent's spaces,
observations and actions stacked by agent), ``Monitor`` is replaced by
:class:`~pyflyt_cli.training.multi_agent.AgentSlots`, and :func:`make_vec_env` gives a
slot per agent (:class:`~pyflyt_cli.training.multi_agent.AgentSlotsVecEnv`).
"""

from __future__ import annotations

import signal
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from pyflyt_engine.envs.config import EnvConfig


def _float32(space: spaces.Box) -> spaces.Box:
    return spaces.Box(
        np.asarray(space.low, dtype=np.float32), np.asarray(space.high, dtype=np.float32), dtype=np.float32
    )


class Float32Observation(gymnasium.ObservationWrapper):
    """Cast a ``Box`` observation (or a ``Dict``'s float Boxes; images stay uint8) to float32:
    what the networks use; halves replay buffers."""

    def __init__(self, env: gymnasium.Env) -> None:
        super().__init__(env)
        space = env.observation_space
        if isinstance(space, spaces.Dict):
            self._cast = [k for k, s in space.spaces.items() if isinstance(s, spaces.Box) and s.dtype.kind == "f"]
            self.observation_space = spaces.Dict(
                {
                    k: _float32(s) if k in self._cast and isinstance(s, spaces.Box) else s
                    for k, s in space.spaces.items()
                }
            )
        else:
            assert isinstance(space, spaces.Box), f"Float32Observation casts a Box or a Dict observation, not {space}"
            self._cast = []
            self.observation_space = _float32(space)

    def observation(self, observation: Any) -> Any:
        if isinstance(observation, dict):
            return {k: np.asarray(v, dtype=np.float32) if k in self._cast else v for k, v in observation.items()}
        return np.asarray(observation, dtype=np.float32)


def wrap_for_agent(env: gymnasium.Env) -> gymnasium.Env:
    """Flatten a ``Dict`` observation to a ``Box`` and rescale a bounded ``Box`` action to [-1, 1]."""
    obs_space = env.observation_space
    if isinstance(obs_space, spaces.Dict):
        if isinstance(obs_space.spaces.get("target_deltas"), spaces.Sequence):
            from pyflyt_engine.envs.wrappers import FlattenWaypointEnv

            env = FlattenWaypointEnv(env)
        elif any(is_image(s) for s in obs_space.spaces.values()):
            env = _FlattenAllButImages(env)
        else:
            env = gymnasium.wrappers.FlattenObservation(env)
    space = env.observation_space
    if (isinstance(space, spaces.Box) and space.dtype != np.float32) or (
        isinstance(space, spaces.Dict)
        and any(
            isinstance(s, spaces.Box) and s.dtype.kind == "f" and s.dtype != np.float32 for s in space.spaces.values()
        )
    ):
        env = Float32Observation(env)
    act_space = env.action_space
    if (
        isinstance(act_space, spaces.Box)  # bounded, and not already [-1, 1]
        and np.all(np.isfinite(act_space.low))
        and np.all(np.isfinite(act_space.high))
        and not (np.allclose(act_space.low, -1.0) and np.allclose(act_space.high, 1.0))
    ):
        # the stubs take NumPy scalars; the wrapper takes any number (its docs, np.issubdtype)
        env = gymnasium.wrappers.RescaleAction(env, -1.0, 1.0)  # type: ignore[arg-type]
    return env


def is_image(space: spaces.Space) -> bool:
    """A camera image: a uint8 Box of rank 3."""
    return isinstance(space, spaces.Box) and space.dtype == np.uint8 and len(space.shape) == 3


class _FlattenAllButImages(gymnasium.ObservationWrapper):
    """A ``Dict`` observation as ``Dict(attitude=<every non-image entry flattened>, <images>)``."""

    def __init__(self, env: gymnasium.Env) -> None:
        super().__init__(env)
        space = env.observation_space
        assert isinstance(space, spaces.Dict)  # wrap_for_agent's choice for a Dict holding an image
        self._images = [k for k, s in space.spaces.items() if is_image(s)]
        self._rest = spaces.Dict({k: s for k, s in space.spaces.items() if k not in self._images})
        flat = spaces.flatten_space(self._rest)
        self.observation_space = spaces.Dict({"attitude": flat, **{k: space[k] for k in self._images}})

    def observation(self, observation: dict[str, Any]) -> dict[str, Any]:
        rest = spaces.flatten(self._rest, {k: observation[k] for k in self._rest.spaces})
        return {"attitude": rest, **{k: observation[k] for k in self._images}}


def _rng_state(env: gymnasium.Env) -> dict[str, Any]:
    base = env.unwrapped
    state: dict[str, Any] = {"env": base.np_random.bit_generator.state}
    world = getattr(base, "world", None)
    if world is not None:
        state["world"] = world.rng_state()
    return state


def _set_rng_state(env: gymnasium.Env, state: dict[str, Any]) -> None:
    base: Any = env.unwrapped  # a pyflyt env: its world, if it has one, set below
    base.np_random.bit_generator.state = state["env"]
    if "world" in state:
        base.world.set_rng_state(state["world"])


class ResumableEpisode(gymnasium.Wrapper):
    """Remember how the episode in progress started and every action since.

    :meth:`episode_state` is that record (plain data and one array); :meth:`restore_episode`
    rebuilds the episode from it in a fresh env of the same configuration, bit for bit:
    the simulation is deterministic, so the same start (the seed, or the random streams of
    an unseeded reset) and the same actions give the same physics, controller, task and
    wrapper state (``Monitor``'s running return included).  Checkpoints store it for every
    training env (:mod:`pyflyt_cli.training.continuity`).

    Cost per step: one copy of the action (a few floats).
    """

    def __init__(self, env: gymnasium.Env) -> None:
        super().__init__(env)
        self._start: dict[str, Any] = {"seed": None, "options": None, "rng": None}
        self._actions: list[np.ndarray] = []

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        self._start = {"seed": seed, "options": options, "rng": None if seed is not None else _rng_state(self.env)}
        self._actions = []
        return self.env.reset(seed=seed, options=options)

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict[str, Any]]:
        self._actions.append(np.array(action, copy=True))
        return self.env.step(action)

    def episode_state(self) -> dict[str, Any]:
        """``{"seed", "options", "rng", "actions"}`` of the episode in progress (actions: (steps, ...) array)."""
        shape = self.action_space.shape or ()
        actions = np.stack(self._actions) if self._actions else np.zeros((0, *shape), self.action_space.dtype)
        return {**self._start, "actions": actions}

    def restore_episode(self, state: dict[str, Any]) -> Any:
        """Rebuild the episode :meth:`episode_state` described; returns its current observation."""
        self.env.reset(seed=0)  # every later reset takes the same (restore-snapshot) path
        if state["seed"] is None:
            _set_rng_state(self.env, state["rng"])
        obs, _ = self.reset(seed=state["seed"], options=state["options"])
        for action in state["actions"]:
            obs, *_ = self.step(action)
        return obs


class EpisodeTaskOptions(gymnasium.Wrapper):
    """Start every episode with the task option values a training curriculum set.

    :meth:`set_task_changes` (called through ``VecEnv.env_method`` by
    :class:`~pyflyt_cli.training.callbacks.TaskCurriculum`) sets them; each later reset
    passes them as ``reset(options={"task": changes})`` (:meth:`UAVEnv.reset
    <pyflyt_engine.envs.env.UAVEnv.reset>`).  The wrapper sits outside
    :class:`ResumableEpisode`, which records those options with the episode, so an episode
    re-simulated after a resume flies the values it started with.
    """

    def __init__(self, env: gymnasium.Env) -> None:
        super().__init__(env)
        self.task_changes: dict[str, Any] = {}

    def set_task_changes(self, changes: dict[str, Any]) -> None:
        """The task option values of the episodes that start from now on ({}: as configured)."""
        self.task_changes = dict(changes)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        if options is None and self.task_changes:
            options = {"task": dict(self.task_changes)}
        return self.env.reset(seed=seed, options=options)


@dataclass(frozen=True)
class EnvFactory:
    """A picklable ``() -> env`` for vectorised training and evaluation environments.

    Attributes:
        config: the environment.
        monitor: add SB3's ``Monitor`` (episode statistics in ``info["episode"]``).
        in_subprocess: the factory runs in a ``SubprocVecEnv`` worker: ignore SIGINT and
            SIGTERM there, so Ctrl-C reaches only the trainer, which stops the run cleanly
            and closes the workers itself.
        render_mode: ``None`` or ``"rgb_array"``.
        record_dir: record every episode to MCAP files in this directory.
        resumable: wrap in :class:`ResumableEpisode` (training envs, whose episodes in
            progress are saved with checkpoints).
        curriculum: wrap (outermost) in :class:`EpisodeTaskOptions` (training envs of a
            run with ``train.curriculum``).
    """

    config: EnvConfig
    monitor: bool = True
    in_subprocess: bool = False
    render_mode: str | None = None
    record_dir: str | None = None
    resumable: bool = False
    curriculum: bool = False

    def __call__(self) -> gymnasium.Env:
        if self.in_subprocess:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
        from pyflyt_engine.envs import make_env

        env: gymnasium.Env = make_env(self.config, render_mode=self.render_mode)
        if self.record_dir is not None:
            from pyflyt_engine.telemetry import RecordEpisode

            env = RecordEpisode(env, Path(self.record_dir), prefix="ep")
        env = wrap_for_agent(env)
        if getattr(self.config, "multi_agent", False):
            if self.monitor:  # training: per-agent slots and statistics (pyflyt_cli.training.multi_agent)
                from pyflyt_cli.training.agent_slots import AgentSlots

                env = AgentSlots(env)
        elif self.monitor:
            from stable_baselines3.common.monitor import Monitor

            env = Monitor(env, info_keywords=("success",))
        if self.resumable:
            env = ResumableEpisode(env)
        if self.curriculum:
            env = EpisodeTaskOptions(env)
        return env


def make_vec_env(config: EnvConfig, n_envs: int, kind: str = "auto", curriculum: bool = False) -> Any:
    """``n_envs`` training environments: a ``SubprocVecEnv`` when ``n_envs > 1`` (``kind="auto"``).

    A multi-agent env gives an :class:`~pyflyt_cli.training.multi_agent.AgentSlotsVecEnv`
    (a slot per agent), its envs in this process for ``"auto"`` and ``"dummy"``, each in its
    own process for ``"subproc"``.

    Seeds are set by the algorithm (``seed + i`` for env ``i``, at the first reset).
    ``env.backend: batched`` gives a :class:`~pyflyt_cli.training.batched.BatchedVecEnv`
    (the ``n_envs`` copies as arrays, seeded by the algorithm's seed).
    ``curriculum``: each env takes per-episode task options (:class:`EpisodeTaskOptions`).
    """
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    backend = getattr(config, "backend", "pybullet")
    if backend == "auto":
        from pyflyt_engine.batched import resolve_backend

        backend = resolve_backend(config)
    if backend == "batched":  # n_envs copies as arrays, in this process
        from pyflyt_cli.training.batched import BatchedVecEnv

        return BatchedVecEnv(config, n_envs)  # a curriculum's task changes go to every env at once
    if getattr(config, "multi_agent", False):
        # one shared policy: a slot per agent; the envs run in this process unless asked for
        # subprocesses (kind="subproc"): an env of N agents already fills N slots
        from pyflyt_cli.training.multi_agent import AgentSlotsVecEnv

        subproc = kind == "subproc"
        factories: list[Callable[[], gymnasium.Env]] = [
            EnvFactory(config, in_subprocess=subproc, resumable=True, curriculum=curriculum) for _ in range(n_envs)
        ]
        return AgentSlotsVecEnv(factories, subprocess=subproc)
    subproc = kind == "subproc" or (kind == "auto" and n_envs > 1)
    factories = [
        EnvFactory(config, in_subprocess=subproc, resumable=True, curriculum=curriculum) for _ in range(n_envs)
    ]
    if subproc:
        return SubprocVecEnv(factories)
    return DummyVecEnv(factories)

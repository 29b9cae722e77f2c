"""The multi-agent task interface: what a task decides for N agents, and the hooks the loop calls.

A multi-agent task is an object, as a single-agent :class:`~pyflyt_engine.envs.tasks.base.Task`
is: it owns the episode's meaning for every agent -- the observation entries beyond the
shared attitude vector, the reward signals (:attr:`MultiAgentTask.provides`, checked
against the reward preset; its own reward terms are registered by its module), the info
entries, termination and success -- and never talks to PyBullet.  The episode core
(:class:`~pyflyt_engine.envs.episode.EpisodeCore`, through the PettingZoo front
:class:`~pyflyt_engine.envs.multi_agent.base.MultiAgentUAVEnv`) builds the world, spawns
the agents, steps the physics, reads contacts and the dome and evaluates the reward
preset; how an agent's step ends its episode is the env config's termination terms
(:mod:`pyflyt_engine.envs.terminations`: contacts crash by :attr:`MultiAgentTask.crash_on_contact`,
the dome, the failures and completion the signals declare, the time limit); the env classes
of the registered ids only name their task and config.

Once, when the env is built: ``MultiAgentTask(options, agents, ...)`` with the resolved
agents (names, teams, spawns, hover points) and ``alive``, the loop's live-agent flags
(updated in place; the task only reads them).  Per episode, in order::

    reset(states)                           # after every agent is placed
    reset_info(i)                           # each agent's entries of the reset info
    observe(i, states)                      # each agent's first task observation
    then per agent step (``live``: the agents that acted):
    update(states, live, collisions, step)  # -> {i: AgentSignals}
    step_info(i, signals)                   # its entries of the agent's info
    observe(i, states)

This is the episode core's per-agent protocol (:class:`~pyflyt_engine.envs.episode.AgentTasks`),
which a single-agent task meets through :class:`~pyflyt_engine.envs.episode.OneAgentTask`.

Here too: :class:`MATaskOptions`, the options every multi-agent task's model extends,
the spawn region of one agent (:class:`SpawnConfig`) and the layouts' grid
(:func:`grid_layout`), and :class:`ResolvedAgent`.  A multi-agent task is a module of
:mod:`pyflyt_engine.envs.tasks` holding its options, its task class, its reward terms and
its registration (:func:`~pyflyt_engine.envs.task_registry.register_task`), as a
single-agent task's (:mod:`.ma_hover`, :mod:`.ma_formation`, :mod:`.dogfight`).

This module imports no PettingZoo, so configs and reward presets are checked without it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from pyflyt_engine.envs.observe import ObservationPart
from pyflyt_engine.envs.task_registry import TaskTable, register_task
from pyflyt_engine.envs.tasks.base import episode_options
from pyflyt_engine.envs.tasks.measures import Measure
from pyflyt_engine.state import KinematicState

Vec3 = tuple[float, float, float]


# ----------------------------------------------------------------- options


class _Options(BaseModel):
    # as every env config model: every float finite, also inside tuples (no .inf / .nan from YAML)
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)


def grid_layout(index: int, count: int, spacing: float, height: float) -> Vec3:
    """Slot ``index`` of ``count`` on a square grid ``spacing`` [m] apart at ``height`` [m],
    centred on the z axis: ``ceil(sqrt(count))`` columns, filled row by row along +x."""
    columns = math.ceil(math.sqrt(count))
    rows = math.ceil(count / columns)
    column, row = index % columns, index // columns
    return ((column - (columns - 1) / 2.0) * spacing, (row - (rows - 1) / 2.0) * spacing, height)


class SpawnConfig(_Options):
    """Where one agent starts: a box around ``position`` and a range of attitudes (the spawn region)."""

    position: Vec3 = Field(description="centre of the spawn region (x, y, z) [m], ground frame")
    position_noise: float = Field(0.1, ge=0, description="each coordinate offset by U(-noise, noise) [m]")
    orientation: Vec3 = Field((0.0, 0.0, 0.0), description="mean attitude (roll, pitch, yaw) [rad]")
    orientation_noise: float = Field(0.1, ge=0, description="each Euler angle offset by U(-noise, noise) [rad]")
    lin_vel: Vec3 = Field((0.0, 0.0, 0.0), description="initial velocity (u, v, w) [m/s], BODY frame")


class MATaskOptions(_Options):
    """Options common to the multi-agent tasks."""

    name: str = Field(description="multi-agent task: ma_hover, ma_formation or dogfight")
    #: agents given by count form this many teams (2: the first half is team 0, the rest team 1)
    teams: ClassVar[int] = 1


@dataclass(frozen=True)
class ResolvedAgent:
    """One agent with every default filled in."""

    name: str
    uav: str
    team: int
    spawn: SpawnConfig
    hover_point: Vec3


# ------------------------------------------------------------------- tasks


@dataclass
class AgentSignals:
    """What a task reports for one live agent after a step."""

    target_distance: float | None = None
    target_distance_rate: float | None = None
    #: the agent passed a waypoint of its own this step (the reward context's ``waypoint_reached``)
    waypoint_reached: bool = False
    #: the agent's job is done: terminate it with success
    complete: bool = False
    #: the task declares the agent lost (e.g. shot down): terminate it as a crash
    failed: bool = False
    extras: dict[str, float] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)


class MultiAgentTask:
    """Base multi-agent task: no observation entries, no signals, crash on any contact.

    Class attributes (as :class:`~pyflyt_engine.envs.tasks.base.Task`'s):
        name: the registry key (``task.name`` of a multi-agent env config).
        Options: the pydantic model of the task's options (``task:`` of the env YAML), a
            :class:`MATaskOptions`.
        provides: names of the reward signals :meth:`update` fills in.
        succeeds_at_time_limit: an agent alive at the time limit succeeded (survival tasks).
        crash_on_contact: any contact of an agent's vehicle (ground or another agent) ends
            its episode as a crash (the ``contact`` termination term's default); a task
            where touching is part of the job sets False.
        episode_options: options an episode may fly with other values through
            ``reset(options={"task": {...}})`` (a training curriculum); only options the
            task reads afresh at every reset or step, never one that shaped the world,
            the spawn layout or the spaces.
        measures: each agent's success measures (:mod:`pyflyt_engine.envs.tasks.measures`),
            whose values for an agent's episode :meth:`episode_measures` gives.

    Args:
        options: the config's ``task`` options.
        agents: every agent, resolved (name, airframe, team, spawn, hover point).
        alive: the loop's (N,) live flags, updated in place by the loop.
        flight_dome_size: the dome's radius [m].
        agent_hz: the agent rate [Hz].
        max_steps: agent steps of an episode.
    """

    name: ClassVar[str] = "base"
    #: the registry's kind of task (:mod:`pyflyt_engine.envs.task_registry`): N agents
    task_kind: ClassVar[Literal["single", "multi"]] = "multi"
    Options: ClassVar[type[MATaskOptions]] = MATaskOptions
    provides: ClassVar[frozenset[str]] = frozenset()
    succeeds_at_time_limit: ClassVar[bool] = False
    crash_on_contact: ClassVar[bool] = True
    episode_options: ClassVar[frozenset[str]] = frozenset()
    measures: ClassVar[tuple[Measure, ...]] = ()

    def __init__(
        self,
        options: MATaskOptions,
        agents: Sequence[ResolvedAgent],
        alive: np.ndarray,
        *,
        flight_dome_size: float,
        agent_hz: float,
        max_steps: int,
    ) -> None:
        self.options = options
        #: the options of the env config; :attr:`options` are the ones of the episode
        self.configured = options
        self._episode_changes: dict[str, Any] = {}
        self.agents = list(agents)
        self.alive = alive
        self.teams = np.array([a.team for a in self.agents], dtype=np.int64)
        self.flight_dome_size = float(flight_dome_size)
        self.dome_squared = self.flight_dome_size**2
        self.agent_dt = 1.0 / float(agent_hz)
        self.max_steps = int(max_steps)

    def set_episode_options(self, changes: dict[str, Any] | None) -> None:
        """Fly the next episodes with ``changes`` to the configured options (None or ``{}``: as
        configured); called by the loop before the agents are placed.

        Raises:
            ValueError: an option not in :attr:`episode_options`, or a value the options'
                model rejects (the message names it).
        """
        changes = dict(changes or {})
        if changes == self._episode_changes:
            return
        self.options = episode_options(self.name, self.episode_options, type(self.configured), self.configured, changes)
        self._episode_changes = changes

    def extra_size(self) -> int:
        """Observation entries each agent gets after the shared attitude vector."""
        return 0

    def observation_parts(self) -> tuple[ObservationPart, ...]:
        """What the :meth:`extra_size` entries after the attitude vector hold, in order (a
        test checks that they add up for every shipped config; the env manuals are written
        from them)."""
        return ()

    def reset(self, states: list[KinematicState]) -> None:
        """Start an episode with every agent placed in ``states``."""

    def update(
        self, states: list[KinematicState], live: list[int], collisions: dict[int, bool], step: int
    ) -> dict[int, AgentSignals]:
        """Advance one agent step (``step`` agent steps since the reset, this one included)."""
        return {i: AgentSignals() for i in live}

    def observe(self, i: int, states: list[KinematicState]) -> np.ndarray:
        """Agent ``i``'s entries after its attitude vector (:meth:`extra_size` of them)."""
        return np.zeros(0)

    def observation(self, i: int, attitude: np.ndarray, states: list[KinematicState]) -> Any:
        """Agent ``i``'s whole observation: its attitude vector, then :meth:`observe`'s entries
        (what the episode core asks, :class:`~pyflyt_engine.envs.episode.AgentTasks`)."""
        return np.concatenate((attitude, self.observe(i, states)))

    def step_info(self, i: int, signals: AgentSignals) -> dict[str, Any]:
        """Agent ``i``'s task entries of a step's info: its signals' ``info``."""
        return signals.info

    def reset_info(self, i: int) -> dict[str, Any]:
        """Agent ``i``'s task entries of the reset info."""
        return {}

    def episode_measures(self, i: int) -> dict[str, float]:
        """Agent ``i``'s values of :attr:`measures` for its episode so far (reported as
        ``info["measures"]`` of the step that ends its episode); computing them must not
        change the episode."""
        return {}

    def markers(self) -> np.ndarray:
        """Ground-frame points drawn when rendering and recorded in the scene, ``(n, 3)``."""
        return np.zeros((0, 3))

    def episode_success(self, successes: np.ndarray) -> bool:
        """Whether an episode whose agents' own outcomes were ``successes`` (N,) succeeded: all of them."""
        return bool(successes.all())


#: multi-agent task name -> task class: a live view of the task registry
#: (:mod:`pyflyt_engine.envs.task_registry`; ``del MA_TASK_CLASSES[name]`` unregisters)
MA_TASK_CLASSES: TaskTable[type[MultiAgentTask]] = TaskTable("multi", "task")


def register_ma_task(task: type[MultiAgentTask], **kwargs: Any) -> type[MultiAgentTask]:
    """Make ``task`` the class that runs ``task.name`` (with its options model ``task.Options``);
    returns it, so it can decorate.  :func:`pyflyt_engine.envs.task_registry.register_task`
    for a multi-agent task (keywords as there: ``env``, ``oracles``, ``name``).

    Raises:
        TypeError: ``task`` is not a :class:`MultiAgentTask` subclass.
    """
    if not (isinstance(task, type) and issubclass(task, MultiAgentTask)):
        raise TypeError(f"register_ma_task needs a MultiAgentTask subclass, got {task!r}")
    return register_task(task, **kwargs)


__all__ = [
    "MA_TASK_CLASSES",
    "AgentSignals",
    "MATaskOptions",
    "MultiAgentTask",
    "ResolvedAgent",
    "SpawnConfig",
    "Vec3",
    "grid_layout",
    "register_ma_task",
]

"""The episode core: the one loop every env runs, for one agent or N.

An env's *front* -- the Gymnasium :class:`~pyflyt_engine.envs.env.UAVEnv` (one agent) or
the PettingZoo :class:`~pyflyt_engine.envs.multi_agent.base.MultiAgentUAVEnv` (N agents)
-- builds the episode (:func:`~pyflyt_engine.envs.build.build_episode`), starts it
(:func:`~pyflyt_engine.envs.build.reset_episode`) and speaks its API; everything between
an action and the next observation is here, once::

    act(i, action)            each acting agent: clip to the bounds, set the flight mode's setpoint
    advance()                 step the physics once for everybody; count the agent step
    judge(live, states)       per acting agent, in agent order: contacts, the dome, the task's
                              signals, the env config's termination terms (crash, end,
                              truncate: pyflyt_engine.envs.terminations), the reward preset,
                              success, the info (with the task's success measures on an
                              agent's last step)
    observe(i, states)        per acting agent: the observation terms the config's sections
                              bind (pyflyt_engine.envs.observe: the delayed state, the sensors'
                              or estimator's view), the attitude vector, the task's
                              observation, camera image and range scans
    check(...)                never NaN: a non-finite observation or reward raises

The task is asked through one per-agent protocol, :class:`AgentTasks`: a multi-agent
task (:class:`~pyflyt_engine.envs.tasks.multi.MultiAgentTask`) implements it for
its N agents, and a single-agent :class:`~pyflyt_engine.envs.tasks.base.Task` is seen
through it by :class:`OneAgentTask`, the N = 1 case.  What stays with the fronts is what
their APIs differ in: Gymnasium returns one agent's tuple and lets the caller reset;
PettingZoo returns dicts of the live agents and retires an agent whose episode ended
(its vehicle is disarmed and falls).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from pyflyt_engine.envs import build
from pyflyt_engine.envs.guard import all_finite, divergence_error
from pyflyt_engine.envs.observe import Observation, attitude_vector
from pyflyt_engine.envs.rewards import RewardFunction
from pyflyt_engine.envs.step import AgentStep, clip_action, step_context
from pyflyt_engine.envs.terminations import Terminations, bind_terminations, outside_dome
from pyflyt_engine.envs.tasks.base import Task
from pyflyt_engine.envs.tasks.measures import INFO_KEY as MEASURES
from pyflyt_engine.state import KinematicState


class AgentTasks(Protocol):
    """What the episode core asks of the task, agent by agent.

    ``signals`` are the task's per-agent step quantities: ``target_distance``,
    ``target_distance_rate``, ``waypoint_reached``, ``complete``, ``failed``, ``extras``
    (the reward context reads them).
    """

    @property
    def succeeds_at_time_limit(self) -> bool:
        """An agent alive at the time limit succeeded (survival tasks)."""
        ...

    @property
    def crash_on_contact(self) -> bool:
        """A contact of an agent's vehicle is a crash (the ``contact`` termination term's default)."""
        ...

    def update(
        self, states: list[KinematicState], live: list[int], collisions: dict[int, bool], step: int
    ) -> dict[int, Any]:
        """Advance one agent step (``step`` agent steps since the reset, this one included);
        the signals of every agent in ``live``."""
        ...

    def observation(self, i: int, attitude: np.ndarray, states: list[KinematicState]) -> Any:
        """Agent ``i``'s observation built on its attitude vector."""
        ...

    def step_info(self, i: int, signals: Any) -> dict[str, Any]:
        """Agent ``i``'s task entries of a step's info."""
        ...

    def reset_info(self, i: int) -> dict[str, Any]:
        """Agent ``i``'s task entries of the reset info."""
        ...

    def episode_measures(self, i: int) -> dict[str, float]:
        """Agent ``i``'s success measures of the episode so far (``info["measures"]`` of
        the step that ends its episode; :mod:`pyflyt_engine.envs.tasks.measures`)."""
        ...


class OneAgentTask:
    """A single-agent :class:`~pyflyt_engine.envs.tasks.base.Task` as the core's per-agent
    protocol (:class:`AgentTasks`) with one agent, index 0."""

    __slots__ = ("task",)

    def __init__(self, task: Task) -> None:
        self.task = task

    @property
    def succeeds_at_time_limit(self) -> bool:
        return self.task.succeeds_at_time_limit

    @property
    def crash_on_contact(self) -> bool:
        return self.task.crash_on_contact

    def update(
        self, states: list[KinematicState], live: list[int], collisions: dict[int, bool], step: int
    ) -> dict[int, Any]:
        return {0: self.task.update(states[0])}

    def observation(self, i: int, attitude: np.ndarray, states: list[KinematicState]) -> Any:
        return self.task.observe(attitude, states[0])

    def step_info(self, i: int, signals: Any) -> dict[str, Any]:
        return self.task.info()

    def reset_info(self, i: int) -> dict[str, Any]:
        return self.task.info()

    def episode_measures(self, i: int) -> dict[str, float]:
        return self.task.episode_measures()


class EpisodeCore:
    """The loop both fronts inherit (see the module docstring); a front calls
    :meth:`_init_core` once its episode is built, :meth:`_reset_core` at each reset and
    :meth:`_act`, :meth:`_advance`, :meth:`_judge`, :meth:`_observe` at each step.

    Attributes the fronts and recorders share (per agent ``i`` in agent order):
    ``world``, ``vehicles``, ``task``, ``reward_function``, ``randomizer``,
    ``agent_payloads``/``obstacles`` and ``last_randomization``; the core's own state is
    ``_actions`` (N, A), ``_steps``, ``_reward_terms`` and ``_alive``; ``terminations`` are
    the env config's termination terms bound to this episode.
    """

    config: Any
    world: Any
    vehicles: list[Any]
    reward_function: RewardFunction
    #: the agent names errors give (None: one agent, the single-agent wording)
    _agent_names: Sequence[str] | None = None

    def _init_core(
        self,
        cfg: Any,
        parts: build.EpisodeParts,
        tasks: AgentTasks,
        reward_function: RewardFunction,
        *,
        info_reward_terms: bool,
        agent_names: Sequence[str] | None = None,
        alive: np.ndarray | None = None,
    ) -> None:
        """Take over what :func:`~pyflyt_engine.envs.build.build_episode` built; ``alive``: the
        (N,) live flags to keep up to date (a multi-agent task reads them), else new ones."""
        self.config = cfg
        #: what the episode flies (:class:`~pyflyt_engine.envs.build.EpisodeParts`)
        self._parts = parts
        self.world = parts.world
        #: the agents' vehicles, in agent order (a front may wrap them: the core drives these)
        self.vehicles = list(parts.vehicles)
        #: the task, asked agent by agent (:class:`AgentTasks`)
        self.tasks = tasks
        self.reward_function = reward_function
        self._agent_names = agent_names
        self._agent_dt = 1.0 / cfg.agent_hz
        self._low = np.array(cfg.action.low, dtype=np.float64)
        self._high = np.array(cfg.action.high, dtype=np.float64)
        self._quaternion = cfg.angle_representation == "quaternion"
        self._dome2 = cfg.flight_dome_size**2
        self._max_steps = cfg.max_steps
        n = len(self.vehicles)
        self._actions = np.zeros((n, self._low.size))
        self._steps = 0
        self._alive = alive if alive is not None else np.zeros(n, dtype=bool)
        self._reward_terms: list[dict[str, float]] = [{} for _ in range(n)]
        #: per agent, its AgentStep record: what its last step was (rewritten by each :meth:`_judge`)
        self._agent_steps = [
            AgentStep(i, None, self._actions[i], False, False, None, 0)  # type: ignore[arg-type]  # (set at each step)
            for i in range(n)
        ]
        #: put each agent's reward breakdown into its step info as ``reward_terms``
        self.info_reward_terms = bool(info_reward_terms)
        #: the values drawn at the last reset (empty without randomisation)
        self.last_randomization: dict[str, float] = {}
        #: action and observation delays in physics steps, every vehicle (docs/engine.md, "Latency");
        #: with ``randomize.action_delay`` / ``observation_delay``, this episode's (set at each reset)
        self.latency_steps = parts.latency_steps
        #: per agent, the index of its observation camera on its vehicle (None without ``camera_observation``)
        self.cameras = parts.cameras
        #: per agent, the sensors its observation is built from (``config.sensors.observe``; None: true states)
        self.sensed = parts.sensed
        #: per agent, its flight controller's state estimator its observation is built from (None: none)
        self.estimators = parts.estimators
        #: per agent, whether its position fix's validity flag follows its auxiliary state
        self.fix_flag = parts.fix_flag
        #: per agent, the range sensors observed (every one its airframe carries), in spec order
        self.range_sensors = parts.range_sensors
        #: per agent, its copy of the config's payloads; empty without payloads
        self.agent_payloads = parts.payloads
        #: the config's obstacles (None without): fixed ones built with the world, layouts drawn at each reset
        self.obstacles = parts.obstacles
        #: samples and applies ``config.randomize`` at each reset (None without)
        self.randomizer = parts.randomizer
        #: the config's termination terms bound to this episode (pyflyt_engine.envs.terminations)
        self.terminations: Terminations = bind_terminations(cfg.terminations, self)
        #: the observation terms the config's sections bind (pyflyt_engine.envs.observe); rebound at each reset
        self.observation = Observation(self)

    # ------------------------------------------------------------------ reset

    def _reset_core(
        self, seed: int | None, rng: np.random.Generator, spawn: Any, start_task: Any
    ) -> list[KinematicState]:
        """Start an episode (:func:`~pyflyt_engine.envs.build.reset_episode`): every agent
        alive, no action yet, step 0; the vehicles' states."""
        self._actions[:] = 0.0
        self._steps = 0
        self._reward_terms = [{} for _ in self._reward_terms]
        self._alive[:] = True
        drawn, states = build.reset_episode(self._parts, seed, rng, spawn, start_task)
        self.last_randomization = dict(drawn) if drawn is not None else {}
        self.latency_steps = self.vehicles[0].latency  # this episode's (one draw, every agent)
        self.observation.reset()
        return states

    def _reset_info(self, i: int) -> dict[str, Any]:
        """Agent ``i``'s info at a reset."""
        info: dict[str, Any] = {"collision": False, "out_of_bounds": False, "env_complete": False, "success": False}
        for event in self._parts.events:  # their info entries (randomization)
            event.reset_info(info)
        self.terminations.reset_info(i, info)  # the terms' entries (payload_ground_contact, ...)
        info.update(self.tasks.reset_info(i))
        return info

    # ------------------------------------------------------------------- step

    def _act(self, i: int, action: Any) -> None:
        """Agent ``i``'s action, clipped to the bounds, as its flight mode's setpoint."""
        agent = self._agent_names[i] if self._agent_names is not None else None
        a = clip_action(action, self._low, self._high, self.config.action.names, agent=agent)
        self.vehicles[i].set_setpoint(a)
        self._actions[i] = a

    def _advance(self) -> list[KinematicState]:
        """One agent step of the physics for every vehicle; their states after it."""
        self.world.step()
        self._steps += 1
        return [v.state for v in self.vehicles]

    def _judge(self, live: list[int], states: list[KinematicState]) -> list[tuple[float, bool, bool, dict[str, Any]]]:
        """``(reward, terminated, truncated, info)`` of each agent in ``live`` (in that order)
        after :meth:`_advance`.

        Episode end: the env config's termination terms (:mod:`pyflyt_engine.envs.terminations`,
        declared in order under ``terminations``): *terminated* when a ``crash`` term holds (a
        contact, leaving the dome, a failure the task declares, a payload on the ground, an
        obstacle touched ...) or an ``end`` term does (the task completes); *truncated* when a
        ``truncate`` term holds (the time limit) and the episode did not terminate.
        """
        world = self.world
        tasks = self.tasks
        collisions = {i: world.collided(i) for i in live}
        steps = self._steps
        signals = tasks.update(states, live, collisions, steps)
        remaining = max(self._max_steps - steps, 0)
        terms = self.terminations
        results = []
        for i in live:
            state = states[i]
            sig = signals[i]
            step = self._agent_steps[i]  # the agent's record, rewritten each step (cheaper than a new one)
            step.state = state
            step.action = self._actions[i]
            step.collision = collisions[i]
            step.out_of_bounds = outside_dome(state, self._dome2)
            step.signals = sig
            step.steps = steps
            entries: dict[str, Any] = {}  # the terms' own info entries
            crashed = False
            for judge in terms.crash:
                if judge(step, entries):
                    crashed = True
            terminated = crashed
            for judge in terms.end:
                if judge(step, entries):
                    terminated = True
            cut = False
            for judge in terms.truncate:
                if judge(step, entries):
                    cut = True
            truncated = cut and not terminated
            ctx = step_context(world, step, crashed=crashed, steps_remaining=remaining, agent_dt=self._agent_dt)
            reward, reward_terms = self.reward_function(ctx)
            self._reward_terms[i] = reward_terms
            info = {
                "collision": step.collision,
                "out_of_bounds": step.out_of_bounds,
                "env_complete": sig.complete,
                "success": (sig.complete and not crashed) or (truncated and tasks.succeeds_at_time_limit),
                **tasks.step_info(i, sig),
            }
            if entries:
                info.update(entries)
            if self.info_reward_terms:
                info["reward_terms"] = reward_terms
            if terminated or truncated:  # the episode's success measures, on its last step
                info[MEASURES] = tasks.episode_measures(i)
            results.append((reward, terminated, truncated, info))
        return results

    def _observe(self, i: int, states: list[KinematicState]) -> Any:
        """Agent ``i``'s observation of ``states`` (every agent's, in agent order), built by
        the observation terms bound to this episode (:class:`~pyflyt_engine.envs.observe.Observation`):
        the source's states and aux, each view's, the attitude vector and the task's
        observation, then each extra's entries."""
        terms = self.observation
        if terms.source is None:
            aux = self.vehicles[i].aux_values()
        else:
            states, aux = terms.source(i, states)
        for view in terms.views:
            states, aux = view(i, states, aux)
        attitude = attitude_vector(states[i], self._quaternion, self._actions[i].tolist(), aux)
        observation = self.tasks.observation(i, attitude, states)
        for extra in terms.extras:
            observation = extra(i, observation)
        return observation

    def _check(self, i: int, observation: Any, reward: float, state: KinematicState) -> None:
        """Never NaN: raise :class:`~pyflyt_engine.errors.SimulationError` if agent ``i``'s
        observation or reward is not finite."""
        if not all_finite(reward, observation):
            self._diverged(i, observation, reward, state)

    def _diverged(self, i: int, observation: Any, reward: float, state: KinematicState) -> None:
        """Raise :class:`SimulationError` describing a non-finite observation or reward."""
        where = self.config.id or self.config.source or "the environment"
        agent = self._agent_names[i] if self._agent_names is not None else None
        raise divergence_error(
            where, self._steps, observation, reward, state, self.vehicles[i], self._actions[i], agent=agent
        )

    @property
    def elapsed_steps(self) -> int:
        """Agent steps since the last reset."""
        return self._steps

"""The multi-agent front: several vehicles in one World, one PettingZoo ``ParallelEnv``.

:class:`MultiAgentUAVEnv` is the N-agent front of the episode core
(:class:`~pyflyt_engine.envs.episode.EpisodeCore`, whose one-agent front is the Gymnasium
:class:`~pyflyt_engine.envs.env.UAVEnv`): the core builds the world from a
:class:`~pyflyt_engine.envs.config.MultiAgentEnvConfig`, spawns each agent in its region,
applies each live agent's action, steps the physics once for everybody, detects contacts
and dome exits, evaluates the reward preset per agent and builds the observations -- and
asks the task object (a :class:`~pyflyt_engine.envs.tasks.multi.MultiAgentTask`; the
shipped ones in :mod:`pyflyt_engine.envs.tasks`: ``ma_hover``, ``ma_formation``,
``dogfight``) for everything the episode means: the observation entries beyond the shared attitude vector, the per-agent
reward signals, termination, info entries and success.  This front speaks PettingZoo's
API and retires agents whose episode ended.  The env classes of the registered ids
(:mod:`.hover`, :mod:`.formation`, :mod:`.dogfight`) only name their task and config.

PettingZoo conventions: ``possible_agents`` never changes; ``agents`` lists the live
ones; ``step`` takes an action for every live agent and returns observations, rewards,
terminations, truncations and infos for exactly those agents; an agent whose episode
ended is dropped from ``agents`` after that step (its vehicle is disarmed and falls, and
remains a body others can hit).  The episode is over when ``agents`` is empty.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv

from pyflyt_engine.envs import build, observe
from pyflyt_engine.envs.config import MultiAgentEnvConfig, ResolvedAgent, RewardPreset, load_reward_preset
from pyflyt_engine.envs.episode import EpisodeCore
from pyflyt_engine.envs.multi_agent.config import get_ma_task
from pyflyt_engine.envs.rewards import RewardFunction
from pyflyt_engine.envs.tasks.base import Spawn
from pyflyt_engine.envs.tasks.multi import AgentSignals, MultiAgentTask
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.payloads import PayloadSet, PayloadSets
from pyflyt_engine.spec import UAVSpec, check_identifier, load_uav_spec
from pyflyt_engine.state import KinematicState


__all__ = ["AgentSignals", "MultiAgentUAVEnv"]


class MultiAgentUAVEnv(EpisodeCore, ParallelEnv):
    """The multi-agent front of the episode core (see the module docstring and each registered env's manual).

    Runs the task its class names (:attr:`task_class`) or, for this class itself, the one
    the config names (``MultiAgentUAVEnv("my_swarm.yaml")``).  Every agent flies the
    config's keys as the single-agent env does (docs/multi_agent.md): with
    ``sensors`` (``observe``) its own rates and position are its sensors' readings; with
    ``camera_observation`` or ``range_sensors`` its observation is a ``Dict`` (the vector
    under ``attitude``, its own image and scans under their keys); with ``payloads`` it
    carries its own copy of each (``agent_payloads``; one failing on the ground ends its
    episode, ``info["payload_ground_contact"]``).

    Args:
        config: env config name (``conf/env``), YAML path, mapping or config object; default
            the class's ``config_name``.
        sparse_reward: shortcut for ``reward="sparse"`` / ``reward="dense"``.
        render_mode: None, ``"rgb_array"`` (headless chase camera on the first live agent)
            or ``"human"`` (PyBullet GUI).
        info_reward_terms: put each agent's reward breakdown in its info as ``reward_terms``.
        airframe: a loaded airframe flown instead of the config's ``uav`` (by every agent
            that does not name its own), e.g. the one a recording carries.
        airframes: loaded airframes flown instead of the files the agents name (the name an
            agent gives -> its spec), e.g. those a recording carries: nothing is read for them.
        **overrides: any top-level config field (``agents=8``, ``agent_hz=60``) or task option.
    """

    metadata: dict[str, Any] = {
        "render_modes": ["human", "rgb_array"],
        "name": "ma_uav",
        "is_parallelizable": True,
        "render_fps": 30,
    }
    config_name: ClassVar[str | None] = None
    #: the task this env runs (None: the one the config names, from the task registry,
    #: :mod:`pyflyt_engine.envs.task_registry`)
    task_class: ClassVar[type[MultiAgentTask] | None] = None

    def __init__(
        self,
        config: str | Path | Mapping[str, Any] | MultiAgentEnvConfig | None = None,
        *,
        sparse_reward: bool | None = None,
        render_mode: str | None = None,
        info_reward_terms: bool = True,
        airframe: UAVSpec | None = None,
        airframes: Mapping[str, UAVSpec] | None = None,
        **overrides: Any,
    ) -> None:
        cfg = build.load_config(config, self.config_name, type(self).__name__, sparse_reward, overrides)
        if not isinstance(cfg, MultiAgentEnvConfig):
            raise ConfigError(
                f"{type(self).__name__} needs a multi-agent env config (one with 'agents'), got {cfg.source}"
            )
        task_cls = self.task_class if self.task_class is not None else get_ma_task(cfg.task.name)
        if cfg.task.name != task_cls.name:
            raise ConfigError(
                f"{type(self).__name__} runs task '{task_cls.name}', the config declares '{cfg.task.name}'"
            )
        build.check_render_mode(render_mode, self.metadata["render_modes"])
        self.config: MultiAgentEnvConfig = cfg
        self.render_mode = render_mode
        self.metadata = {**type(self).metadata, "render_fps": cfg.agent_hz}
        self.agent_list: list[ResolvedAgent] = cfg.resolved_agents()
        self.possible_agents: list[str] = [a.name for a in self.agent_list]
        self.agents: list[str] = []
        self.agent_index: dict[str, int] = {name: i for i, name in enumerate(self.possible_agents)}
        self.teams = np.array([a.team for a in self.agent_list], dtype=np.int64)

        self.reward_preset: RewardPreset = load_reward_preset(cfg.reward_preset_name())
        self.reward_function: RewardFunction = self.reward_preset.compile(task_cls.provides, cfg.task.name)
        #: the airframe of ``config.uav`` (agents naming no airframe of their own fly it)
        self.airframe: UAVSpec = airframe if airframe is not None else load_uav_spec(cfg.uav)
        specs: dict[str, UAVSpec] = {**(airframes or {}), cfg.uav: self.airframe}
        for agent in self.agent_list:
            if agent.uav not in specs:
                specs[agent.uav] = load_uav_spec(agent.uav)
        # the World, each agent's payloads (each named ``<agent>-<payload>``), the obstacles,
        # latency, sensors, estimators, range sensors and randomiser: as for a single agent
        parts = build.build_episode(
            cfg,
            [specs[a.uav] for a in self.agent_list],
            [(a.spawn.position, a.spawn.orientation) for a in self.agent_list],
            render=render_mode == "human",
            agent_names=self.possible_agents,
            payload_name=lambda i, payload: _payload_name(self.possible_agents[i], i, payload),
        )
        #: per agent, its copy of the config's payloads (each named ``<agent>-<payload>``), built
        #: around its vehicle; empty without payloads
        self.agent_payloads: list[PayloadSet] = parts.payloads
        #: every agent's payloads as one (what the recorder reads; None without payloads)
        self.payloads: PayloadSets | None = PayloadSets(self.agent_payloads) if self.agent_payloads else None
        # the task, then the episode core (pyflyt_engine.envs.episode), which runs the step
        n = len(self.possible_agents)
        self._alive = np.zeros(n, dtype=bool)
        #: the task object: observation entries, signals, termination, info, success
        self.task: MultiAgentTask = task_cls(
            cfg.task,
            self.agent_list,
            self._alive,
            flight_dome_size=cfg.flight_dome_size,
            agent_hz=cfg.agent_hz,
            max_steps=cfg.max_steps,
        )
        self._init_core(
            cfg,
            parts,
            self.task,
            self.reward_function,
            info_reward_terms=info_reward_terms,
            agent_names=self.possible_agents,
            alive=self._alive,
        )
        aux = {v.aux_state.size + int(flag) for v, flag in zip(self.vehicles, self.fix_flag)}
        if len(aux) > 1:
            self.world.close()
            sizes = ", ".join(
                f"{v.spec.name}: {v.aux_state.size + int(f)}" for v, f in zip(self.vehicles, self.fix_flag)
            )
            raise ConfigError(
                "agents: every agent must observe the same number of values (one policy is shared): their airframes' "
                f"auxiliary states differ in size ({sizes}); "
                "mix airframes of the same kind (e.g. quadrotors) and sensors (a position fix adds its validity flag)"
            )
        self._check_layout_spacing()
        self.attitude_size = observe.attitude_size(self._quaternion, len(cfg.action.names), aux.pop())
        size = self.attitude_size + self.task.extra_size()
        obs_space: spaces.Space = spaces.Box(-np.inf, np.inf, shape=(size,), dtype=np.float64)
        if cfg.camera_observation is not None:
            obs_space = observe.with_image_space(obs_space, cfg.camera_observation)
        if any(self.range_sensors):
            layouts = {tuple((r.name, r.shape, r.max_range) for r in sensors) for sensors in self.range_sensors}
            if len(layouts) > 1:
                self.world.close()
                raise ConfigError(
                    "agents: every agent must observe the same range sensors (one policy is shared): their airframes "
                    "carry different ones; give the range sensors in the env config's range_sensors only"
                )
            obs_space = observe.with_range_spaces(obs_space, self.range_sensors[0])
        act_space = spaces.Box(self._low, self._high, dtype=np.float64)
        # one space object per agent, the same object at every call (PettingZoo's api_test checks it)
        self.observation_spaces = {name: obs_space for name in self.possible_agents}
        self.action_spaces = {name: act_space for name in self.possible_agents}

        self.np_random, _ = seeding.np_random(None)
        self._markers = None
        if render_mode is not None and len(self.markers()):
            from pyflyt_engine.envs.render import Markers

            self._markers = Markers(self.world.client, len(self.markers()), 0.05)

    def _check_layout_spacing(self) -> None:
        """Agents the task's layout places (``agents`` given by count) must spawn clear of each other.

        The rule: the closest two layout centres are at least ``2 rho + 2 sqrt(3) noise``
        apart, with ``rho`` the largest distance from an agent's centre of mass to a corner
        of its collision bounding box (PyBullet, at the level spawn attitude) and ``noise``
        the layout's ``position_noise`` (each agent can move ``sqrt(3) noise`` off its
        centre).  Listed agents are placed by the user and not checked.
        """
        cfg = self.config
        gap_of = getattr(cfg.task, "layout_gap", None)
        if gap_of is None or not isinstance(cfg.agents, int):
            return
        gap = gap_of(cfg.agents)
        if gap is None:
            return
        from pyflyt_engine.bullet import pybullet as p

        radius = 0.0
        cid = self.world.client
        for vehicle in self.vehicles:
            links = range(-1, p.getNumJoints(vehicle.body_id, physicsClientId=cid))
            boxes = [p.getAABB(vehicle.body_id, link, physicsClientId=cid) for link in links]
            centre = vehicle.spawn_position
            corner = [max(abs(b[k][axis] - centre[axis]) for b in boxes for k in (0, 1)) for axis in range(3)]
            radius = max(radius, math.sqrt(corner[0] ** 2 + corner[1] ** 2 + corner[2] ** 2))
        noise = float(getattr(cfg.task, "position_noise", 0.0))
        need = 2.0 * radius + 2.0 * math.sqrt(3.0) * noise
        if gap < need:
            self.world.close()
            layout = getattr(cfg.task, "layout", "grid")
            layout = layout if isinstance(layout, str) else "grid"
            if layout == "ring":
                fix = (
                    f"raise task.layout_radius to at least {need / (2.0 * math.sin(math.pi / cfg.agents)):.3f} m, "
                    f"or use task.layout: grid with task.layout_spacing >= {need:.3f} m"
                )
            else:
                fix = f"raise task.layout_spacing to at least {need:.3f} m"
            raise ConfigError(
                f"agents: {cfg.agents} agents on the {layout} layout spawn {gap:.3f} m apart, but they need "
                f"{need:.3f} m not to touch (2 x {radius:.3f} m airframe bounding radius + 2 sqrt(3) x "
                f"task.position_noise {noise:g} m); {fix}, or lower task.position_noise"
            )

    # --------------------------------------------------------------- spaces

    def observation_layout(self, quaternion: bool | None = None) -> observe.ObservationLayout:
        """The declared parts of every agent's observation space (one layout, shared by all):
        entry key -> its parts (key ``observe.FLAT``: a Box), the attitude vector then the
        task's :meth:`~pyflyt_engine.envs.tasks.multi.MultiAgentTask.observation_parts`;
        ``quaternion`` as for :meth:`UAVEnv.observation_layout
        <pyflyt_engine.envs.env.UAVEnv.observation_layout>`."""
        cfg = self.config
        q = self._quaternion if quaternion is None else quaternion
        aux = self.vehicles[0].aux_layout()
        attitude = observe.attitude_parts(q, cfg.action.names, cfg.action.units, aux, self.fix_flag[0])
        layout = {observe.FLAT: (*attitude, *self.task.observation_parts())}
        return observe.layout_with_extras(layout, cfg.camera_observation, self.range_sensors[0])

    def observation_space(self, agent: str) -> spaces.Space:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        return self.action_spaces[agent]

    @property
    def num_agents_total(self) -> int:
        return len(self.possible_agents)

    # ------------------------------------------------------------ pettingzoo

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode: every agent alive, spawned in its region (drawn in agent order).

        With ``config.randomize``, its entries are drawn first (as in the single-agent env),
        once per reset, and applied to every agent: the airframe factors to each vehicle's
        own nominal values, the ``spawn_*`` offsets to each agent's spawn, ``wind.*`` to the
        one atmosphere.  ``options``: ``None``, or ``{"task": {...}}`` with options the task
        lets an episode change (its ``episode_options``: dogfight ``lethal_distance``,
        ``lethal_angle``, ``damage_per_second``; formation ``tolerance``, ``separation``;
        hover none), as a single-agent env's; any other change is refused (``ValueError``)
        rather than ignored, and the next reset without them flies the configured task.
        ``action_delay`` / ``observation_delay`` apply to every vehicle (the agents share one
        draw of each delay, as of every other parameter).  Other keys (PettingZoo's API test
        passes ``{"options": 1}``) are ignored with a warning.
        """
        changes = None
        if options:
            if not isinstance(options, Mapping):
                raise ValueError(f'reset options must be None or {{"task": {{option: value}}}}, got {options!r}')
            changes = build.task_changes({"task": options["task"]}) if "task" in options else None
            other = sorted(str(k) for k in options if k != "task")
            if other:  # PettingZoo's API test passes {"options": 1}: accepted, but never silently
                warnings.warn(
                    f"{type(self).__name__}.reset: options {', '.join(other)} mean nothing to this env and are "
                    'ignored (it takes {"task": {...}} only)',
                    stacklevel=2,
                )
        self.task.set_episode_options(changes)
        if seed is not None:
            self.np_random, _ = seeding.np_random(seed)
        states = self._reset_core(seed, self.np_random, self._spawn, self._start_task)
        if self._markers is not None:
            self._markers.show(self.markers())
        observations = {name: self._observe(i, states) for i, name in enumerate(self.possible_agents)}
        infos = {name: self._reset_info(i) for i, name in enumerate(self.possible_agents)}
        return observations, infos

    def step(
        self, actions: Mapping[str, Any]
    ) -> tuple[dict[str, Any], dict[str, float], dict[str, bool], dict[str, bool], dict[str, dict[str, Any]]]:
        """One agent step for every live agent (``actions`` must hold one per live agent)."""
        live = [self.agent_index[name] for name in self.agents]
        if not live:
            raise RuntimeError("step() after the episode ended (no live agents): call reset()")
        self._actions[~self._alive] = 0.0  # retired agents receive nothing
        for i in live:
            name = self.possible_agents[i]
            try:
                raw = actions[name]
            except KeyError:
                raise ValueError(f"no action for live agent '{name}' (live: {', '.join(self.agents)})") from None
            self._act(i, raw)
        states = self._advance()
        results = self._judge(live, states)

        observations: dict[str, Any] = {}
        rewards: dict[str, float] = {}
        terminations: dict[str, bool] = {}
        truncations: dict[str, bool] = {}
        infos: dict[str, dict[str, Any]] = {}
        ended = []
        for i, (reward, terminated, truncated, info) in zip(live, results):
            name = self.possible_agents[i]
            rewards[name] = reward
            terminations[name] = terminated
            truncations[name] = truncated
            infos[name] = info
            if terminated or truncated:
                ended.append(i)
        for i in live:
            name = self.possible_agents[i]
            observations[name] = obs = self._observe(i, states)
            self._check(i, obs, rewards[name], states[i])
        for i in ended:  # PettingZoo's way: an agent whose episode ended leaves the episode
            self._alive[i] = False
            self.world.set_armed(i, False)  # a retired vehicle cuts its actuators and falls
        if ended:
            self.agents = [name for name in self.agents if self._alive[self.agent_index[name]]]
        if self._markers is not None:
            self._markers.show(self.markers())
        return observations, rewards, terminations, truncations, infos

    def render(self) -> np.ndarray | None:
        """``rgb_array``: an (H, W, 3) uint8 chase-camera image of the first live agent."""
        if self.render_mode is None:
            return None
        from pyflyt_engine.envs import render as _render

        r = self.config.render
        index = self.agent_index[self.agents[0]] if self.agents else 0
        state = self.vehicles[index].state
        if self.render_mode == "rgb_array":
            return _render.chase_camera(
                self.world.client, state, r.resolution, r.camera_distance, r.camera_height, r.fov
            )
        _render.follow_in_gui(self.world.client, state, r.camera_distance)
        return None

    def close(self) -> None:
        """Disconnect the PyBullet client (idempotent)."""
        if getattr(self, "world", None) is not None:
            self.world.close()

    def state(self) -> np.ndarray:
        """The global state: every vehicle's (ang_vel, quaternion, lin_vel, lin_pos), flattened."""
        return np.concatenate(
            [np.array((*s.ang_vel, *s.quaternion, *s.lin_vel, *s.lin_pos)) for s in (v.state for v in self.vehicles)]
        )

    # ------------------------------------------------------------- helpers

    def _spawn(self, i: int) -> Spawn:
        """Agent ``i``'s spawn this episode: its region's centre and the noise drawn around it."""
        s, rng = self.agent_list[i].spawn, self.np_random
        dp = rng.uniform(-s.position_noise, s.position_noise, 3) if s.position_noise else np.zeros(3)
        da = rng.uniform(-s.orientation_noise, s.orientation_noise, 3) if s.orientation_noise else np.zeros(3)
        return Spawn(np.add(s.position, dp).tolist(), np.add(s.orientation, da).tolist(), lin_vel=s.lin_vel)

    def _start_task(self, states: list[KinematicState]) -> np.ndarray:
        """Every agent alive, the task started on their states; its markers, which obstacles keep clear of."""
        self.agents = list(self.possible_agents)
        self.task.reset(states)
        return self.task.markers()

    def episode_success(self, successes: np.ndarray) -> bool:
        """Whether an episode whose agents' own outcomes were ``successes`` (N,) succeeded (the task decides)."""
        return self.task.episode_success(successes)

    @property
    def alive(self) -> np.ndarray:
        """(N,) bool: which agents are still in the episode (a copy)."""
        return self._alive.copy()

    @property
    def last_actions(self) -> np.ndarray:
        """(N, A): the clipped action each agent's vehicle received at the last step (zeros after a reset or death)."""
        return self._actions.copy()

    @property
    def last_reward_terms(self) -> list[dict[str, float]]:
        """Per agent, the reward breakdown of its last step (empty after a reset)."""
        return [dict(t) for t in self._reward_terms]

    def markers(self) -> np.ndarray:
        """Ground-frame points drawn when rendering and recorded in the scene, ``(n, 3)`` (the task's)."""
        return self.task.markers()


def _payload_name(agent: str, index: int, payload: str) -> str:
    """Agent ``index``'s copy of payload ``payload``: ``<agent>-<payload>`` when that is an
    identifier (every default name), else ``agent<index>-<payload>``."""
    try:
        return check_identifier(f"{agent}-{payload}")
    except ValueError:
        return f"agent{index}-{payload}"

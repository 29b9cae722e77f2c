"""The generic environment: one vehicle in a :class:`World`, a task, a reward preset.

:class:`UAVEnv` is the one-agent front of the episode core
(:class:`~pyflyt_engine.envs.episode.EpisodeCore`), the loop every env runs: what an
episode flies and how it starts (:func:`~pyflyt_engine.envs.build.build_episode`,
:func:`~pyflyt_engine.envs.build.reset_episode`) and each step (act, advance, judge,
observe) are the core's, the same code as for N agents; this front speaks Gymnasium.
The vehicle is the model (named state read-outs, a flight mode that takes the action as
its setpoint), the task decides spawn, targets, extra observations and completion, and
the reward is the weighted sum of the preset's named terms (see
:mod:`pyflyt_engine.envs.rewards`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import gymnasium
import numpy as np
from gymnasium import spaces

from pyflyt_engine.envs import build, observe
from pyflyt_engine.envs.config import EnvConfig, RewardPreset, load_reward_preset
from pyflyt_engine.envs.episode import EpisodeCore, OneAgentTask
from pyflyt_engine.envs.rewards import RewardFunction
from pyflyt_engine.envs.tasks import Task, get_task
from pyflyt_engine.payloads import PayloadSet
from pyflyt_engine.spec import UAVSpec, load_uav_spec
from pyflyt_engine.state import KinematicState
from pyflyt_engine.world import World


#: the live agents of every step: the one agent
_ONE = [0]


class UAVEnv(EpisodeCore, gymnasium.Env):
    """A single-vehicle UAV task as a Gymnasium environment, built from an env config.

    Prefer the registered ids (``gymnasium.make("PyFlyt/QuadX-Hover-v0")``), whose
    manuals ``pyflyt envs <id>`` prints (generated from the config and spaces,
    :mod:`pyflyt_engine.envs.manual`); this class runs any env config, e.g. one written by a
    user: ``UAVEnv("my_env.yaml")``.

    Observation: the task's, built on the shared attitude vector (paper, "Observation
    Spaces")::

        [ang_vel (3, body, rad/s), attitude (3 Euler rad | 4 quaternion xyzw, ground),
         lin_vel (3, body, m/s), lin_pos (3, ground ENU, m), previous action (A), aux (n)]

    where aux is the vehicle's auxiliary state (motor throttles for a multirotor).  With
    ``config.latency``, the action reaches the flight controller ``action_delay`` later and
    the observation shows the vehicle as it was ``observation_delay`` ago (both rounded to
    physics steps); rewards and episode ends use the true state.  ``config.randomize``
    entries ``action_delay`` / ``observation_delay`` draw those delays at every reset
    instead (each replacing its ``latency`` entry; in ``info["randomization"]``).  With
    ``config.sensors`` (``observe: true``), ``ang_vel`` is the noisy gyro's reading,
    ``lin_pos`` the position fix's (its z the barometer's, when there is one), attitude
    and velocity stay true, and the fix's validity flag (0/1) follows aux
    (docs/environments.md, "Sensor observation"); rewards and episode ends use the true
    state.  With ``sensors.estimator: complementary`` attitude, velocity and position come
    from the flight controller's estimator instead (:attr:`estimator`,
    :mod:`pyflyt_engine.components.estimator`; docs/environments.md, "Estimated state").

    Action: ``config.action``, a Box sent (after clipping to its bounds) as the setpoint
    of the vehicle's flight mode ``config.action.mode``.

    Camera image (``config.camera_observation``, optional): the camera is added to the
    airframe for this env, rendered at every step, and the observation becomes a ``Dict``
    with the image (``Box`` uint8, (H, W, C) or (C, H, W), RGB or RGBA) under its key and
    the task's observation under ``attitude`` (or merged, if it is a ``Dict``).

    Payloads (``config.payloads``, optional): rigid bodies attached to the vehicle or the
    world (:mod:`pyflyt_engine.payloads`), placed relative to their parent at every reset;
    a payload touching the ground ends the episode as a crash when it declares
    ``ground_contact_fails`` (``info["payload_ground_contact"]``).

    Episode end: *terminated* on a crash — any contact of the vehicle (ground included;
    unless the task sets ``crash_on_contact = False``), leaving the flight dome
    (``|lin_pos| > flight_dome_size``) or a failure the task declares — or when the task
    completes; *truncated* after ``max_duration_seconds`` of simulated time (the env
    counts its own steps, so no ``TimeLimit`` wrapper is needed or registered).

    Info: ``collision``, ``out_of_bounds``, ``env_complete`` (task completed),
    ``success`` (completed, or reached the time limit uncrashed for survival tasks),
    ``reward_terms`` (the weighted per-entry breakdown, summing to the reward; after
    ``step`` only; left out with ``info_reward_terms=False``) plus the task's entries.
    The breakdown of the last step is also :attr:`last_reward_terms`.

    Never NaN: an observation or reward that is not finite (the physics blew up, e.g. on
    an airframe with absurd parameters) raises :class:`~pyflyt_engine.errors.SimulationError`
    naming the step, the vehicle's state and the action, instead of reaching the learner.

    Args:
        config: env config name (``conf/env``), YAML path, mapping or :class:`EnvConfig`;
            default: the class's ``config_name``.
        sparse_reward: shortcut for ``reward="sparse"`` / ``reward="dense"``.
        render_mode: None, ``"rgb_array"`` (headless chase camera, (H, W, 3) uint8) or
            ``"human"`` (PyBullet GUI; needs a display).
        info_reward_terms: put the reward breakdown into every step's ``info`` as
            ``reward_terms`` (default); False leaves it out: each info entry is pickled
            and merged by subprocess vector envs at every step.
        airframe: a loaded :class:`~pyflyt_engine.spec.UAVSpec` to fly instead of loading
            ``config.uav`` (e.g. the airframe a recording carries); kept as :attr:`airframe`.
        **overrides: any top-level config field (``agent_hz=60``, ``reward="my.yaml"``,
            ``flight_dome_size=4``) or task option (``num_targets=3``).

    Resets restore the PyBullet state saved at the first reset (no rebuild) and are
    deterministic under a seed; ``reset(seed=None)`` continues the current RNG streams.
    """

    metadata: dict[str, Any] = {"render_modes": ["human", "rgb_array"], "render_fps": 30}
    #: env config loaded when none is given (subclasses for registered ids set it)
    config_name: ClassVar[str | None] = None

    def __init__(
        self,
        config: str | Path | Mapping[str, Any] | EnvConfig | None = None,
        *,
        sparse_reward: bool | None = None,
        render_mode: str | None = None,
        info_reward_terms: bool = True,
        airframe: UAVSpec | None = None,
        **overrides: Any,
    ) -> None:
        cfg = build.load_config(config, self.config_name, type(self).__name__, sparse_reward, overrides)
        build.check_render_mode(render_mode, self.metadata["render_modes"])
        self.config: EnvConfig = cfg
        self.render_mode = render_mode
        self.metadata = {**type(self).metadata, "render_fps": cfg.agent_hz}

        # task and reward first: a bad config fails before PyBullet starts
        task_cls = get_task(cfg.task.name)
        self.task: Task = task_cls(cfg.task, flight_dome_size=cfg.flight_dome_size, agent_hz=cfg.agent_hz)
        self.reward_preset: RewardPreset = load_reward_preset(cfg.reward_preset_name())
        self.reward_function: RewardFunction = self.reward_preset.compile(task_cls.provides, task_cls.name)
        #: the airframe flown, before the task adjusts it (:meth:`Task.vehicle_spec`)
        self.airframe: UAVSpec = airframe if airframe is not None else load_uav_spec(cfg.uav)

        parts = build.build_episode(
            cfg,
            [self.task.vehicle_spec(self.airframe)],
            [(cfg.task.start_position, cfg.task.start_orientation)],
            render=render_mode == "human",
            setup=self._setup_task,
        )
        # the episode core (pyflyt_engine.envs.episode) runs the step; this env is its N = 1 case
        self._init_core(cfg, parts, OneAgentTask(self.task), self.reward_function, info_reward_terms=info_reward_terms)
        #: the config's payloads, built around the vehicle (None without payloads)
        self.payloads: PayloadSet | None = parts.payloads[0] if parts.payloads else None
        #: the flight controller's state estimator the observation is built from (None: none)
        self.estimator = parts.estimators[0] if parts.estimators is not None else None

        self.action_space = spaces.Box(self._low, self._high, dtype=np.float64)
        aux_size = self.world.aux_state(0).size + int(self.fix_flag[0])
        size = observe.attitude_size(self._quaternion, self._low.size, aux_size)
        self.attitude_space = spaces.Box(-np.inf, np.inf, shape=(size,), dtype=np.float64)
        self.observation_space = self.task.observation_space(self.attitude_space)
        if cfg.camera_observation is not None:
            self.observation_space = observe.with_image_space(self.observation_space, cfg.camera_observation)
        if self.range_sensors[0]:
            self.observation_space = observe.with_range_spaces(self.observation_space, self.range_sensors[0])
        self._markers = None
        if render_mode is not None:
            from pyflyt_engine.envs.render import Markers

            self._markers = Markers(self.world.client, *self.task.marker_style())

    def observation_layout(self, quaternion: bool | None = None) -> observe.ObservationLayout:
        """The declared parts of :attr:`observation_space`: entry key -> its parts, in order
        (key ``observe.FLAT``: a Box observation); ``quaternion`` True / False: as with that
        ``angle_representation`` instead of the configured one.  What the env manuals
        (:mod:`pyflyt_engine.envs.manual`) print; their sizes add up to the space."""
        cfg = self.config
        q = self._quaternion if quaternion is None else quaternion
        aux = self.world.vehicles[0].aux_layout()
        attitude = observe.attitude_parts(q, cfg.action.names, cfg.action.units, aux, self.fix_flag[0])
        layout = self.task.observation_parts(attitude)
        return observe.layout_with_extras(layout, cfg.camera_observation, self.range_sensors[0])

    @property
    def vehicle(self) -> Any:
        """The vehicle flown (:class:`~pyflyt_engine.vehicle.Vehicle`)."""
        return self.vehicles[0]

    @vehicle.setter
    def vehicle(self, vehicle: Any) -> None:  # a front may wrap it (the compat envs' command meanings)
        self.vehicles[0] = vehicle

    def _start_task(self, state: KinematicState, rng: np.random.Generator) -> Any:
        """Start the task on the spawned vehicle; the goals obstacles must keep clear of."""
        self.task.reset(state, rng)
        return self.task.keep_clear()

    def _setup_task(self, world: World, payloads: list[PayloadSet]) -> None:
        """The task's scenery and payload checks, once the payloads and obstacles are built."""
        self.task.payloads = payloads[0] if payloads else None
        self.task.setup(world)

    # ----------------------------------------------------------------- gymnasium

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Start an episode.

        ``options``: ``None``, or ``{"task": {option: value, ...}}`` to fly this episode with
        other values of the task options its task lists in ``episode_options`` (e.g. a
        wider ``goal_reach_distance`` early in training); the next reset without them
        flies the configured task again.  Anything else raises ``ValueError``.
        """
        self.task.set_episode_options(build.task_changes(options))
        super().reset(seed=seed)
        rng = self.np_random
        (state,) = self._reset_core(
            seed, rng, lambda _: self.task.spawn(rng), lambda states: self._start_task(states[0], rng)
        )
        if self._markers is not None:
            self._markers.show(self.task.markers())
        info = self._reset_info(0)
        observation = self._observe(0, [state])
        self._check(0, observation, 0.0, state)
        return observation, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Apply ``action`` for one agent step (``physics_hz / agent_hz`` physics steps)."""
        self._act(0, action)
        states = self._advance()
        ((reward, terminated, truncated, info),) = self._judge(_ONE, states)
        if self._markers is not None:  # the task's targets as they are now (a reached one moves on)
            self._markers.show(self.task.markers())
        observation = self._observe(0, states)
        self._check(0, observation, reward, states[0])
        return observation, reward, terminated, truncated, info

    def render(self) -> np.ndarray | None:
        """``rgb_array``: an (H, W, 3) uint8 chase-camera image; ``human``: follow in the GUI."""
        if self.render_mode is None:
            gymnasium.logger.warn("render() called with render_mode=None; pass render_mode='rgb_array' or 'human'")
            return None
        from pyflyt_engine.envs import render as _render

        r = self.config.render
        if self.render_mode == "rgb_array":
            return _render.chase_camera(
                self.world.client, self.vehicle.state, r.resolution, r.camera_distance, r.camera_height, r.fov
            )
        _render.follow_in_gui(self.world.client, self.vehicle.state, r.camera_distance)
        return None

    def close(self) -> None:
        """Disconnect the PyBullet client (idempotent)."""
        if getattr(self, "world", None) is not None:
            self.world.close()

    # ------------------------------------------------------------------ helpers

    @property
    def state(self) -> KinematicState:
        """The vehicle's current :class:`KinematicState`."""
        return self.vehicle.state

    @property
    def last_reward_terms(self) -> dict[str, float]:
        """The reward breakdown of the last step: entry name -> weighted value, summing to
        the reward (empty after a reset), a copy; also ``info["reward_terms"]`` unless
        ``info_reward_terms=False``."""
        return dict(self._reward_terms[0])

    @property
    def measures(self) -> tuple[Any, ...]:
        """The task's success measures (:attr:`Task.measures
        <pyflyt_engine.envs.tasks.base.Task.measures>`), whose values the step that ends an
        episode reports as ``info["measures"]``."""
        return tuple(self.task.measures)

    @property
    def action_names(self) -> list[str]:
        """The names of the action's entries (``config.action.names``), as recorded."""
        return list(self.config.action.names)

    def scene_markers(self) -> tuple[np.ndarray, float]:
        """The task's marker points, ``(n, 3)`` ground frame, and their radius [m] (recorded in the scene)."""
        return np.asarray(self.task.markers(), dtype=float).reshape(-1, 3), float(self.task.marker_style()[1])

    @property
    def last_action(self) -> np.ndarray:
        """The action the vehicle received at the last step, after clipping to the bounds
        (zeros after a reset), a copy: what a recording must re-apply to re-run the episode."""
        return self._actions[0].copy()

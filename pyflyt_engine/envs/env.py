"""The generic environment: one vehicle in a :class:`World`, a task, a reward preset.

The step is sequenced here; what an episode flies and how it starts are built by the
episode core shared with the multi-agent loop (:func:`~pyflyt_engine.envs.core.build_episode`,
:func:`~pyflyt_engine.envs.core.reset_episode`), this env being its one-agent case.  The
vehicle is the model (named state read-outs, a flight mode that takes the action as its
setpoint), the task decides spawn, targets, extra observations and completion, and the
reward is the weighted sum of the preset's named terms (see :mod:`pyflyt_engine.envs.rewards`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import gymnasium
import numpy as np
from gymnasium import spaces

from pyflyt_engine.envs import core
from pyflyt_engine.envs.config import EnvConfig, RewardPreset, load_reward_preset
from pyflyt_engine.envs.randomization import Randomizer
from pyflyt_engine.envs.rewards import RewardFunction
from pyflyt_engine.envs.tasks import Task, get_task
from pyflyt_engine.obstacles import ObstacleField
from pyflyt_engine.payloads import PayloadSet
from pyflyt_engine.spec import UAVSpec, load_uav_spec
from pyflyt_engine.state import KinematicState
from pyflyt_engine.world import World


class UAVEnv(gymnasium.Env):
    """A single-vehicle UAV task as a Gymnasium environment, built from an env config.

    Prefer the registered ids (``gymnasium.make("PyFlyt/QuadX-Hover-v0")``), whose
    classes document their spaces and rewards; this class runs any env config, e.g. one
    written by a user: ``UAVEnv("my_env.yaml")``.

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

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human", "rgb_array"], "render_fps": 30}
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
        cfg = core.load_config(config, self.config_name, type(self).__name__, sparse_reward, overrides)
        core.check_render_mode(render_mode, self.metadata["render_modes"])
        self.config: EnvConfig = cfg
        self.render_mode = render_mode
        self.metadata = {**type(self).metadata, "render_fps": cfg.agent_hz}
        self._agent_dt = 1.0 / cfg.agent_hz

        # task and reward first: a bad config fails before PyBullet starts
        task_cls = get_task(cfg.task.name)
        self.task: Task = task_cls(cfg.task, flight_dome_size=cfg.flight_dome_size, agent_hz=cfg.agent_hz)
        self.reward_preset: RewardPreset = load_reward_preset(cfg.reward_preset_name())
        self.reward_function: RewardFunction = self.reward_preset.compile(task_cls.provides, task_cls.name)
        #: the airframe flown, before the task adjusts it (:meth:`Task.vehicle_spec`)
        self.airframe: UAVSpec = airframe if airframe is not None else load_uav_spec(cfg.uav)

        parts = core.build_episode(
            cfg,
            [self.task.vehicle_spec(self.airframe)],
            [(cfg.task.start_position, cfg.task.start_orientation)],
            render=render_mode == "human",
            setup=self._setup_task,
        )
        #: what the episode flies (:class:`~pyflyt_engine.envs.core.EpisodeParts`)
        self._parts = parts
        self.world = parts.world
        self.vehicle = self.world.vehicles[0]
        self._camera: int | None = parts.cameras[0]
        #: action and observation delays in physics steps (docs/engine.md, "Latency"); with
        #: ``randomize.action_delay`` / ``observation_delay``, this episode's (set at each reset)
        self.latency_steps = parts.latency_steps
        #: the config's payloads, built around the vehicle (None without payloads)
        self.payloads: PayloadSet | None = parts.payloads[0] if parts.payloads else None
        #: the config's obstacles (None without): fixed ones built here, layouts drawn at each reset
        self.obstacles: ObstacleField | None = parts.obstacles
        #: the observation is built from the noisy sensors (``config.sensors.observe``)
        self._sensed = parts.sensed[0] if parts.sensed is not None else None
        #: the position fix's validity flag follows the auxiliary state in the observation
        self._fix_flag = parts.fix_flag[0]
        #: the flight controller's state estimator the observation is built from (None: none)
        self.estimator = parts.estimators[0] if parts.estimators is not None else None
        #: the range sensors observed (every one the flown airframe carries), in spec order
        self._range_sensors = parts.range_sensors[0]
        #: samples and applies ``config.randomize`` at each reset (None without)
        self.randomizer: Randomizer | None = parts.randomizer

        self._low = np.array(cfg.action.low, dtype=np.float64)
        self._high = np.array(cfg.action.high, dtype=np.float64)
        self.action_space = spaces.Box(self._low, self._high, dtype=np.float64)
        self._quaternion = cfg.angle_representation == "quaternion"
        aux_size = self.world.aux_state(0).size + int(self._fix_flag)
        size = core.attitude_size(self._quaternion, self._low.size, aux_size)
        self.attitude_space = spaces.Box(-np.inf, np.inf, shape=(size,), dtype=np.float64)
        self.observation_space = self.task.observation_space(self.attitude_space)
        if cfg.camera_observation is not None:
            self.observation_space = core.with_image_space(self.observation_space, cfg.camera_observation)
        if self._range_sensors:
            self.observation_space = core.with_range_spaces(self.observation_space, self._range_sensors)

        self._dome2 = cfg.flight_dome_size**2
        self._max_steps = cfg.max_steps
        self._action = np.zeros_like(self._low)
        self._steps = 0
        #: put ``reward_terms`` into every step's info (see the class docstring)
        self.info_reward_terms = bool(info_reward_terms)
        self._reward_terms: dict[str, float] = {}
        #: the values drawn at the last reset (empty without randomisation)
        self.last_randomization: dict[str, float] = {}
        self._markers = None
        if render_mode is not None:
            from pyflyt_engine.envs.render import Markers

            self._markers = Markers(self.world.client, *self.task.marker_style())

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
        self.task.set_episode_options(core.task_changes(options))
        super().reset(seed=seed)
        rng = self.np_random
        drawn, (state,) = core.reset_episode(
            self._parts, seed, rng, lambda _: self.task.spawn(rng), lambda states: self._start_task(states[0], rng)
        )
        self.latency_steps = self.vehicle.latency  # this episode's, with randomised delays drawn
        if drawn is not None:
            self.last_randomization = drawn
        self._action = np.zeros_like(self._low)
        self._steps = 0
        self._reward_terms = {}
        if self._markers is not None:
            self._markers.show(self.task.markers())
        info = {"collision": False, "out_of_bounds": False, "env_complete": False, "success": False}
        if drawn is not None:
            info["randomization"] = dict(drawn)
        if self.payloads is not None:
            info["payload_ground_contact"] = False
        if self.obstacles is not None:
            info["obstacle_contact"] = False
            info["obstacles_parked"] = self.obstacles.parked
        info.update(self.task.info())
        observation = self._observe(state)
        if not core.all_finite(0.0, observation):
            self._diverged(observation, 0.0, state)
        return observation, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Apply ``action`` for one agent step (``physics_hz / agent_hz`` physics steps)."""
        a = core.clip_action(action, self._low, self._high, self.config.action.names)
        self.vehicle.set_setpoint(a)
        self._action = a.copy()
        self.world.step()

        state = self.vehicle.state
        world = self.world
        collision = world.collided(0)
        out_of_bounds = core.outside_dome(state, self._dome2)
        signals = self.task.update(state)
        crashed, terminated = self.task.termination(collision, out_of_bounds, signals)
        payload_ground = self.payloads is not None and self.payloads.ground_failure()
        if payload_ground:  # a payload the config says must not touch the ground did
            crashed = terminated = True
        obstacle_contact = self.obstacles is not None and self.obstacles.touched(0)
        if obstacle_contact and self.config.obstacles.crash_on_contact:  # type: ignore[union-attr]
            crashed = terminated = True
        ctx = core.step_context(
            world,
            0,
            state,
            a,
            collision,
            out_of_bounds,
            crashed,
            signals,
            signals.waypoint_reached,
            max(self._max_steps - self._steps - 1, 0),
            self._agent_dt,
        )
        reward, terms = self.reward_function(ctx)
        self._reward_terms = terms
        self._steps += 1

        truncated = not terminated and self._steps >= self._max_steps
        success = (signals.complete and not crashed) or (truncated and self.task.succeeds_at_time_limit)
        if self._markers is not None and signals.waypoint_reached:
            self._markers.show(self.task.markers())
        info = {
            "collision": collision,
            "out_of_bounds": out_of_bounds,
            "env_complete": signals.complete,
            "success": success,
        }
        if self.payloads is not None:
            info["payload_ground_contact"] = payload_ground
        if self.obstacles is not None:
            info["obstacle_contact"] = obstacle_contact
            info["obstacles_parked"] = self.obstacles.parked
        if self.info_reward_terms:
            info["reward_terms"] = terms
        info.update(self.task.info())
        observation = self._observe(state)
        if not core.all_finite(reward, observation):
            self._diverged(observation, reward, state)
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

    def _observe(self, state: KinematicState) -> Any:
        if self.latency_steps[1]:  # the agent sees the vehicle as it was observation_delay ago
            state, aux = self.vehicle.delayed_observation()
        else:
            aux = self.vehicle.aux_values()
        if self.estimator is not None:  # the estimator's attitude, velocity and position, the gyro's rates
            state = core.estimated_state(state, self._sensed, self.estimator)
            if self._fix_flag:
                aux = [*aux, self._sensed.position_valid]  # type: ignore[union-attr]
        elif self._sensed is not None:  # the sensors' readings in place of the true rates and position
            state = core.sensed_state(state, self._sensed)
            if self._fix_flag:
                aux = [*aux, self._sensed.position_valid]
        attitude = core.attitude_vector(state, self._quaternion, self._action.tolist(), aux)
        observation = self.task.observe(attitude, state)
        if not self._range_sensors and self._camera is None:
            return observation
        return core.with_readings(
            observation, self.world, 0, self._range_sensors, self._camera, self.config.camera_observation
        )

    def _diverged(self, observation: Any, reward: float, state: KinematicState) -> None:
        """Raise :class:`SimulationError` describing a non-finite observation or reward."""
        where = self.config.id or self.config.source or "the environment"
        raise core.divergence_error(where, self._steps, observation, reward, state, self.vehicle, self._action)

    @property
    def state(self) -> KinematicState:
        """The vehicle's current :class:`KinematicState`."""
        return self.vehicle.state

    @property
    def elapsed_steps(self) -> int:
        """Agent steps since the last reset."""
        return self._steps

    @property
    def last_reward_terms(self) -> dict[str, float]:
        """The reward breakdown of the last step: entry name -> weighted value, summing to
        the reward (empty after a reset), a copy; also ``info["reward_terms"]`` unless
        ``info_reward_terms=False``."""
        return dict(self._reward_terms)

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
        return self._action.copy()

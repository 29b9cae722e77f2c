"""The episode core: what every env loop does the same way, for one agent or N.

The single-agent loop (:class:`~pyflyt_engine.envs.env.UAVEnv`) and the multi-agent loop
(:class:`~pyflyt_engine.envs.multi_agent.base.MultiAgentUAVEnv`) both call these, so the
config loading, what an episode flies, the action clipping, the observation layout, the
flight-dome check, the reward context of a step and the divergence report exist once:

* :func:`load_config` -- the env config from a name, path, mapping or model, with the
  ``sparse_reward`` shortcut and overrides, and the render-mode check;
* :func:`build_episode` -- what an episode flies (:class:`EpisodeParts`): the World with
  one vehicle per agent, each agent's payloads, the obstacle field, the latency, the
  observed sensors and estimators, the range sensors and the randomiser;
* :func:`reset_episode` -- the start of an episode: World reset, randomiser draw, each
  vehicle's spawn, payloads, the task's start, obstacle layouts;
* :func:`clip_action` -- one agent's action checked for size and clipped to its bounds;
* :func:`attitude_size`, :func:`attitude_vector` -- the shared observation layout
  ``[ang_vel, attitude, lin_vel, lin_pos, previous action, aux]``;
* :func:`outside_dome` -- the flight-dome check;
* :func:`termination` -- how a step ends an agent's episode (what a task's
  ``termination`` returns by default);
* :func:`step_context` -- the :class:`~pyflyt_engine.envs.rewards.StepContext` of one
  agent's step;
* :func:`all_finite`, :func:`divergence_error` -- the never-NaN guard and its report;
* :func:`task_changes` -- the ``reset(options={"task": ...})`` mapping;
* :func:`with_sensors`, :func:`sensed_state` -- an agent's noisy sensors (env ``sensors``)
  and its state as they see it;
* :func:`with_observation_camera`, :func:`with_range_sensors` (the airframe an agent flies),
  :func:`with_image_space`, :func:`with_range_spaces` (its observation space),
  :func:`with_readings` (its observation) -- camera images and range sensors observed;
* :class:`RecordableEnv` -- what an env shows of itself to the recorder and replay.

Everything here is built and computed in the same order as the loops did it before (the
golden trajectories hold it bit for bit).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np
from gymnasium import spaces

from pyflyt_engine import exact
from pyflyt_engine.envs.config import EnvConfig, load_env_config
from pyflyt_engine.envs.randomization import Randomizer
from pyflyt_engine.envs.rewards import StepContext
from pyflyt_engine.errors import ConfigError, SimulationError
from pyflyt_engine.frames import quaternion_to_rows
from pyflyt_engine.obstacles import ObstacleField
from pyflyt_engine.payloads import PayloadSet
from pyflyt_engine.spec import SensorsSpec, UAVSpec
from pyflyt_engine.state import KinematicState
from pyflyt_engine.world import VehicleConfig, World


def load_config(
    config: str | Path | Mapping[str, Any] | EnvConfig | None,
    default: str | None,
    owner: str,
    sparse_reward: bool | None,
    overrides: dict[str, Any],
) -> EnvConfig:
    """The env config an env is built from: ``config`` (or ``default``) with ``overrides``.

    ``sparse_reward`` is the shortcut for ``reward="sparse"`` / ``"dense"``; ``owner`` (the
    env class's name) words the error when neither ``config`` nor ``default`` is given.
    """
    if config is None:
        if default is None:
            raise ConfigError(f"{owner} needs an env config (a name in conf/env, a path or a mapping)")
        config = default
    if sparse_reward is not None:
        if "reward" in overrides:
            raise ConfigError("give either sparse_reward or reward, not both")
        overrides = {**overrides, "reward": "sparse" if sparse_reward else "dense"}
    return load_env_config(config).with_overrides(**overrides)


def check_render_mode(render_mode: str | None, modes: Sequence[str]) -> None:
    """ConfigError unless ``render_mode`` is None or one of ``modes``."""
    if render_mode is not None and render_mode not in modes:
        raise ConfigError(f"unknown render_mode '{render_mode}': use one of {list(modes)} or None")


def clip_action(
    action: Any, low: np.ndarray, high: np.ndarray, names: Sequence[str], agent: str | None = None
) -> np.ndarray:
    """``action`` as a flat float64 array clipped to ``[low, high]``.

    Raises:
        ValueError: the action has another number of entries than ``names`` (naming
            ``agent`` when given).
    """
    a = np.asarray(action, dtype=np.float64).reshape(-1)
    if a.shape != low.shape:
        if agent is None:
            raise ValueError(f"action must have {low.size} values ({', '.join(names)}), got {a.size}")
        raise ValueError(f"agent '{agent}': action must have {low.size} values, got {a.size}")
    return np.minimum(np.maximum(a, low), high)


def attitude_size(quaternion: bool, actions: int, aux: int) -> int:
    """Entries of the attitude vector: rates 3, attitude 4 (quaternion) or 3, velocity 3,
    position 3, the previous action and the auxiliary state."""
    return 3 + (4 if quaternion else 3) + 3 + 3 + actions + aux


def attitude_vector(
    state: KinematicState, quaternion: bool, action: Sequence[float], aux: Sequence[float]
) -> np.ndarray:
    """``[ang_vel (3, body), attitude (quaternion xyzw | Euler), lin_vel (3, body),
    lin_pos (3, ground), previous action, aux]`` as one float64 array (one flat tuple)."""
    angles = state.quaternion if quaternion else state.ang_pos
    return np.array(
        (*state.ang_vel, *angles, *state.lin_vel, *state.lin_pos, *action, *aux),
        dtype=np.float64,
    )


def outside_dome(state: KinematicState, dome_squared: float) -> bool:
    """Whether the centre of mass is farther from the origin than the flight dome's radius."""
    x, y, z = state.lin_pos
    return x * x + y * y + z * z > dome_squared


def step_context(
    world: Any,
    index: int,
    state: KinematicState,
    action: np.ndarray,
    collision: bool,
    out_of_bounds: bool,
    crashed: bool,
    signals: Any,
    waypoint_reached: bool,
    steps_remaining: int,
    agent_dt: float,
) -> StepContext:
    """The reward context of vehicle ``index``'s step; ``signals`` the task's (``complete``,
    ``target_distance``, ``target_distance_rate``, ``extras``)."""
    return StepContext(
        state,
        action,
        collision,
        world.collided_with_ground(index) if collision else False,
        out_of_bounds,
        crashed,
        signals.complete,
        signals.target_distance,
        signals.target_distance_rate,
        waypoint_reached,
        signals.extras,
        steps_remaining,
        agent_dt,
    )


@functools.lru_cache(maxsize=16)
def _zeros(size: int) -> np.ndarray:
    zeros = np.zeros(size)
    zeros.flags.writeable = False
    return zeros


def all_finite(reward: float, observation: Any) -> bool:
    """Whether ``reward`` and every number in ``observation`` (an array or a mapping of arrays) are finite.

    One dot product with zeros per array: it is 0 unless an entry is NaN or infinite
    (0 * inf is NaN), so a finite observation can never be mistaken for a bad one.
    """
    if isinstance(observation, np.ndarray) and observation.ndim == 1:  # a flat Box: the common case
        return math.isfinite(reward + observation.dot(_zeros(observation.shape[0])))
    total = reward
    mapping = type(observation) is dict or isinstance(observation, Mapping)
    for value in observation.values() if mapping else (observation,):
        if type(value) is np.ndarray and value.dtype.kind in "biu":  # integers (images) are always finite
            continue
        flat = np.asarray(value, dtype=np.float64).ravel()  # np.ravel's own method, without its wrapper
        total += flat.dot(_zeros(flat.size))
    return math.isfinite(total)


def _rounded(values: Any) -> list[float]:
    return [round(float(v), 4) for v in values]


def divergence_error(
    where: str,
    step: int,
    observation: Any,
    reward: float,
    state: KinematicState,
    vehicle: Any,
    action: Any,
    agent: str | None = None,
) -> SimulationError:
    """The :class:`SimulationError` describing a non-finite observation or reward at ``step``:
    which entries, the vehicle's state and the last action (and the agent, when several fly)."""
    parts = observation.items() if isinstance(observation, Mapping) else [("observation", observation)]
    bad = [
        f"{name}[{', '.join(map(str, np.flatnonzero(~np.isfinite(np.asarray(value, dtype=np.float64)))))}]"
        for name, value in parts
        if not np.isfinite(np.asarray(value, dtype=np.float64)).all()
    ]
    if not math.isfinite(reward):
        bad.append(f"reward ({reward})")
    who = f"Agent '{agent}', vehicle" if agent is not None else "Vehicle"
    return SimulationError(
        f"{where}: the simulation diverged at step {step} of the episode: not finite: {', '.join(bad)}. "
        f"{who} '{vehicle.spec.name}': position {_rounded(state.lin_pos)} m, attitude "
        f"{_rounded(state.ang_pos)} rad, body velocity {_rounded(state.lin_vel)} m/s, body rates "
        f"{_rounded(state.ang_vel)} rad/s, aux {_rounded(vehicle.aux_state)}; last action "
        f"{_rounded(action)}. Check the airframe's parameters (mass, inertia, motor, drag and surface "
        "coefficients) and anything that moved the vehicle from outside the environment"
    )


def task_changes(options: dict[str, Any] | None) -> dict[str, Any] | None:
    """The task option changes in a ``reset(options=...)`` mapping: ``None`` or ``{"task": {...}}``.

    Raises:
        ValueError: anything else.
    """
    if not options:
        return None
    if not isinstance(options, dict) or set(options) - {"task"} or not isinstance(options.get("task", {}), dict):
        raise ValueError(f'reset options must be None or {{"task": {{option: value}}}}, got {options!r}')
    return options.get("task")


def with_sensors(spec: UAVSpec, sensors: Any) -> UAVSpec:
    """The airframe with the env's noisy sensors (``config.sensors``): the ones it gives
    replace the airframe's section; none given keeps the airframe's own."""
    if sensors is None:
        return spec
    given = {k: getattr(sensors, k) for k in ("imu", "position", "barometer")}
    if any(v is not None for v in given.values()):
        spec = spec.model_copy(update={"sensors": SensorsSpec(**given)})
    if sensors.observe and spec.sensors is None:
        raise ConfigError(
            f"sensors.observe: airframe '{spec.name}' has no 'sensors' section to observe; give sensors.imu, "
            "sensors.position or sensors.barometer, or fly an airframe with sensors"
        )
    if sensors.estimator.active:
        for part, what in (("imu", "the attitude filter integrates the gyro and takes the accelerometer as 'up'"),
                           ("position", "the velocity filter corrects with the position fixes")):  # fmt: skip
            if getattr(spec.sensors, part) is None:
                raise ConfigError(
                    f"sensors.estimator: '{sensors.estimator.type}' needs an IMU and a position fix ({what}), and "
                    f"airframe '{spec.name}' has no sensors.{part}: give sensors.{part} in the env config, fly an "
                    "airframe with one, or set estimator: none"
                )
    return spec


def sensed_state(state: KinematicState, suite: Any) -> KinematicState:
    """``state`` as the sensors see it: body rates from the gyro (their ground-frame copy
    turned with the true attitude), position from the position sensor, height from the
    barometer; attitude and velocity stay true (docs/environments.md, "Sensor observation")."""
    ang_vel, lin_pos, ang_ground = state.ang_vel, state.lin_pos, state.ang_vel_ground
    if suite.gyro is not None:
        ang_vel = suite.gyro.reading
        r = quaternion_to_rows(state.quaternion)
        ang_ground = exact.rotate(r, ang_vel)
    names = suite.names
    if "position" in names:
        lin_pos = suite.position
    if "altitude" in names:
        lin_pos = (lin_pos[0], lin_pos[1], suite.altitude)
    return state._replace(ang_vel=ang_vel, lin_pos=lin_pos, ang_vel_ground=ang_ground)


def estimated_state(state: KinematicState, suite: Any, estimator: Any) -> KinematicState:
    """``state`` as the flight controller's estimator sees it: body rates from the gyro,
    attitude, velocity and position estimated (:mod:`pyflyt_engine.components.estimator`);
    the body-frame velocity and the ground-frame rates turned with the estimated attitude
    (docs/environments.md, "Estimated state")."""
    ang_vel = suite.gyro.reading
    q = estimator.quaternion
    r = quaternion_to_rows(q)
    velocity = estimator.velocity
    return state._replace(
        ang_vel=ang_vel,
        ang_pos=estimator.euler,
        lin_vel=exact.rotate_t(r, velocity),
        lin_pos=estimator.position,
        quaternion=q,
        lin_vel_ground=velocity,
        ang_vel_ground=exact.rotate(r, ang_vel),
    )


def with_observation_camera(spec: UAVSpec, obs: Any) -> tuple[UAVSpec, int]:
    """The airframe with the observation camera appended, and its index."""
    if any(c.name == obs.camera.name for c in spec.cameras):
        raise ConfigError(
            f"camera_observation.camera.name '{obs.camera.name}' is already a camera of airframe '{spec.name}': "
            "give the observation camera another name"
        )
    camera = obs.camera.model_copy(update={"outputs": ["rgba"]})
    return spec.model_copy(update={"cameras": [*spec.cameras, camera]}), len(spec.cameras)


def with_image_space(space: spaces.Space, obs: Any) -> spaces.Dict:
    """``space`` as a Dict with the camera image Box (uint8) under ``obs.key``."""
    cam = obs.camera
    depth = 3 if obs.channels == "rgb" else 4
    shape = (depth, cam.height, cam.width) if obs.channel_first else (cam.height, cam.width, depth)
    image = spaces.Box(0, 255, shape=shape, dtype=np.uint8)
    if isinstance(space, spaces.Dict):
        return spaces.Dict({**space.spaces, obs.key: image})
    return spaces.Dict({"attitude": space, obs.key: image})


#: observation keys the tasks and the env use themselves
_TAKEN_KEYS = ("attitude", "target_deltas", "goal_delta", "gate")


def with_range_sensors(spec: UAVSpec, sensors: list[Any]) -> UAVSpec:
    """The airframe with the env config's range sensors appended."""
    have = {s.name for s in spec.range_sensors}
    for sensor in sensors:
        if sensor.name in have:
            raise ConfigError(
                f"range_sensors: '{sensor.name}' is already a range sensor of airframe '{spec.name}': give it another name"
            )
    return spec.model_copy(update={"range_sensors": [*spec.range_sensors, *sensors]})


def with_range_spaces(space: spaces.Space, sensors: list[Any]) -> spaces.Dict:
    """``space`` as a Dict with one float32 Box of readings in [0, max_range] per sensor."""
    entries = dict(space.spaces) if isinstance(space, spaces.Dict) else {"attitude": space}
    for sensor in sensors:
        if sensor.name in entries or sensor.name in _TAKEN_KEYS:
            raise ConfigError(
                f"range sensor '{sensor.name}': its name is already an observation key ({', '.join(entries)}); rename it"
            )
        entries[sensor.name] = spaces.Box(0.0, sensor.max_range, shape=sensor.shape, dtype=np.float32)
    return spaces.Dict(entries)


def with_readings(
    observation: Any, world: Any, index: int, range_sensors: Sequence[Any], camera: int | None, camera_config: Any
) -> Any:
    """``observation`` (the task's) with vehicle ``index``'s range sensor readings under their
    names and, with ``camera`` (its index on the vehicle), the camera image under
    ``camera_config.key``: a Dict, the task's part under ``attitude`` unless it is one already."""
    if range_sensors:
        if not isinstance(observation, dict):
            observation = {"attitude": observation}
        for k, sensor in enumerate(range_sensors):
            observation[sensor.name] = world.scan(index, k)
    if camera is None:
        return observation
    c = camera_config
    rgba = world.vehicles[index].capture(camera)["rgba"]
    image = rgba[:, :, :3] if c.channels == "rgb" else rgba
    image = np.ascontiguousarray(image.transpose(2, 0, 1) if c.channel_first else image)
    if isinstance(observation, dict):
        return {**observation, c.key: image}
    return {"attitude": observation, c.key: image}


@dataclass
class EpisodeParts:
    """What :func:`build_episode` builds for an env loop, one entry per vehicle where per agent.

    Attributes:
        world: the :class:`~pyflyt_engine.world.World`, one vehicle per agent in agent order.
        vehicles: the vehicles built for the agents (``world.vehicles`` as built; the episode
            resets these, a vehicle added to the world later only by the world's own reset).
        cameras: per vehicle, the index of its observation camera (None without ``camera_observation``).
        payloads: per vehicle, its :class:`~pyflyt_engine.payloads.PayloadSet` (empty without payloads).
        obstacles: the config's :class:`~pyflyt_engine.obstacles.ObstacleField` (None without).
        latency_steps: action and observation delays in physics steps, set on every vehicle.
        sensed: per vehicle, the sensor suite its observation is built from (None: true states).
        estimators: per vehicle, its flight controller's state estimator (None: none).
        fix_flag: per vehicle, whether its position fix's validity flag follows its auxiliary state.
        range_sensors: per vehicle, the range sensors observed (every one it carries), in spec order.
        randomizer: samples ``config.randomize`` at each reset (None without).
    """

    world: World
    vehicles: list[Any]
    cameras: list[int | None]
    payloads: list[PayloadSet]
    obstacles: ObstacleField | None
    latency_steps: tuple[int, int]
    sensed: list[Any] | None
    estimators: list[Any] | None
    fix_flag: list[bool]
    range_sensors: list[list[Any]]
    randomizer: Randomizer | None


def build_episode(
    cfg: Any,
    specs: Sequence[UAVSpec],
    spawns: Sequence[tuple[Any, Any]],
    *,
    render: bool,
    agent_names: Sequence[str] | None = None,
    payload_name: Callable[[int, str], str] | None = None,
    setup: Callable[[World, list[PayloadSet]], None] | None = None,
) -> EpisodeParts:
    """Build what one episode of an env config flies: the World with one vehicle per entry of
    ``specs`` (each airframe with the config's observation camera, range sensors and noisy
    sensors added, once per distinct spec object) at ``spawns`` (position, orientation),
    each vehicle's copy of the payloads, the obstacle field, the latency, the observed
    sensor suites and estimators, the range sensors and the randomiser, in that order.

    ``agent_names`` (one per spec) names the agent in errors of a multi-agent env (None: the
    single-agent wording); ``payload_name(i, name)`` renames vehicle ``i``'s copy of a payload
    (None: the config's names); ``setup(world, payloads)``, called right after the obstacles
    are built, is where a task adds its scenery (bodies must exist before the first reset's
    snapshot).

    Raises:
        ConfigError: a flight mode takes another number of setpoint entries than the action
            has, or an airframe lacks what ``config.randomize`` varies (the World is closed
            before the first).
    """
    flown_of: dict[int, tuple[UAVSpec, int | None]] = {}
    for spec in specs:
        if id(spec) in flown_of:
            continue
        camera = None
        flown = spec
        if cfg.camera_observation is not None:
            flown, camera = with_observation_camera(flown, cfg.camera_observation)
        if cfg.range_sensors:
            flown = with_range_sensors(flown, cfg.range_sensors)
        if getattr(cfg, "controller", "own") == "betaflight":
            from pyflyt_engine.firmware.betaflight import with_betaflight

            flown = with_betaflight(flown, cfg.action.mode)
        flown_of[id(spec)] = (with_sensors(flown, cfg.sensors), camera)
    world = World(
        [
            VehicleConfig(flown_of[id(spec)][0], position, orientation, mode=cfg.action.mode)
            for spec, (position, orientation) in zip(specs, spawns)
        ],
        physics_hz=cfg.physics_hz,
        control_hz=cfg.control_hz,
        agent_hz=cfg.agent_hz,
        render=render,
        drag=cfg.drag,
        wind=cfg.wind,
        ground_effect=cfg.ground_effect,
        downwash=cfg.downwash,
    )
    vehicles = list(world.vehicles)  # the episode's own (a caller may add more vehicles to the world)
    payloads: list[PayloadSet] = []
    if cfg.payloads:
        for i, vehicle in enumerate(vehicles):
            entries = list(cfg.payloads)
            if payload_name is not None:
                entries = [p.model_copy(update={"name": payload_name(i, p.name)}) for p in entries]
            payloads.append(PayloadSet(world, vehicle, entries))
    obstacles = ObstacleField(world, cfg.obstacles) if cfg.obstacles is not None else None
    if setup is not None:
        setup(world, payloads)
    n_act = len(cfg.action.names)
    for i, vehicle in enumerate(vehicles):
        if vehicle.setpoint.size != n_act:
            world.close()
            if agent_names is None:
                raise ConfigError(
                    f"action has {n_act} entries ({', '.join(cfg.action.names)}) but flight mode "
                    f"'{cfg.action.mode}' of '{specs[i].name}' takes {vehicle.setpoint.size} "
                    f"({', '.join(vehicle.setpoint_layout)}): give action.names, low and high in that layout"
                )
            raise ConfigError(
                f"agent '{agent_names[i]}': action has {n_act} entries ({', '.join(cfg.action.names)}) but flight "
                f"mode '{cfg.action.mode}' of '{vehicle.spec.name}' takes {vehicle.setpoint.size}"
            )
    latency = cfg.latency.steps(cfg.physics_hz) if cfg.latency is not None else (0, 0)
    for vehicle in vehicles:
        vehicle.set_latency(*latency)
    # (with_sensors gave every flown spec the env's sensors: no suite is None; EpisodeParts.sensed)
    sensed: list[Any] | None = (
        [v.sensors for v in vehicles] if cfg.sensors is not None and cfg.sensors.observe else None
    )
    estimators = None
    if sensed is not None and cfg.sensors.estimator.active:
        estimators = [suite.attach_estimator(cfg.sensors.estimator) for suite in sensed]
    fix_flag = [
        sensed is not None and v.spec.sensors is not None and v.spec.sensors.position is not None for v in vehicles
    ]
    randomizer = Randomizer(cfg.randomize, world, latency) if cfg.randomize else None
    return EpisodeParts(
        world=world,
        vehicles=vehicles,
        cameras=[flown_of[id(spec)][1] for spec in specs],
        payloads=payloads,
        obstacles=obstacles,
        latency_steps=latency,
        sensed=sensed,
        estimators=estimators,
        fix_flag=fix_flag,
        range_sensors=[list(v.range_sensors) for v in vehicles],
        randomizer=randomizer,
    )


def reset_episode(
    parts: EpisodeParts,
    seed: int | None,
    rng: np.random.Generator,
    spawn: Callable[[int], Any],
    start_task: Callable[[list[KinematicState]], Any],
) -> tuple[dict[str, float] | None, list[KinematicState]]:
    """Start an episode of what :func:`build_episode` built, in one order for one agent or N.

    The World is reset (restoring its first snapshot, reseeding its own streams with
    ``seed``), the randomiser draws this episode's values from ``rng``, then, vehicle by
    vehicle in agent order, ``spawn(i)`` gives its :class:`~pyflyt_engine.envs.tasks.base.Spawn`
    (drawing from ``rng`` if it draws), the drawn spawn offsets move it and the vehicle is
    put there; then every payload is placed, ``start_task(states)`` starts the task on the
    vehicles' states and returns the points obstacles must keep clear of besides the
    vehicles, and the obstacle layouts are drawn from ``rng``.

    Returns:
        the values drawn (None without randomisation) and the vehicles' states.
    """
    parts.world.reset(seed)
    drawn = parts.randomizer.sample(rng) if parts.randomizer is not None else None
    for i, vehicle in enumerate(parts.vehicles):
        s = spawn(i)
        position, orientation = s.position, s.orientation
        if drawn is not None:
            position, orientation = Randomizer.spawn(drawn, position, orientation)
        vehicle.reset(position, orientation, lin_vel=s.lin_vel, ang_vel=s.ang_vel)
    for payloads in parts.payloads:  # after every vehicle is placed
        payloads.place()
    states = [v.state for v in parts.vehicles]
    keep_clear = start_task(states)
    if parts.obstacles is not None:  # this episode's layouts, clear of every spawn point and the task's points
        parts.obstacles.generate(rng, [*(state.lin_pos for state in states), *np.asarray(keep_clear).reshape(-1, 3)])
    return drawn, states


@runtime_checkable
class RecordableEnv(Protocol):
    """The public face of an env that :class:`~pyflyt_engine.telemetry.RecordEpisode` records
    and :func:`~pyflyt_engine.telemetry.replay.verify` re-simulates: nothing else of an env is
    read from outside.  :class:`~pyflyt_engine.envs.env.UAVEnv` and
    :class:`~pyflyt_engine.envs.multi_agent.shared.SharedPolicyEnv` implement it.

    Attributes:
        world: the :class:`~pyflyt_engine.world.World` (vehicles, contacts, wind, RNG state).
        config: the resolved env config.
        airframe: the airframe flown before a task adjusts it.
        reward_preset: the resolved reward preset.
        np_random: the env's generator (its state is recorded at each reset).
        payloads: the env's :class:`~pyflyt_engine.payloads.PayloadSet` (every agent's as one
            :class:`~pyflyt_engine.payloads.PayloadSets` in a multi-agent env), or None.
        obstacles: the env's :class:`~pyflyt_engine.obstacles.ObstacleField`, or None (its mesh
            files are embedded in a recording).
        action_names: the names of the recorded action vector's entries.
        last_action: the action the vehicles received at the last step (flat).
        last_reward_terms: the reward breakdown of the last step.
        last_randomization: the values domain randomisation drew at the last reset.
    """

    world: Any
    config: Any
    airframe: Any
    reward_preset: Any
    np_random: np.random.Generator
    payloads: Any
    obstacles: Any

    @property
    def action_names(self) -> list[str]: ...

    @property
    def last_action(self) -> np.ndarray: ...

    @property
    def last_reward_terms(self) -> dict[str, float]: ...

    @property
    def last_randomization(self) -> dict[str, float]: ...

    def scene_markers(self) -> tuple[np.ndarray, float]:
        """The points drawn in the scene now, ``(n, 3)`` ground frame, and their radius [m]."""
        ...


#: the members of :class:`RecordableEnv`, for messages naming what an env lacks
RECORDABLE = (
    "world", "config", "airframe", "reward_preset", "np_random", "payloads", "obstacles", "action_names",
    "last_action", "last_reward_terms", "last_randomization", "scene_markers",
)  # fmt: skip

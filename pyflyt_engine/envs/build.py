"""What an episode flies, and how it starts: the part of an env loop built from its config.

* :func:`load_config` -- the env config from a name, path, mapping or model, with the
  ``sparse_reward`` shortcut and overrides; :func:`check_render_mode`;
* :func:`build_episode` -- what an episode flies (:class:`EpisodeParts`): the World with
  one vehicle per agent, each agent's payloads, the obstacle field, the latency, the
  observed sensors and estimators, the range sensors and the randomiser;
* :func:`reset_episode` -- the start of an episode: World reset, randomiser draw, each
  vehicle's spawn, payloads, the task's start, obstacle layouts;
* :func:`task_changes` -- the ``reset(options={"task": ...})`` mapping.

The single-agent and the multi-agent fronts both call these (the episode core,
:mod:`pyflyt_engine.envs.episode`); everything is built in the same order for one agent
or N (the golden trajectories hold it bit for bit).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pyflyt_engine.envs.config import EnvConfig, load_env_config
from pyflyt_engine.envs.events import ResetEvent, bind_events
from pyflyt_engine.envs.observe import with_observation_camera, with_range_sensors, with_sensors
from pyflyt_engine.envs.randomization import Randomizer
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.obstacles import ObstacleField
from pyflyt_engine.payloads import PayloadSet
from pyflyt_engine.spec import UAVSpec
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
        events: the reset events that apply (:mod:`pyflyt_engine.envs.events`), in their order.
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
    events: tuple[ResetEvent, ...] = ()

    def __post_init__(self) -> None:
        if not self.events:
            self.events = bind_events(self)


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
    ``seed``), the reset events (:mod:`pyflyt_engine.envs.events`) draw this episode's
    values from ``rng`` (domain randomisation), then, vehicle by vehicle in agent order,
    ``spawn(i)`` gives its :class:`~pyflyt_engine.envs.tasks.base.Spawn` (drawing from
    ``rng`` if it draws), the events move it (the drawn spawn offsets) and the vehicle is
    put there; then the events place every payload, ``start_task(states)`` starts the task
    on the vehicles' states and returns the points obstacles must keep clear of besides the
    vehicles, and the events draw the obstacle layouts from ``rng``.

    Returns:
        the values drawn (None without randomisation) and the vehicles' states.
    """
    parts.world.reset(seed)
    events = parts.events
    for event in events:
        event.draw(rng)
    for i, vehicle in enumerate(parts.vehicles):
        s = spawn(i)
        position, orientation = s.position, s.orientation
        for event in events:
            position, orientation = event.spawn(i, position, orientation)
        vehicle.reset(position, orientation, lin_vel=s.lin_vel, ang_vel=s.ang_vel)
    for event in events:  # after every vehicle is placed
        event.placed()
    states = [v.state for v in parts.vehicles]
    keep_clear = start_task(states)
    for event in events:
        event.started(rng, states, keep_clear)
    drawn = next((event.drawn for event in events if event.drawn is not None), None)
    return drawn, states

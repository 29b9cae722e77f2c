"""What an agent observes: the shared attitude vector, its sensors' view of its state, and
the camera image and range-sensor readings beside the task's observation.

* :func:`attitude_size`, :func:`attitude_vector` -- the shared observation layout
  ``[ang_vel, attitude, lin_vel, lin_pos, previous action, aux]``;
* :func:`with_sensors`, :func:`sensed_state`, :func:`estimated_state` -- an agent's noisy
  sensors (env ``sensors``) and its state as they, or its estimator, see it;
* :func:`with_observation_camera`, :func:`with_range_sensors` (the airframe an agent flies),
  :func:`with_image_space`, :func:`with_range_spaces` (its observation space),
  :func:`with_readings` (its observation) -- camera images and range sensors observed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np
from gymnasium import spaces

from pyflyt_engine import exact
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import quaternion_to_rows
from pyflyt_engine.spec import SensorsSpec, UAVSpec
from pyflyt_engine.state import KinematicState


class ObservationPart(NamedTuple):
    """One declared part of an observation entry: ``size`` consecutive values (for a
    ``Sequence`` entry, of each row), what they mean and their frame and unit.  The parts of
    an entry, in order, make it up exactly (tests/envs/test_observation_parts.py checks every
    shipped config), so a manual generated from them (:mod:`pyflyt_engine.envs.manual`)
    cannot drift from the space."""

    name: str
    size: int
    meaning: str
    unit: str = ""


#: an observation's declared layout: entry key -> its parts, in order; the key
#: :data:`FLAT` stands for an observation that is one Box (no Dict)
ObservationLayout = dict[str, tuple[ObservationPart, ...]]
FLAT = ""

#: what each component kind's share of the auxiliary state holds (Vehicle.aux_state)
_AUX_MEANING = {
    "motors": ("motor throttles", "1"),
    "surfaces": ("control-surface deflections / their limits", "[-1, 1]"),
    "boosters": ("per booster: fuel fraction, duty, ignition", "[0, 1], 0/1"),
    "gimbals": ("gimbal angles / their limits", "[-1, 1]"),
    "battery": ("battery state of charge", "[0, 1]"),
}


def attitude_parts(
    quaternion: bool,
    action_names: Sequence[str],
    action_units: Sequence[str] | None,
    aux: Sequence[tuple[str, int]],
    fix_flag: bool = False,
) -> tuple[ObservationPart, ...]:
    """The parts of the attitude vector (:func:`attitude_vector`): ``aux`` is the vehicle's
    ``(component kind, entries)`` layout of its auxiliary state (:meth:`Vehicle.aux_layout
    <pyflyt_engine.vehicle.Vehicle.aux_layout>`); ``fix_flag`` appends the position fix's
    validity flag (``sensors.observe`` with a position sensor)."""
    units = ", ".join(action_units) if action_units else "as the action"
    parts = [
        ObservationPart("ang_vel", 3, "angular velocity (p, q, r)", "body, rad/s"),
        ObservationPart("attitude", 4, "attitude quaternion (x, y, z, w)", "ground, 1")
        if quaternion
        else ObservationPart("attitude", 3, "attitude Euler angles (roll, pitch, yaw)", "ground, rad"),
        ObservationPart("lin_vel", 3, "linear velocity (u, v, w)", "body, m/s"),
        ObservationPart("lin_pos", 3, "position (x, y, z)", "ground ENU, m"),
        ObservationPart(
            "previous_action",
            len(action_names),
            f"previous action ({', '.join(action_names)}); zeros after a reset",
            units,
        ),
    ]
    for kind, n in aux:
        meaning, unit = _AUX_MEANING.get(kind, (f"{kind} read-outs", ""))
        parts.append(ObservationPart(f"aux_{kind}", n, f"auxiliary state: {meaning}", unit))
    if fix_flag:
        parts.append(ObservationPart("fix_valid", 1, "the position fix's validity flag (sensors.observe)", "0/1"))
    return tuple(parts)


def layout_with_extras(layout: ObservationLayout, camera: Any, range_sensors: Sequence[Any]) -> ObservationLayout:
    """``layout`` with the camera image (``camera_observation``, or None) and the range
    sensors' readings, as :func:`with_image_space` and :func:`with_range_spaces` add them."""
    if camera is None and not range_sensors:
        return layout
    entries = dict(layout) if FLAT not in layout else {"attitude": layout[FLAT]}
    if camera is not None:
        cam = camera.camera
        depth = 3 if camera.channels == "rgb" else 4
        shape = (depth, cam.height, cam.width) if camera.channel_first else (cam.height, cam.width, depth)
        entries[camera.key] = (
            ObservationPart(
                "image",
                depth * cam.height * cam.width,
                f"camera '{cam.name}' image {shape}, {camera.channels.upper()}",
                "uint8 [0, 255]",
            ),
        )
    for sensor in range_sensors:
        size = int(np.prod(sensor.shape))
        entries[sensor.name] = (
            ObservationPart(
                sensor.name,
                size,
                f"{sensor.kind} range readings {tuple(sensor.shape)}",
                f"m, [0, {sensor.max_range:g}]",
            ),
        )
    return entries


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


# --------------------------------------------------------------- observation terms
#
# An agent's observation is built by the observation terms its env config's sections bind
# (``latency``/``randomize`` delays, ``sensors``, ``range_sensors``, ``camera_observation``):
# a *source* gives every vehicle's state and the agent's auxiliary state, *views* replace the
# agent's own state with what its sensors or estimator see, then the attitude vector and the
# task's observation are built, and *extras* add entries beside them.  Each term binds to an
# episode (None where its section is absent) and the episode core runs what is bound, with
# no branch of its own per feature.


class ObservationTerm(NamedTuple):
    """A registered observation term: where it acts (``source``, ``view`` or ``extra``) and
    ``bind(episode)``, its stage for one built episode or None (its config section is absent)."""

    bind: Callable[[Any], Callable[..., Any] | None]
    slot: str

    @property
    def description(self) -> str:
        return (self.bind.__doc__ or "").strip().splitlines()[0]


def delayed_state(episode: Any) -> Callable[..., Any] | None:
    """Every vehicle as it was observation_delay ago (latency, randomize observation_delay; drawn per reset)."""
    if not episode.latency_steps[1]:
        return None
    vehicles = episode.vehicles

    def source(i: int, states: list[KinematicState]) -> tuple[list[KinematicState], Any]:
        delayed = [v.delayed_observation() for v in vehicles]
        return [state for state, _ in delayed], delayed[i][1]

    return source


def _with_fix_flag(episode: Any, i: int, aux: Any, suite: Any) -> Any:
    return [*aux, suite.position_valid] if episode.fix_flag[i] else aux


def sensor_state(episode: Any) -> Callable[..., Any] | None:
    """The agent's rates and position as its noisy sensors read them, the fix's validity flag after aux (sensors.observe)."""
    if episode.sensed is None or episode.estimators is not None:
        return None
    sensed = episode.sensed

    def view(i: int, states: list[KinematicState], aux: Any) -> tuple[list[KinematicState], Any]:
        suite = sensed[i]
        states = [*states]
        states[i] = sensed_state(states[i], suite)
        return states, _with_fix_flag(episode, i, aux, suite)

    return view


def estimator_state(episode: Any) -> Callable[..., Any] | None:
    """The agent's attitude, velocity and position from its flight controller's estimator, its gyro's rates (sensors.estimator)."""
    if episode.sensed is None or episode.estimators is None:
        return None
    sensed, estimators = episode.sensed, episode.estimators

    def view(i: int, states: list[KinematicState], aux: Any) -> tuple[list[KinematicState], Any]:
        suite = sensed[i]
        states = [*states]
        states[i] = estimated_state(states[i], suite, estimators[i])
        return states, _with_fix_flag(episode, i, aux, suite)

    return view


def range_readings(episode: Any) -> Callable[..., Any] | None:
    """Each range sensor's readings under its name; the task's observation under attitude (range_sensors)."""
    if not any(episode.range_sensors):
        return None
    world, sensors = episode.world, episode.range_sensors

    def extra(i: int, observation: Any) -> Any:
        if not sensors[i]:
            return observation
        if not isinstance(observation, dict):
            observation = {"attitude": observation}
        for k, sensor in enumerate(sensors[i]):
            observation[sensor.name] = world.scan(i, k)
        return observation

    return extra


def camera_image(episode: Any) -> Callable[..., Any] | None:
    """The onboard camera's image under its key; the task's observation under attitude (camera_observation)."""
    c = episode.config.camera_observation
    if c is None:
        return None
    world, cameras = episode.world, episode.cameras

    def extra(i: int, observation: Any) -> Any:
        rgba = world.vehicles[i].capture(cameras[i])["rgba"]
        image = rgba[:, :, :3] if c.channels == "rgb" else rgba
        image = np.ascontiguousarray(image.transpose(2, 0, 1) if c.channel_first else image)
        if isinstance(observation, dict):
            return {**observation, c.key: image}
        return {"attitude": observation, c.key: image}

    return extra


#: Every observation term, in the order the stages of a slot run.
OBSERVATION_TERMS: dict[str, ObservationTerm] = {
    "delayed_state": ObservationTerm(delayed_state, "source"),
    "sensor_state": ObservationTerm(sensor_state, "view"),
    "estimator_state": ObservationTerm(estimator_state, "view"),
    "range_readings": ObservationTerm(range_readings, "extra"),
    "camera_image": ObservationTerm(camera_image, "extra"),
}


class Observation:
    """The observation terms bound to an episode (an :class:`~pyflyt_engine.envs.episode.EpisodeCore`),
    by slot: :attr:`source` (None: the true states and each vehicle's auxiliary state now),
    :attr:`views` and :attr:`extras`, which the episode core runs around the attitude vector
    and the task's observation (:meth:`EpisodeCore._observe
    <pyflyt_engine.envs.episode.EpisodeCore._observe>`).

    :meth:`reset` binds them again at every reset (a delay drawn per episode starts or
    stops the delayed source); the names bound are :attr:`bound`.
    """

    def __init__(self, episode: Any) -> None:
        self.episode = episode
        self.reset()

    def reset(self) -> None:
        """Bind the terms to the episode as it is now (after its reset's draws)."""
        episode = self.episode
        stages: dict[str, list[tuple[str, Callable[..., Any]]]] = {"source": [], "view": [], "extra": []}
        for name, term in OBSERVATION_TERMS.items():
            stage = term.bind(episode)
            if stage is not None:
                stages[term.slot].append((name, stage))
        if len(stages["source"]) > 1:
            raise ValueError(f"observation terms {[n for n, _ in stages['source']]} are all sources: one may bind")
        #: the names of the terms bound, in the order they run
        self.bound = tuple(name for slot in stages.values() for name, _ in slot)
        #: ``source(i, states) -> (states, aux)``; None: the true states, the vehicle's aux now
        self.source: Callable[..., Any] | None = stages["source"][0][1] if stages["source"] else None
        #: ``view(i, states, aux) -> (states, aux)``, in order
        self.views = tuple(stage for _, stage in stages["view"])
        #: ``extra(i, observation) -> observation``, in order
        self.extras = tuple(stage for _, stage in stages["extra"])

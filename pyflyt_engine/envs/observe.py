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

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from pyflyt_engine import exact
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import quaternion_to_rows
from pyflyt_engine.spec import SensorsSpec, UAVSpec
from pyflyt_engine.state import KinematicState


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

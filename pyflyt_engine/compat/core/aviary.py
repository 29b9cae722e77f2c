"""``Aviary``: the reference's world API over :class:`pyflyt_engine.world.World`.

What it keeps from the reference (PyFlyt 0.29.0 ``Aviary``, cited per item):

* ``state(i)`` is the (4, 3) array [ang_vel (body), ang_pos (Euler), lin_vel (body),
  lin_pos (ground)], so ``state(i)[-1]`` is the position (the native
  :class:`~pyflyt_engine.state.KinematicState` is a named tuple whose last field is not);
* one :meth:`Aviary.step` is one period of the slowest drone's controller: 1/120 s by
  default (a native ``World.step`` is one agent step, 1/30 s by default);
* integer flight modes with the reference's setpoint presets on a mode change, per-drone
  ``control_hz``, ``register_controller`` with a :class:`ControlClass`, wind as a
  :class:`WindFieldClass` or a plain function, ``contact_array`` indexed by body id,
  cameras from ``drone_options``, and every PyBullet function as a method
  (``aviary.loadURDF(...)``: the reference's Aviary is a ``BulletClient``).

Airframes are the shipped ones: ``"quadx"`` (``quadx_cf2x``), ``"fixedwing"`` and
``"rocket"``; a YAML path works too.  Python drone classes (``drone_type_mappings``)
are refused with :class:`~pyflyt_engine.compat.core.abstractions.UnsupportedFeature`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np

from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.compat.core.abstractions import (
    MODEL_FILES,
    YAML_AIRFRAMES,
    ControlClass,
    DroneClass,
    UnsupportedFeature,
    WindFieldClass,
)
from pyflyt_engine.compat.core.drones import Fixedwing, QuadX, Rocket
from pyflyt_engine.compat._commands import command_to_thrust_fraction, surface_commands_to_channels, thrust_gain
from pyflyt_engine.spec import CameraSpec, UAVSpec, load_uav_spec
from pyflyt_engine.atmosphere.field import WindField
from pyflyt_engine.state import KinematicState
from pyflyt_engine.vehicle import Controller
from pyflyt_engine.world import World

__all__ = [
    "Aviary",
    "AviaryInitException",
    "DroneClass",
    "DroneIndex",
    "Fixedwing",
    "QuadX",
    "Rocket",
    "WindFieldClass",
]

#: PyFlyt 0.29.0 ``core.aviary``: a drone's index in ``Aviary.drones`` (a type alias)
DroneIndex = int

#: reference drone type -> shipped airframe (PyFlyt 0.29.0 Aviary: "quadx", "fixedwing", "rocket")
DRONE_TYPES = {"quadx": "quadx_cf2x", "fixedwing": "fixedwing", "rocket": "rocket"}
#: PyFlyt 0.29.0 QuadX drone_model "cf2x" is the default model
_QUADX_MODELS = {"cf2x": "quadx_cf2x"}
#: drone_options the reference's drones take and what happens to them here
_KNOWN_OPTIONS = {
    "control_hz",
    "use_camera",
    "use_gimbal",
    "camera_angle_degrees",
    "camera_FOV_degrees",
    "camera_position_offset",
    "camera_resolution",
    "camera_fps",
    "drone_model",
    "starting_velocity",
    "starting_fuel_ratio",
    "np_random",
    "model_dir",
}


#: PyFlyt 0.29.0 Rocket ``aux_state``: [fins x 4, ignition, fuel, throttle, gimbals x 2]; the
#: shipped rocket's is [fins x 4, fuel, duty, ignition, gimbals x 2]: index map ours -> theirs
ROCKET_AUX_ORDER = (0, 1, 2, 3, 6, 4, 5, 7, 8)
#: PyFlyt 0.29.0 Camera: projection near and far planes [m]
CAMERA_NEAR, CAMERA_FAR = 0.1, 255.0


class AviaryInitException(ValueError):
    """A malformed Aviary argument (PyFlyt 0.29.0 ``AviaryInitException``; a ``ValueError`` here)."""


def reference_rocket_aux(aux: np.ndarray) -> np.ndarray:
    """The shipped rocket's auxiliary state in the reference's order (:data:`ROCKET_AUX_ORDER`)."""
    aux = np.asarray(aux, dtype=np.float64)
    if aux.shape[-1] != len(ROCKET_AUX_ORDER):
        return aux
    return aux[..., list(ROCKET_AUX_ORDER)]


def depth_to_zbuffer(depth: np.ndarray, near: float = CAMERA_NEAR, far: float = CAMERA_FAR) -> np.ndarray:
    """Linear depth [m] back to PyBullet's z-buffer value in [0, 1]: the inverse of
    ``depth = near far / (far - (far - near) d)`` (OpenGL perspective projection)."""
    depth = np.clip(np.asarray(depth, dtype=np.float64), near, far)
    return far * (1.0 - near / depth) / (far - near)


def state_array(state: KinematicState) -> np.ndarray:
    """The reference's (4, 3) state: [ang_vel, ang_pos, lin_vel, lin_pos] (PyFlyt 0.29.0 ``DroneClass.state``)."""
    return np.array((state.ang_vel, state.ang_pos, state.lin_vel, state.lin_pos), dtype=np.float64)


class _ControllerAdapter:
    """A reference :class:`ControlClass` constructor as a native custom controller.

    The reference builds a new instance each time its mode is selected (PyFlyt 0.29.0
    ``QuadX.set_mode``); the native vehicle calls :meth:`reset` then, which does the same.
    """

    def __init__(self, constructor: Callable[[], ControlClass], pwm_thrust: bool, gain: float) -> None:
        self.constructor = constructor
        self.instance = constructor()
        self.pwm_thrust = pwm_thrust
        self.gain = gain

    def reset(self) -> None:
        self.instance = self.constructor()

    def __call__(self, state: KinematicState, setpoint: np.ndarray) -> np.ndarray:
        out = np.asarray(self.instance.step(state_array(state), np.asarray(setpoint)), dtype=np.float64).reshape(-1)
        if out.shape != (4,):
            raise AssertionError(f"custom controller outputting wrong shape, expected (4, ) but got {out.shape}.")
        if self.pwm_thrust:
            out = out.copy()
            out[3] = command_to_thrust_fraction(out[3], self.gain)
        return out


class Drone:
    """One vehicle of an :class:`Aviary`, with the reference drone's attributes (PyFlyt 0.29.0 ``DroneClass``).

    Attributes: ``Id`` (PyBullet body), ``state`` (4, 3), ``aux_state``, ``setpoint``,
    ``mode``, ``control_period``, ``physics_period``, ``use_camera`` and, with a camera,
    ``rgbaImg`` (H, W, 4) uint8, ``depthImg`` (H, W, 1) PyBullet's z-buffer in [0, 1]
    (near 0.1 m, far 255 m, as the reference's camera), ``segImg`` (H, W, 1).  After the
    Aviary is disconnected, ``state`` and ``aux_state`` keep their last values.
    """

    def __init__(self, aviary: Aviary, index: int, kind: str, control_hz: float, camera: int | None) -> None:
        self._aviary = aviary
        self._index = index
        self.kind = kind
        self.vehicle = aviary.world.vehicles[index]
        self.Id = self.vehicle.body_id
        self.control_period = 1.0 / control_hz
        self.physics_period = 1.0 / aviary.physics_hz
        self.use_camera = camera is not None
        self._camera = camera
        self.rgbaImg: np.ndarray | None = None
        self.depthImg: np.ndarray | None = None
        self.segImg: np.ndarray | None = None
        self.mode = 0
        self._setpoint = np.zeros(0)
        self._controllers: dict[int, tuple[Callable[[], ControlClass], int]] = {}
        self.np_random = aviary.np_random
        self._gain = thrust_gain(self.vehicle) if kind == "quadx" else 1.0
        self._last_state: np.ndarray | None = None
        self._last_aux: np.ndarray | None = None
        self._state_source: KinematicState | None = None  # the vehicle state _last_state was made from

    # ------------------------------------------------------------------ read-outs

    @property
    def state(self) -> np.ndarray:
        """(4, 3): [ang_vel (body), ang_pos (Euler), lin_vel (body), lin_pos (ground)]."""
        if not self._aviary.connected:  # PyFlyt 0.29.0: the last state stays readable
            return self._last_state.copy() if self._last_state is not None else np.zeros((4, 3))
        source = self.vehicle.state  # the same object until the body moves
        if source is not self._state_source or self._last_state is None:
            self._state_source, self._last_state = source, state_array(source)
        return self._last_state.copy()

    @property
    def aux_state(self) -> np.ndarray:
        """The auxiliary state; the rocket's in the reference's order (see :data:`ROCKET_AUX_ORDER`)."""
        if not self._aviary.connected:
            return self._last_aux.copy() if self._last_aux is not None else np.zeros(0)
        aux = np.asarray(self.vehicle.aux_state, dtype=np.float64)
        if self.kind == "rocket":
            aux = reference_rocket_aux(aux)
        self._last_aux = aux
        return aux.copy()

    # ------------------------------------------------------------------ commands

    def _base_mode(self, mode: int) -> int:
        return self._controllers[mode][1] if mode in self._controllers else mode

    @property
    def setpoint(self) -> np.ndarray:
        """The setpoint as given, in the reference's layout for the current mode."""
        return self._setpoint.copy()

    @setpoint.setter
    def setpoint(self, value: Any) -> None:
        value = np.asarray(value, dtype=np.float64).reshape(-1)
        base = self._base_mode(self.mode)
        native = value
        if self.kind == "quadx" and base == 0 and self.mode not in self._controllers:
            native = value.copy()  # PyFlyt 0.29.0 QuadX mode 0: thrust is a motor command
            native[3] = command_to_thrust_fraction(native[3], self._gain)
        elif self.kind == "quadx" and base == -1 and self.mode not in self._controllers:
            native = np.clip(value * self._gain, -1.0, 1.0)  # PyFlyt 0.29.0 motor commands, matched at hover
        elif self.kind == "fixedwing" and self.mode == -1:
            native = surface_commands_to_channels(value)
        self.vehicle.set_setpoint(native)
        self._setpoint = value.copy()

    def set_mode(self, mode: int) -> None:
        """Select flight mode ``mode`` (the reference's numbers; registered ids too) and preset its setpoint.

        QuadX (PyFlyt 0.29.0 ``QuadX.set_mode``): -1 motors, 0 [p, q, r, T], 1 [roll,
        pitch, yaw, vz], 2 [p, q, r, z], 3 [roll, pitch, yaw, z], 4 [u, v, yaw rate, z],
        5 [u, v, yaw rate, vz], 6 [vx, vy, yaw rate, vz], 7 [x, y, yaw, z].  Presets: mode
        0 thrust -1 (motors idle), 1/5/6 zeros, 7 hold the current position and yaw, the
        others hold the current height.  Fixed-wing and rocket: -1 and 0, their raw commands.
        """
        mode = int(mode)
        base = self._base_mode(mode)
        if self.kind == "quadx":
            if not -1 <= base <= 7:
                raise ValueError(
                    f"`mode` must be between -1 and 7 or be registered in {list(self._controllers)}, got {mode}."
                )
            self.vehicle.set_mode(f"pyflyt_{mode}" if mode in self._controllers else mode)
        else:
            if mode not in (-1, 0):
                raise ValueError(f"`mode` must be -1 or 0 for the {self.kind}, got {mode}.")
            self.vehicle.set_mode("channels")
        self.mode = mode
        s = self.vehicle.state
        if self.kind == "quadx":
            if base == 0:
                preset = [0.0, 0.0, 0.0, -1.0]
            elif base in (1, 5, 6):
                preset = [0.0, 0.0, 0.0, 0.0]
            elif base == 7:
                preset = [s.lin_pos[0], s.lin_pos[1], s.ang_pos[2], s.lin_pos[2]]
            elif base == -1:
                preset = [0.0, 0.0, 0.0, 0.0]
            else:
                preset = [0.0, 0.0, 0.0, s.lin_pos[2]]
            self.setpoint = np.array(preset)
        else:
            self.setpoint = np.zeros(6 if (self.kind == "fixedwing" and mode == -1) else self.vehicle.setpoint.size)

    def register_controller(
        self, controller_id: int, controller_constructor: type[ControlClass], base_mode: int
    ) -> None:
        """Add flight mode ``controller_id`` flown by ``controller_constructor()`` over ``base_mode``
        (PyFlyt 0.29.0 ``QuadX.register_controller``: QuadX only, base modes -1 to 7)."""
        if self.kind != "quadx":
            raise UnsupportedFeature(f"custom controllers are supported on the QuadX only, not the {self.kind}")
        if not -1 <= int(base_mode) <= 7:
            raise ValueError(f"`base_mode` must be between -1 and 7, got {base_mode}.")
        if -1 <= int(controller_id) <= 7:
            raise ValueError(f"`controller_id` must not be a built-in mode (-1 to 7), got {controller_id}.")
        adapter = _ControllerAdapter(controller_constructor, pwm_thrust=int(base_mode) == 0, gain=self._gain)
        # the adapter returns an array where the protocol says Sequence[float]: the vehicle takes either
        self.vehicle.register_controller(f"pyflyt_{int(controller_id)}", cast(Controller, adapter), int(base_mode))
        self._controllers[int(controller_id)] = (controller_constructor, int(base_mode))

    def get_joint_info(self) -> None:
        """Print the body's links and joints (PyFlyt 0.29.0 ``DroneClass.get_joint_info``)."""
        cid = self._aviary.world.client
        count = p.getNumJoints(self.Id, physicsClientId=cid)
        infos = [p.getJointInfo(self.Id, i, physicsClientId=cid) for i in range(count)]
        print(f"Spawned UAV with ID {self.Id} and {len(infos)} links.")
        for info in infos:
            print(f"Joint {info[0]}: {info[1].decode()}, link {info[12].decode()}")

    def disable_artificial_damping(self) -> None:
        """Zero PyBullet's linear and angular damping on every link."""
        cid = self._aviary.world.client
        for link in range(-1, p.getNumJoints(self.Id, physicsClientId=cid)):
            p.changeDynamics(self.Id, link, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)

    def reset(self) -> None:
        self.vehicle.reset()
        self.set_mode(0)

    def _capture(self) -> None:
        if self._camera is None:
            return
        images = self._aviary.world.capture(self._index, self._camera)
        self.rgbaImg, self.segImg = images["rgba"], images["segmentation"]
        self.depthImg = depth_to_zbuffer(images["depth"])


class Aviary:
    """The reference's ``Aviary`` over a native :class:`World` (see the module docstring).

    Args (PyFlyt 0.29.0 ``Aviary``): ``start_pos`` (n, 3), ``start_orn`` (n, 3),
    ``drone_type`` (one or n of "quadx", "fixedwing", "rocket", or YAML paths),
    ``drone_type_mappings`` (refused when it names Python classes), ``drone_options`` (one
    dict for all or n dicts: ``control_hz``, ``use_camera``, ``use_gimbal``,
    ``camera_angle_degrees``, ``camera_FOV_degrees``, ``camera_position_offset``,
    ``camera_resolution``, ``camera_fps``, ``drone_model``, ``starting_velocity``),
    ``wind_type`` (a :class:`WindFieldClass` subclass, or the name of a native wind preset
    such as ``"dryden_light"``), ``wind_options``, ``render``, ``physics_hz`` (240),
    ``world_scale`` (accepted; the ground plane is infinite here), ``seed``, ``np_random``.
    """

    def __init__(
        self,
        start_pos: np.ndarray,
        start_orn: np.ndarray,
        drone_type: str | Sequence[str],
        drone_type_mappings: None | dict[str, Any] = None,
        drone_options: dict[str, Any] | Sequence[dict[str, Any]] | None = None,
        wind_type: None | str | type[WindFieldClass] = None,
        wind_options: dict[str, Any] | None = None,
        render: bool = False,
        physics_hz: int = 240,
        world_scale: float = 1.0,
        seed: None | int = None,
        np_random: None | np.random.Generator = None,
    ) -> None:
        start_pos = np.asarray(start_pos, dtype=np.float64)
        start_orn = np.asarray(start_orn, dtype=np.float64)
        if start_pos.ndim != 2 or start_pos.shape[1] != 3:
            raise AviaryInitException(f"start_pos must be an array of shape (n, 3), got {start_pos.shape}.")
        if start_orn.shape != start_pos.shape:
            raise AviaryInitException(f"start_orn must have the same shape as start_pos, got {start_orn.shape}.")
        n = start_pos.shape[0]
        kinds = [drone_type] * n if isinstance(drone_type, str) else list(drone_type)
        if len(kinds) != n:
            raise AviaryInitException(f"drone_type must be a string or {n} strings, got {len(kinds)}.")
        mappings = dict(drone_type_mappings or {})
        for kind in kinds:
            if kind in mappings and not (isinstance(mappings[kind], str) and mappings[kind] in DRONE_TYPES):
                raise UnsupportedFeature(f"drone_type '{kind}' (drone_type_mappings): {YAML_AIRFRAMES}")
        kinds = [mappings.get(k, k) for k in kinds]
        options: list[dict[str, Any]]
        if drone_options is None:
            options = [{} for _ in range(n)]
        elif isinstance(drone_options, dict):
            options = [dict(drone_options) for _ in range(n)]
        else:
            options = [dict(o) for o in drone_options]
            if len(options) != n:
                raise AviaryInitException(f"drone_options must be a dict or {n} dicts, got {len(options)}.")
        for option in options:
            unknown = set(option) - _KNOWN_OPTIONS
            if unknown:
                raise TypeError(f"unknown drone_options {sorted(unknown)}; known: {sorted(_KNOWN_OPTIONS)}")
            if option.get("model_dir") is not None:
                raise UnsupportedFeature(f"drone_options model_dir: {MODEL_FILES}")

        self.physics_hz = int(physics_hz)
        self.world_scale = world_scale
        self.render = bool(render)
        # PyFlyt 0.29.0 drones: control_hz 120 unless given; the step is the slowest controller's period
        rates = [float(o.get("control_hz", 120)) for o in options] or [120.0]
        fastest, slowest = max(rates), min(rates)
        for rate in rates:
            if (fastest / rate) % 1 or (rate / slowest) % 1 or (self.physics_hz / rate) % 1:
                raise AssertionError("Looprates must form common multiples of each other.")
        self.world = World(
            physics_hz=self.physics_hz,
            control_hz=fastest,
            agent_hz=slowest,
            seed=seed,
            render=self.render,
            wind=wind_type if isinstance(wind_type, str) else None,
        )
        self.np_random = np_random if np_random is not None else self.world.np_random
        self.step_period = 1.0 / slowest
        self.updates_per_step = int(self.physics_hz / slowest)

        self.drones: list[Drone] = []
        self._kinds: list[str] = []
        base_ratio = self.world.physics_per_control
        for i, (kind, option, rate) in enumerate(zip(kinds, options, rates)):
            spec, kind_name = self._airframe(kind, option)
            spec = self._with_fuel(spec, kind_name, option)
            spec, camera = self._with_camera(spec, option, slowest)
            # the vehicle's controller runs at its own rate: built with that period, held in between
            self.world.physics_per_control = int(round(self.physics_hz / rate))
            try:
                self.world.add_vehicle(spec, start_pos[i].tolist(), start_orn[i].tolist())
            finally:
                self.world.physics_per_control = base_ratio
            if kind_name == "yaml":  # a multirotor flies the QuadX's numbered modes, anything else raw commands
                kind_name = "quadx" if self.world.vehicles[i].controller is not None else "yaml"
            hold = int(round(fastest / rate))
            if hold > 1:
                _hold_controller(self.world.vehicles[i], hold)
            self.drones.append(Drone(self, i, kind_name, rate, camera))
            self._kinds.append(kind_name)
        self._start_velocities = [self._start_velocity(k, o, orn) for k, o, orn in zip(self._kinds, options, start_orn)]

        self.wind_field: Callable[[float, np.ndarray], np.ndarray] | None = None
        if wind_type is not None and not isinstance(wind_type, str):
            if not callable(wind_type):
                raise LookupError("Invalid setting for wind field.")
            field = wind_type(np_random=self.np_random, **(wind_options or {}))
            WindFieldClass._check_wind_field_validity(field)
            self.register_wind_field_function(field)

        self.aviary_steps = 0
        self.reset_count = 0
        self.armed_drones: list[Drone] = list(self.drones)
        self._reset_drones()

    @classmethod
    def over_world(cls, world: World, kinds: Sequence[str]) -> Aviary:
        """An Aviary view of a world built elsewhere (a compat env's), one drone per vehicle.

        ``kinds``: "quadx", "fixedwing" or "rocket" per vehicle.  Reads (``state``,
        ``aux_state``, ``contact_array``, ``planeId``, ``drones``, PyBullet functions) see
        that world; :meth:`step` advances it by one of its agent steps; :meth:`reset`
        restores it, as its owner's reset would not: leave resets to the owner.
        """
        self = cls.__new__(cls)
        self.world = world
        self.physics_hz = int(world.physics_hz)
        self.world_scale = 1.0
        self.render = False
        self.np_random = world.np_random
        self.step_period = 1.0 / world.agent_hz
        self.updates_per_step = int(world.physics_per_agent)
        self.drones = [Drone(self, i, kind, world.control_hz, None) for i, kind in enumerate(kinds)]
        for drone in self.drones:
            drone.mode = 0
        self._kinds = list(kinds)
        self._start_velocities = [None] * len(self.drones)
        self.wind_field = None
        self.aviary_steps = 0
        self.reset_count = 0
        self.armed_drones = list(self.drones)
        return self

    # ------------------------------------------------------------------ building

    @staticmethod
    def _airframe(kind: str, option: dict[str, Any]) -> tuple[UAVSpec, str]:
        if kind in DRONE_TYPES:
            name = DRONE_TYPES[kind]
            model = option.get("drone_model")
            if model is not None:
                if kind != "quadx" or model not in _QUADX_MODELS:
                    raise UnsupportedFeature(f"drone_model '{model}' of '{kind}': {MODEL_FILES}")
                name = _QUADX_MODELS[model]
            return load_uav_spec(name), kind
        path = Path(kind)
        if path.suffix in (".yaml", ".yml"):
            return load_uav_spec(path), "yaml"
        raise UnsupportedFeature(f"unknown drone_type '{kind}' (shipped: {', '.join(DRONE_TYPES)}); {YAML_AIRFRAMES}")

    @staticmethod
    def _with_fuel(spec: UAVSpec, kind: str, option: dict[str, Any]) -> UAVSpec:
        """The rocket's tank at ``starting_fuel_ratio`` (PyFlyt 0.29.0 Rocket: default 0.05)."""
        if kind != "rocket" or spec.boosters is None:
            return spec
        fuel = float(option.get("starting_fuel_ratio", 0.05))
        if not 0.0 <= fuel <= 1.0:
            raise ValueError(f"starting_fuel_ratio must be in [0, 1], got {fuel}")
        return spec.model_copy(update={"boosters": spec.boosters.model_copy(update={"initial_fuel": fuel})})

    @staticmethod
    def _with_camera(spec: UAVSpec, option: dict[str, Any], step_hz: float) -> tuple[UAVSpec, int | None]:
        """The airframe with the reference's drone camera added (PyFlyt 0.29.0 QuadX: angle 20 deg,
        FOV 90 deg, 128 x 128, refreshed every step unless camera_fps)."""
        if not option.get("use_camera", False):
            return spec, None
        height, width = option.get("camera_resolution", (128, 128))
        angle = float(option.get("camera_angle_degrees", 20))
        gimbal = bool(option.get("use_gimbal", False))
        offset = tuple(float(v) for v in option.get("camera_position_offset", (0.0, 0.0, 0.0)))
        fps = option.get("camera_fps")
        camera = CameraSpec(
            name="pyflyt_camera",
            position=offset,
            # PyFlyt 0.29.0 Camera: gimballed, tilted down from the horizon; fixed, tilted up
            # (here a positive pitch looks down)
            orientation_deg=(0.0, angle if gimbal else -angle, 0.0),
            fov=float(option.get("camera_FOV_degrees", 90)),
            width=int(width),
            height=int(height),
            horizon_lock=gimbal,
            capture_hz=float(fps) if fps else float(step_hz),
            near=CAMERA_NEAR,
            far=CAMERA_FAR,
            outputs=["rgba", "depth", "segmentation"],
        )
        return spec.model_copy(update={"cameras": [*spec.cameras, camera]}), len(spec.cameras)

    @staticmethod
    def _start_velocity(kind: str, option: dict[str, Any], start_orn: np.ndarray) -> tuple[float, float, float] | None:
        """The fixed-wing's spawn velocity in its body frame.

        PyFlyt 0.29.0 Fixedwing: ``starting_velocity`` (default (20, 0, 0)) is passed to
        ``resetBaseVelocity`` as it is, so it is a ground-frame vector (its dogfight points it
        along each aircraft's nose); the native reset takes body-frame velocities.
        """
        if kind != "fixedwing":
            return None
        velocity = np.asarray(option.get("starting_velocity", (20.0, 0.0, 0.0)), dtype=np.float64).reshape(-1)
        if velocity.shape != (3,):
            raise ValueError(f"starting_velocity must be 3 numbers (ground frame, m/s), got {velocity.shape}")
        body_to_ground = np.array(p.getMatrixFromQuaternion(p.getQuaternionFromEuler(start_orn.tolist()))).reshape(3, 3)
        return tuple(float(v) for v in body_to_ground.T @ velocity)  # type: ignore[return-value]

    def _reset_drones(self) -> None:
        self.world.reset()  # re-arms every vehicle
        self.armed_drones = list(self.drones)
        for drone, velocity in zip(self.drones, self._start_velocities):
            if velocity is not None:
                drone.vehicle.reset(lin_vel=velocity)
            drone.set_mode(0)
            drone._capture()
        self.aviary_steps = 0

    # ------------------------------------------------------------------ the reference's API

    def reset(self) -> None:
        """Every drone back to its start, idle, in mode 0 (PyFlyt 0.29.0 ``Aviary.reset``)."""
        self.reset_count += 1
        self._reset_drones()

    def step(self) -> None:
        """One period of the slowest controller (1/120 s by default), as PyFlyt 0.29.0 ``Aviary.step``."""
        self.world.step()
        self.aviary_steps += 1
        for drone in self.drones:
            if drone.use_camera:
                drone._capture()

    @property
    def elapsed_time(self) -> float:
        """Simulated time since the start or the last reset [s]."""
        return self.world.elapsed

    @property
    def physics_steps(self) -> int:
        return self.world.physics_steps

    @property
    def planeId(self) -> int:  # noqa: N802 - the reference's name
        return self.world.ground_id  # type: ignore[return-value]

    @property
    def contact_array(self) -> np.ndarray:
        """(B, B) bool by PyBullet body id: which bodies touched during the last step
        (PyFlyt 0.29.0 ``Aviary.contact_array``)."""
        bodies = self.world.contact_bodies
        size = max([*bodies, p.getNumBodies(physicsClientId=self.world.client) - 1]) + 1
        out = np.zeros((size, size), dtype=bool)
        ids = np.array(bodies, dtype=np.int64)
        matrix = self.world.contact_array
        out[np.ix_(ids, ids)] = matrix
        return out

    def _touches_ground(self) -> bool:
        """``np.any(contact_array[planeId])``, without building the whole array."""
        bodies, ground = self.world.contact_bodies, self.world.ground_id
        if ground is None or ground not in bodies:
            return False
        return bool(np.any(self.world.contact_array[bodies.index(ground)]))

    def register_all_new_bodies(self) -> None:
        """Track collisions of every body created since (e.g. with ``aviary.loadURDF``)."""
        cid = self.world.client
        known = set(self.world.contact_bodies)
        for i in range(p.getNumBodies(physicsClientId=cid)):
            body = p.getBodyUniqueId(i, physicsClientId=cid)
            if body not in known:
                self.world.add_body(body)

    def register_wind_field_function(self, wind_field: Callable[[float, np.ndarray], np.ndarray]) -> None:
        """Wind from ``wind_field(time, positions (n, 3)) -> (n, 3)`` [m/s], ground frame, sampled
        at each vehicle's position at every read of its state (PyFlyt 0.29.0
        ``Aviary.register_wind_field_function``).  It replaces the native atmosphere."""
        if not callable(wind_field):
            raise AssertionError("`wind_field` function must be callable.")
        WindFieldClass._check_wind_field_validity(wind_field)
        self.wind_field = wind_field
        # duck-typed: _FunctionWind is the part of a WindField the atmosphere reads
        self.world.atmosphere.field = cast(WindField, _FunctionWind(wind_field, self.world))
        for vehicle in self.world.vehicles:
            vehicle.state_changed()

    def state(self, index: int) -> np.ndarray:
        """(4, 3): [ang_vel (body), ang_pos (Euler), lin_vel (body), lin_pos (ground)]."""
        return self.drones[index].state

    def aux_state(self, index: int) -> np.ndarray:
        return self.drones[index].aux_state

    @property
    def all_states(self) -> list[np.ndarray]:
        return [d.state for d in self.drones]

    @property
    def all_aux_states(self) -> list[np.ndarray]:
        return [d.aux_state for d in self.drones]

    def set_mode(self, flight_modes: int | Sequence[int]) -> None:
        """One mode for every drone, or one per drone."""
        if isinstance(flight_modes, (int, np.integer)):
            for drone in self.drones:
                drone.set_mode(int(flight_modes))
            return
        if len(flight_modes) != len(self.drones):
            raise AssertionError(f"Expected {len(self.drones)} flight_modes, got {len(flight_modes)}.")
        for drone, mode in zip(self.drones, flight_modes):
            drone.set_mode(int(mode))

    def set_setpoint(self, index: int, setpoint: np.ndarray) -> None:
        self.drones[index].setpoint = setpoint

    def set_all_setpoints(self, setpoints: np.ndarray) -> None:
        for drone, setpoint in zip(self.drones, setpoints):
            drone.setpoint = setpoint

    def set_armed(self, settings: int | bool | Sequence[int] | Sequence[bool]) -> None:
        """Arm or disarm every drone, or each drone by its own setting."""
        if isinstance(settings, (bool, int, np.integer)):
            settings = [bool(settings)] * len(self.drones)
        if len(settings) != len(self.drones):
            raise AssertionError(f"Expected {len(self.drones)} settings, got {len(settings)}.")
        for i, armed in enumerate(settings):
            self.world.set_armed(i, bool(armed))
        #: the drones that receive updates (PyFlyt 0.29.0 ``Aviary.armed_drones``)
        self.armed_drones = [d for d, armed in zip(self.drones, settings) if armed]

    def print_all_bodies(self) -> None:
        cid = self.world.client
        for i in range(p.getNumBodies(physicsClientId=cid)):
            body = p.getBodyUniqueId(i, physicsClientId=cid)
            print(f"ID {body}: {p.getBodyInfo(body, physicsClientId=cid)}")

    @property
    def connected(self) -> bool:
        """Whether the PyBullet client is still open."""
        client = self.world.client
        return client is not None and client >= 0 and bool(p.isConnected(client))

    def disconnect(self) -> None:
        """Close the PyBullet client (idempotent); the drones' last states stay readable."""
        if self.connected:
            for drone in self.drones:
                drone.state, drone.aux_state  # noqa: B018 - keeps the last values
        self.world.close()

    def __getattr__(self, name: str) -> Any:
        # the reference's Aviary is a BulletClient: every PyBullet function is a method and
        # every PyBullet constant an attribute (aviary.GEOM_MESH, aviary.JOINT_FIXED)
        if name.startswith("_") or "world" not in self.__dict__:
            raise AttributeError(name)
        member = getattr(p, name, None)
        if isinstance(member, (int, float)) and not isinstance(member, bool) and name.isupper():
            return member
        if not callable(member):
            raise AttributeError(f"'Aviary' object has no attribute '{name}'")
        return functools.partial(member, physicsClientId=self.world.client)


def _hold_controller(vehicle: Any, hold: int) -> None:
    """Run ``vehicle``'s controller on one control tick of the world in ``hold`` and keep its
    commands in between (a slower drone in a faster world, PyFlyt 0.29.0
    ``DroneClass.update_control``: ``physics_step % physics_control_ratio``); the count
    restarts at every reset of the vehicle."""
    vehicle.set_control_hold(hold)


class _FunctionWind:
    """A wind function in the place of the world's wind field (the part of
    :class:`~pyflyt_engine.atmosphere.WindField` the atmosphere uses): each vehicle's probe
    calls ``function(time, position (1, 3))`` at the world's elapsed time; no rotary gust."""

    static = False  # the function may change with time: sampled at every read

    def __init__(self, function: Callable[[float, np.ndarray], np.ndarray], world: Any) -> None:
        self.function, self.world = function, world

    def add_vehicle(self, span: float) -> Callable[[Sequence[float]], tuple[float, ...]]:
        def probe(position: Sequence[float]) -> tuple[float, ...]:
            w = np.asarray(self.function(self.world.elapsed, np.asarray(position, dtype=np.float64).reshape(1, 3)))
            return (float(w[0, 0]), float(w[0, 1]), float(w[0, 2]), 0.0, 0.0, 0.0)

        return probe

    def advance(self) -> None:
        """Nothing to move on: the function is called with the time."""

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Nothing to redraw: the function holds its own state."""

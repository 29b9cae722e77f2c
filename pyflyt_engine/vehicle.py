"""A vehicle in the world: its spec, its PyBullet body, its components and controller.

This module is the adapter between the pure component models and PyBullet.  Per
physics step a vehicle reads its velocity when its loads depend on it (drag, lifting
surfaces), advances every actuator, sums every component load into one net force and
one net torque about its centre of mass (the body origin), and applies them in the body
frame: two PyBullet calls whatever the number of components.  Summing is exact for a
rigid body: a force F at a point r is F at the centre of mass plus the torque r x F.

Control inputs.  A vehicle's ``setpoint`` is interpreted by its flight mode:

* multirotor modes (:mod:`pyflyt_engine.control.modes`): the mode's four values,
  followed by one value per declared channel (for actuators outside the multirotor
  mixer, e.g. a quadplane's pusher and control surfaces);
* ``channels``: one value per declared channel (the spec's ``channels`` section), which
  drive motors, flaps, boosters and gimbals through their ``mix`` weights;
* ``attitude_airspeed`` (fixed-wing autopilot): [roll, pitch, yaw rate, airspeed].
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pybullet as p

from pyflyt_engine.assembly import Assembly, assemble
from pyflyt_engine.components.booster import (
    booster_loads,
    booster_step,
    initial_booster_state,
    tank_mass_properties,
)
from pyflyt_engine.components.camera import capture
from pyflyt_engine.components.drag import DragParams, drag_wrench
from pyflyt_engine.components.gimbal import gimbal_step, rotate_axes
from pyflyt_engine.components.lifting_surface import flap_step, surface_loads
from pyflyt_engine.components.motor import (
    MotorParams,
    clip_command,
    motor_lag,
    motor_step_wrench,
    motor_wrench_matrix,
    noise_factors,
)
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.control.fixedwing import FIXEDWING_MODES, FixedwingAutopilot
from pyflyt_engine.control.mixer import Mixer
from pyflyt_engine.control.modes import FlightMode, resolve_mode
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import euler_to_quaternion
from pyflyt_engine.spec import FixedwingControlSpec, MultirotorControlSpec, UAVSpec
from pyflyt_engine.state import KinematicState
from pyflyt_engine.urdf import urdf_path

#: Standard normals drawn per refill of a vehicle's noise buffer (per actuator).
_NOISE_BLOCK = 1024
_ORIGIN = (0.0, 0.0, 0.0)
_LINK_FRAME = p.LINK_FRAME
# Hot-path PyBullet calls pass the client id positionally: keyword parsing in the
# binding costs a few tenths of a microsecond per call, at the physics rate.


class Controller(Protocol):
    """A user controller: maps (state, setpoint) to the setpoint of a built-in base mode."""

    def __call__(self, state: KinematicState, setpoint: np.ndarray) -> Sequence[float]: ...


@dataclass
class _CustomMode:
    mode: FlightMode
    controller: Controller
    base: FlightMode


def _subset(motors: MotorParams, indices: Sequence[int]) -> MotorParams:
    idx = list(indices)
    return MotorParams(
        positions=motors.positions[idx],
        thrust_axes=motors.thrust_axes[idx],
        spin=motors.spin[idx],
        tau=motors.tau[idx],
        max_rpm=motors.max_rpm[idx],
        kf=motors.kf[idx],
        kt=motors.kt[idx],
        noise_ratio=motors.noise_ratio[idx],
    )


def motor_params_from_spec(spec: UAVSpec) -> MotorParams | None:
    """The :class:`MotorParams` of a spec's ``motors`` (centre-of-mass frame; None without)."""
    return assemble(spec).motors


class Vehicle:
    """One UAV in a :class:`~pyflyt_engine.world.World`.

    Create vehicles through :meth:`World.add_vehicle`; the world calls
    :meth:`read_state`, :meth:`control_step` and :meth:`apply_loads` on its schedule.

    Attributes:
        spec: the validated airframe spec.
        parts: its components in the centre-of-mass frame (:class:`Assembly`).
        body_id: the PyBullet body id.
        state: the latest :class:`KinematicState`.
        mode: the active :class:`FlightMode`; setpoint: its current setpoint.
        channels: the current channel vector (names: ``parts.channels``).
        armed: when False, every actuator is commanded to zero.
    """

    def __init__(
        self,
        client: int,
        spec: UAVSpec,
        position: Sequence[float],
        orientation: Sequence[float],
        physics_dt: float,
        control_dt: float,
        rng: np.random.Generator,
        mode: str | int | None = None,
        drag: bool = True,
    ) -> None:
        self.spec = spec
        self.parts: Assembly = assemble(spec)
        parts = self.parts
        self._client = client
        self.physics_dt = physics_dt
        self.control_dt = control_dt
        self._rng = rng
        self.spawn_position = tuple(float(v) for v in position)
        self.spawn_orientation = tuple(float(v) for v in orientation)
        if len(self.spawn_position) != 3 or len(self.spawn_orientation) != 3:
            raise ConfigError("a vehicle's position and orientation need 3 values each ([x, y, z], [roll, pitch, yaw])")

        self.body_id = p.loadURDF(
            str(urdf_path(spec)),
            basePosition=self.spawn_position,
            baseOrientation=euler_to_quaternion(*self.spawn_orientation),
            flags=p.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=client,
        )
        # PyBullet damps every body by default (0.04); vehicles get drag from the model only.
        p.changeDynamics(self.body_id, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=client)
        self._dry_inertia = np.diag(parts.inertia).copy()

        # --- motors: fixed-axis ones through a precomputed wrench map
        motors = parts.motors
        self.motors = motors
        n = motors.count if motors is not None else 0
        self._gimballed_motors = sorted({i for kind, i in parts.gimbal_targets if kind == "motor"})
        if motors is not None:
            wrench = motor_wrench_matrix(motors)
            wrench[:, self._gimballed_motors] = 0.0
            self._motor_wrench = wrench
            self._motor_lag = motor_lag(motors, physics_dt).tolist()
            self._motor_has_noise = bool(np.any(motors.noise_ratio > 0))
        else:
            self._motor_wrench = np.zeros((6, 0))
            self._motor_lag = []
            self._motor_has_noise = False
        # Motor state lives in Python lists, stepped by motor_step_wrench: with a handful
        # of motors, float arithmetic beats NumPy's per-call overhead at the physics rate.
        self._wrench_columns = [tuple(col) for col in self._motor_wrench.T.tolist()]
        self._no_noise = [1.0] * n
        self._throttle = [0.0] * n
        self._command = [0.0] * n
        self._noise: list[list[float]] = []
        self._noise_index = 0
        self._channel_motors = [i for i in range(n) if i not in parts.mixer_motors]

        # --- lifting surfaces, boosters, gimbals, cameras
        self.surface_deflection = np.zeros(len(parts.surfaces))
        self.surface_command = np.zeros(len(parts.surfaces))
        self.booster_state = initial_booster_state(parts.boosters, fuel_fraction=spec.boosters.initial_fuel) if parts.boosters else None
        self.booster_ignition = np.zeros(parts.boosters.n, dtype=bool) if parts.boosters else None
        self.booster_throttle = np.zeros(parts.boosters.n) if parts.boosters else None
        self.gimbal_angles = np.zeros((parts.gimbals.n, 2)) if parts.gimbals else None
        self.gimbal_command = np.zeros((parts.gimbals.n, 2)) if parts.gimbals else None
        self._camera_cache: dict[int, tuple[float, dict[str, np.ndarray]]] = {}

        # --- drag
        drag_params = DragParams(spec.drag.coefficients, spec.drag.areas, spec.drag.angular_damping)
        self._drag_on = drag and drag_params.active
        self._drag_factors = drag_params.factors
        self._angular_damping = drag_params.angular_damping
        self._velocity_body = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        self.needs_velocity = self._drag_on or bool(parts.surfaces)
        """Whether the loads need fresh velocities every physics step (drag, surfaces)."""

        # --- control
        self.channels = np.clip(np.zeros(len(parts.channels)), parts.channel_low, parts.channel_high)
        self.controller: MultirotorController | None = None
        self.autopilot: FixedwingAutopilot | None = None
        self._custom_modes: dict[str, _CustomMode] = {}
        if isinstance(spec.control, MultirotorControlSpec):
            assert motors is not None  # guaranteed by the spec validator
            self.mixer = Mixer(_subset(motors, parts.mixer_motors))
            self.controller = MultirotorController(
                spec.control, parts.mass, np.diag(parts.inertia), self.mixer, control_dt
            )
            self._modes: dict[str, FlightMode] = {}
            self.mode = self.controller.mode
        else:
            self._modes = dict(FIXEDWING_MODES) if isinstance(spec.control, FixedwingControlSpec) else {"channels": FIXEDWING_MODES["channels"]}
            if isinstance(spec.control, FixedwingControlSpec):
                self.autopilot = FixedwingAutopilot(spec.control, parts.channels, parts.channel_low, parts.channel_high, control_dt)
            self.mode = self._resolve(spec.control.mode if isinstance(spec.control, FixedwingControlSpec) else "channels")
        self.setpoint = np.zeros(self._setpoint_size(self.mode))
        self._plain_multirotor = (
            self.controller is not None and not parts.channels and len(parts.mixer_motors) == n
            and list(parts.mixer_motors) == list(range(n))
        )
        self._has_components = parts.gimbals is not None or bool(parts.surfaces) or parts.boosters is not None
        self.armed = True
        if mode is not None:
            self.set_mode(mode)
        self._update_mass()
        self.state = self.read_state()

    # ------------------------------------------------------------ commanding

    def _resolve(self, mode: str | int) -> FlightMode:
        if self.controller is not None:
            return resolve_mode(mode, {k: v.mode for k, v in self._custom_modes.items()})
        name = str(mode)
        if name not in self._modes:
            raise ConfigError(f"unknown mode '{mode}' for vehicle '{self.spec.name}': available {', '.join(self._modes)}")
        return self._modes[name]

    def _setpoint_size(self, mode: FlightMode) -> int:
        if mode.name == "channels":
            return len(self.parts.channels)
        if mode.name == "motors":
            return len(self.parts.mixer_motors) + len(self.parts.channels)
        extra = len(self.parts.channels) if self.controller is not None else 0
        return len(mode.setpoint) + extra

    @property
    def setpoint_layout(self) -> tuple[str, ...]:
        """Names of the setpoint entries in the current mode."""
        if self.mode.name == "channels":
            return self.parts.channels
        if self.mode.name == "motors":
            return tuple(f"m{i + 1}" for i in self.parts.mixer_motors) + self.parts.channels
        extra = self.parts.channels if self.controller is not None else ()
        return tuple(self.mode.setpoint) + extra

    def set_mode(self, mode: str | int) -> None:
        """Select a flight mode by name, alias, PyFlyt integer or registered custom name."""
        resolved = self._resolve(mode)
        if self.controller is not None:
            base = self._custom_modes[resolved.name].base if resolved.name in self._custom_modes else resolved
            self.controller.set_mode(base)
            custom = self._custom_modes.get(resolved.name)
            if custom is not None and hasattr(custom.controller, "reset"):
                custom.controller.reset()  # type: ignore[attr-defined]
        elif self.autopilot is not None and resolved is not self.mode:
            self.autopilot.reset()
        if resolved is not self.mode or self.setpoint.size != self._setpoint_size(resolved):
            self.setpoint = np.zeros(self._setpoint_size(resolved))
        self.mode = resolved

    def set_setpoint(self, setpoint: Sequence[float] | np.ndarray) -> None:
        """Set the setpoint of the current mode (layout: :attr:`setpoint_layout`)."""
        value = np.asarray(setpoint, dtype=np.float64).reshape(-1)
        if value.shape != self.setpoint.shape:
            layout = ", ".join(self.setpoint_layout)
            raise ConfigError(
                f"setpoint for mode '{self.mode.name}' needs {self.setpoint.size} values ({layout}), got {value.size}"
            )
        if not math.isfinite(value.sum()):  # any inf or nan makes the sum non-finite
            raise ConfigError(f"setpoint contains non-finite values: {value.tolist()}")
        self.setpoint = value

    def register_controller(
        self,
        name: str,
        controller: Controller | Callable[[KinematicState, np.ndarray], Sequence[float]],
        base_mode: str | int,
        setpoint: Sequence[str] = ("a", "b", "c", "d"),
    ) -> None:
        """Add a flight mode ``name`` run by ``controller`` on top of ``base_mode``.

        At each control step ``controller(state, setpoint)`` returns a setpoint for the
        built-in ``base_mode``, which the cascade then flies.  ``setpoint`` names the
        new mode's setpoint entries (its length is the setpoint size).
        """
        if self.controller is None:
            raise ConfigError(f"vehicle '{self.spec.name}' has no multirotor controller to extend")
        base = resolve_mode(base_mode)
        mode = FlightMode(name, None, tuple(setpoint), f"custom controller over {base.name}")
        self._custom_modes[name] = _CustomMode(mode, controller, base)

    # -------------------------------------------------------------- stepping

    def read_state(self) -> KinematicState:
        """Read the body's pose and velocity from PyBullet into :attr:`state`."""
        cid = self._client
        pos, quat = p.getBasePositionAndOrientation(self.body_id, cid)
        lin, ang = p.getBaseVelocity(self.body_id, cid)
        r = p.getMatrixFromQuaternion(quat, cid)  # body-to-ground, row-major
        lx, ly, lz = lin
        ax, ay, az = ang
        # body frame = R^T ground frame
        ang_vel = (r[0] * ax + r[3] * ay + r[6] * az, r[1] * ax + r[4] * ay + r[7] * az, r[2] * ax + r[5] * ay + r[8] * az)
        lin_vel = (r[0] * lx + r[3] * ly + r[6] * lz, r[1] * lx + r[4] * ly + r[7] * lz, r[2] * lx + r[5] * ly + r[8] * lz)
        self._velocity_body = (lin_vel, ang_vel)
        self.state = KinematicState(
            ang_vel=ang_vel,
            ang_pos=p.getEulerFromQuaternion(quat, cid),
            lin_vel=lin_vel,
            lin_pos=pos,
            quaternion=quat,
            lin_vel_ground=lin,
            ang_vel_ground=ang,
        )
        return self.state

    def read_velocity(self) -> None:
        """Refresh only the body-frame velocities (what the loads need between control ticks)."""
        cid = self._client
        quat = p.getBasePositionAndOrientation(self.body_id, cid)[1]
        (lx, ly, lz), (ax, ay, az) = p.getBaseVelocity(self.body_id, cid)
        r = p.getMatrixFromQuaternion(quat, cid)
        self._velocity_body = (
            (r[0] * lx + r[3] * ly + r[6] * lz, r[1] * lx + r[4] * ly + r[7] * lz, r[2] * lx + r[5] * ly + r[8] * lz),
            (r[0] * ax + r[3] * ay + r[6] * az, r[1] * ax + r[4] * ay + r[7] * az, r[2] * ax + r[5] * ay + r[8] * az),
        )

    def control_step(self) -> None:
        """Run the flight controller once (at the control rate) and route its outputs."""
        parts = self.parts
        if not self.armed:
            self._command = [0.0] * len(self._command)
            self.channels = np.clip(np.zeros(len(parts.channels)), parts.channel_low, parts.channel_high)
            if self.booster_ignition is not None:
                self.booster_ignition[:] = False
            self._route_channels(mixer_throttles=None)
            return
        name = self.mode.name
        setpoint = self.setpoint
        if self._plain_multirotor and not self._custom_modes:
            # fast path: every motor flown by the mixer, no channels
            throttles = self.controller(self.state, setpoint.tolist())  # type: ignore[misc]
            self._command = [1.0 if t > 1.0 else -1.0 if t < -1.0 else float(t) for t in throttles]
            return
        if self.controller is not None:
            k = len(setpoint) - len(parts.channels)
            self.channels = np.clip(setpoint[k:], parts.channel_low, parts.channel_high)
            head = setpoint[:k]
            custom = self._custom_modes.get(name) if self._custom_modes else None
            if custom is not None:
                head = np.asarray(custom.controller(self.state, head), dtype=np.float64)
            throttles = self.controller(self.state, head.tolist())
            self._route_channels(mixer_throttles=throttles)
        else:
            if name == "channels":
                self.channels = np.clip(setpoint, parts.channel_low, parts.channel_high)
            else:  # fixed-wing autopilot
                self.channels = self.autopilot(self.state, setpoint.tolist())  # type: ignore[misc]
            self._route_channels(mixer_throttles=None)

    def _route_channels(self, mixer_throttles: Sequence[float] | None) -> None:
        """Turn the channel vector (and the mixer's throttles) into actuator commands."""
        parts = self.parts
        c = self.channels
        if self.motors is not None:
            command = parts.motor_mix @ c if len(c) else np.zeros(self.motors.count)
            if mixer_throttles is not None and parts.mixer_motors:
                command[list(parts.mixer_motors)] = mixer_throttles
            self._command = clip_command(command).tolist()
        if parts.surfaces:
            self.surface_command = np.clip(parts.surface_mix @ c, -1.0, 1.0)
        if parts.boosters is not None:
            self.booster_ignition = c[parts.ignition_index] > 0.5
            self.booster_throttle = np.clip(c[parts.throttle_index], 0.0, 1.0)
        if parts.gimbals is not None:
            self.gimbal_command = np.clip(c[parts.gimbal_channels], -1.0, 1.0)

    def apply_loads(self) -> None:
        """Advance the actuators one physics step and apply the net wrench to the body."""
        if self.motors is not None:
            if self._motor_has_noise:
                if self._noise_index >= len(self._noise):
                    eta = self._rng.standard_normal((_NOISE_BLOCK, self.motors.count))
                    self._noise = noise_factors(self.motors, eta).tolist()
                    self._noise_index = 0
                noise = self._noise[self._noise_index]
                self._noise_index += 1
            else:
                noise = self._no_noise
            self._throttle, (fx, fy, fz, tx, ty, tz) = motor_step_wrench(
                self._throttle, self._command, self._motor_lag, noise, self._wrench_columns
            )
        else:
            fx = fy = fz = tx = ty = tz = 0.0
        if self._has_components:
            extra = self._component_loads()
            fx, fy, fz = fx + extra[0], fy + extra[1], fz + extra[2]
            tx, ty, tz = tx + extra[3], ty + extra[4], tz + extra[5]
        if self._drag_on:
            drag = drag_wrench(self._drag_factors, self._angular_damping, *self._velocity_body)
            fx, fy, fz = fx + drag[0], fy + drag[1], fz + drag[2]
            tx, ty, tz = tx + drag[3], ty + drag[4], tz + drag[5]
        cid = self._client
        p.applyExternalForce(self.body_id, -1, (fx, fy, fz), _ORIGIN, _LINK_FRAME, cid)
        p.applyExternalTorque(self.body_id, -1, (tx, ty, tz), _LINK_FRAME, cid)

    def _component_loads(self) -> list[float]:
        """Net wrench of gimballed motors, lifting surfaces and boosters (body frame)."""
        parts, dt = self.parts, self.physics_dt
        total = np.zeros(6)
        axes_override: dict[tuple[str, int], np.ndarray] = {}
        if parts.gimbals is not None:
            self.gimbal_angles = gimbal_step(parts.gimbals, self.gimbal_angles, self.gimbal_command, dt)
            for g, (kind, index) in enumerate(parts.gimbal_targets):
                base = (self.motors.thrust_axes if kind == "motor" else parts.boosters.thrust_axes)[index]  # type: ignore[union-attr]
                rotated = rotate_axes(parts.gimbals, self.gimbal_angles, np.tile(base, (parts.gimbals.n, 1)))[g]
                axes_override[(kind, index)] = rotated
        for index in self._gimballed_motors:
            m = self.motors
            x = self._throttle[index]
            thrust = m.max_thrust[index] * x * abs(x)  # type: ignore[union-attr]
            axis = axes_override[("motor", index)]
            force = axis * thrust
            reaction = -m.spin[index] * m.max_torque[index] * x * abs(x) * axis  # type: ignore[union-attr]
            total[:3] += force
            total[3:] += np.cross(m.positions[index], force) + reaction  # type: ignore[union-attr]
        if parts.surfaces:
            velocity, rates = self._velocity_body
            for i, surface in enumerate(parts.surfaces):
                self.surface_deflection[i] = flap_step(surface, self.surface_deflection[i], self.surface_command[i], dt)
                force, torque = surface_loads(surface, self.surface_deflection[i], velocity, rates)
                total[:3] += force
                total[3:] += torque
        if parts.boosters is not None:
            b = parts.boosters
            noise = self._rng.standard_normal(b.n) if np.any(b.noise_ratio > 0) else np.zeros(b.n)
            self.booster_state, thrust = booster_step(b, self.booster_state, self.booster_ignition, self.booster_throttle, dt, noise)
            axes = b.thrust_axes
            if axes_override:
                axes = axes.copy()
                for (kind, index), axis in axes_override.items():
                    if kind == "booster":
                        axes[index] = axis
            force, torque = booster_loads(b, thrust, thrust_axes=axes)
            total[:3] += force
            total[3:] += torque
        return total.tolist()

    def _update_mass(self) -> None:
        """Set the body's mass and inertia to the dry airframe plus remaining fuel.

        The fuel tanks' offset from the centre of mass enters the inertia through the
        parallel-axis theorem (diagonal terms); the shift of the centre of mass as fuel
        burns is not modelled.  Without boosters the mass is the dry mass.
        """
        if self.parts.boosters is None:
            self.mass = self.parts.mass
            return
        b = self.parts.boosters
        fuel_mass, tank_inertia = tank_mass_properties(b, self.booster_state.fuel)  # type: ignore[union-attr]
        r = b.fuel_tank_positions
        parallel = fuel_mass[:, None] * (np.sum(r * r, axis=1)[:, None] - r * r)
        inertia = self._dry_inertia + (tank_inertia + parallel).sum(axis=0)
        mass = self.parts.mass + float(fuel_mass.sum())
        p.changeDynamics(self.body_id, -1, mass=mass, localInertiaDiagonal=inertia.tolist(), physicsClientId=self._client)
        self.mass = mass

    def update_mass(self) -> None:
        """Refresh mass properties that change in flight (fuel); the world calls this at the control rate."""
        if self.parts.boosters is not None:
            self._update_mass()

    # --------------------------------------------------------------- cameras

    def capture(self, camera: int = 0, time: float | None = None) -> dict[str, np.ndarray]:
        """Images of camera ``camera`` (see :func:`pyflyt_engine.components.camera.capture`).

        With ``time`` (the world's simulated time), the image is re-rendered only when
        ``1 / capture_hz`` has passed since the last one; otherwise the cached one is
        returned.
        """
        cameras = self.parts.cameras
        if not 0 <= camera < len(cameras):
            raise ConfigError(f"vehicle '{self.spec.name}' has {len(cameras)} camera(s); no camera {camera}")
        params = cameras[camera]
        cached = self._camera_cache.get(camera)
        if time is not None and cached is not None and time - cached[0] < 1.0 / params.capture_hz - 1e-9:
            return cached[1]
        images = capture(self._client, params, self.state.lin_pos, self.state.quaternion)
        self._camera_cache[camera] = (time if time is not None else float("nan"), images)
        return images

    # --------------------------------------------------------------- resets

    def reset(
        self,
        position: Sequence[float] | None = None,
        orientation: Sequence[float] | None = None,
        lin_vel: Sequence[float] | None = None,
        ang_vel: Sequence[float] | None = None,
    ) -> None:
        """Put the vehicle at a pose (default: its spawn pose) with idle actuators.

        Args:
            position: (x, y, z) [m], ground frame.
            orientation: (roll, pitch, yaw) [rad].
            lin_vel: initial linear velocity (u, v, w) [m/s] in the BODY frame (default rest),
                e.g. (20, 0, 0) to spawn a fixed-wing at cruise speed.
            ang_vel: initial angular velocity (p, q, r) [rad/s] in the body frame.
        """
        position = self.spawn_position if position is None else position
        orientation = self.spawn_orientation if orientation is None else orientation
        cid = self._client
        quat = euler_to_quaternion(*orientation)
        p.resetBasePositionAndOrientation(self.body_id, list(position), quat, physicsClientId=cid)
        rotation = np.array(p.getMatrixFromQuaternion(quat, physicsClientId=cid)).reshape(3, 3)  # body to ground
        lin = rotation @ np.asarray(lin_vel if lin_vel is not None else (0.0, 0.0, 0.0), dtype=float)
        ang = rotation @ np.asarray(ang_vel if ang_vel is not None else (0.0, 0.0, 0.0), dtype=float)
        p.resetBaseVelocity(self.body_id, lin.tolist(), ang.tolist(), physicsClientId=cid)
        parts = self.parts
        self._throttle = [0.0] * len(self._throttle)
        self._command = [0.0] * len(self._command)
        self.setpoint[:] = 0.0
        self.channels = np.clip(np.zeros(len(parts.channels)), parts.channel_low, parts.channel_high)
        self.surface_deflection[:] = 0.0
        self.surface_command[:] = 0.0
        if parts.boosters is not None:
            self.booster_state = initial_booster_state(parts.boosters, fuel_fraction=self.spec.boosters.initial_fuel)  # type: ignore[union-attr]
            self.booster_ignition[:] = False  # type: ignore[index]
            self.booster_throttle[:] = 0.0  # type: ignore[index]
            self._update_mass()
        if parts.gimbals is not None:
            self.gimbal_angles[:] = 0.0  # type: ignore[index]
            self.gimbal_command[:] = 0.0  # type: ignore[index]
        self._camera_cache.clear()
        self._noise_index = len(self._noise)  # discard buffered noise: redraw from the stream
        if self.controller is not None:
            self.controller.reset()
        if self.autopilot is not None:
            self.autopilot.reset()
        self.read_state()

    def reseed(self, rng: np.random.Generator) -> None:
        """Use a new noise stream (on a seeded world reset)."""
        self._rng = rng
        self._noise = []
        self._noise_index = 0

    @property
    def rng_state(self) -> dict:
        """Position of this vehicle's noise stream: its numpy bit-generator state (a
        JSON-serialisable dict); restore it with ``reseed`` (see :meth:`World.set_rng_state`)."""
        return self._rng.bit_generator.state

    # -------------------------------------------------------------- read-outs

    @property
    def motor_throttle(self) -> np.ndarray:
        """(n,) current normalised motor throttles (a copy)."""
        return np.array(self._throttle)

    @property
    def motor_command(self) -> np.ndarray:
        """(n,) throttles the motors are commanded toward, in [-1, 1] (a copy)."""
        return np.array(self._command)

    @property
    def aux_state(self) -> np.ndarray:
        """Auxiliary state, concatenated: motor throttles [-1, 1]; flap deflections
        normalised by their limits [-1, 1]; per booster fuel fraction, duty [0, 1] and
        ignition (0/1); gimbal angles normalised by their limits [-1, 1]."""
        parts = [self.motor_throttle]
        if self.parts.surfaces:
            limits = np.array([s.max_deflection or 1.0 for s in self.parts.surfaces])
            parts.append(self.surface_deflection / limits)
        if self.booster_state is not None:
            b = self.parts.boosters
            parts.append(np.stack([self.booster_state.fuel / b.total_fuel, self.booster_state.duty,  # type: ignore[union-attr]
                                   self.booster_state.ignited.astype(float)], axis=1).ravel())
        if self.gimbal_angles is not None:
            parts.append((self.gimbal_angles / np.maximum(self.parts.gimbals.max_angles, 1e-12)).ravel())  # type: ignore[union-attr]
        return np.concatenate(parts) if len(parts) > 1 else parts[0].copy()

    def hover_throttle(self) -> float:
        """Analytic throttle at which the mixer motors' vertical thrust equals the weight (level)."""
        if self.motors is None or not self.parts.mixer_motors:
            raise ConfigError(f"vehicle '{self.spec.name}' has no multirotor motors")
        idx = list(self.parts.mixer_motors)
        lift = float(self.motors.thrust_axes[idx, 2] @ self.motors.max_thrust[idx])
        return float(np.sqrt(self.parts.mass * GRAVITY / lift))

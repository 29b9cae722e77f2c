"""The air each vehicle flies through, as the inputs of its actuator groups.

Every time the world reads a vehicle's motion (its full state at a control tick, its
position and velocities at a physics step between ticks), it asks the
:class:`Atmosphere` for the air at that vehicle and hands the result to the vehicle's
loads (:meth:`pyflyt_engine.vehicle.Vehicle.apply_loads`):

* the body's **velocity through the air**, body frame: ``R^T (v - v_wind)`` and
  ``R^T (omega - omega_gust)`` with ``R`` body to ground (:func:`air_velocity`), where the
  wind is the field's (:mod:`pyflyt_engine.atmosphere.field`) plus the wakes of the
  rotorcraft above (downwash, :mod:`pyflyt_engine.atmosphere.rotors`).  Drag and lifting
  surfaces take it, so wind enters once, by subtraction;
* each rotor's **ground-effect thrust ratio** (:meth:`RotorInteractions.ground_effect_ratios`),
  which the motors take.

In still air without rotor interactions the world has no atmosphere: the air velocity is
the body's own (:func:`air_velocity` with no wind).

At a control tick the body-frame velocities are already in the state, and the air
velocity is formed from them as ``R^T v - R^T v_wind`` (:func:`air_velocity_from_body`):
the same quantity rounded differently.  Both forms are kept as they are because every
recorded trajectory depends on their last bits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from pyflyt_engine.atmosphere.field import WindField, WindSample, vehicle_span
from pyflyt_engine.atmosphere.rotors import RotorInteractions
from pyflyt_engine.components import AirVelocity

if TYPE_CHECKING:
    from pyflyt_engine.vehicle import Vehicle

#: What a vehicle's loads receive from the air: its velocity through it, and the rotors'
#: ground-effect thrust ratios (None: 1 for every rotor).
Air = tuple[AirVelocity, "list[float] | None"]


def air_velocity(
    r: Sequence[float], lin: Sequence[float], ang: Sequence[float], wind: WindSample | None = None
) -> AirVelocity:
    """``R^T (v - v_wind)``, ``R^T (omega - omega_gust)``: the body-frame velocity through the air.

    Args:
        r: body-to-ground rotation matrix, row-major (9 floats).
        lin, ang: the body's velocity [m/s] and angular velocity [rad/s], ground frame.
        wind: the wind sample at the body (x, y, z [m/s], p, q, r [rad/s]), ground frame;
            None: still air.
    """
    (lx, ly, lz), (ax, ay, az) = lin, ang
    if wind is not None:
        wx, wy, wz, gp, gq, gr = wind
        lx, ly, lz, ax, ay, az = lx - wx, ly - wy, lz - wz, ax - gp, ay - gq, az - gr
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
    return (
        (r0 * lx + r3 * ly + r6 * lz, r1 * lx + r4 * ly + r7 * lz, r2 * lx + r5 * ly + r8 * lz),
        (r0 * ax + r3 * ay + r6 * az, r1 * ax + r4 * ay + r7 * az, r2 * ax + r5 * ay + r8 * az),
    )


def air_velocity_from_body(
    r: Sequence[float], lin_body: Sequence[float], ang_body: Sequence[float], wind: WindSample | None
) -> AirVelocity:
    """The velocity through the air from velocities already in the body frame (a full state
    read): ``v_body - R^T v_wind``, ``omega_body - R^T omega_gust`` (see the module docstring)."""
    if wind is None:
        return (lin_body, ang_body)  # type: ignore[return-value]
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
    wx, wy, wz, gp, gq, gr = wind
    return (
        (
            lin_body[0] - (r0 * wx + r3 * wy + r6 * wz),
            lin_body[1] - (r1 * wx + r4 * wy + r7 * wz),
            lin_body[2] - (r2 * wx + r5 * wy + r8 * wz),
        ),
        (
            ang_body[0] - (r0 * gp + r3 * gq + r6 * gr),
            ang_body[1] - (r1 * gp + r4 * gq + r7 * gr),
            ang_body[2] - (r2 * gp + r5 * gq + r8 * gr),
        ),
    )


class Atmosphere:
    """The air of one world: its wind field (None: still) and its rotor interactions (None: off).

    Args:
        field: the wind field.
        rotors: ground effect and downwash.
        vehicles: the world's vehicles, in order (read, never written: each one's latest
            read position and its motors' throttles are the source of the downwash on
            the others).
    """

    def __init__(self, field: WindField | None, rotors: RotorInteractions | None, vehicles: list[Vehicle]) -> None:
        self.rotors = rotors
        self.vehicles = vehicles
        #: inside :meth:`stepping`: the world reads each vehicle right before asking for its
        #: air, so the wake grid stays current by rebinning the vehicle asked about
        self._stepping = False
        self._spans: list[float] = []
        self._probes: list = []
        #: per vehicle, the motor constants its wake's full thrusts were taken from (:meth:`refresh_wakes`)
        self._thrust_params: list[Any] = []
        self.field = field

    @property
    def field(self) -> WindField | None:
        """The wind field (None: still air apart from the downwash)."""
        return self._field

    @field.setter
    def field(self, field: WindField | None) -> None:
        self._field = field
        self._probes = [field.add_vehicle(span) for span in self._spans] if field is not None else []

    @property
    def moving(self) -> bool:
        """Whether the air moves anywhere (a wind field, or downwash)."""
        return self._field is not None or (self.rotors is not None and self.rotors.downwash)

    def add_vehicle(self, vehicle: Vehicle) -> None:
        """Register the next vehicle of the world (its span for the rotary gusts, its rotors)."""
        motors = vehicle.parts.motors
        span = vehicle_span(motors.positions if motors is not None else None, vehicle.parts.surfaces)
        self._spans.append(span)
        if self._field is not None:
            self._probes.append(self._field.add_vehicle(span))
        if self.rotors is not None:
            spec = vehicle.spec.motors
            hubs = motors.positions.tolist() if motors is not None else []
            radii: list[float | None] = [None] * len(hubs)
            if spec is not None and spec.prop_radius is not None:
                radii = spec.to_array("prop_radius").tolist()
            self.rotors.add_vehicle(hubs, radii, motors.max_thrust.tolist() if motors is not None else [])
        group = vehicle.actuators.motors
        self._thrust_params.append(group.params if group is not None else None)

    def refresh_wakes(self) -> None:
        """Rebin, in the downwash's wake grid, every vehicle read since it was last binned, and
        take the full thrusts of every vehicle whose motors have new constants (O(vehicles);
        nothing without downwash)."""
        rotors = self.rotors
        if rotors is None or not rotors.downwash:
            return
        placed = rotors.wakes.placed
        seen = self._thrust_params
        for j, vehicle in enumerate(self.vehicles):
            position = vehicle.position
            if placed.get(j) is not position:
                rotors.place(j, position)
            # each wake as strong as its vehicle's motors are now: new constants (a drawn
            # motor_kf, set before the episode's first step) are taken at the next step
            motors = vehicle.actuators.motors
            if motors is not None and motors.params is not seen[j]:
                seen[j] = motors.params
                rotors.set_max_thrust(j, motors.params.max_thrust.tolist())
        wakes = rotors.wakes
        wakes.top = max((placed[j][2] for j in wakes.where), default=-math.inf)

    def stepping(self, on: bool) -> None:
        """The world enters (True, after :meth:`refresh_wakes`) or leaves (False) its physics loop."""
        if on:
            self.refresh_wakes()
        self._stepping = on

    def wind_at(self, index: int, position: Sequence[float]) -> WindSample | None:
        """The wind at vehicle ``index`` at ``position``: the field's plus the downwash of the
        others (None: the air does not move).

        The downwash sums only the wakes that can reach ``position``
        (:meth:`RotorInteractions.sources`): the other vehicles at their latest reads,
        exactly as the all-pairs :meth:`RotorInteractions.downwash_at`."""
        sample = self._probes[index](position) if self._field is not None else None
        rotors = self.rotors
        if rotors is None or not rotors.downwash:
            return sample
        vehicles = self.vehicles
        if self._stepping:  # only this vehicle has been read since the wakes were last binned
            rotors.place(index, vehicles[index].position)
        else:  # asked from outside the loop: any vehicle may have been read since
            self.refresh_wakes()
        sources = rotors.sources(index, position)
        w = 0.0
        if sources:
            near = [vehicles[j] for j in sources]
            w = rotors.downwash_near(
                index, position, sources, [v.position for v in near], [v.actuators.motors.throttle for v in near]
            )
        if sample is None:
            return (0.0, 0.0, w, 0.0, 0.0, 0.0)
        wx, wy, wz, p, q, r = sample
        return (wx, wy, wz + w, p, q, r)

    def at_motion(
        self, index: int, position: Sequence[float], r: Sequence[float], lin: Sequence[float], ang: Sequence[float]
    ) -> Air:
        """The air of vehicle ``index`` from a read of its motion (ground-frame velocities)."""
        thrust_ratio = self.rotors.ground_effect_ratios(index, position, r) if self.rotors is not None else None
        return air_velocity(r, lin, ang, self.wind_at(index, position)), thrust_ratio

    def at_state(self, index: int, vehicle: Vehicle) -> Air:
        """The air of vehicle ``index`` from its latest full state read (:meth:`Vehicle.read_state`)."""
        state, r = vehicle.state, vehicle.rotation
        position = state.lin_pos
        thrust_ratio = self.rotors.ground_effect_ratios(index, position, r) if self.rotors is not None else None
        return air_velocity_from_body(r, state.lin_vel, state.ang_vel, self.wind_at(index, position)), thrust_ratio

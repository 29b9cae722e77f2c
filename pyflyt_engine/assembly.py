"""From a validated :class:`~pyflyt_engine.spec.UAVSpec` to component parameters.

Positions in a spec may be measured from any reference point; the body origin of the
built vehicle is the centre of mass, so every position is shifted by it here, once.
Angles given in degrees in the spec become radians here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pyflyt_engine.allocation import Tilt
from pyflyt_engine.components.battery import BatteryParams
from pyflyt_engine.components.booster import BoosterParams
from pyflyt_engine.components.camera import CameraParams
from pyflyt_engine.components.gimbal import GimbalParams
from pyflyt_engine.components.lifting_surface import LiftingSurfaceParams
from pyflyt_engine.components.motor import MotorParams
from pyflyt_engine.spec import UAVSpec


@dataclass(frozen=True)
class Assembly:
    """Everything a vehicle is built from, in the centre-of-mass body frame.

    Attributes:
        com: centre of mass in the spec's coordinates [m] (subtracted from positions).
        mass: dry mass [kg]; inertia: 3 x 3 dry inertia about the centre of mass.
        channels: channel names in setpoint order; channel_low/high: their ranges.
        motors: all motors (None without); mixer_motors: indices flown by a multirotor
            controller; motor_mix: (n_motors, n_channels) channel weights.
        surfaces: lifting surfaces; surface_mix: (n_surfaces, n_channels).
        boosters, ignition_index, throttle_index: boosters and their channel indices.
        gimbals, gimbal_channels, gimbal_targets: gimbals, their (n, 2) channel
            indices (-1 for a gimbal the mixer flies) and (kind, index) targets.
        mixer_tilts: per gimbal the mixer flies, (gimbal index, its
            :class:`~pyflyt_engine.allocation.Tilt`), in gimbal order.
        cameras: camera parameters, in spec order.
        battery: the battery driving the motors (None: an ideal supply).
        lowest_point: the collision geometry's lowest point along body z, from the centre
            of mass [m] (negative: below it; None for mesh or URDF geometry).
    """

    com: np.ndarray
    mass: float
    inertia: np.ndarray
    channels: tuple[str, ...]
    channel_low: np.ndarray
    channel_high: np.ndarray
    motors: MotorParams | None
    mixer_motors: tuple[int, ...]
    motor_mix: np.ndarray
    surfaces: tuple[LiftingSurfaceParams, ...]
    surface_mix: np.ndarray
    boosters: BoosterParams | None
    ignition_index: np.ndarray
    throttle_index: np.ndarray
    gimbals: GimbalParams | None
    gimbal_channels: np.ndarray
    gimbal_targets: tuple[tuple[str, int], ...]
    cameras: tuple[CameraParams, ...]
    mixer_tilts: tuple[tuple[int, Tilt], ...] = ()
    battery: BatteryParams | None = None
    lowest_point: float | None = None


def _mix_matrix(rows: list[dict[str, float] | None], channels: tuple[str, ...]) -> np.ndarray:
    matrix = np.zeros((len(rows), len(channels)))
    for i, row in enumerate(rows):
        for name, weight in (row or {}).items():
            matrix[i, channels.index(name)] = weight
    return matrix


def assemble(spec: UAVSpec) -> Assembly:
    """Component parameters of ``spec`` in the centre-of-mass frame."""
    com = spec.center_of_mass()
    channels = tuple(spec.channels)
    low = np.array([spec.channels[c][0] for c in channels], dtype=float)
    high = np.array([spec.channels[c][1] for c in channels], dtype=float)

    motors: MotorParams | None = None
    mixer_motors: tuple[int, ...] = ()
    motor_mix = np.zeros((0, len(channels)))
    if spec.motors is not None:
        m = spec.motors
        motors = MotorParams(
            positions=np.asarray(m.positions, dtype=float) - com,
            thrust_axes=m.to_array("thrust_axes"),
            spin=m.to_array("spin"),
            tau=m.to_array("tau"),
            max_rpm=m.to_array("max_rpm"),
            kf=m.to_array("kf"),
            kt=m.to_array("kt"),
            noise_ratio=m.to_array("noise_ratio"),
            tau_fall=m.to_array("tau_fall") if m.tau_fall is not None else None,
            rotor_drag=m.to_array("rotor_drag") if m.rotor_drag is not None else None,
            prop_radius=m.to_array("prop_radius") if m.prop_radius is not None else None,
            inflow=(m.inflow.solidity, m.inflow.lift_slope) if m.inflow is not None else None,
        )
        mixes: list[dict[str, float] | None] = list(m.mix) if m.mix is not None else [None] * motors.count
        motor_mix = _mix_matrix(mixes, channels)
        mixer_motors = spec.mixer_motor_indices()

    surfaces = tuple(
        LiftingSurfaceParams(
            position=np.asarray(s.position, dtype=float) - com,
            chord_axis=np.asarray(s.chord_axis, dtype=float),
            normal_axis=np.asarray(s.normal_axis, dtype=float),
            chord=s.chord,
            span=s.span,
            flap_to_chord=s.flap_to_chord,
            alpha_0_base=math.radians(s.alpha_0_deg),
            stall_pos_base=math.radians(s.stall_pos_deg),
            stall_neg_base=math.radians(s.stall_neg_deg),
            cd_0=s.cd_0,
            cl_alpha_2d=s.cl_alpha_2d,
            eta=s.eta,
            max_deflection=math.radians(s.max_deflection_deg),
            tau=s.tau,
        )
        for s in spec.surfaces
    )
    surface_mix = _mix_matrix([s.mix for s in spec.surfaces], channels)

    boosters, ignition_index, throttle_index = None, np.zeros(0, int), np.zeros(0, int)
    if spec.boosters is not None:
        b = spec.boosters
        n = len(b.positions)
        positions = np.asarray(b.positions, dtype=float) - com
        tanks = np.asarray(b.fuel_tank_positions, dtype=float) - com if b.fuel_tank_positions else positions
        boosters = BoosterParams(
            positions=positions,
            thrust_axes=np.asarray(b.thrust_axes, dtype=float) if b.thrust_axes else np.tile([0.0, 0.0, 1.0], (n, 1)),
            fuel_tank_positions=tanks,
            total_fuel=np.asarray(b.per_booster("total_fuel"), dtype=float),
            max_fuel_rate=np.asarray(b.per_booster("max_fuel_rate"), dtype=float),
            inertia_full=np.asarray(b.inertia_full, dtype=float) if b.inertia_full else np.zeros((n, 3)),
            min_thrust=np.asarray(b.per_booster("min_thrust"), dtype=float),
            max_thrust=np.asarray(b.per_booster("max_thrust"), dtype=float),
            reignitable=np.asarray(b.per_booster("reignitable"), dtype=bool),
            tau=np.asarray(b.per_booster("tau"), dtype=float),
            noise_ratio=np.asarray(b.per_booster("noise_ratio"), dtype=float),
        )
        ignition_index = np.array([channels.index(c) for c in b.per_booster("ignition_channel")], dtype=int)
        throttle_index = np.array([channels.index(c) for c in b.per_booster("throttle_channel")], dtype=int)

    gimbals: GimbalParams | None = None
    gimbal_channels = np.zeros((0, 2), int)
    gimbal_targets: tuple[tuple[str, int], ...] = ()
    if spec.gimbals:
        g = spec.gimbals
        gimbals = GimbalParams(
            axis_a=np.array([x.axis_a for x in g], dtype=float),
            axis_b=np.array([x.axis_b for x in g], dtype=float),
            max_angle_a=np.radians([x.max_angle_a_deg for x in g]),
            max_angle_b=np.radians([x.max_angle_b_deg for x in g]),
            tau=np.array([x.tau for x in g], dtype=float),
        )
        gimbal_channels = np.array(
            [[-1, -1] if x.mixer else [channels.index(c) for c in x.channels] for x in g], dtype=int
        )
        gimbal_targets = tuple((x.target_kind, x.target_index) for x in g)
    slots = {motor: slot for slot, motor in enumerate(spec.mixer_motor_indices())}
    mixer_tilts = tuple(
        (i, Tilt(slots[g.target_index], g.axis_a, math.radians(g.max_angle_a_deg)))
        for i, g in enumerate(spec.gimbals)
        if g.mixer
    )

    cameras = tuple(
        CameraParams(
            position=tuple(np.asarray(c.position, dtype=float) - com),
            orientation=(
                math.radians(c.orientation_deg[0]),
                math.radians(c.orientation_deg[1]),
                math.radians(c.orientation_deg[2]),
            ),
            fov=c.fov,
            width=c.width,
            height=c.height,
            near=c.near,
            far=c.far,
            horizon_lock=c.horizon_lock,
            capture_hz=c.capture_hz,
            channels=tuple(c.outputs),
        )
        for c in spec.cameras
    )

    battery = None
    if spec.battery is not None:
        cell = spec.battery
        battery = BatteryParams(
            capacity_mah=cell.capacity_mah,
            internal_resistance=cell.internal_resistance,
            open_circuit_voltage=tuple((float(q), float(v)) for q, v in cell.open_circuit_voltage),
            efficiency=cell.efficiency,
            avionics_power=cell.avionics_power,
            initial_charge=cell.initial_charge,
        )

    return Assembly(
        battery=battery,
        com=com,
        mass=spec.total_mass(),
        inertia=spec.inertia_matrix(),
        channels=channels,
        channel_low=low,
        channel_high=high,
        motors=motors,
        mixer_motors=mixer_motors,
        motor_mix=motor_mix,
        surfaces=surfaces,
        surface_mix=surface_mix,
        boosters=boosters,
        ignition_index=ignition_index,
        throttle_index=throttle_index,
        gimbals=gimbals,
        gimbal_channels=gimbal_channels,
        gimbal_targets=gimbal_targets,
        cameras=cameras,
        mixer_tilts=mixer_tilts,
        lowest_point=None if (low_z := spec.body.lowest_point()) is None else low_z - float(com[2]),
    )

"""The rocket autopilot's modes: authority by hand and by the surface model, step responses,
hover on thrust as the fuel burns, and the ignition rule (pyflyt_engine/control/rocket.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.components.lifting_surface import surface_wrench
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.control.rocket import (
    AIM_FALL,
    FLOOR_HEIGHT,
    MAX_TILT,
    ROCKET_MODES,
    TOUCHDOWN_SPEED,
)
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.world import VehicleConfig, World

ROCKET = load_uav_spec("rocket")
T_MIN, T_MAX = 2966.7, 7607.0  # conf/uav/rocket.yaml


def _rocket(fuel: float):
    """The shipped rocket with ``fuel`` (fraction of a full tank) and no thrust noise."""
    boosters = ROCKET.boosters.model_copy(update={"initial_fuel": fuel, "noise_ratio": 0.0})
    return ROCKET.model_copy(update={"boosters": boosters})


def _world(fuel: float, mode: str, setpoint, height: float = 300.0) -> World:
    world = World([VehicleConfig(_rocket(fuel), (0.0, 0.0, height), mode=mode)], seed=0)
    world.set_setpoint(0, setpoint)
    return world


def _tilt(vehicle) -> float:
    x, y = vehicle.state.quaternion[:2]
    return math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y))))


def test_rocket_modes_are_offered_on_gimballed_boosters_only():
    world = World([VehicleConfig(ROCKET, (0.0, 0.0, 10.0))], seed=0)
    try:
        vehicle = world.vehicles[0]
        assert vehicle.mode.name == "channels"  # the shipped default is unchanged
        vehicle.set_mode("velocity")
        assert vehicle.setpoint_layout == ("vx", "vy", "vz", "ignition")
        vehicle.set_mode("attitude_thrust")
        assert vehicle.setpoint_layout == ("tilt_x", "tilt_y", "roll_rate", "throttle", "ignition")
        vehicle.set_mode("descent")
        assert vehicle.setpoint_layout == ("vx", "vy", "descent", "ignition")
    finally:
        world.close()
    assert set(ROCKET_MODES) == {"channels", "attitude_thrust", "velocity", "descent"}
    with pytest.raises(ConfigError, match="attitude_airspeed"):  # the fixed-wing has no gimballed booster
        World([VehicleConfig("fixedwing", (0.0, 0.0, 10.0), mode="attitude_thrust")], seed=0)


def test_gimbal_and_fin_authority_match_the_geometry_and_the_surface_model():
    world = _world(0.01, "attitude_thrust", [0.0] * 5)
    try:
        autopilot = world.vehicles[0].rocket
        com_z = world.vehicles[0].parts.com[2]
        # gimbal a turns the nozzle about body x: at thrust T and full command the moment is
        # T sin(5 deg) * (booster below the centre of mass) about -x, by hand
        columns = {channel: arm for channel, _, arm, _ in autopilot._gimbal_columns}
        channels = world.vehicles[0].parts.channels
        a, b = columns[channels.index("gimbal_a")], columns[channels.index("gimbal_b")]
        assert a == pytest.approx((-math.radians(5.0) * com_z, 0.0, 0.0), abs=1e-12)
        assert b == pytest.approx((0.0, -math.radians(5.0) * com_z, 0.0), abs=1e-12)
        # fins: the linear column against the Khan & Nahon surfaces at a small deflection,
        # falling at 50 m/s (air from below along the fins' chord)
        surfaces = world.vehicles[0].parts.surfaces
        mix = world.vehicles[0].parts.surface_mix
        speed, command = 50.0, 0.05
        for channel, terms, _ in autopilot._fin_columns:
            linear = [sum(speed * speed * g[i] for g, _ in terms) * command for i in range(3)]
            model = [0.0, 0.0, 0.0]
            for s, surface in enumerate(surfaces):
                deflection = mix[s][channel] * command * surface.max_deflection
                _, _, _, tx, ty, tz = surface_wrench(surface.constants, deflection, 0.0, 0.0, -speed, 0.0, 0.0, 0.0)
                _, _, _, ux, uy, uz = surface_wrench(surface.constants, 0.0, 0.0, 0.0, -speed, 0.0, 0.0, 0.0)
                model = [model[0] + tx - ux, model[1] + ty - uy, model[2] + tz - uz]
            assert np.allclose(linear, model, rtol=0.05, atol=1e-6 * max(map(abs, model))), (
                channels[channel],
                linear,
                model,
            )
        # the documented signs: fin_x a + moment about x, fin_y about y, fin_roll about z
        signs = {channels[c]: [sum(g[i] for g, _ in terms) for i in range(3)] for c, terms, _ in autopilot._fin_columns}
        assert signs["fin_x"][0] > 0 and signs["fin_y"][1] > 0 and signs["fin_roll"][2] > 0
    finally:
        world.close()


def test_velocity_mode_hovers_on_thrust_equal_to_the_weight_and_throttles_down_as_fuel_burns():
    """Full tank: 138 + 410.9 kg, weight 5 385 N within the 2 967-7 607 N thrust range."""
    world = _world(1.0, "velocity", [0.0, 0.0, 0.0, 1.0])
    vehicle = world.vehicles[0]
    boosters = vehicle.actuators.boosters
    throttle_channel = vehicle.parts.channels.index("throttle")
    try:
        samples = []
        for second in range(1, 9):
            for _ in range(int(world.agent_hz)):
                world.step()
            if second in (2, 8):
                weight = vehicle.mass * GRAVITY
                thrust = boosters.duty[0] * T_MAX
                throttle = float(vehicle.channels[throttle_channel])
                assert abs(vehicle.state.lin_vel_ground[2]) < 0.01
                assert thrust == pytest.approx(weight, rel=2e-3)  # throttle x thrust range = weight
                assert throttle == pytest.approx((weight - T_MIN) / (T_MAX - T_MIN), abs=3e-3)
                samples.append((vehicle.mass, throttle))
        (m2, throttle2), (m8, throttle8) = samples
        # 6 s near duty 0.7 burns ~6 kg: the mass falls and the hover throttle with it
        assert m8 < m2 - 5.0
        assert throttle2 - throttle8 == pytest.approx((m2 - m8) * GRAVITY / (T_MAX - T_MIN), rel=0.05)
        assert abs(vehicle.state.lin_pos[2] - 300.0) < 0.1
    finally:
        world.close()


def test_attitude_thrust_tilt_step_settles_without_overshoot():
    hover = (_rocket(1.0).total_mass() * GRAVITY - T_MIN) / (T_MAX - T_MIN)
    world = _world(1.0, "attitude_thrust", [0.1, 0.0, 0.0, hover, 1.0])
    vehicle = world.vehicles[0]
    try:
        tilts = []
        for _ in range(int(3 * world.agent_hz)):
            world.step()
            tilts.append(_tilt(vehicle))
        settled = tilts[int(2 * world.agent_hz) :]
        assert max(tilts) < 0.1 * 1.05  # overshoot under 5 %
        assert max(abs(t - 0.1) for t in settled) < 0.003  # within 3 mrad from 2 s on
        rows = vehicle.rotation
        assert rows[2] > 0.099 and abs(rows[5]) < 1e-3  # the long axis leans toward +x
    finally:
        world.close()


@pytest.mark.parametrize("setpoint", [(3.0, 0.0, 1.0), (-2.0, 2.0, -1.0)])
def test_velocity_step_settles_within_stated_bounds(setpoint):
    world = _world(1.0, "velocity", [*setpoint, 1.0])
    vehicle = world.vehicles[0]
    try:
        tilts, errors = [], []
        for _ in range(int(12 * world.agent_hz)):
            world.step()
            tilts.append(_tilt(vehicle))
            errors.append(np.subtract(vehicle.state.lin_vel_ground, setpoint))
        late = np.array(errors[int(10 * world.agent_hz) :])
        assert np.abs(late[:, :2]).max() < 0.3  # horizontal within 0.3 m/s from 10 s on
        assert np.abs(late[:, 2]).max() < 0.02  # vertical within 2 cm/s
        assert max(tilts) < MAX_TILT
    finally:
        world.close()


def test_ignition_rule_pulses_where_the_minimum_thrust_exceeds_the_weight_and_obeys_the_veto():
    """1 % fuel: weight 1 396 N < T_min / 2 = 1 483 N < T_min: holding vz = 0 is pulsing."""
    world = _world(0.01, "velocity", [0.0, 0.0, 0.0, 1.0])
    vehicle = world.vehicles[0]
    try:
        lit, vz = [], []
        for _ in range(int(4 * world.agent_hz)):
            world.step()
            lit.append(vehicle.actuators.boosters.ignited[0])
            vz.append(vehicle.state.lin_vel_ground[2])
        assert 0 < sum(lit) < len(lit)  # on and off
        assert abs(np.mean(vz[int(world.agent_hz) :])) < 0.1 and max(map(abs, vz)) < 0.5
        # ignition 0: the booster stays out whatever the velocity asks -> free fall
        world.reset()
        world.set_setpoint(0, [0.0, 0.0, 5.0, 0.0])
        for _ in range(int(world.agent_hz)):
            world.step()
            assert not vehicle.actuators.boosters.ignited[0]
        assert vehicle.state.lin_vel_ground[2] == pytest.approx(-GRAVITY, rel=0.02)
    finally:
        world.close()


def test_fins_alone_hold_the_lean_and_the_roll_rate_in_descent():
    """Booster out, falling at 50-70 m/s: the fins steer.  The loops are proportional, so
    the fins' aerodynamic damping and restoring moments leave a steady error (stated)."""
    world = World([VehicleConfig(ROCKET, (0.0, 0.0, 400.0), mode="attitude_thrust")], seed=0)
    vehicle = world.vehicles[0]
    try:
        vehicle.reset(lin_vel=(0.0, 0.0, -50.0))
        world.set_setpoint(0, [0.05, 0.0, 0.3, 0.0, 0.0])
        for _ in range(int(1.5 * world.agent_hz)):
            world.step()
        assert not vehicle.actuators.boosters.ignited[0]
        assert vehicle.state.ang_vel[2] == pytest.approx(0.3, rel=0.15)  # 0.27 rad/s measured
        assert _tilt(vehicle) == pytest.approx(0.05, rel=0.15)  # 0.045 rad measured
        assert vehicle.rotation[2] > 0.0  # leaning toward +x
    finally:
        world.close()


# ------------------------------------------------------------------ descent mode

#: the shipped rocket's feet below its dry centre of mass [m], by hand from conf/uav/rocket.yaml:
#: a leg box 1.122 x 0.04 x 0.04 m at z = 0.3 m, pitched 0.9309 rad, reaches down
#: 0.5 (1.122 sin 0.9309 + 0.04 cos 0.9309) = 0.4520 m; the dry centre of mass is at 1.5584 m
FEET_BELOW_COM = 1.5584058 - (0.3 - 0.5 * (1.122 * math.sin(0.9309) + 0.04 * math.cos(0.9309)))


def test_descent_envelope_is_the_stated_formula_from_the_airframe():
    world = _world(0.01, "descent", [0.0, 0.0, 2.0 / 3.0, 1.0], height=100.0)
    vehicle = world.vehicles[0]
    try:
        assert -vehicle.parts.lowest_point == pytest.approx(FEET_BELOW_COM, abs=1e-6)
        mass = vehicle.mass
        assert mass == pytest.approx(138.0 + 0.01 * 410.9)
        a_max = T_MAX / mass - GRAVITY
        assert a_max == pytest.approx(43.7, abs=0.05)  # the figure the docstring quotes
        h = 100.0 - FEET_BELOW_COM  # the feet's height at the spawn
        for descent in (2.0 / 3.0, 1.0, 0.25):
            expected = math.sqrt(2.0 * descent * a_max * (h - FLOOR_HEIGHT))
            assert vehicle.rocket.envelope_speed(vehicle.state, descent) == pytest.approx(expected, rel=1e-9)
        assert vehicle.rocket.envelope_speed(vehicle.state, 0.0) == TOUCHDOWN_SPEED
        vehicle.reset(position=(0.0, 0.0, FEET_BELOW_COM + 0.5 * FLOOR_HEIGHT))
        assert vehicle.rocket.envelope_speed(vehicle.state, 1.0) == TOUCHDOWN_SPEED  # the floor
    finally:
        world.close()


@pytest.mark.parametrize("descent", [2.0 / 3.0, 0.4])
def test_descent_along_the_envelope_touches_down_slowly(descent):
    """Dropped upright from 150 m with 1 % fuel, a constant setpoint (no sideways speed,
    an envelope at ``descent`` of the full-thrust deceleration) falls, brakes on the
    envelope and touches the ground under the landing task's 1 m/s limit."""
    world = _world(0.01, "descent", [0.0, 0.0, descent, 1.0], height=150.0)
    vehicle = world.vehicles[0]
    try:
        speeds, tracked = [], []
        for _ in range(int(20 * world.agent_hz)):
            world.step()
            vz = vehicle.state.lin_vel_ground[2]
            feet = vehicle.state.lin_pos[2] - FEET_BELOW_COM
            if feet < 0.02:
                break
            envelope = vehicle.rocket.envelope_speed(vehicle.state, descent)
            if vehicle.actuators.boosters.ignited[0] and feet > 5.0:
                tracked.append(abs(-vz - envelope) / envelope)
            speeds.append(-vz)
        assert feet < 0.02, "did not reach the ground in 20 s"
        assert max(speeds) > 30.0  # it fell freely before braking
        assert speeds[-1] < 0.7  # the last agent step before touchdown: the floor 0.4 m/s and the pulses' ripple
        assert tracked and np.median(tracked) < 0.1  # braking follows the envelope within 10 % (median)
        assert _tilt(vehicle) < 0.02
    finally:
        world.close()


def test_descent_zero_comes_down_at_the_floor_speed():
    world = _world(0.01, "descent", [0.0, 0.0, 0.0, 1.0], height=50.0)
    vehicle = world.vehicles[0]
    try:
        for _ in range(int(world.agent_hz)):
            world.step()
        vz = []
        for _ in range(int(2 * world.agent_hz)):
            world.step()
            vz.append(vehicle.state.lin_vel_ground[2])
        # minimum-thrust pulses (T_min > weight) hold it with a ripple: mean 0.47 m/s measured
        assert np.mean(vz) == pytest.approx(-TOUCHDOWN_SPEED, abs=0.1)
        assert max(abs(v + TOUCHDOWN_SPEED) for v in vz) < 0.3
    finally:
        world.close()


def test_descent_aim_pulses_change_the_sideways_speed_in_the_fall_only_when_permitted():
    """Falling at 40 m/s far above the envelope (no thrust asked), a sideways setpoint of
    3 m/s: the attitude loop leans the long axis toward it and the autopilot fires
    minimum-thrust pulses; the sideways speed grows toward the setpoint.  With the ignition
    withheld: no pulse; the lean alone (booster out) moves it by the body's and the fins'
    aerodynamic force, and the other way (-0.85 against +2.8 m/s measured)."""
    results = {}
    for ignition in (1.0, 0.0):
        world = _world(0.01, "descent", [3.0, 0.0, 1.0, ignition], height=400.0)
        vehicle = world.vehicles[0]
        try:
            vehicle.reset(lin_vel=(0.0, 0.0, -40.0))
            world.set_setpoint(0, [3.0, 0.0, 1.0, ignition])  # (a reset clears the setpoint)
            pulses = 0
            for _ in range(int(2 * world.agent_hz)):
                world.step()
                pulses += vehicle.actuators.boosters.ignited[0]
                assert -vehicle.state.lin_vel_ground[2] > AIM_FALL
            results[ignition] = (pulses, vehicle.state.lin_vel_ground[0], vehicle.state.lin_pos[2])
        finally:
            world.close()
    pulses, vx_aimed, _ = results[1.0]
    assert pulses > 0 and 2.0 < vx_aimed < 3.3
    pulses, vx, _ = results[0.0]
    assert pulses == 0 and abs(vx) < vx_aimed / 3.0
    assert results[1.0][2] > results[0.0][2]  # the pulses' thrust also slowed the fall

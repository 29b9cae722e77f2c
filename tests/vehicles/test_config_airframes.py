"""Airframes authored in YAML alone (hexacopter, flying wing, quadplane) fly under control."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.world import VehicleConfig, World
from tests.vehicles.aero import level_trim
from tests.vehicles.test_fixedwing import fly, launch


def test_config_airframes_load_and_build_from_yaml_alone():
    for name, motors, surfaces in (("hexacopter", 6, 0), ("flying_wing", 1, 5), ("quadplane", 5, 5)):
        spec = load_uav_spec(name)
        assert len(spec.motors.positions) == motors and len(spec.surfaces) == surfaces
    with World(
        [
            VehicleConfig("hexacopter", (0, 0, 1)),
            VehicleConfig("flying_wing", (5, 0, 5)),
            VehicleConfig("quadplane", (-5, 0, 1)),
        ]
    ) as world:
        hexa, wing, quadplane = world.vehicles
        assert hexa.mixer.allocation.shape == (4, 6)
        assert (hexa.mass, wing.mass, quadplane.mass) == pytest.approx((1.8, 1.5, 3.05))  # from the parts
        assert quadplane.parts.mixer_motors == (0, 1, 2, 3)
        assert quadplane.setpoint_layout == ("x", "y", "yaw", "z", "aileron", "elevator", "rudder", "thrust")
        assert wing.setpoint_layout == ("roll", "pitch", "yaw_rate", "airspeed")


def test_hexacopter_holds_position_and_hovers_at_the_analytic_throttle():
    """position_yaw to (1, -1, 2) m, yaw 0.5 rad: within 5 cm and 0.05 rad over the last
    2 s of 8 s; the mean motor throttle in hover is sqrt(m g / (6 k_F max_rpm^2))."""
    with World([VehicleConfig("hexacopter", (0.0, 0.0, 1.0), mode="position_yaw")], seed=0) as world:
        vehicle = world.vehicles[0]
        world.set_setpoint(0, [1.0, -1.0, 0.5, 2.0])
        states = fly(world, 6.0)
        throttles = []
        for _ in range(60):
            world.step()
            states.append(world.state(0))
            throttles.append(vehicle.motor_throttle.copy())
    last = states[-60:]
    error = max(np.linalg.norm(np.subtract(s.lin_pos, (1.0, -1.0, 2.0))) for s in last)
    assert error < 0.05, f"position error {error:.3f} m"
    assert max(abs(s.ang_pos[2] - 0.5) for s in last) < 0.05
    hover = math.sqrt(1.8 * GRAVITY / 60.0)  # 60 N at full throttle, thrust ~ throttle^2
    assert vehicle.hover_throttle() == pytest.approx(hover)
    assert np.mean(throttles) == pytest.approx(hover, rel=0.02)


def test_flying_wing_autopilot_holds_level_flight():
    """Autopilot, wings level, pitch from the static trim at 15 m/s: altitude within +-1 m
    and airspeed within +-0.5 m/s for 15 s."""
    spec = load_uav_spec("flying_wing")
    trim = level_trim(spec, 15.0)
    world = launch(spec, "attitude_airspeed", altitude=100.0, speed=15.0, pitch=trim["pitch"])
    world.set_setpoint(0, [0.0, trim["pitch"], 0.0, 15.0])
    held = fly(world, 18.0)[90:]
    world.close()
    z = np.array([s.lin_pos[2] for s in held])
    assert np.abs(z - 100.0).max() < 1.0, f"altitude {z.min():.2f}..{z.max():.2f} m"
    assert max(abs(s.lin_vel[0] - 15.0) for s in held) < 0.5
    assert max(abs(s.ang_pos[0]) for s in held) < math.radians(1.0)


def test_flying_wing_elevons_mix_roll_and_pitch():
    """Each elevon takes both channels: +roll lowers the left one and raises the right one,
    +pitch lowers both (flap deflections read back from the vehicle)."""
    with World([VehicleConfig("flying_wing", (0, 0, 50), mode="channels")]) as world:
        vehicle = world.vehicles[0]
        names = [s.name for s in vehicle.spec.surfaces]
        left, right = names.index("left_elevon"), names.index("right_elevon")
        for setpoint, signs in (([0.5, 0, 0, 0], (1, -1)), ([0, 0.5, 0, 0], (1, 1)), ([0.5, 0.5, 0, 0], (1, 0))):
            vehicle.reset()
            world.set_setpoint(0, setpoint)
            world.step()
            world.step()
            world.step()
            deflection = vehicle.surface_deflection[[left, right]]
            for value, sign in zip(deflection, signs):
                assert np.sign(round(value, 6)) == sign, (setpoint, deflection)


def test_quadplane_hovers_on_its_lift_motors():
    """position_yaw to (0.5, -0.5, 2.5) m with the pusher and surfaces idle: within 10 cm
    over the last 2 s of 7 s; the pusher stays off."""
    with World([VehicleConfig("quadplane", (0.0, 0.0, 2.0), mode="position_yaw")], seed=0) as world:
        vehicle = world.vehicles[0]
        world.set_setpoint(0, [0.5, -0.5, 0.0, 2.5, 0.0, 0.0, 0.0, 0.0])
        last = fly(world, 7.0)[-60:]
        assert vehicle.motor_throttle[4] == 0.0
    error = max(np.linalg.norm(np.subtract(s.lin_pos, (0.5, -0.5, 2.5))) for s in last)
    assert error < 0.1, f"position error {error:.3f} m"


def test_quadplane_flies_forward_on_its_pusher_while_holding_altitude():
    """attitude_z (level, z = 10 m) with the pusher channel at 0.6: the forward speed rises
    steadily (the lift motors only hold attitude and height), the altitude stays within
    +-0.5 m, and the lift motors throttle back as the wing takes up the weight."""
    with World([VehicleConfig("quadplane", (0.0, 0.0, 10.0), mode="position_yaw")], seed=0) as world:
        vehicle = world.vehicles[0]
        world.set_setpoint(0, [0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 0.0])
        fly(world, 2.0)
        lift_hover = float(np.mean(vehicle.motor_throttle[:4]))
        world.set_mode(0, "attitude_z")
        world.set_setpoint(0, [0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 0.6])
        states = fly(world, 8.0)
        lift_cruise = float(np.mean(vehicle.motor_throttle[:4]))
    speed = np.array([s.lin_vel_ground[0] for s in states])
    z = np.array([s.lin_pos[2] for s in states])
    assert speed[-1] > 12.0, f"forward speed {speed[-1]:.2f} m/s after 8 s"
    assert np.all(np.diff(speed[::15]) > 0)  # rising every half second
    assert np.abs(z - 10.0).max() < 0.5, f"altitude {z.min():.2f}..{z.max():.2f} m"
    assert lift_cruise < 0.9 * lift_hover

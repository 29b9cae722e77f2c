"""World physics against analytic oracles: hover, free fall, collisions, scheduling."""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.components.motor import motor_wrench_matrix
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.world import VehicleConfig, World


def test_hover_throttle_gives_thrust_equal_to_weight(quiet_cf2x):
    world = World([VehicleConfig(quiet_cf2x, (0.0, 0.0, 2.0), mode="motors")], seed=0)
    vehicle = world.vehicles[0]
    hover = vehicle.hover_throttle()
    # analytic: 4 k_F (x max_rpm)^2 = m g
    m = quiet_cf2x.motors
    assert 4 * m.kf * (hover * m.max_rpm) ** 2 == pytest.approx(quiet_cf2x.body.mass * GRAVITY, rel=1e-12)
    world.set_setpoint(0, [hover] * 4)
    for _ in range(15):  # motors settle (0.5 s >> tau)
        world.step()
    wrench = motor_wrench_matrix(vehicle.motors) @ (vehicle.motor_throttle * np.abs(vehicle.motor_throttle))
    assert wrench[2] == pytest.approx(quiet_cf2x.body.mass * GRAVITY, rel=0.01)
    np.testing.assert_allclose(wrench[3:], 0.0, atol=1e-12)
    # and the simulated body does not accelerate vertically
    z0, vz0 = vehicle.state.lin_pos[2], vehicle.state.lin_vel_ground[2]
    for _ in range(30):
        world.step()
    accel = 2 * (vehicle.state.lin_pos[2] - z0 - vz0 * 1.0) / 1.0**2
    assert abs(accel) < 0.01 * GRAVITY
    world.close()


def test_free_fall_follows_half_g_t_squared(quiet_cf2x):
    world = World([VehicleConfig(quiet_cf2x, (0.0, 0.0, 20.0), mode="motors")], seed=0, drag=False)
    world.set_armed(0, False)
    times, heights = [], []
    for _ in range(30):  # 1 s
        world.step()
        times.append(world.elapsed)
        heights.append(world.state(0).lin_pos[2])
    times, heights = np.array(times), np.array(heights)
    drop = 20.0 - heights
    analytic = 0.5 * GRAVITY * times**2
    # within 1 % of the 1-second drop at every sample, and within 1 % at t = 1 s
    assert np.abs(drop - analytic).max() < 0.01 * analytic[-1]
    assert drop[-1] == pytest.approx(analytic[-1], rel=0.01)
    # PyBullet integrates with semi-implicit Euler: after n steps the drop is exactly
    # g dt^2 n (n + 1) / 2, which tends to 1/2 g t^2 as dt -> 0
    n = np.round(times * 240).astype(int)
    np.testing.assert_allclose(drop, GRAVITY * (1 / 240) ** 2 * n * (n + 1) / 2, rtol=1e-9)
    world.close()


def test_position_hold_within_5cm_for_10_seconds():
    world = World([VehicleConfig("quadx_cf2x", (0.0, 0.0, 1.0), mode="position_yaw")], seed=0)
    world.set_setpoint(0, [0.0, 0.0, 0.0, 1.0])  # x, y, yaw, z
    errors = []
    for _ in range(300):  # 10 s at 30 Hz
        world.step()
        errors.append(np.linalg.norm(np.subtract(world.state(0).lin_pos, (0.0, 0.0, 1.0))))
    assert max(errors) < 0.05, f"max deviation {max(errors):.3f} m"
    world.close()


def test_vehicle_dropped_on_ground_registers_contact_and_free_air_does_not(quiet_cf2x):
    world = World(
        [
            VehicleConfig(quiet_cf2x, (0.0, 0.0, 0.3), mode="motors"),
            VehicleConfig(quiet_cf2x, (5.0, 0.0, 50.0), mode="motors"),
        ],
        seed=0,
    )
    world.set_armed(0, False)
    world.set_armed(1, False)
    touched = []
    for _ in range(15):
        world.step()
        touched.append((world.collided(0), world.collided_with_ground(0), world.collided(1)))
    touched = np.array(touched)
    assert not touched[0, 0]  # 0.3 m up at the start: still in the air
    assert touched[-1, 0] and touched[-1, 1]  # resting on the ground
    assert not touched[:, 2].any()  # the high vehicle never touched anything
    matrix = world.contact_array
    assert matrix.shape == (3, 3) and (matrix == matrix.T).all()
    assert matrix[0, 1] and not matrix[0, 2] and not matrix[1, 2]
    world.close()


def test_two_vehicles_flown_into_each_other_collide():
    world = World(
        [
            VehicleConfig("quadx_cf2x", (-1.0, 0.0, 1.0), mode="velocity_yawrate"),
            VehicleConfig("quadx_cf2x", (1.0, 0.0, 1.0), mode="velocity_yawrate"),
        ],
        seed=0,
    )
    world.set_setpoint(0, [1.5, 0.0, 0.0, 0.0])
    world.set_setpoint(1, [-1.5, 0.0, 0.0, 0.0])
    hit = False
    for _ in range(90):
        world.step()
        if world.collided_with(0, 1):
            hit = True
            break
    assert hit
    world.close()


def test_mixed_airframes_in_one_world():
    world = World(
        [
            VehicleConfig("quadx_cf2x", (0.0, 0.0, 1.0), mode="position_yaw"),
            VehicleConfig("quadx_f450", (2.0, 0.0, 1.0), mode="position_yaw"),
            VehicleConfig("quadx_cf2x", (-2.0, 0.0, 1.0), mode=7),
        ],
        seed=0,
    )
    targets = [(0.5, 0.0, 1.5), (2.0, 1.0, 2.0), (-2.0, -0.5, 1.0)]
    for i, (x, y, z) in enumerate(targets):
        world.set_setpoint(i, [x, y, 0.0, z])
    for _ in range(150):
        world.step()
    for i, target in enumerate(targets):
        assert np.linalg.norm(np.subtract(world.state(i).lin_pos, target)) < 0.1
    world.close()


@pytest.mark.parametrize(
    "rates, message",
    [
        ((250.0, 120.0, 30.0), "physics_hz / control_hz"),
        ((240.0, 120.0, 70.0), "physics_hz / agent_hz"),
        ((240.0, 480.0, 30.0), "physics_hz / control_hz"),
    ],
)
def test_non_integer_loop_rate_ratios_are_rejected(rates, message):
    physics, control, agent = rates
    with pytest.raises(ConfigError, match=message):
        World(physics_hz=physics, control_hz=control, agent_hz=agent)


def test_step_runs_the_configured_number_of_physics_and_control_steps(quiet_cf2x):
    world = World(
        [VehicleConfig(quiet_cf2x, (0.0, 0.0, 5.0), mode="rates_thrust")], physics_hz=240, control_hz=60, agent_hz=20
    )
    vehicle = world.vehicles[0]
    calls = []
    original = vehicle.control_step
    vehicle.control_step = lambda: (calls.append(world.physics_steps), original())[1]
    world.step()
    assert world.physics_steps == 12
    assert calls == [0, 4, 8]
    assert world.elapsed == pytest.approx(12 / 240)
    world.close()


def test_reset_restores_spawn_state_without_rebuilding(quiet_cf2x):
    world = World([VehicleConfig(quiet_cf2x, (0.0, 0.0, 1.0), mode="position_yaw")], seed=1)
    body = world.vehicles[0].body_id
    world.reset(seed=1)
    world.set_setpoint(0, [1.0, 0.0, 0.0, 2.0])
    first = []
    for _ in range(20):
        world.step()
        first.append(world.state(0).lin_pos)
    world.reset(seed=1)
    assert world.vehicles[0].body_id == body
    np.testing.assert_allclose(world.state(0).lin_pos, (0.0, 0.0, 1.0))
    world.set_setpoint(0, [1.0, 0.0, 0.0, 2.0])
    second = []
    for _ in range(20):
        world.step()
        second.append(world.state(0).lin_pos)
    assert np.array_equal(first, second)
    world.close()


def test_setpoint_of_wrong_size_is_rejected():
    world = World([VehicleConfig("quadx_cf2x", (0.0, 0.0, 1.0), mode="position_yaw")])
    with pytest.raises(ConfigError, match=r"needs 4 values \(x, y, yaw, z\)"):
        world.set_setpoint(0, [1.0, 2.0])
    with pytest.raises(ConfigError, match="no vehicle 3"):
        world.set_setpoint(3, [0, 0, 0, 1])
    world.close()


def test_reset_with_body_frame_velocity(quiet_cf2x):
    world = World([VehicleConfig(quiet_cf2x, (0.0, 0.0, 5.0))], seed=0, gravity=0.0, drag=False)
    vehicle = world.vehicles[0]
    vehicle.reset((0.0, 0.0, 5.0), (0.0, 0.0, np.pi / 2), lin_vel=(2.0, 0.0, 0.0), ang_vel=(0.0, 0.0, 0.5))
    state = vehicle.state
    np.testing.assert_allclose(state.lin_vel, (2.0, 0.0, 0.0), atol=1e-9)
    # body forward is ground north (+y) at yaw 90 degrees
    np.testing.assert_allclose(state.lin_vel_ground, (0.0, 2.0, 0.0), atol=1e-9)
    np.testing.assert_allclose(state.ang_vel, (0.0, 0.0, 0.5), atol=1e-9)
    world.close()

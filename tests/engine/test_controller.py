"""The multirotor controller and mixer against their equations, evaluated by hand.

Each loop is checked on one constructed state against its law written out with numbers
(the docstrings of :mod:`pyflyt_engine.control.multirotor` and
:mod:`pyflyt_engine.control.mixer`); convergence in flight is :mod:`test_flight_modes`.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pybullet as p
import pytest

from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.control.modes import MULTIROTOR_MODES
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.state import KinematicState
from pyflyt_engine.world import VehicleConfig, World
from tests.conftest import spec_variant

DT = 1.0 / 120.0


def _controller(mode: str, **changes) -> tuple[MultirotorController, object]:
    spec = spec_variant("quadx_f450", **{"body.inertia": [0.011, 0.009, 0.016], **changes})
    vehicle = World([VehicleConfig(spec)], seed=0).vehicles[0]
    controller = MultirotorController(
        spec.control, vehicle.parts.mass, np.diag(vehicle.parts.inertia), vehicle.mixer, DT
    )
    controller.set_mode(MULTIROTOR_MODES[mode])
    return controller, spec


def _state(ang_vel=(0.0, 0.0, 0.0), ang_pos=(0.0, 0.0, 0.0), lin_pos=(0.0, 0.0, 1.0), lin_vel_ground=(0.0, 0.0, 0.0)):
    return KinematicState(
        ang_vel, ang_pos, (0.0, 0.0, 0.0), lin_pos, (0.0, 0.0, 0.0, 1.0), lin_vel_ground, (0.0, 0.0, 0.0)
    )


def test_rate_loop_is_pi_plus_derivative_times_inertia_plus_gyroscopic_term():
    controller, spec = _controller("rates_thrust", **{"control.rate.kd": [0.02, 0.03, 0.01]})
    g = spec.control.rate
    jx, jy, jz = 0.011, 0.009, 0.016
    w0, w1 = (0.3, -0.2, 0.5), (0.35, -0.1, 0.45)
    sp = (1.0, -0.5, 0.2)
    controller._rate_loop(_state(ang_vel=w0), sp)  # first call: no derivative history yet
    torques = controller._rate_loop(_state(ang_vel=w1), sp)
    expected = []
    for axis in range(3):
        e0, e1 = sp[axis] - w0[axis], sp[axis] - w1[axis]
        limit = g.integral_limit[axis] / g.ki[axis]
        integral = max(-limit, min(limit, e0 * DT + e1 * DT))
        expected.append(g.kp[axis] * e1 + g.ki[axis] * integral - g.kd[axis] * (w1[axis] - w0[axis]) / DT)
    ax, ay, az = expected
    wx, wy, wz = w1
    # J alpha + omega x (J omega)
    gyro = np.cross(w1, np.multiply((jx, jy, jz), w1))
    np.testing.assert_allclose(torques, np.multiply((jx, jy, jz), (ax, ay, az)) + gyro, rtol=1e-12)


def test_attitude_loop_is_clipped_proportional_and_wraps_the_yaw_error():
    controller, spec = _controller("attitude_z")
    g = spec.control.attitude
    p_sp, q_sp, r_sp = controller._attitude_rates(_state(ang_pos=(0.1, -0.05, 3.0)), 0.2, 0.05, -3.0, 0.0)
    assert p_sp == pytest.approx(min(g.kp[0] * 0.1, g.max_rate[0]))
    assert q_sp == pytest.approx(g.kp[1] * 0.1)
    yaw_error = -3.0 - 3.0 + 2 * math.pi  # -6 rad wrapped into [-pi, pi): +0.283 rad, the short way round
    assert r_sp == pytest.approx(max(-g.max_rate[2], min(g.max_rate[2], g.kp[2] * yaw_error)))
    assert r_sp > 0.0


def test_thrust_is_weight_plus_climb_compensated_for_tilt():
    controller, _ = _controller("attitude_z")
    mass = controller.mass
    assert controller._thrust_for(_state(), 0.0) == pytest.approx(mass * GRAVITY)
    tilted = _state(ang_pos=(0.3, 0.2, 0.0))
    assert controller._thrust_for(tilted, 1.5) == pytest.approx(
        mass * (GRAVITY + 1.5) / (math.cos(0.3) * math.cos(0.2))
    )
    assert controller._thrust_for(_state(ang_pos=(1.4, 0.0, 0.0)), 0.0) == pytest.approx(mass * GRAVITY / 0.5)
    assert controller._thrust_for(_state(), -2 * GRAVITY) == 0.0  # never pulls


def test_velocity_loop_integrates_while_the_error_is_large_and_stops_only_at_saturation():
    controller, spec = _controller("velocity_yawrate")
    g = spec.control.velocity
    horizontal, up, down = controller.authority
    # |e| = 1 m/s, far outside the old 0.5 m/s window: kp e = 3 < a_h, so it integrates
    a = controller._velocity_loop(_state(), (1.0, None, None))
    assert controller._vel_integral[0] == pytest.approx(1.0 * DT)
    assert a[0] == pytest.approx(g.kp[0] * 1.0 + g.ki[0] * 1.0 * DT)
    # e = 10 m/s: kp e = 30 > a_h and e pushes further into saturation: no integration
    far = controller._velocity_loop(_state(), (10.0, None, None))
    assert controller._vel_integral[0] == pytest.approx(1.0 * DT)
    assert far[0] == pytest.approx(g.kp[0] * 10.0 + g.ki[0] * 1.0 * DT)
    # ... but an error that leads out of saturation is integrated at once
    controller._vel_integral = [horizontal / g.ki[0], 0.0, 0.0]
    controller._velocity_loop(_state(), (-0.5, None, None))
    assert controller._vel_integral[0] == pytest.approx(horizontal / g.ki[0] - 0.5 * DT)
    # the integral term never passes the authority: vertical (up, down) bounds
    controller._vel_integral = [0.0, 0.0, up / g.ki[2] - 1e-9]
    controller._velocity_loop(_state(lin_vel_ground=(0.0, 0.0, 0.0)), (None, None, 0.001))
    assert g.ki[2] * controller._vel_integral[2] == pytest.approx(up)
    controller._vel_integral = [0.0, 0.0, -down / g.ki[2] + 1e-9]
    controller._velocity_loop(_state(), (None, None, -0.001))
    assert g.ki[2] * controller._vel_integral[2] == pytest.approx(-down)


def test_velocity_authority_is_the_thrust_margin_by_hand():
    controller, spec = _controller("velocity_yawrate")
    # quadx_f450: 1 kg, 40 N, max_tilt 0.6 rad
    horizontal, up, down = controller.authority
    assert horizontal == pytest.approx(GRAVITY * math.tan(0.6))  # tilt-bound: 6.71 < sqrt(40^2 - 9.81^2)
    full = 4 * 3.0e-7 * 5773.5**2  # k_F max_rpm^2 per motor: 40 N
    assert controller.mixer.max_collective == pytest.approx(full, rel=1e-12)
    assert up == pytest.approx(full / 1.0 - GRAVITY, rel=1e-12) and down == pytest.approx(0.9 * GRAVITY)
    from pyflyt_engine.control.multirotor import velocity_authority

    # a thin margin: 1.2 m g of thrust leans to sqrt(1.2^2 - 1) g before max_tilt
    assert velocity_authority(1.2 * GRAVITY, 1.0, 1.0)[0] == pytest.approx(GRAVITY * math.sqrt(1.44 - 1.0))
    assert velocity_authority(0.9 * GRAVITY, 1.0, 0.6)[:2] == (0.0, 0.0)  # cannot hover: no authority


def test_the_old_window_and_a_fixed_integral_limit_are_still_honoured_when_given():
    controller, spec = _controller(
        "velocity_yawrate", **{"control.velocity.integral_window": 0.5, "control.velocity.integral_limit": [2, 2, 3]}
    )
    controller._velocity_loop(_state(), (1.0, None, None))  # |e| = 1 > window: no integration
    assert controller._vel_integral == [0.0, 0.0, 0.0]
    near = controller._velocity_loop(_state(lin_vel_ground=(0.0, 0.1, 0.0)), (None, 0.3, 0.0))
    assert near[1] == pytest.approx(spec.control.velocity.kp[1] * 0.2 + spec.control.velocity.ki[1] * 0.2 * DT)
    controller._vel_integral = [0.0, 3.0 / spec.control.velocity.ki[1], 0.0]
    controller._velocity_loop(_state(), (None, -0.1, None))  # integrating, it is clamped to the limit
    assert spec.control.velocity.ki[1] * controller._vel_integral[1] == pytest.approx(2.0)


def test_mixer_reproduces_any_wrench_it_can_and_gives_up_yaw_first():
    controller, _ = _controller("rates_thrust")
    mixer = controller.mixer
    fm = np.array(mixer.max_thrust)
    rng = np.random.default_rng(0)
    for _ in range(500):  # within the motors' range: exact allocation
        request = np.array([rng.uniform(0.3, 0.6) * mixer.max_collective, *rng.normal(0, 0.02, 3)])
        throttles = np.array(mixer.throttles(*request))
        np.testing.assert_allclose(mixer.allocation @ (fm * throttles**2), request, rtol=1e-9, atol=1e-12)
    hover = 0.5 * mixer.max_collective
    throttles = np.array(mixer.throttles(hover, 0.05, -0.05, 50.0))  # an impossible yaw torque
    achieved = mixer.allocation @ (fm * throttles**2)
    assert np.all((throttles >= 0.0) & (throttles <= 1.0))
    np.testing.assert_allclose(achieved[:3], (hover, 0.05, -0.05), rtol=1e-9)  # thrust, roll, pitch kept
    assert 0.0 < achieved[3] < 50.0  # yaw given up as far as needed


def test_motors_mode_limits_the_command():
    world = World([VehicleConfig("quadx_cf2x", (0, 0, 1), mode="motors")], seed=0)
    world.set_setpoint(0, [1.5, -2.0, 0.25, -0.5])
    world.vehicles[0].control_step()
    assert world.vehicles[0].motor_command.tolist() == [1.0, -1.0, 0.25, -0.5]


def test_state_after_a_step_is_read_when_asked_and_reading_it_changes_nothing():
    def run(read_every_step: bool) -> str:
        world = World([VehicleConfig("quadx_cf2x", (0, 0, 1), mode="position_yaw")], seed=1)
        world.set_setpoint(0, [0.5, 0.2, 0.1, 1.4])
        out = []
        for i in range(20):
            world.step()
            if read_every_step or i % 7 == 0:
                out.append((world.state(0), world.aux_state(0).tolist()))
        out.append((world.state(0), world.aux_state(0).tolist()))
        world.close()
        return hashlib.sha256(repr(out[-1]).encode()).hexdigest()

    assert run(True) == run(False)
    world = World([VehicleConfig("quadx_cf2x", (0, 0, 1), mode="motors")], seed=0)
    vehicle = world.vehicles[0]
    world.step()
    lazily = vehicle.state
    assert lazily == vehicle.read_state()
    assert vehicle.state is vehicle.state  # read once, then kept until the next step
    # a pose set directly in PyBullet between steps shows in the state read after it
    world.step()
    p.resetBasePositionAndOrientation(vehicle.body_id, [5.0, 0.0, 1.0], [0, 0, 0, 1], physicsClientId=world.client)
    assert vehicle.state.lin_pos[0] == 5.0
    world.close()


def _staged_allocation(mixer, thrust, tx, ty, tz):
    """The mixer's docstring, stage by stage in NumPy: yaw scale, then collective scale, then throttles."""
    rows = np.array([r[:4] for r in mixer._rows])
    fm = np.array(mixer.max_thrust)
    from_thrust = rows[:, 0] * thrust
    base = from_thrust + rows[:, 1] * tx + rows[:, 2] * ty
    yaw = rows[:, 3] * tz
    yaw_scale = 1.0
    for b, y, full in zip(base, yaw, fm):
        if y > 0.0 and b + y > full:
            yaw_scale = min(yaw_scale, max((full - b) / y, 0.0))
        elif y < 0.0 and b + y < 0.0:
            yaw_scale = min(yaw_scale, max(-b / y, 0.0))
    from_torque = (base - from_thrust) + yaw_scale * yaw
    scale = 1.0
    for ft, fq, full in zip(from_thrust, from_torque, fm):
        if ft + fq > full and ft > 0.0:
            scale = min(scale, max((full - fq) / ft, 0.0))
    force = scale * from_thrust + from_torque
    return np.where(force <= 0.0, 0.0, np.where(force >= fm, 1.0, np.sqrt(np.clip(force, 0.0, None) / fm)))


@pytest.mark.parametrize("uav", ["quadx_cf2x", "hexacopter"])
def test_mixer_equals_its_staged_equations_bit_for_bit_saturated_or_not(uav):
    """The first pass's early answer (nothing saturates) and the staged passes give
    exactly the staged equations' throttles, across requests that saturate and not."""
    world = World([VehicleConfig(uav, (0.0, 0.0, 1.0), mode="rates_thrust")], seed=0)
    mixer = world.vehicles[0].mixer
    rng = np.random.default_rng(1)
    saturated = 0
    for _ in range(3000):
        request = (rng.uniform(-0.1, 1.1) * mixer.max_collective, *rng.normal(0, 0.005, 2), rng.normal(0, 0.0005))
        request = tuple(float(r) for r in request)
        got = mixer.throttles(*request)
        assert got == _staged_allocation(mixer, *request).tolist(), request
        saturated += any(t in (0.0, 1.0) for t in got)
    assert 300 < saturated < 2700  # both branches were exercised

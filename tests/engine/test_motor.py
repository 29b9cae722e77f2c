"""Motor component against the paper's equations: lag, thrust law, zero-mean noise."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pyflyt_engine.components.lag import lag_coefficient
from pyflyt_engine.components.motor import MotorParams, Motors, motor_lag, motor_wrench_matrix
from pyflyt_engine.components.noise import NoiseSource
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.vehicle import motor_params_from_spec
from pyflyt_engine.world import VehicleConfig, World
from tests.conftest import spec_variant

DT = 1.0 / 240.0


def group(params, throttle=0.0, command=0.0, seed=0) -> Motors:
    """The motors as the vehicle steps them, at ``throttle`` with ``command``, noise from a seeded generator."""
    motors = Motors(params, DT, NoiseSource(np.random.default_rng(seed)))
    motors.throttle = np.broadcast_to(np.asarray(throttle, dtype=float), params.count).tolist()
    motors.command = np.broadcast_to(np.asarray(command, dtype=float), params.count).tolist()
    return motors


def motor_step(params, throttle, command):
    """The new throttles after one noiseless ``Motors.step`` (what the simulator runs), as an array."""
    motors = group(dataclasses.replace(params, noise_ratio=0.0), throttle, command)
    motors.step()
    return np.array(motors.throttle)


def thrust_and_torque(params, throttle):
    """Oracle: thrust k_F omega|omega| [N] and reaction-torque magnitude k_T omega|omega| [N m]
    per motor at ``throttle`` (omega = throttle * max_rpm), from the paper's law."""
    omega = np.asarray(throttle) * params.max_rpm
    return params.kf * omega * np.abs(omega), params.kt * omega * np.abs(omega)


def _params(n: int = 4, tau: float = 0.05, noise: float = 0.0) -> MotorParams:
    angles = np.arange(n) * 2 * np.pi / n
    return MotorParams(
        positions=np.stack([np.cos(angles), np.sin(angles), np.zeros(n)], axis=1) * 0.1,
        thrust_axes=np.tile([0.0, 0.0, 1.0], (n, 1)),
        spin=np.where(np.arange(n) % 2 == 0, 1.0, -1.0),
        tau=tau,
        max_rpm=20000.0,
        kf=3e-10,
        kt=8e-12,
        noise_ratio=noise,
    )


def test_step_response_reaches_63_percent_after_tau():
    tau = 12 * DT  # a whole number of physics steps, so the sample lands on t = tau
    params = _params(tau=tau)
    throttle = np.zeros(4)
    command = np.full(4, 0.8)
    for _ in range(12):
        throttle = motor_step(params, throttle, command)
    fraction = throttle / 0.8
    np.testing.assert_allclose(fraction, 1 - np.exp(-1), rtol=0.05)
    np.testing.assert_allclose(fraction, 0.632, atol=0.001)


def test_step_response_at_the_crazyflie_time_constant():
    """tau = 0.01 s is 2.4 physics steps; the discrete response still follows 1 - e^(-t/tau)."""
    spec = load_uav_spec("quadx_cf2x")
    params = motor_params_from_spec(spec)
    throttle = np.zeros(4)
    samples = []
    for _ in range(5):
        throttle = motor_step(params, throttle, np.ones(4))
        samples.append(throttle[0])
    t = DT * np.arange(1, 6)
    np.testing.assert_allclose(samples, 1 - np.exp(-t / 0.01), rtol=1e-12)
    # value at t = tau by interpolating the samples: 63 % within 5 %
    assert np.interp(0.01, t, samples) == pytest.approx(0.632, rel=0.05)


@pytest.mark.parametrize("throttle", [0.2, 0.5, 0.9, 1.0, -0.4])
def test_thrust_and_torque_are_kf_and_kt_times_rpm_squared(throttle):
    """One motor at the origin, thrust along +Z, no lag (tau = 0): the step's wrench is
    F = k_F rpm|rpm| along the axis and the reaction -spin k_T rpm|rpm| about it."""
    params = MotorParams(positions=[[0.0, 0.0, 0.0]], thrust_axes=[[0.0, 0.0, 1.0]], spin=1.0, tau=0.0,
                         max_rpm=20000.0, kf=3e-10, kt=8e-12, noise_ratio=0.0)  # fmt: skip
    motors = group(params, command=throttle)
    fx, fy, fz, tx, ty, tz = motors.step()
    (x,) = motors.throttle
    rpm = throttle * 20000.0
    assert x == throttle
    assert fz == pytest.approx(3e-10 * rpm * abs(rpm), rel=1e-12)
    assert tz == pytest.approx(-8e-12 * rpm * abs(rpm), rel=1e-12)
    assert fx == fy == tx == ty == 0.0


def test_wrench_matrix_is_sum_of_thrusts_moments_and_reactions():
    params = _params()
    throttle = np.array([0.3, 0.6, 0.4, 0.8])
    wrench = motor_wrench_matrix(params) @ (throttle * np.abs(throttle))
    thrust, torque = thrust_and_torque(params, throttle)
    force = (params.thrust_axes * thrust[:, None]).sum(axis=0)
    moment = sum(np.cross(r, f * a) for r, f, a in zip(params.positions, thrust, params.thrust_axes))
    reaction = -(params.spin * torque)[:, None] * params.thrust_axes
    np.testing.assert_allclose(wrench[:3], force, rtol=1e-12)
    np.testing.assert_allclose(wrench[3:], moment + reaction.sum(axis=0), rtol=1e-12, atol=1e-15)


def test_noise_is_zero_mean_and_independent_per_motor_in_the_world():
    """10 000 physics steps at constant command through the vehicle adapter."""
    spec = spec_variant("quadx_cf2x", **{"motors.noise_ratio": 0.02})
    world = World(
        [VehicleConfig(spec, (0.0, 0.0, 50.0), mode="motors")],
        seed=3,
        ground=False,
        agent_hz=240.0,
        control_hz=240.0,
        gravity=0.0,
        drag=False,
    )
    vehicle = world.vehicles[0]
    command = 0.6
    world.set_setpoint(0, [command] * 4)
    for _ in range(50):  # settle the lag
        world.step()
    throttles = np.empty((10_000, 4))
    for i in range(10_000):
        world.step()
        throttles[i] = vehicle.motor_throttle
    thrust = thrust_and_torque(vehicle.motors, throttles)[0]
    noiseless = thrust_and_torque(vehicle.motors, np.full(4, command))[0]
    np.testing.assert_allclose(thrust.mean(axis=0), noiseless, rtol=0.005)
    assert thrust.std(axis=0).min() > 0.005 * noiseless[0]  # noise is really there
    corr = np.corrcoef(throttles.T)
    off_diagonal = corr[~np.eye(4, dtype=bool)]
    assert np.abs(off_diagonal).max() < 0.05
    world.close()


def test_shared_biased_noise_would_fail_the_oracle():
    """The reference package's N(4, 1) shared scalar: the same check flags it as biased."""
    params = _params(noise=0.02)
    rng = np.random.default_rng(0)
    throttle = np.full(4, 0.6)
    lag = motor_lag(params, DT)
    means = []
    for _ in range(2000):
        shared = rng.normal(4, 1)  # one scalar for all motors, mean 4
        throttle = (throttle + lag * (0.6 - throttle)) * (1.0 + params.noise_ratio * shared)  # the lag and noise law
        means.append(throttle.copy())
    assert abs(np.mean(means) / 0.6 - 1) > 0.05


def test_lag_coefficient_limits():
    assert lag_coefficient(DT, 0.0) == 1.0
    assert lag_coefficient(DT, 1e6) == pytest.approx(DT / 1e6, rel=1e-6)
    # Euler's coefficient 1/(tau r_p) for tau >> dt
    assert lag_coefficient(DT, 1.0) == pytest.approx(DT, rel=0.01)


def test_motor_step_is_the_lag_noise_and_thrust_law_of_the_paper():
    """One step of ``Motors.step`` against the equations evaluated with NumPy:
    x' = (x + a (c - x)) z with z = 1 + sigma eta, wrench = M (x'|x'|)."""
    params = _params(n=6, noise=0.05)
    rng = np.random.default_rng(1)
    throttle = rng.uniform(-1, 1, 6)
    command = rng.uniform(-1, 1, 6)
    motors = group(params, throttle, command, seed=2)
    wrench = motors.step()
    new = motors.throttle
    noise = 1.0 + params.noise_ratio * np.random.default_rng(2).standard_normal(6)  # the first row the group drew
    lag = motor_lag(params, DT)
    expected = (throttle + lag * (command - throttle)) * noise
    np.testing.assert_allclose(new, expected, rtol=1e-14)
    thrust = params.kf * (expected * params.max_rpm) * np.abs(expected * params.max_rpm)
    torque = params.kt * (expected * params.max_rpm) * np.abs(expected * params.max_rpm)
    force = (params.thrust_axes * thrust[:, None]).sum(axis=0)
    moment = (
        np.cross(params.positions, params.thrust_axes * thrust[:, None])
        - (params.spin * torque)[:, None] * params.thrust_axes
    ).sum(axis=0)
    np.testing.assert_allclose(wrench, np.concatenate([force, moment]), rtol=1e-12, atol=1e-18)

"""The tricopter: the multirotor mixer allocates through the tail servo (a gimbal it flies).

Oracles: the allocation inverts exactly (the wrench of the commanded thrusts along the
servo-rotated axes is the request); the hover trim satisfies the yaw balance
``tan(delta) = kappa / arm``; the vehicle holds its hover in every multirotor flight mode.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.errors import SpecError
from pyflyt_engine.spec import parse_uav_spec
from pyflyt_engine.world import VehicleConfig, World
from tests.conftest import spec_dict


def _rotate(axis: np.ndarray, about: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: ``axis`` turned by ``angle`` about the unit vector ``about``."""
    return (axis * math.cos(angle) + np.cross(about, axis) * math.sin(angle)
            + about * (about @ axis) * (1 - math.cos(angle)))  # fmt: skip


def _wrench(vehicle, outputs: list[float]) -> np.ndarray:
    """[thrust along z, roll, pitch, yaw torque] of the mixer's outputs, evaluated by hand:
    each motor's thrust fm throttle^2 along its (servo-turned) axis, from its position."""
    motors, mixer = vehicle.parts.motors, vehicle.mixer
    idx = list(vehicle.parts.mixer_motors)
    n = len(idx)
    axes = motors.thrust_axes[idx].copy()
    for k, tilt in enumerate(mixer.tilts):
        axes[tilt.motor] = _rotate(axes[tilt.motor], np.asarray(tilt.axis), outputs[n + k] * tilt.max_angle)
    f = np.asarray(mixer.max_thrust) * np.asarray(outputs[:n]) ** 2
    kappa = motors.kt[idx] / motors.kf[idx]
    torque = np.cross(motors.positions[idx], axes) - (motors.spin[idx] * kappa)[:, None] * axes
    return np.concatenate([[f @ axes[:, 2]], f @ torque])


@pytest.fixture(scope="module")
def tricopter():
    with World([VehicleConfig("tricopter", (0.0, 0.0, 1.0))], seed=0) as world:
        yield world.vehicles[0]


def test_the_mixer_allocates_through_the_tail_servo_exactly(tricopter):
    mixer = tricopter.mixer
    assert mixer.allocation.shape == (4, 4) and mixer.outputs == 4  # 3 motors + the servo angle
    rng = np.random.default_rng(0)
    weight = tricopter.mass * GRAVITY
    for _ in range(200):
        request = np.array([rng.uniform(0.8, 1.3) * weight, *rng.normal(0.0, 0.05, 3)])
        outputs = mixer.throttles(*request)
        assert all(0.0 < t < 1.0 for t in outputs[:3]) and -1.0 < outputs[3] < 1.0
        np.testing.assert_allclose(_wrench(tricopter, outputs), request, rtol=1e-9, atol=1e-12)


def test_hover_trim_is_the_yaw_balance_of_the_tail(tricopter):
    """No torque requested: the tail's lateral thrust cancels the reaction torques,
    arm f3 sin(delta) = kappa (f1 - f2 + f3 cos(delta)) (spins +1, -1, +1); the front pair
    nearly cancel, so tan(delta) is close to kappa / arm."""
    outputs = tricopter.mixer.throttles(tricopter.mass * GRAVITY, 0.0, 0.0, 0.0)
    delta = outputs[3] * tricopter.mixer.tilts[0].max_angle
    f1, f2, f3 = np.asarray(tricopter.mixer.max_thrust) * np.asarray(outputs[:3]) ** 2
    arm = -tricopter.parts.motors.positions[2][0]  # tail behind the centre of mass
    kappa = 4.8e-9 / 3.0e-7  # k_T / k_F of conf/uav/tricopter.yaml
    assert arm * f3 * math.sin(delta) == pytest.approx(kappa * (f1 - f2 + f3 * math.cos(delta)), rel=1e-9)
    assert math.tan(delta) == pytest.approx(kappa / arm, rel=0.02)


def _trim_roll(vehicle) -> float:
    """Roll at which thrust plus the tail's side force point straight up: atan(F_y / T)."""
    return math.atan(vehicle.mixer.side_force[1])


HOLD = {
    # mode: (setpoint, seconds, largest distance from the start [m])
    "position_yaw": ([0, 0, 0, 1], 5.0, 0.05),
    "position_yawrate": ([0, 0, 0, 1], 5.0, 0.05),
    "velocity_yaw": ([0, 0, 0, 0], 5.0, 0.05),
    "velocity_yawrate": ([0, 0, 0, 0], 5.0, 0.05),
    "heading_velocity_z": ([0, 0, 0, 1], 5.0, 0.05),
    "heading_velocity_vz": ([0, 0, 0, 0], 5.0, 0.05),
    "attitude_z": (["trim", 0, 0, 1], 5.0, 0.05),
    "attitude_vz": (["trim", 0, 0, 0], 5.0, 0.05),
    # no attitude feedback: the hover is held open loop for a while, as by any multirotor
    "rates_z": ([0, 0, 0, 1], 2.0, 0.05),
    "rates_thrust": ([0, 0, 0, "hover"], 1.0, 0.2),
    "motors": ("mixer", 1.0, 0.2),
}


@pytest.mark.parametrize("mode", list(HOLD))
def test_holds_its_hover_in_every_multirotor_flight_mode(mode):
    """Spawned at rest at (0, 0, 1) m in its trim attitude, given the mode's hover setpoint
    (attitude modes: the trim roll; thrust modes: the weight), it stays within the bound
    and keeps its heading (the yaw comes from the servo)."""
    setpoint, seconds, bound = HOLD[mode]
    with World([VehicleConfig("tricopter", (0.0, 0.0, 1.0))], seed=0) as world:
        roll = _trim_roll(world.vehicles[0])
    with World([VehicleConfig("tricopter", (0.0, 0.0, 1.0), orientation=(roll, 0.0, 0.0), mode=mode)], seed=0) as world:
        vehicle = world.vehicles[0]
        thrust = vehicle.mass * GRAVITY / math.cos(roll)
        if setpoint == "mixer":
            setpoint = vehicle.mixer.throttles(thrust, 0.0, 0.0, 0.0)
        setpoint = [
            roll if s == "trim" else thrust / vehicle.mixer.max_collective if s == "hover" else s for s in setpoint
        ]
        world.set_setpoint(0, setpoint)
        errors, yaws = [], []
        for _ in range(round(seconds * 30)):
            world.step()
            state = world.state(0)
            errors.append(float(np.linalg.norm(np.subtract(state.lin_pos, (0.0, 0.0, 1.0)))))
            yaws.append(abs(state.ang_pos[2]))
    assert max(errors) < bound, f"{mode}: drifted {max(errors):.3f} m"
    if mode != "motors":
        assert max(yaws) < 0.01, f"{mode}: yaw drifted {max(yaws):.4f} rad"


def test_motors_mode_takes_the_servo_command_after_the_throttles():
    with World([VehicleConfig("tricopter", (0, 0, 1), mode="motors")], seed=0) as world:
        vehicle = world.vehicles[0]
        assert vehicle.setpoint_layout == ("m1", "m2", "m3", "tilt_tail_servo")
        world.set_setpoint(0, [0.5, 0.5, 0.5, -0.4])
        vehicle.control_step()
        assert vehicle.gimbal_command.tolist() == [[-0.4, 0.0]]


def _tricopter_with(**changes) -> dict:
    data = spec_dict("tricopter")
    data["gimbals"][0].update(changes)
    return data


def _error(data: dict) -> str:
    with pytest.raises(SpecError) as info:
        parse_uav_spec(data, source="tri.yaml")
    return str(info.value)


def test_without_its_servo_a_tricopter_cannot_yaw():
    assert "has rank 3 < 4" in _error(
        _tricopter_with(mixer=False, channels=["yaw_servo", "unused"])
        | {"channels": {"yaw_servo": [-1, 1], "unused": [-1, 1]}}
    )


@pytest.mark.parametrize(
    "change, message",
    [
        ({"target": "motor:5"}, "target 'motor:5' does not exist"),
        ({"axis_a": [0.0, 0.0, 1.0]}, "must be perpendicular to the thrust axis"),
        ({"max_angle_b_deg": 10.0}, "give max_angle_a_deg > 0 and max_angle_b_deg: 0"),
        ({"max_angle_a_deg": 0.0}, "give max_angle_a_deg > 0 and max_angle_b_deg: 0"),
    ],
)
def test_a_servo_the_mixer_cannot_fly_is_refused_naming_the_gimbal(change, message):
    text = _error(_tricopter_with(**change))
    assert "gimbals.tail_servo" in text or "gimbals.0" in text or "gimbals" in text
    assert message in text


def test_a_mixer_servo_needs_multirotor_control():
    data = spec_dict("rocket")
    data["gimbals"][0]["mixer"] = True
    assert "mixer: true needs control.type 'multirotor'" in _error(data)

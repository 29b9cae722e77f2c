"""Every flight mode converges to a step setpoint (tolerances and times stated per case)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.control.modes import MULTIROTOR_MODES, resolve_mode
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.state import KinematicState
from pyflyt_engine.world import VehicleConfig, World

START = (0.0, 0.0, 2.0)


def _fly(uav: str, mode: str | int, setpoint, seconds: float, start=START) -> KinematicState:
    """Fly ``seconds``; return the state averaged over the last second.

    Averaging removes the motor-noise jitter (2 % per motor on the 27 g Crazyflie moves
    its body rates by a few tenths of a rad/s from one sample to the next) so the check
    is on where the mode converged, not on one noisy sample.
    """
    world = World([VehicleConfig(uav, start, mode=mode)], seed=0)
    vehicle = world.vehicles[0]
    world.set_setpoint(0, setpoint)
    steps = int(seconds * world.agent_hz)
    window = int(world.agent_hz)
    samples = []
    for i in range(steps):
        world.step()
        if i >= steps - window:
            samples.append(vehicle.state)
    world.close()
    return KinematicState(*(tuple(np.mean([getattr(s, f) for s in samples], axis=0)) for f in KinematicState._fields))


# (mode, setpoint, seconds, check(state) -> error, tolerance)
CASES = [
    (
        "attitude_vz",
        [0.0, 0.0, 0.8, 0.5],
        3.0,
        lambda s: max(abs(s.ang_pos[2] - 0.8), abs(s.lin_vel_ground[2] - 0.5)),
        0.05,
    ),
    # body rates: 1-s mean within 0.1 rad/s (the cf2x's 2 % motor noise jitters them by ~0.3 rad/s)
    ("rates_z", [0.0, 0.0, 0.5, 3.0], 4.0, lambda s: max(abs(s.ang_vel[2] - 0.5), abs(s.lin_pos[2] - 3.0)), 0.1),
    (
        "attitude_z",
        [0.1, -0.1, 0.5, 2.5],
        3.0,
        lambda s: max(abs(s.ang_pos[0] - 0.1), abs(s.ang_pos[1] + 0.1), abs(s.ang_pos[2] - 0.5)),
        0.03,
    ),
    (
        "heading_velocity_z",
        [1.0, 0.5, 0.0, 2.5],
        4.0,
        lambda s: max(abs(s.lin_vel_ground[0] - 1.0), abs(s.lin_vel_ground[1] - 0.5), abs(s.lin_pos[2] - 2.5)),
        0.08,
    ),
    (
        "heading_velocity_vz",
        [1.0, 0.0, 0.3, 0.0],
        4.0,
        lambda s: max(abs(math.hypot(*s.lin_vel_ground[:2]) - 1.0), abs(s.ang_vel[2] - 0.3), abs(s.lin_vel_ground[2])),
        0.08,
    ),
    (
        "velocity_yawrate",
        [1.0, -1.0, 0.0, 0.3],
        4.0,
        lambda s: float(np.abs(np.subtract(s.lin_vel_ground, (1.0, -1.0, 0.3))).max()),
        0.08,
    ),
    (
        "velocity_yaw",
        [-1.0, 0.5, 1.0, 0.0],
        4.0,
        lambda s: max(float(np.abs(np.subtract(s.lin_vel_ground, (-1.0, 0.5, 0.0))).max()), abs(s.ang_pos[2] - 1.0)),
        0.08,
    ),
    (
        "position_yawrate",
        [1.0, 1.0, 0.0, 3.0],
        5.0,
        lambda s: float(np.linalg.norm(np.subtract(s.lin_pos, (1.0, 1.0, 3.0)))),
        0.05,
    ),
    (
        "position_yaw",
        [1.0, -1.0, 1.5, 1.0],
        5.0,
        lambda s: max(float(np.linalg.norm(np.subtract(s.lin_pos, (1.0, -1.0, 1.0)))), abs(s.ang_pos[2] - 1.5)),
        0.05,
    ),
]


@pytest.mark.parametrize("uav", ["quadx_cf2x", "quadx_f450"])
@pytest.mark.parametrize("mode, setpoint, seconds, error, tolerance", CASES, ids=[c[0] for c in CASES])
def test_mode_converges_to_step_setpoint(uav, mode, setpoint, seconds, error, tolerance):
    state = _fly(uav, mode, setpoint, seconds)
    assert error(state) < tolerance, f"{mode}: error {error(state):.4f} after {seconds} s"


@pytest.mark.parametrize("uav", ["quadx_cf2x", "quadx_f450"])
def test_rates_thrust_mode_tracks_body_rates(uav):
    world = World([VehicleConfig(uav, START, mode="rates_thrust")], seed=0)
    vehicle = world.vehicles[0]
    hover = vehicle.hover_throttle() ** 2  # normalised collective thrust for hover
    world.set_setpoint(0, [0.0, 0.0, 1.0, hover])
    rates = []
    for _ in range(60):  # 2 s; average the second one
        world.step()
        rates.append(vehicle.state.ang_vel)
    mean = np.mean(rates[30:], axis=0)
    assert abs(mean[2] - 1.0) < 0.1
    assert abs(mean[0]) < 0.1 and abs(mean[1]) < 0.1
    # a roll-rate step from level hover: after a 0.1 s rise, p holds 1 rad/s
    world.reset()
    world.set_setpoint(0, [1.0, 0.0, 0.0, hover])
    roll_rates = []
    for _ in range(15):  # 0.5 s
        world.step()
        roll_rates.append(vehicle.state.ang_vel[0])
    assert np.mean(roll_rates[3:]) == pytest.approx(1.0, abs=0.1)
    world.close()


def test_motors_mode_drives_throttles_directly():
    world = World([VehicleConfig("quadx_cf2x", START, mode=-1)], seed=0)
    world.set_setpoint(0, [0.1, 0.2, 0.3, 0.4])
    for _ in range(10):
        world.step()
    np.testing.assert_allclose(world.vehicles[0].motor_throttle, [0.1, 0.2, 0.3, 0.4], rtol=0.1)
    world.close()


def test_pyflyt_integers_alias_named_modes():
    expected = {
        -1: "motors",
        0: "rates_thrust",
        1: "attitude_vz",
        2: "rates_z",
        3: "attitude_z",
        4: "heading_velocity_z",
        5: "heading_velocity_vz",
        6: "velocity_yawrate",
        7: "position_yaw",
    }
    for number, name in expected.items():
        assert resolve_mode(number).name == name
        assert resolve_mode(str(number)).name == name
    assert resolve_mode("position").name == "position_yaw"
    assert len(MULTIROTOR_MODES) == 11
    with pytest.raises(ConfigError, match="Did you mean 'position_yaw'"):
        resolve_mode("positon_yaw")
    with pytest.raises(ConfigError, match="-1 to 7"):
        resolve_mode(9)


def test_user_registered_controller_flies_on_a_base_mode():
    """A circle-following controller written by a user, run on top of position_yaw."""
    world = World([VehicleConfig("quadx_cf2x", (1.0, 0.0, 1.0), mode="position_yaw")], seed=0)
    vehicle = world.vehicles[0]

    class Circle:
        def __init__(self):
            self.t = 0.0
            self.resets = 0

        def reset(self):
            self.resets += 1
            self.t = 0.0

        def __call__(self, state, setpoint):
            radius, omega, z = setpoint
            self.t += vehicle.control_dt
            return [radius * math.cos(omega * self.t), radius * math.sin(omega * self.t), 0.0, z]

    circle = Circle()
    vehicle.register_controller("circle", circle, base_mode="position_yaw", setpoint=("radius", "omega", "z"))
    world.set_mode(0, "circle")
    assert circle.resets == 1
    world.set_setpoint(0, [1.0, 0.3, 1.0])
    radii = []
    for _ in range(300):
        world.step()
        x, y, _ = vehicle.state.lin_pos
        radii.append(math.hypot(x, y))
    assert np.abs(np.array(radii[60:]) - 1.0).max() < 0.1
    # it really went around: the heading of the position vector changed by > 90 degrees
    x, y, _ = vehicle.state.lin_pos
    assert abs(math.atan2(y, x)) > math.pi / 2
    world.close()

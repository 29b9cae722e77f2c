"""``pyflyt fly``'s default setpoint (``setpoint: null``): every mode of every shipped
multirotor takes off from the ground and hovers 1 m above the spawn point without touching
anything once airborne (conf/fly.yaml, docs/cli.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.control.modes import MULTIROTOR_MODES
from pyflyt_engine.flight import fly, hover_setpoint
from pyflyt_engine.spec import available_uavs, load_uav_spec
from pyflyt_engine.world import VehicleConfig, World

MULTIROTORS = [u for u in available_uavs() if load_uav_spec(u).control.type == "multirotor"]
DURATION = 6.0  # [s]
AIRBORNE = 1.0  # [s] after which no contact is allowed (it starts on the ground)
#: modes whose vehicle has no position feedback: it hovers, but may drift slowly
OPEN_HORIZONTAL = {"attitude_vz", "attitude_z"}


def test_every_airframe_is_covered():
    assert {"quadx_cf2x", "quadx_f450", "hexacopter", "tricopter", "quadplane"} <= set(MULTIROTORS)


@pytest.mark.parametrize("uav", MULTIROTORS)
def test_every_mode_takes_off_and_hovers_one_metre_above_the_spawn_point(uav):
    spec = load_uav_spec(uav)
    for mode in MULTIROTOR_MODES:
        traj = fly(spec, mode, None, DURATION, position=(0.5, -0.5, 0.0))
        where = f"{uav} in {mode}"
        airborne = traj.time > AIRBORNE
        assert not traj.collided[airborne].any(), f"{where}: contact after {AIRBORNE} s"
        x, y, z = traj.position[-1]
        assert abs(z - 1.0) < 0.05, f"{where}: ends at z = {z:.3f} m, not 1 m above the spawn point"
        speed = math.sqrt(sum(v * v for v in traj.velocity[-1]))
        assert speed < 0.15, f"{where}: still moving at {speed:.2f} m/s"
        drift = math.hypot(x - 0.5, y + 0.5)
        assert drift < (1.5 if mode in OPEN_HORIZONTAL else 0.05), f"{where}: {drift:.2f} m from the spawn point"


def test_tricopter_motors_default_puts_the_tail_servo_at_its_trim_not_the_hover_throttle():
    world = World([VehicleConfig("tricopter", mode="motors")], seed=0)
    vehicle = world.vehicles[0]
    layout = vehicle.setpoint_layout
    setpoint = hover_setpoint(vehicle, 1.0)
    assert layout[-1].startswith("tilt_") and len(setpoint) == len(layout)
    # the mixer's answer to [m g, 0, 0, 0]: the thrusts sum to the weight along body z, no torque
    mixer = vehicle.mixer
    expected = mixer.throttles(vehicle.parts.mass * GRAVITY, 0.0, 0.0, 0.0)
    np.testing.assert_allclose(setpoint, expected, rtol=0, atol=0)
    assert abs(setpoint[-1]) < 0.2 and abs(setpoint[-1] - vehicle.hover_throttle()) > 0.3
    world.close()


def test_attitude_default_is_the_trim_attitude():
    world = World([VehicleConfig("tricopter", mode="attitude_z")], seed=0)
    vehicle = world.vehicles[0]
    roll, pitch, yaw, z = hover_setpoint(vehicle, 1.0)
    fx, fy = vehicle.mixer.side_force
    # the attitude whose thrust tilt cancels the tail's side force: roll = atan(fy), pitch = -atan(fx)
    assert (roll, pitch, yaw, z) == (math.atan(fy), -math.atan(fx), 0.0, 1.0)
    assert math.degrees(roll) == pytest.approx(-1.3, abs=0.05)  # the figure of the issue
    world.close()


def test_the_command_line_default_climbs_in_a_climb_rate_mode():
    result = CliRunner().invoke(app, ["fly", "uav=tricopter", "mode=velocity_yawrate", "duration=6", "rows=2"])
    assert result.exit_code == 0, result.output
    final = result.output.split("final position (")[1].split(")")[0]
    assert float(final.split(",")[2]) == pytest.approx(1.0, abs=0.05)

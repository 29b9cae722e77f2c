"""`pyflyt fly` and `pyflyt modes` from the command line; errors exit 2 without tracebacks."""

from __future__ import annotations

import re

import pytest
from typer.testing import CliRunner

from pyflyt_cli.main import app

runner = CliRunner()


def test_fly_defaults_hover_one_metre_and_prints_summary():
    result = runner.invoke(app, ["fly", "duration=4", "rows=3"])
    assert result.exit_code == 0, result.output
    assert "quadx_cf2x in mode position_yaw" in result.output
    final = re.search(r"final position \(([-\d.]+), ([-\d.]+), ([-\d.]+)\)", result.output)
    x, y, z = map(float, final.groups())
    assert abs(z - 1.0) < 0.05 and abs(x) < 0.05 and abs(y) < 0.05


@pytest.mark.parametrize("mode", ["velocity", "attitude_thrust"])
def test_fly_a_rocket_mode_holds_the_spawn_height_and_flies_a_setpoint(mode):
    """The shipped rocket spawns with a full tank: it can hover on thrust."""
    result = runner.invoke(app, ["fly", "uav=rocket", f"mode={mode}", "position=[0,0,100]", "duration=3", "rows=2"])
    assert result.exit_code == 0, result.output
    assert f"rocket in mode {mode}" in result.output
    final = re.search(r"final position \(([-\d.]+), ([-\d.]+), ([-\d.]+)\)", result.output)
    assert abs(float(final.group(3)) - 100.0) < 0.5
    if mode == "velocity":
        result = runner.invoke(
            app,
            ["fly", "uav=rocket", "mode=velocity", "setpoint={vz:2,ignition:1}", "position=[0,0,100]", "duration=3"],
        )
        final = re.search(r"final position \(([-\d.]+), ([-\d.]+), ([-\d.]+)\)", result.output)
        assert 104.0 < float(final.group(3)) < 106.0  # 2 m/s up, reached within a fraction of a second


def test_fly_with_named_setpoint_and_other_airframe():
    result = runner.invoke(app, ["fly", "uav=quadx_f450", "mode=7", "setpoint={x:1,z:2}", "duration=5", "rows=2"])
    assert result.exit_code == 0, result.output
    final = re.search(r"final position \(([-\d.]+), ([-\d.]+), ([-\d.]+)\)", result.output)
    x, y, z = map(float, final.groups())
    assert abs(x - 1.0) < 0.05 and abs(z - 2.0) < 0.05


@pytest.mark.parametrize(
    "args, message",
    [
        (["uav=quadx_f45"], "Did you mean 'quadx_f450'"),
        (["durration=3"], "unknown key 'durration'"),
        (["mode=bogus"], "unknown flight mode 'bogus'"),
        (["setpoint=[1,2]"], "needs 4 values"),
        (["physics_hz=250"], "must divide evenly"),
        (["uav.body.mass=-1"], "body.mass"),
        (["seed"], "not an override"),
        (["duration=0"], "duration: Input should be greater than 0"),
        (["setpoint=[1,2"], "malformed override"),
        (["duration=abc"], "duration: Input should be a valid number, unable to parse string as a number (got 'abc')"),
        (["duration=inf"], "duration: Input should be a finite number (got inf)"),
        (["seed=-1"], "seed: Input should be greater than or equal to 0 (got -1)"),
        (["seed=1.5"], "seed: Input should be a valid integer"),
        (["position=[nan,0,0]"], "position.0: Input should be a finite number (got nan)"),
        (["orientation=[0,0]"], "orientation.2: Field required"),
        (["physics_hz=-240"], "physics_hz: Input should be greater than 0"),
        (["rows=many"], "rows: Input should be a valid integer"),
        (["setpoint={x:inf}"], "setpoint: every value must be a finite number, got {'x': inf}"),
        (["setpoint=[0,0,nan,1]"], "setpoint: every value must be a finite number"),
        (["setpoint=[1,abc]"], "setpoint: give a list of numbers in the mode's layout"),
        (["mode=[1]"], "mode: give a flight mode name or PyFlyt integer -1 ... 7"),
    ],
)
def test_fly_bad_input_exits_2_with_message(args, message):
    result = runner.invoke(app, ["fly", *args])
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert "Traceback" not in result.output


def test_modes_lists_names_and_pyflyt_numbers():
    result = runner.invoke(app, ["modes"])
    assert result.exit_code == 0
    assert re.search(r"position_yaw\s+7\s+\[x, y, yaw, z\]", result.output)
    assert re.search(r"motors\s+-1", result.output)
    assert re.search(r"velocity\s+\[vx, vy, vz, ignition\]", result.output)
    assert re.search(r"attitude_thrust\s+\[tilt_x, tilt_y, roll_rate, throttle, ignition\]", result.output)
    assert re.search(r"attitude_airspeed\s+\[roll, pitch, yaw_rate, airspeed\]", result.output)

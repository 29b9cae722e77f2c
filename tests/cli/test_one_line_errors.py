"""Inputs that ended in a Python traceback now end in one line naming the value and the fix, exit code 2.

Each case is a reproduction from the attack on shared artefacts and command lines (issue 52, "~40
inputs end in tracebacks instead of one line"), run as the command line runs it.
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from pyflyt_cli.main import app

runner = CliRunner()


def one_line(args: list[str], *fragments: str) -> str:
    """``pyflyt <args>`` exits 2 with exactly one ``error:`` line holding every fragment, and no traceback."""
    result = runner.invoke(app, args)
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, result.output
    rest = result.output.split(errors[0], 1)[1].strip()
    assert not rest, f"more after the error line: {rest!r}"
    for fragment in fragments:
        assert fragment in errors[0], errors[0]
    return errors[0]


@pytest.mark.parametrize("args", [
    ["fly", "duration=${eval:1+1}"],  # UnsupportedInterpolationType: a traceback (eval), three lines (fly)
    ["fly", "duration=${now:%H}"],  # resolved: the flight lasted the hour of the day
    ["eval", "oracle:rocket_lander", "episodes=1", "env.max_duration_seconds=${eval:1}"],
    ["train", "env=quadx_hover", "env.id=${oc.env:HOME}", "train.total_timesteps=1"],  # the environment, saved
    ["train", "env=quadx_hover", "seed=${now:%S}", "train.total_timesteps=1"],
])  # fmt: skip
def test_an_interpolation_in_a_command_line_value_is_refused(args):
    item = next(a for a in args if "${" in a)
    one_line(args, f"'{item}'", "holds no ${...} interpolation", f"give {item.partition('=')[0]} its value itself")


@pytest.mark.parametrize("urdf", [
    "<foo/>",  # PyBullet: expected a robot element
    '<robot name="r"></robot>',  # no links
    '<robot name="r"><link name="a"/><joint name="j" type="fixed"><parent link="a"/><child link="zz"/></joint></robot>',
])  # fmt: skip
@pytest.mark.parametrize("command", ["fly", "validate"])
def test_a_urdf_pybullet_cannot_load_is_one_line_naming_it(tmp_path, urdf, command):
    """``pybullet.error: Cannot load URDF file.`` was a traceback from ``pyflyt fly``."""
    from pyflyt_engine.paths import uav_dir

    text = (uav_dir() / "quadx_cf2x.yaml").read_text().replace("\nbody:\n", "\nbody:\n  urdf: body.urdf\n", 1)
    assert "urdf: body.urdf" in text
    (tmp_path / "airframe.yaml").write_text(text)
    (tmp_path / "body.urdf").write_text(urdf)
    args = ["fly", f"uav={tmp_path / 'airframe.yaml'}", "duration=0.1"] if command == "fly" else [
        "uav", "validate", str(tmp_path / "airframe.yaml")]  # fmt: skip
    one_line(args, f"{tmp_path / 'airframe.yaml'}: PyBullet cannot load its URDF {tmp_path / 'body.urdf'}")


def refused(args: list[str], *fragments: str) -> str:
    """``pyflyt <args>`` exits 2 with an ``error:`` message (a validation list may follow it), no traceback."""
    result = runner.invoke(app, args)
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    assert result.output.startswith("error:"), result.output
    for fragment in fragments:
        assert fragment in result.output, result.output
    return result.output


@pytest.mark.parametrize("override, fragment", [
    ("wind.gust.length=1e-320", "gust.length 9.99989e-321 is positive but below 1e-06"),  # math domain error
    ("wind.gust.speed=1e-320", "gust.speed 9.99989e-321 is positive but below 1e-06"),
])  # fmt: skip
def test_a_subnormal_gust_is_refused(override, fragment):
    refused(["fly", "wind=gust", override, "duration=2"], fragment)


@pytest.mark.parametrize("override, fragment", [
    ("wind.turbulence.wind_speed_20ft=1e-320", "turbulence.wind_speed_20ft 9.99989e-321 is positive but below"),
    ("wind.turbulence.airspeed=1e-320", "turbulence.airspeed 9.99989e-321 is positive but below"),  # ZeroDivisionError
    ("wind.turbulence.height=1e-320", "turbulence.height 9.99989e-321 is positive but below"),
])  # fmt: skip
def test_a_subnormal_turbulence_speed_is_refused(override, fragment):
    refused(["fly", "wind=dryden_severe", override, "duration=1"], fragment)


def test_calm_turbulence_and_the_smallest_gust_still_fly():
    for args in (["fly", "wind=dryden_severe", "wind.turbulence.wind_speed_20ft=0", "duration=0.5"],
                 ["fly", "wind=gust", "wind.gust.length=1e-6", "duration=0.5"]):  # fmt: skip
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output


@pytest.mark.parametrize("args, fragments", [
    # trained NaN weights, then torch's "invalid values" traceback
    (["train", "algo.learning_rate=inf"], ["algo.learning_rate", "a finite number"]),
    (["train", "algo=sac", "algo.tau=nan"], ["algo.tau", "a finite number"]),
    (["train", "algo.policy_kwargs.log_std_init=1e308"], ["algo.policy_kwargs.log_std_init", "less than or equal to 10"]),
    # an episode shorter than one agent step trained episodes of one step each
    (["train", "env.max_duration_seconds=1e-9"], ["max_duration_seconds 1e-09 s is shorter than one agent step"]),
    # a body of 1e-320 kg flew through the ground
    (["fly", "uav.body.mass=1e-320"], ["body.mass", "below 1e-06 kg"]),
    (["fly", "uav.body.mass=null", "uav.body.shapes=[{type: box, size: [0.1, 0.1, 0.1], mass: 1e30}]"],
     ["the shapes' masses (their sum) 1e+30 is above the limit of 100000 kg"]),
    # NumPy's "Seed must be between 0 and 2**32 - 1" traceback
    (["plot", ".", "--seed", "-5"], ["--seed must be 0 to 2147483647, got -5"]),
    (["plot", ".", "--seed", "99999999999999999999"], ["--seed must be 0 to 2147483647"]),
])  # fmt: skip
def test_values_that_trained_nan_or_flew_through_the_ground_are_refused(args, fragments):
    refused(args, *fragments)


def test_pybullets_reason_is_inside_the_one_line_not_glued_in_front_of_it(tmp_path):
    """PyBullet writes its reason (``b3Error[...]: expected a robot element``, no line break) through
    C's stdout, which the CLI runner above cannot see: in a terminal it was glued to the front of the
    error line.  Run as a real process, the output is the one error line, holding the reason."""
    import subprocess
    import sys

    from pyflyt_engine.paths import uav_dir

    text = (uav_dir() / "quadx_cf2x.yaml").read_text().replace("\nbody:\n", "\nbody:\n  urdf: body.urdf\n", 1)
    (tmp_path / "airframe.yaml").write_text(text)
    (tmp_path / "body.urdf").write_text("<foo/>")
    done = subprocess.run(
        [sys.executable, "-m", "pyflyt_cli.main", "fly", f"uav={tmp_path / 'airframe.yaml'}", "duration=0.1"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stdout == "", done.stdout
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), done.stderr
    assert "PyBullet cannot load its URDF" in lines[0] and "(PyBullet: expected a robot element)" in lines[0]

"""Your own airframe file, relative or absolute, in every command that takes an airframe.

``uav=<path>.yaml`` and ``env.uav=<path>.yaml``: fly it, train on it, evaluate and record
it, benchmark it, show and validate it; a missing or invalid file is one message and exit 2.
"""

from __future__ import annotations

import re
import shutil

import pytest
import yaml
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_engine.paths import conf_dir
from tests.train.conftest import TINY_PPO

runner = CliRunner()


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """A working directory holding ``airframes/y6.yaml`` (the shipped hexacopter, renamed)."""
    data = yaml.safe_load((conf_dir() / "uav" / "hexacopter.yaml").read_text())
    data["name"] = "my_hexa"
    (tmp_path / "airframes").mkdir()
    (tmp_path / "airframes" / "y6.yaml").write_text(yaml.safe_dump(data))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _final_position(output: str) -> tuple[float, float, float]:
    found = re.search(r"final position \(([-\d.]+), ([-\d.]+), ([-\d.]+)\)", output)
    assert found, output
    return tuple(map(float, found.groups()))  # type: ignore[return-value]


@pytest.mark.parametrize("relative", [True, False])
def test_fly_an_airframe_file(workdir, relative):
    path = "airframes/y6.yaml" if relative else str(workdir / "airframes" / "y6.yaml")
    result = runner.invoke(app, ["fly", f"uav={path}", "duration=3", "rows=2"])
    assert result.exit_code == 0, result.output
    assert result.output.startswith("my_hexa in mode position_yaw")
    x, y, z = _final_position(result.output)
    assert abs(z - 1.0) < 0.1 and abs(x) < 0.1 and abs(y) < 0.1


def test_fly_overrides_apply_to_the_file(workdir):
    result = runner.invoke(app, ["fly", "uav=airframes/y6.yaml", "uav.name=renamed", "duration=0.2", "rows=2"])
    assert result.exit_code == 0, result.output
    assert result.output.startswith("renamed in mode")


def test_a_file_named_like_a_shipped_airframe_is_the_file(workdir):
    """``./quadx_cf2x.yaml`` is the user's file, not the shipped airframe of that name."""
    shutil.copy(workdir / "airframes" / "y6.yaml", workdir / "quadx_cf2x.yaml")
    result = runner.invoke(app, ["fly", "uav=quadx_cf2x.yaml", "duration=0.2", "rows=2"])
    assert result.exit_code == 0, result.output
    assert result.output.startswith("my_hexa in mode")


@pytest.mark.parametrize(
    "command",
    [
        ["fly", "uav={}"],
        ["train", "uav={}", "--cfg"],
        ["train", "env.uav={}", "--cfg"],
        ["benchmark", "experiment=smoke_benchmark", "uav={}", "--dry-run"],
    ],
    ids=["fly", "train", "train-env.uav", "benchmark"],
)
def test_missing_and_invalid_files_are_one_message(workdir, command):
    missing = runner.invoke(app, [arg.format("airframes/y7.yaml") for arg in command])
    assert missing.exit_code == 2, missing.output
    key = next(arg for arg in command if "{}" in arg).partition("=")[0]
    assert (
        f"error: {key}=airframes/y7.yaml: no such airframe file ({workdir / 'airframes' / 'y7.yaml'})" in missing.output
    )
    assert "Traceback" not in missing.output
    bad = workdir / "airframes" / "bad.yaml"
    bad.write_text("name: bad\nbody: {mass: -1, inertia: [1, 1, 1]}\n")
    invalid = runner.invoke(app, [arg.format("airframes/bad.yaml") for arg in command])
    assert invalid.exit_code == 2, invalid.output
    assert "bad.yaml: invalid UAV spec" in invalid.output and "body.mass" in invalid.output
    unknown = runner.invoke(app, [arg.format("hexacoptr") for arg in command])
    assert unknown.exit_code == 2, unknown.output
    assert "hexacopter" in unknown.output


def test_train_composes_an_absolute_path_from_either_key(workdir):
    for key in ("uav", "env.uav"):
        result = runner.invoke(app, ["train", f"{key}=airframes/y6.yaml", "--cfg"])
        assert result.exit_code == 0, result.output
        assert f"uav: {workdir / 'airframes' / 'y6.yaml'}" in result.output


def test_benchmark_runs_name_the_file_by_its_absolute_path(workdir):
    result = runner.invoke(
        app,
        [
            "benchmark",
            "experiment=smoke_benchmark",
            "uav=airframes/y6.yaml",
            f"benchmark.output_dir={workdir}",
            "--dry-run",
        ],
    )
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("pyflyt train")]
    assert len(lines) == 6 and all(f"uav={workdir / 'airframes' / 'y6.yaml'}" in line for line in lines)


def test_uav_show_and_validate_take_relative_paths(workdir):
    shown = runner.invoke(app, ["uav", "show", "airframes/y6.yaml"])
    assert shown.exit_code == 0 and shown.output.startswith("my_hexa:"), shown.output
    checked = runner.invoke(app, ["uav", "validate", "airframes/y6.yaml", "airframes/y7.yaml"])
    assert checked.exit_code == 2
    assert "ok: airframes/y6.yaml: my_hexa" in checked.output and "airframes/y7.yaml" in checked.output


@pytest.mark.long
def test_train_eval_and_replay_an_airframe_file(workdir, tmp_path_factory):
    """Train on a relative file; the run keeps a copy, so it evaluates, records and replays after
    the file and the run have moved, from another working directory."""
    overrides = [*TINY_PPO, "train.total_timesteps=256", "train.eval_freq=0", "run_dir=run"]
    trained = runner.invoke(app, ["train", "uav=airframes/y6.yaml", *overrides])
    assert trained.exit_code == 0, trained.output
    assert (workdir / "run" / "airframe.yaml").read_text() == (workdir / "airframes" / "y6.yaml").read_text()
    (workdir / "airframes" / "y6.yaml").unlink()
    moved = tmp_path_factory.mktemp("elsewhere") / "run"
    shutil.move(workdir / "run", moved)
    evaluated = runner.invoke(app, ["eval", str(moved), "episodes=1"])
    assert evaluated.exit_code == 0, evaluated.output
    episode = moved / "episodes" / "ep_0000.mcap"
    replayed = runner.invoke(app, ["replay", str(episode), "--verify"])
    assert replayed.exit_code == 0, replayed.output
    assert "my_hexa" in replayed.output and "verify    OK" in replayed.output

"""``pyflyt speed`` runs end to end and prints its tables (smoke tests, not timings)."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from pyflyt_cli.commands import speed_probe
from pyflyt_cli.commands.speed import SpeedSettings, format_report, run_speed
from pyflyt_cli.main import app

runner = CliRunner()


def test_quick_speed_for_one_env_prints_every_section(tmp_path):
    out = tmp_path / "speed.json"
    result = runner.invoke(
        app, ["speed", "--quick", "--env", "PyFlyt/QuadX-Hover-v0", "--vehicles", "1,2", "--json", str(out)]
    )
    assert result.exit_code == 0, result.output
    text = result.stdout
    for expected in ("machine:", "PyFlyt/QuadX-Hover-v0", "bare PyBullet floor", "vehicles", "rgba + depth + segmentation"):
        assert expected in text
    report = json.loads(out.read_text())
    assert [row["n"] for row in report["worlds"]] == [1, 2]
    env = report["envs"][0]["ours"]
    assert env["steps_per_s"] > 0 and env["reset_s"] > 0 and env["peak_rss_mb"] > 0 and env["rtf"] > 0
    assert not report["worlds"][1]["ours"]["contacts"]  # the grid keeps vehicles apart


def test_markdown_tables_from_a_report():
    report = run_speed(SpeedSettings.quick(envs=("PyFlyt/QuadX-Hover-v0",), vehicles=(1,)))
    text = format_report(report, markdown=True)
    assert "| env | steps/s |" in text and "|---|---:" in text
    assert "| PyFlyt/QuadX-Hover-v0 |" in text


def test_unknown_env_and_missing_reference_are_user_errors():
    result = runner.invoke(app, ["speed", "--quick", "--env", "PyFlyt/Nope-v0"])
    assert result.exit_code == 2 and "unknown env id" in result.output
    result = runner.invoke(app, ["speed", "--quick", "--reference-python", "/no/such/python"])
    assert result.exit_code == 2 and "--reference-python" in result.output


def test_probe_prints_one_marked_json_line(capsys):
    assert speed_probe.main(['{"probe": "floor", "n": 2, "seconds": 0.05}']) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith(speed_probe.RESULT_MARKER)
    result = json.loads(line[len(speed_probe.RESULT_MARKER):])
    assert result["n"] == 2 and result["rtf"] > 0


@pytest.mark.slow
def test_full_quick_speed_run_prints_the_table():
    result = runner.invoke(app, ["speed", "--quick", "--vector"])
    assert result.exit_code == 0, result.output
    assert "64" in result.stdout and "2 workers" in result.stdout


def test_vector_section_pairs_runs_by_repeat_and_measures_stand_in_and_machine():
    report = run_speed(SpeedSettings.quick(envs=("PyFlyt/QuadX-Hover-v0",), vehicles=(1,), vector=True))
    assert [(row["id"], row["backend"]) for row in report["vector"]] == [
        ("PyFlyt/QuadX-Hover-v0", "gymnasium"), ("PyFlyt/QuadX-Hover-v0", "sb3")
    ]
    for row in report["vector"]:
        assert row["steps_per_s"]["1"] > 0 and row["steps_per_s"]["2"] > 0
        assert row["scaling"]["ratios"] == [row["steps_per_s"]["2"] / row["steps_per_s"]["1"]]  # one repeat: one pair
        assert row["stand_in"]["env_step_cpu_s"] > 0 and row["stand_in"]["scaling"]["median"] > 0
    assert report["parallel"]["median"] > 0
    text = format_report(report)
    assert "stand-in scaling" in text and "machine: 2 processes of pure CPU work" in text


def test_scaling_is_taken_pair_by_pair():
    from pyflyt_cli.commands.speed import _scaling

    # pairs (1 worker, 2 workers) from three repeats: ratios 2.0, 1.5, 1.6
    scaling = _scaling([100.0, 200.0, 50.0], [200.0, 300.0, 80.0])
    assert scaling["ratios"] == [2.0, 1.5, 1.6]
    assert scaling["median"] == 1.6 and scaling["min"] == 1.5 and scaling["max"] == 2.0


def test_stand_in_env_has_the_env_spaces_and_passes_the_checker():
    import gymnasium
    from gymnasium.utils.env_checker import check_env

    env = speed_probe._make_flat_env("PyFlyt/QuadX-Waypoints-v0")  # variable-size observation, flattened
    stand_in = speed_probe._make_stand_in(env.observation_space, env.action_space, iterations=100)
    assert stand_in.observation_space == env.observation_space and stand_in.action_space == env.action_space
    check_env(stand_in, skip_render_check=True)
    observation, reward, terminated, truncated, info = stand_in.step(stand_in.action_space.sample())
    assert observation in stand_in.observation_space and info == {} and not (terminated or truncated)
    assert isinstance(stand_in, gymnasium.Env)
    env.close()


def test_machine_scaling_probe_runs_its_processes():
    one = speed_probe.measure_parallel(processes=1, seconds=0.02)
    two = speed_probe.measure_parallel(processes=2, seconds=0.02)
    assert one["processes"] == 1 and two["processes"] == 2
    assert one["work_per_s"] > 0 and two["work_per_s"] > 0

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

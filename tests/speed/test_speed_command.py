"""``pyflyt speed`` runs end to end and prints its tables (smoke tests, not timings).

Report building and printing are checked with a stand-in ``measure`` (canned results,
no processes); one command run and the vector probes measure for real.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter
from pathlib import Path
from typing import ClassVar

import pytest
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_cli.speed import Case, SpeedSettings, format_report, probes, protocols, run_speed
from pyflyt_cli.speed.measure import scaling
from tests.train.conftest import cli_env

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[2]
HOVER = "PyFlyt/QuadX-Hover-v0"


class Canned:
    """A ``measure`` of made-up figures; vector throughput changes from repeat to repeat."""

    #: per repeat: env steps/s with 1 and 2 workers (ratios 1.8, 2.0, 1.5; medians apart: 1.5)
    VECTOR: ClassVar = {1: (1000.0, 500.0, 800.0), 2: (1800.0, 1000.0, 1200.0)}

    def __init__(self) -> None:
        self.calls: Counter = Counter()

    def __call__(self, case: Case) -> dict:
        repeat = self.calls[(case.section, case.key)]
        self.calls[(case.section, case.key)] += 1
        probe = case.probe
        kind = probe["probe"]
        if kind == "machine":
            return {"python": "3.11", "cores": 2, "pybullet": "3.2.7", "numpy": "2", "gymnasium": "1"}
        if kind == "env":
            return {"id": probe["env_id"], "steps_per_s": 3000.0, "rtf": 100.0, "reset_s": 2e-4, "peak_rss_mb": 97.0}
        if kind == "floor":
            return {"n": probe["n"], "physics_step_s": 5e-6, "rtf": 800.0 / probe["n"], "peak_rss_mb": 94.0}
        if kind == "world":
            return {"n": probe["n"], "rtf": 400.0 / probe["n"], "contacts": False, "peak_rss_mb": 96.0}
        if kind == "swarm":  # 400 agent-steps/s at any size: a linear cost
            n = probe["agents"]
            return {"env": probe["env"], "agents": n, "agent_steps_per_s": 400.0, "env_steps_per_s": 400.0 / n,
                    "rtf": 400.0 / n / 30, "live_fraction": 1.0, "agent_steps_per_cpu_s": 500.0}  # fmt: skip
        if kind == "camera":
            return {"capture_s": 3e-3, "capture_cpu_s": 2e-3, "channels": probe["channels"]}
        if kind == "parallel":
            return {"processes": probe["processes"], "work_per_s": 1.0 * probe["processes"]}
        if kind == "vector":
            rate = self.VECTOR[probe["workers"]][repeat]
            return {"steps_per_s": rate / (2 if probe["stand_in"] else 1), "cpu_per_step_s": 3e-4,
                    "env_step_cpu_s": 7e-5 if probe["stand_in"] else None}  # fmt: skip
        raise AssertionError(kind)


@pytest.mark.slow  # a whole sweep / install: run with -m slow
def test_quick_speed_for_one_env_prints_every_section(tmp_path):
    out = tmp_path / "speed.json"
    result = runner.invoke(app, ["speed", "--quick", "--env", HOVER, "--vehicles", "1,2", "--json", str(out)])
    assert result.exit_code == 0, result.output
    text = result.stdout
    for expected in ("machine:", HOVER, "bare PyBullet floor", "vehicles", "rgba + depth + segmentation"):
        assert expected in text
    report = json.loads(out.read_text())
    assert [row["n"] for row in report["worlds"]] == [1, 2]
    env = report["envs"][0]
    assert env["id"] == HOVER
    assert env["steps_per_s"] > 0 and env["reset_s"] > 0 and env["peak_rss_mb"] > 0 and env["rtf"] > 0
    assert not report["worlds"][1]["contacts"]  # the grid keeps vehicles apart
    assert report["worlds"][1]["floor"]["rtf"] > 0


def test_markdown_tables_from_a_report():
    report = run_speed(SpeedSettings.quick(envs=(HOVER,), vehicles=(1, 8)), measure=Canned())
    text = format_report(report, markdown=True)
    assert "| env | steps/s | RTF | reset ms | peak MB |" in text and "|---|---:|---:|---:|---:|" in text
    assert f"| {HOVER} | 3,000 | 100.0 | 0.20 | 97 |" in text
    assert "| 8 | 50.00 | 100.00 | 2.00x |" in text  # floor / ours for 8 vehicles
    assert "| rgba only | 3.00 (2.00) |" in text
    assert "Vector envs" not in text  # measured only with vector=True


def test_every_case_runs_every_repeat_in_order():
    canned = Canned()
    settings = SpeedSettings.quick(envs=(HOVER,), vehicles=(1,), repeats=3)
    seen: list[str] = []
    run_speed(settings, progress=seen.append, measure=canned)
    assert canned.calls[("machine", None)] == 1
    assert set(canned.calls.values()) == {1, 3}
    assert seen[0] == f"[1/3] envs {HOVER}" and seen[-1] == "[3/3] camera depth"


def test_unknown_env_bad_vehicles_and_the_removed_reference_option_are_user_errors():
    result = runner.invoke(app, ["speed", "--quick", "--env", "PyFlyt/Nope-v0"])
    assert result.exit_code == 2 and "unknown env id" in result.output
    result = runner.invoke(app, ["speed", "--quick", "--vehicles", "1,x"])
    assert result.exit_code == 2 and "--vehicles takes world sizes" in result.output
    result = runner.invoke(app, ["speed", "--quick", "--reference-python", "/usr/bin/python3"])
    assert result.exit_code == 2 and "No such option" in result.output


def test_probe_prints_one_marked_json_line(capsys):
    assert protocols.main(['{"probe": "floor", "n": 2, "seconds": 0.05}'], probes.PROBES) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith(protocols.RESULT_MARKER)
    result = json.loads(line[len(protocols.RESULT_MARKER) :])
    assert result["n"] == 2 and result["rtf"] > 0


@pytest.mark.slow
def test_full_quick_speed_run_prints_the_table():
    result = runner.invoke(app, ["speed", "--quick", "--vector"])
    assert result.exit_code == 0, result.output
    assert "64" in result.stdout and "2 workers" in result.stdout


def test_vector_section_pairs_runs_by_repeat_beside_stand_in_and_machine():
    settings = SpeedSettings.quick(envs=(HOVER,), vehicles=(1,), vector=True, repeats=3)
    report = run_speed(settings, measure=Canned())
    assert [(row["id"], row["backend"]) for row in report["vector"]] == [(HOVER, "gymnasium"), (HOVER, "sb3")]
    for row in report["vector"]:
        assert row["scaling"]["ratios"] == [1.8, 2.0, 1.5]  # 2 workers over 1 worker, repeat by repeat
        assert row["scaling"]["median"] == 1.8  # not 1200 / 800: medians taken apart mix moments
        assert row["steps_per_s"] == {"1": 800.0, "2": 1200.0}
        assert row["stand_in"]["steps_per_s"] == {"1": 400.0, "2": 600.0}
        assert row["stand_in"]["env_step_cpu_s"] == 7e-5 and row["cpu_per_step_s"] == {"1": 3e-4, "2": 3e-4}
    assert report["parallel"]["ratios"] == [2.0, 2.0, 2.0]
    text = format_report(report)
    assert "stand-in scaling" in text and "1.80x (1.50-2.00)" in text
    assert "machine: 2 processes of pure CPU work" in text


def test_stand_in_vector_probe_measures_two_workers():
    result = probes.measure_vector(HOVER, workers=2, steps=10, warmup=2, stand_in=True)
    assert result["workers"] == 2 and result["stand_in"]
    assert result["steps_per_s"] > 0 and result["env_step_cpu_s"] > 0


def test_scaling_is_taken_pair_by_pair():
    # pairs (1 worker, 2 workers) from three repeats: ratios 2.0, 1.5, 1.6
    result = scaling([100.0, 200.0, 50.0], [200.0, 300.0, 80.0])
    assert result["ratios"] == [2.0, 1.5, 1.6]
    assert result["median"] == 1.6 and result["min"] == 1.5 and result["max"] == 2.0


def test_stand_in_env_has_the_env_spaces_and_passes_the_checker():
    import gymnasium
    from gymnasium.utils.env_checker import check_env

    env = probes._make_flat_env("PyFlyt/QuadX-Waypoints-v0")  # variable-size observation, flattened
    stand_in = probes._make_stand_in(env.observation_space, env.action_space, iterations=100)
    assert stand_in.observation_space == env.observation_space and stand_in.action_space == env.action_space
    check_env(stand_in, skip_render_check=True)
    observation, _, terminated, truncated, info = stand_in.step(stand_in.action_space.sample())
    assert observation in stand_in.observation_space and info == {} and not (terminated or truncated)
    assert isinstance(stand_in, gymnasium.Env)
    env.close()


def test_machine_scaling_probe_runs_its_processes():
    one = probes.measure_parallel(processes=1, seconds=0.02)
    two = probes.measure_parallel(processes=2, seconds=0.02)
    assert one["processes"] == 1 and two["processes"] == 2
    assert one["work_per_s"] > 0 and two["work_per_s"] > 0


@pytest.mark.slow  # a whole sweep / install: run with -m slow
def test_reference_comparison_script_runs_without_the_reference(tmp_path):
    """experiments/compare_reference.py: our side of every table, '-' where the reference's figures go."""
    out = tmp_path / "comparison.json"
    args = ["--quick", "--env", HOVER, "--vehicles", "1", "--json", str(out)]
    env = {k: v for k, v in cli_env().items() if k != "PYFLYT_REFERENCE_PYTHON"}
    script = ROOT / "experiments" / "compare_reference.py"
    done = subprocess.run(
        [sys.executable, str(script), *args], check=False, capture_output=True, text=True, cwd=tmp_path, env=env
    )
    assert done.returncode == 0, done.stderr
    assert "reference: not measured" in done.stdout
    row = next(line for line in done.stdout.splitlines() if line.startswith(HOVER))
    assert row.split()[1:3] != ["-", "-"] and row.split()[2] == "-"  # ours measured, the reference's blank
    data = json.loads(out.read_text())
    assert data["ours"]["envs"][0]["id"] == HOVER and data["reference"]["envs"] == {HOVER: None}


def test_swarm_section_has_a_row_per_env_and_size_and_refuses_bad_sizes():
    report = run_speed(SpeedSettings.quick(envs=(HOVER,), vehicles=(1,), swarm=(1, 8)), measure=Canned())
    assert [(row["env"], row["agents"]) for row in report["swarm"]] == [
        ("hover", 1),
        ("hover", 8),
        ("formation", 1),
        ("formation", 8),
        ("dogfight", 4),
    ]
    text = format_report(report, markdown=True)
    assert "| MAQuadX-Hover | 8 | 400 | 2,500 | 50.0 | 1.67 | 100% |" in text
    assert "Multi-agent envs against the number of agents" in text
    assert run_speed(SpeedSettings.quick(envs=(HOVER,), vehicles=(1,), swarm=()), measure=Canned())["swarm"] == []
    result = runner.invoke(app, ["speed", "--quick", "--agents", "1,129"])
    assert result.exit_code == 2 and "--agents takes swarm sizes" in result.output


def test_the_swarm_probe_times_live_agent_steps():
    result = probes.measure_swarm("formation", agents=3, steps=4, warmup=1)
    assert result["agents"] == 3 and result["agent_steps_per_s"] > 0 and result["rtf"] > 0
    assert 0 < result["live_fraction"] <= 1
    assert result["agent_steps_per_s"] == pytest.approx(result["env_steps_per_s"] * 3 * result["live_fraction"])


def test_the_protocols_grid_is_the_envs_grid_layout():
    from pyflyt_engine.envs.config import grid_layout

    for n in (1, 2, 5, 64, 128):
        assert protocols.centred_grid(n, 0.7, 1.2) == [grid_layout(i, n, 0.7, 1.2) for i in range(n)]

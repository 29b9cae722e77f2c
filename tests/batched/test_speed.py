"""``pyflyt speed --backend batched``: the cases it plans, its table, its user errors, and the probe
measuring for real (smoke tests, not timings)."""

from __future__ import annotations

from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_cli.speed import Case, SpeedSettings, format_report, plan_cases, probes, run_speed

runner = CliRunner()
HOVER = "PyFlyt/QuadX-Hover-v0"


def _canned(case: Case) -> dict:
    probe = case.probe
    if probe["probe"] == "machine":
        return {"python": "3.11", "cores": 2, "pybullet": "3.2.7", "numpy": "2", "gymnasium": "1"}
    if probe["probe"] == "env":
        return {"id": probe["env_id"], "steps_per_s": 4000.0, "rtf": 130.0, "reset_s": 2e-4, "peak_rss_mb": 97.0}
    assert probe["probe"] == "batched"
    n = probe["n"]
    rate = 5000.0 * n / (1 + n / 100)  # a cost per agent-step that falls with N
    return {"id": probe["env_id"], "n": n, "agent_steps": 1000, "steps_per_s": rate,
            "cpu_per_agent_step_s": 1 / rate, "first_step_s": 1.0, "memory_per_env_kb": 3.0}  # fmt: skip


def test_it_plans_the_pybullet_env_then_every_size_of_the_batched_backend():
    settings = SpeedSettings.quick(backend="batched", batch_sizes=(1, 256), envs=(HOVER,))
    cases = plan_cases(settings)
    assert [(c.section, c.key) for c in cases] == [("envs", HOVER), ("batched", (HOVER, 1)), ("batched", (HOVER, 256))]


def test_an_env_config_sharing_an_id_is_measured_by_its_name():
    """The velocity variant shares QuadX-Waypoints' id: ``--env`` takes its config name."""
    settings = SpeedSettings.quick(backend="batched", batch_sizes=(4,), envs=("quadx_waypoints_velocity",))
    assert [(c.section, c.key) for c in plan_cases(settings)] == [
        ("envs", "quadx_waypoints_velocity"),
        ("batched", ("quadx_waypoints_velocity", 4)),
    ]
    result = probes.measure_batched("quadx_waypoints_velocity", n=8, agent_steps=400, warmup=2)
    assert result["id"] == "quadx_waypoints_velocity" and result["steps_per_s"] > 0
    pybullet = probes.measure_env("quadx_waypoints_velocity", steps=20, resets=1, warmup=2)  # its PyBullet env
    assert pybullet["id"] == "quadx_waypoints_velocity" and pybullet["steps_per_s"] > 0
    result = runner.invoke(app, ["speed", "--quick", "--backend", "batched", "--env", "quadx_nope"])
    assert result.exit_code == 2 and "--env quadx_nope is neither a registered env id" in result.output


def test_the_table_sets_each_size_beside_the_pybullet_env():
    report = run_speed(SpeedSettings.quick(backend="batched", batch_sizes=(1, 256), envs=(HOVER,)), measure=_canned)
    text = format_report(report, markdown=True)
    # 5000 * 256 / 3.56 = 359,551 agent-steps/s: 90x the PyBullet env's 4,000
    assert f"| {HOVER} | 256 | 359,551 | 2.78 | 90x | 3.0 | 1.00 |" in text
    assert f"| {HOVER} | PyBullet env | 4,000 |" in text


def test_the_table_sets_each_size_beside_the_pybullet_env_per_core():
    """The per-core column: the PyBullet env's CPU time per step over the batched backend's per
    agent-step, both from the same run (the canned env: 250 us of CPU per step)."""

    def measured(case: Case) -> dict:
        result = _canned(case)
        if case.probe["probe"] == "env":
            result["step_cpu_s"] = 250e-6
        return result

    report = run_speed(SpeedSettings.quick(backend="batched", batch_sizes=(1, 256), envs=(HOVER,)), measure=measured)
    text = format_report(report, markdown=True)
    # 250 us against 1 / 359,551 s = 2.78 us per agent-step: 90x per core; at N = 1, 250 / 202 us = 1.24x
    assert f"| {HOVER} | 256 | 359,551 | 2.78 | 90x | 3.0 | 1.00 | 90x |" in text
    assert f"| {HOVER} | 1 | 4,950 | 202.00 | 1.24x | 3.0 | 1.00 | 1.24x |" in text
    assert f"| {HOVER} | PyBullet env | 4,000 | 250.00 | 1x | - | - | 1x |" in text
    assert "x PyBullet env per core" in text


def test_envs_it_does_not_run_and_bad_sizes_are_user_errors():
    result = runner.invoke(app, ["speed", "--quick", "--backend", "batched", "--env", "PyFlyt/Rocket-Landing-v0"])
    assert result.exit_code == 2 and "does not simulate" in result.output
    result = runner.invoke(app, ["speed", "--quick", "--backend", "batched", "--batch-sizes", "0,4"])
    assert result.exit_code == 2 and "--batch-sizes takes env counts" in result.output
    result = runner.invoke(app, ["speed", "--quick", "--batch-sizes", "4"])
    assert result.exit_code == 2 and "--batch-sizes goes with --backend batched" in result.output
    result = runner.invoke(app, ["speed", "--quick", "--backend", "jax"])
    assert result.exit_code == 2 and "--backend takes pybullet or batched" in result.output


def test_the_probe_measures_for_real():
    result = probes.measure_batched(HOVER, n=32, agent_steps=3200, warmup=2)
    assert result["n"] == 32 and result["agent_steps"] >= 3200 - 64
    assert result["steps_per_s"] > 0 and result["cpu_per_agent_step_s"] > 0 and result["memory_per_env_kb"] >= 0

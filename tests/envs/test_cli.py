"""`pyflyt envs` lists every registered environment with its spaces and rewards; `pyflyt envs
<name>` prints one env's generated manual."""

from __future__ import annotations

from typer.testing import CliRunner

from pyflyt_cli.catalog import list_envs
from pyflyt_cli.main import app
from pyflyt_engine.envs import ENVS
from pyflyt_engine.envs.manual import env_manual


def test_list_envs_table():
    table = list_envs()
    for env_id, entry in ENVS.items():
        assert env_id in table and f"config: {entry.config}" in table
    assert "observation: Box(21,)" in table
    assert "Dict(attitude: Box(21,), target_deltas: Sequence(Box(3,)))" in table
    assert "mode rates_thrust: p [-3.14159, 3.14159]" in table and "thrust [0, 1]" in table
    assert "dense=quadx_hover_dense, sparse=quadx_hover_sparse" in table
    assert "dense=quadx_waypoints_dense, sparse=quadx_waypoints_sparse" in table
    assert "episode 10 s (300 steps), dome 3 m" in table and "episode 20 s (600 steps), dome 5 m" in table
    assert "num_targets=5, goal_reach_distance=0.2" in table


def test_config_variants_are_listed_under_their_env():
    """Env configs declaring a registered id (another observation or flight mode of the task)
    are listed under it, with what differs, and nowhere else."""
    table = list_envs()
    block = table.split("PyFlyt/QuadX-Gates-v0", 1)[1].split("\n\n", 1)[0]
    assert "variant:     quadx_gates_state:" in block
    assert "observation Dict(attitude: Box(21,), gate: Box(12,)), action mode rates_thrust" in block
    assert "(pyflyt train env=quadx_gates_state)" in block
    waypoints = table.split("PyFlyt/QuadX-Waypoints-v0", 1)[1].split("\n\n", 1)[0]
    assert "quadx_waypoints_velocity:" in waypoints and "action mode velocity_yawrate" in waypoints
    assert table.count("variant:     quadx_gates_state:") == 1 and "variant:     quadx_gates:" not in table


def test_envs_command():
    result = CliRunner().invoke(app, ["envs"])
    assert result.exit_code == 0, result.output
    assert "PyFlyt/QuadX-Waypoints-v0" in result.output and "reward terms:" in result.output


def test_envs_command_prints_one_manual_by_id_or_config():
    result = CliRunner().invoke(app, ["envs", "PyFlyt/QuadX-Hover-v0"])
    assert result.exit_code == 0, result.output
    assert result.output == env_manual("PyFlyt/QuadX-Hover-v0")
    assert "| agent | 30 Hz: one agent step = 8 physics steps" in result.output
    variant = CliRunner().invoke(app, ["envs", "quadx_waypoints_velocity"])
    assert variant.exit_code == 0, variant.output
    assert (
        "flight mode `velocity_yawrate`" in variant.output
        and "a variant of `PyFlyt/QuadX-Waypoints-v0`" in variant.output
    )


def test_envs_command_refuses_an_unknown_name_listing_the_known_ones():
    result = CliRunner().invoke(app, ["envs", "QuadX-Hovr"])
    assert result.exit_code == 2
    assert "Traceback" not in result.output
    assert "error: unknown environment 'QuadX-Hovr'" in result.output
    assert "PyFlyt/QuadX-Hover-v0" in result.output and "ma_quadx_hover_v0" in result.output

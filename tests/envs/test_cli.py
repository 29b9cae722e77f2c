"""`pyflyt envs` lists every registered environment with its spaces and rewards."""

from __future__ import annotations

from typer.testing import CliRunner

from pyflyt_cli.catalog import list_envs
from pyflyt_cli.main import app
from pyflyt_engine.envs import ENVS


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


def test_envs_command():
    result = CliRunner().invoke(app, ["envs"])
    assert result.exit_code == 0, result.output
    assert "PyFlyt/QuadX-Waypoints-v0" in result.output and "reward terms:" in result.output

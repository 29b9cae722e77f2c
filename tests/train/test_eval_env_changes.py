"""``pyflyt eval <run> env.<key>=value``: a trained policy flown in its env with one key changed
(episode length, wind, task options), refused when the change would alter its spaces."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_cli.training import evaluate_run, train
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.telemetry import load_episode
from pyflyt_engine.telemetry.replay import verify

from .conftest import TINY_PPO, load

runner = CliRunner()


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return train(load(TINY_PPO, tmp_path_factory.mktemp("runs"))).run_dir


def test_a_changed_episode_length_is_flown_recorded_and_reported(run):
    hz = load(TINY_PPO, run.parent).env.agent_hz
    plain = evaluate_run(run, {"episodes": 2, "seed": 3, "record": False})
    limit = round(0.2 * hz)
    assert all(e.length > limit for e in plain.episodes)  # the tiny policy flies longer than 0.2 s
    report = evaluate_run(run, {"episodes": 2, "seed": 3, "record": True}, env={"max_duration_seconds": 0.2})
    assert [e.length for e in report.episodes] == [limit, limit]
    assert report.env_changes == {"max_duration_seconds": 0.2}
    assert "env:    the run's, with max_duration_seconds=0.2" in report.table()
    saved = json.loads((run / "eval.json").read_text())
    assert saved["env_changes"] == {"max_duration_seconds": 0.2}
    recorded = load_episode(report.recordings[0])  # the recording carries the env it flew
    assert recorded.config["max_duration_seconds"] == 0.2
    assert verify(recorded, tolerance=0.0).max_deviation == 0.0  # and re-simulates exactly
    plain = evaluate_run(run, {"episodes": 1, "seed": 3, "record": False})
    assert plain.env_changes is None and "env:" not in plain.table()
    assert "env_changes" not in json.loads((run / "eval.json").read_text())


def test_a_task_option_and_the_wind_change_the_flight(run):
    calm = evaluate_run(run, {"episodes": 1, "seed": 4, "record": False})
    windy = evaluate_run(run, {"episodes": 1, "seed": 4, "record": False}, env={"wind": "dryden_severe"})
    assert windy.episodes[0].ret != calm.episodes[0].ret
    moved = evaluate_run(
        run, {"episodes": 1, "seed": 4, "record": False}, env={"task": {"hover_point": [0.0, 0.0, 2.0]}}
    )
    assert moved.episodes[0].ret != calm.episodes[0].ret


def _snapshot(run):
    return {p.name: p.stat().st_mtime_ns for p in run.rglob("*") if p.is_file()}


def test_unknown_keys_and_space_changes_are_refused_before_anything_is_written(run):
    before = _snapshot(run)
    with pytest.raises(ConfigError, match="unknown environment argument 'max_duration'.*max_duration_seconds"):
        evaluate_run(run, {"episodes": 1}, env={"max_duration": 3})
    with pytest.raises(ConfigError, match="env.angle_representation: changes the observation space"):
        evaluate_run(run, {"episodes": 1}, env={"angle_representation": "euler"})
    assert _snapshot(run) == before


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("env=quadx_waypoints", "flies the env it was trained in"),
        ("env.render.fov=30", "nested keys cannot be changed here"),
        ("env.flight_dome_size=[1", "not YAML data"),
    ],
)
def test_the_command_names_a_bad_env_change_and_exits_2(run, override, message):
    before = _snapshot(run)
    result = runner.invoke(app, ["eval", str(run), "episodes=1", override])
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert _snapshot(run) == before


def test_the_command_flies_an_env_change(run):
    result = runner.invoke(app, ["eval", str(run), "episodes=1", "record=false", "env.max_duration_seconds=0.2"])
    assert result.exit_code == 0, result.output
    assert "env:    the run's, with max_duration_seconds=0.2" in result.output


def test_the_firmware_flies_a_rates_policy_s_actions_as_rates_and_sticks_are_refused(run):
    """``env.controller=betaflight`` for a policy of the own controller's rates_thrust keeps its
    actions' meaning (``firmware_action: rates``, at its own agent rate); the firmware's sticks
    would give the same normalised actions another meaning and are refused by the env's own
    action space (the training wrappers rescale both to [-1, 1])."""
    from pyflyt_cli.training.evaluate import _changed_env, _firmware_keeps_the_actions

    cfg = load(TINY_PPO, run.parent)
    assert cfg.env.action.mode == "rates_thrust"
    kept = _firmware_keeps_the_actions(cfg, {"controller": "betaflight"})
    assert kept == {"controller": "betaflight", "firmware_action": "rates"}
    flown = _changed_env(cfg, dict(kept))  # the SITL starts with the first tick: not here
    assert flown.controller == "betaflight" and flown.agent_hz == cfg.env.agent_hz
    assert (
        _firmware_keeps_the_actions(cfg, {"controller": "betaflight", "firmware_action": "sticks"})["firmware_action"]
        == "sticks"
    )
    with pytest.raises(ConfigError, match="changes the action space the policy was trained on"):
        _changed_env(cfg, {"controller": "betaflight", "firmware_action": "sticks"})

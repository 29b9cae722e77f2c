"""``pyflyt eval oracle:<name>``: a scripted controller flown through the evaluation of trained runs.

Oracle: the same controller flown by hand in the plain environment from the same seeds, on
the float32 observations an agent sees (the returns agree to rounding: the evaluation's
actions pass through the agent's [-1, 1] scaling and back), the landing task's own outcome, and ``pyflyt replay
--verify`` of the recordings.  Bad input: a message naming the problem, exit 2, nothing
left on disk.
"""

from __future__ import annotations

import json

import gymnasium
import numpy as np
import pytest
import yaml

import pyflyt_engine.envs  # noqa: F401  (registers the ids)
from pyflyt_engine.envs.oracles import ORACLES, make_oracle

from .conftest import pyflyt


def _by_hand(seeds: list[int]) -> list[float]:
    env = gymnasium.make("PyFlyt/Rocket-Landing-v0")
    oracle = make_oracle("rocket_lander", env)
    returns = []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        total, done = 0.0, False
        while not done:
            obs, reward, terminated, truncated, _ = env.step(oracle(obs.astype(np.float32)))
            total += float(reward)
            done = terminated or truncated
        returns.append(total)
    env.close()
    return returns


def test_the_rocket_lander_flies_its_seeded_drops_as_by_hand_and_its_recordings_replay(tmp_path):
    result = pyflyt(
        ["eval", "oracle:rocket_lander", "episodes=2", "seed=3", f"train.output_dir={tmp_path / 'runs'}"],
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    (run,) = (tmp_path / "runs" / "rocket_landing" / "oracle_rocket_lander").iterdir()
    assert run.name.endswith("-seed3")
    report = json.loads((run / "eval.json").read_text())
    assert report["oracle"] == "rocket_lander" and report["seed"] == 3
    assert [e["seed"] for e in report["episodes"]] == [3, 4]
    assert report["success_rate"] == 1.0  # both drops land safely, as the task itself judges
    np.testing.assert_allclose([e["return"] for e in report["episodes"]], _by_hand([3, 4]), rtol=1e-9)
    assert "oracle: rocket_lander (scripted), seeds 3..4" in result.stdout
    written = yaml.safe_load((run / "oracle.yaml").read_text())
    assert written["oracle"] == "rocket_lander" and written["env"]["id"] == "PyFlyt/Rocket-Landing-v0"

    replay = pyflyt(["replay", str(run / "episodes" / "ep_0001.mcap"), "--verify"], cwd=tmp_path)
    assert replay.returncode == 0, replay.stderr
    assert "largest state deviation 0," in replay.stdout


@pytest.mark.long
def test_env_keys_change_the_flight_and_run_dir_names_the_directory(tmp_path):
    """From 300 m above the pad without sideways offset (the default: 450 m, +-20 m): a shorter flight."""
    out = tmp_path / "lander"
    args = [
        "eval",
        "oracle:rocket_lander",
        "episodes=1",
        "seed=3",
        "record=false",
        "env.task.start_position=[0,0,300]",
        "env.task.start_position_noise=0",
        f"run_dir={out}",
    ]
    result = pyflyt(args, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    report = json.loads((out / "eval.json").read_text())
    assert report["success_rate"] == 1.0 and report["episodes"][0]["length"] < 450  # from 450 m: > 500 steps
    assert yaml.safe_load((out / "oracle.yaml").read_text())["env"]["task"]["start_position"] == [0, 0, 300]
    again = pyflyt(args, cwd=tmp_path)  # the directory exists now: refused, the first results kept
    assert again.returncode == 2 and "already exists" in again.stderr
    assert json.loads((out / "eval.json").read_text()) == report


@pytest.mark.long
def test_bad_oracle_evaluations_name_the_problem_and_leave_nothing(tmp_path):
    runs = f"train.output_dir={tmp_path / 'runs'}"
    cases = {
        ("oracle:nope",): "unknown oracle 'nope' in oracle:nope. Oracles: " + ", ".join(sorted(ORACLES)),
        ("oracle:rocket_lander", "env=quadx_hover"): "flies PyFlyt/Rocket-Landing-v0, not PyFlyt/QuadX-Hover-v0",
        ("oracle:rocket_lander", "model=best"): "model= applies to a trained run",
        ("oracle:rocket_lander", "episodes=0"): "episodes",
        ("oracle:rocket_lander", "env.angle_representation=euler"): "set env.angle_representation=quaternion",
    }
    for args, message in cases.items():
        result = pyflyt(["eval", *args, runs], cwd=tmp_path)
        assert result.returncode == 2, (args, result.stderr)
        assert message in result.stderr, (args, result.stderr)
        assert "Traceback" not in result.stderr
    assert not [p for p in (tmp_path / "runs").rglob("*") if p.is_file()]
    assert not list((tmp_path / "runs").glob("*/*/*"))  # no run directory either


@pytest.mark.parametrize(
    ("name", "env_name"), [("quadx_gate_racer", "quadx_gates_state"), ("quadx_forest_navigator", "quadx_obstacles")]
)
def test_the_quadx_oracles_fly_their_state_env_by_default(tmp_path, name, env_name):
    """Without env=, the gate racer flies the Gates env that shows the corners (the id's own
    config sees the camera), the navigator the Obstacles env; both succeed on seed 0."""
    out = tmp_path / name
    result = pyflyt(["eval", f"oracle:{name}", "episodes=1", "seed=0", "record=false", f"run_dir={out}"], cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert yaml.safe_load((out / "oracle.yaml").read_text())["env_name"] == env_name
    assert json.loads((out / "eval.json").read_text())["success_rate"] == 1.0

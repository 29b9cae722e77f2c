"""experiments/learn_obstacles.py: its probe names every way an episode ends, and its CPU-time
budget stops training (cheap: constructed cases with known answers, one training of ~1 s).

A reach sphere wider than the flight dome is reached on the first step (success); zero thrust
drops the vehicle from 1 m onto the ground; full thrust climbs out of the 7 m dome; a trunk
standing on the spawn point is touched at once.
"""

from __future__ import annotations

import json

import pytest
import yaml

from pyflyt_cli.studies import probes, report

from .conftest import ROOT, FixedAction, experiment


@pytest.fixture(scope="module")
def exp():
    return experiment("learn_obstacles")


def _env(task=None, obstacles=None):
    from pyflyt_cli.training.envs import wrap_for_agent
    from pyflyt_engine.envs import make_env

    data = yaml.safe_load((ROOT / "conf" / "env" / "quadx_obstacles.yaml").read_text())
    data["task"].update(task or {})
    if obstacles is not None:
        data["obstacles"] = obstacles
    return wrap_for_agent(make_env(data))


def _probe(exp, env, action, episodes=2):
    try:
        return probes.obstacle_probe(FixedAction(action), env, episodes=episodes, seed=0)
    finally:
        env.close()


def test_reached_goal_is_a_success(exp):
    probe = _probe(exp, _env(task={"goal_reach_distance": 20.0}), [0, 0, 0, 0])
    assert probe["success"] == 1.0 and probe["successes"] == [True, True]
    assert probe["endings"] == {"reached": 2} and probe["mean_closest"] == 0.0
    assert probe["mean_length"] == pytest.approx(1 / 30)  # one agent step at 30 Hz


def test_falling_ends_on_the_ground(exp):
    probe = _probe(exp, _env(), [0, 0, 0, -1.0])  # no thrust, 1 m up, 1 m from the nearest trunk
    assert probe["success"] == 0.0 and probe["endings"] == {"ground": 2}
    assert 7.5 < probe["mean_closest"] < 9.0  # the goal is 8 m ahead and up to 2 m aside


def test_full_thrust_leaves_the_dome(exp):
    probe = _probe(exp, _env(), [0, 0, 0, 1.0])
    assert probe["endings"] == {"out": 2} and probe["success"] == 0.0


def test_a_trunk_on_the_spawn_point_is_touched(exp):
    trunk = {"type": "cylinder", "position": [-4.0, 0.0, 2.0], "radius": 0.5, "height": 4.0}
    probe = _probe(exp, _env(obstacles={"crash_on_contact": True, "items": [trunk], "generators": []}), [0, 0, 0, 0])
    assert probe["endings"] == {"trunk": 2} and probe["success"] == 0.0


#: the shipped tuning, shrunk: one env, 64-step rollouts, and the imitation stage cut to the
#: oracle's own round of one episode (the budget counts it; the first probe flies its policy)
TINY = [
    "train.n_envs=1",
    "algo.n_steps=64",
    "algo.batch_size=64",
    "algo.n_epochs=1",
    "train.total_timesteps=100000000",
    "train.checkpoint_freq=0",
    "train.imitation.rounds=0",
    "train.imitation.episodes=1",
    "train.imitation.value_warmup=64",
]


def test_cpu_budget_stops_training_and_saves_every_probe(exp, tmp_path):
    saved = []
    row = exp.run(0, 0.15, 64, 1, tmp_path, TINY, save=lambda r: saved.append(json.loads(json.dumps(r))))
    assert row["status"] == "cpu budget" and row["steps"] < 100_000_000
    assert row["training_cpu"] >= 0.15 * 60  # stopped at the budget, probes not counted
    assert row["process_cpu"] >= row["training_cpu"] + row["probe_cpu"] - 1e-6
    # a partial row after every scheduled probe, the final one last
    assert [r["status"] for r in saved[:-1]] == ["running"] * (len(saved) - 1) and saved[-1]["status"] == "cpu budget"
    assert [h[0] for h in saved[-1]["history"]] == [h[0] for h in row["history"]]
    assert all(h[0] % 64 == 0 for h in row["history"][:-1])
    # the imitated policy is probed before learning, and its CPU time is in the budget
    first = row["history"][0]
    assert first[0] == 0 and first[2]["cpu"] > 0.0
    assert len(row["history"]) >= 3 and row["steps"] >= 128  # and learning went on after it
    # the run's own training episodes, per 64-step window, on the task as configured (the tuning
    # has no curriculum: no goal distance or reach sphere of its own is recorded)
    assert row["training"] and all(t["step"] % 64 == 0 and 0.0 <= t["success"] <= 1.0 for t in row["training"])
    assert {(t["goal_x"], t["reach"]) for t in row["training"]} == {(None, None)}


def test_curve_uses_the_probe_steps_every_seed_reached(exp):
    def r(steps):
        return {"history": [(s, 0.0, {"success": 0.5}) for s in steps]}

    cut = report.common_prefix([r([10, 20, 30, 35]), r([10, 20, 27]), r([10, 20, 30])])
    assert [[h[0] for h in c["history"]] for c in cut] == [[10, 20]] * 3

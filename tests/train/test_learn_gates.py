"""experiments/learn_gates.py: its probe counts the gates passed in order and the fraction passing
the target's 3, and its CPU-time budget stops a training of the state-based Gates env (cheap:
constructed cases with known answers, one training of ~1 s).
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import gymnasium
import numpy as np
import pytest
import yaml

from pyflyt_cli.studies import probes, runs

from .conftest import ROOT, FixedAction, experiment


@pytest.fixture(scope="module")
def exp():
    return experiment("learn_gates")


class _Scripted(gymnasium.Env):
    """Episode i (reset seed s + i) lasts one step and passes ``passed[i]`` gates of 5, ending as ``ends[i]``."""

    observation_space = gymnasium.spaces.Box(-1.0, 1.0, (2,))
    action_space = gymnasium.spaces.Box(-1.0, 1.0, (4,))

    def __init__(self, passed, ends):
        self.passed, self.ends, self.i = passed, ends, 0
        self.task = SimpleNamespace(options=SimpleNamespace(gates=[f"gate_{k}" for k in range(5)]))

    def reset(self, *, seed=None, options=None):
        self.i = seed
        return np.zeros(2, dtype=np.float32), {}

    def step(self, action):
        n, end = self.passed[self.i], self.ends[self.i]
        info = {
            "num_targets_reached": n,
            "env_complete": end == "complete",
            "out_of_bounds": end == "out",
            "collision": end == "crash",
        }
        return np.zeros(2, dtype=np.float32), 100.0 * n, end != "time", end == "time", info


def test_probe_counts_gates_in_a_row_and_the_target_fraction(exp):
    passed = [0, 1, 2, 3, 5, 4, 3, 0]
    ends = ["crash", "crash", "out", "time", "complete", "crash", "crash", "time"]
    probe = probes.gates_probe(FixedAction([0, 0, 0, 0]), _Scripted(passed, ends), episodes=8, seed=0)
    assert probe["reached"] == passed
    assert probe["at_least"] == [6 / 8, 5 / 8, 4 / 8, 2 / 8, 1 / 8]
    assert probe["success"] == 4 / 8  # >= 3 gates: episodes 3, 4, 5, 6
    assert probe["all"] == 1 / 8 and probe["mean_reached"] == pytest.approx(18 / 8)
    assert probe["endings"] == {"complete": 1, "time": 2, "out": 1, "crash": 4}
    assert probe["mean_return"] == pytest.approx(100 * 18 / 8)
    assert probes.gates_probe(FixedAction([0, 0, 0, 0]), _Scripted(passed, ends), 8, 0, gates=1)["success"] == 6 / 8


def _env():
    from pyflyt_cli.training.envs import wrap_for_agent
    from pyflyt_engine.envs import make_env

    return wrap_for_agent(make_env(yaml.safe_load((ROOT / "conf" / "env" / "quadx_gates_state.yaml").read_text())))


def test_falling_passes_no_gate(exp):
    env = _env()
    try:  # no thrust from 1 m: the ground, before the first gate (1-3 m ahead)
        probe = probes.gates_probe(FixedAction([0, 0, 0, -1.0]), env, episodes=2, seed=0)
    finally:
        env.close()
    assert probe["reached"] == [0, 0] and probe["endings"] == {"crash": 2} and probe["success"] == 0.0


def test_cpu_budget_stops_training_of_the_state_env(exp, tmp_path):
    saved = []
    from .test_learn_obstacles import TINY

    row = runs.budgeted_run(
        0,
        0.15,
        64,
        1,
        tmp_path,
        TINY,
        save=lambda r: saved.append(json.loads(json.dumps(r))),
        env=exp.ENV,
        target=exp.TARGET,
        probe_cls=probes.GatesProbe,
    )  # as learn_gates.py's seeds
    assert row["env"] == "quadx_gates_state" and row["status"] == "cpu budget" and row["steps"] < 100_000_000
    assert row["training_cpu"] >= 0.15 * 60
    # the envs' share of the collection, timed by the loop's StepTimer, the rest of it apart
    assert row["split"]["env"] > 0 and row["split"]["collect_other"] > 0
    assert row["history"][0][0] == 0  # the imitated policy, probed before learning
    assert saved[-1]["status"] == "cpu budget" and [h[0] for h in saved[-1]["history"]] == [
        h[0] for h in row["history"]
    ]
    assert all(len(h[2]["at_least"]) == 5 and 0.0 <= h[2]["success"] <= 1.0 for h in row["history"])


def test_the_scripted_table_flies_the_oracles_through_the_probes():
    """experiments/quadx_scripted.py: an oracle behind a policy's interface, in the agent's units,
    measured by the learning runs' own probes (the first probe seed: every gate, the goal)."""
    scripted = experiment("quadx_scripted")
    gates = scripted.fly("quadx_gates_state", "quadx_gate_racer", scripted.gates_probe, 1)
    assert gates["at_least"] == [1.0] * 5 and gates["success"] == 1.0
    goal = scripted.fly("quadx_obstacles", "quadx_forest_navigator", scripted.obstacle_probe, 1)
    assert goal["success"] == 1.0 and goal["endings"] == {"reached": 1}
    lines = scripted.report([("quadx_gates_state", "quadx_gate_racer", gates)], 1)
    assert "| quadx_gates_state | quadx_gate_racer | 100 | complete 1 | 100 / 100 / 100 / 100 / 100 | - |" in lines

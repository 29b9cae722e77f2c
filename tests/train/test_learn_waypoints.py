"""The waypoint probe of experiments/learn_waypoints.py counts what it should (cheap, no training).

Constructed cases with known answers: a reach distance wider than the flight dome makes
every step reach the next waypoint (the tracker moves on by one per step), so every
episode reaches all of them and completes; zero thrust with a tiny reach distance drops
the vehicle from 1 m onto the ground before anything is reached.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from pyflyt_cli.studies import probes

from .conftest import ROOT, FixedAction, experiment


def _experiment():
    return experiment("learn_waypoints")


def _env(num_targets: int, reach: float):
    from pyflyt_cli.training.envs import wrap_for_agent
    from pyflyt_engine.envs import make_env

    data = yaml.safe_load((ROOT / "conf" / "env" / "quadx_waypoints.yaml").read_text())
    data["task"].update(num_targets=num_targets, goal_reach_distance=reach)
    return wrap_for_agent(make_env(data))


@pytest.fixture(scope="module")
def exp():
    return _experiment()


def test_every_waypoint_counted_when_each_step_reaches_one(exp):
    env = _env(num_targets=3, reach=20.0)  # wider than the 5 m dome: reached at once, one per step
    try:
        probe = probes.waypoint_probe(FixedAction([0, 0, 0, -0.7]), env, episodes=2, seed=0)
    finally:
        env.close()
    assert probe["reached"] == [3, 3]
    assert probe["at_least"] == [1.0, 1.0, 1.0] and probe["all"] == 1.0 and probe["mean_reached"] == 3.0
    assert probe["endings"] == {"complete": 2}


def test_nothing_counted_when_the_vehicle_falls(exp):
    env = _env(num_targets=5, reach=1e-4)
    try:
        probe = probes.waypoint_probe(FixedAction([0, 0, 0, -1.0]), env, episodes=2, seed=0)  # no thrust
    finally:
        env.close()
    assert probe["reached"] == [0, 0]
    assert probe["at_least"] == [0.0] * 5 and probe["all"] == 0.0
    assert probe["endings"] == {"crash": 2}


def test_fractions_of_mixed_episodes(exp):
    probe = probes.summarize_probe([0, 2, 5, 5], ["crash", "out", "complete", "complete"], [1.0, 2.0, 3.0, 6.0], 5)
    assert probe["at_least"] == [0.75, 0.75, 0.5, 0.5, 0.5]
    assert probe["mean_reached"] == 3.0 and probe["all"] == 0.5 and probe["mean_return"] == 3.0
    assert probe["endings"] == {"complete": 2, "out": 1, "crash": 1}


def test_probe_run_flies_the_checkpoints_after_a_step_with_their_normaliser(exp, tmp_path):
    """--probe-run: each checkpoint after --after, loaded as `pyflyt eval` loads it (observation
    normaliser included), flies the same probe episodes as the live policy of that step."""
    from pyflyt_cli.training import train
    from pyflyt_cli.training.envs import EnvFactory

    from .conftest import TINY_PPO, load

    overrides = [o for o in TINY_PPO if not o.startswith("env=")]
    # the tuning's curriculum would outlast the tiny budget
    cfg = load(
        ["env=quadx_waypoints", *overrides, "algo.normalize.observation=true", "train.curriculum=null"], tmp_path
    )
    live = {}

    from stable_baselines3.common.callbacks import BaseCallback

    class ProbeAtEnd(BaseCallback):
        def _on_step(self) -> bool:
            return True

        def _on_training_end(self) -> None:
            env = EnvFactory(cfg.env, monitor=False)()
            try:
                live["probe"] = probes.waypoint_probe(self.model, env, episodes=2, seed=probes.PROBE_SEED)
            finally:
                env.close()

    result = train(cfg, callbacks=[ProbeAtEnd()], log=lambda line: None)
    flown = exp.probe_run(Path(result.run_dir), episodes=2, after=256)
    assert [step for step, _ in flown] == [512]
    assert flown[0][1] == live["probe"]


def test_replayed_evaluations_are_the_run_s_own(tmp_path, capsys):
    """``--as-evaluations`` flies each checkpoint as the run's own evaluation: the same
    summaries as its /eval records at those steps (evaluations do not change training)."""
    from pyflyt_cli.training import train
    from pyflyt_engine.telemetry import read_metrics

    from .conftest import TINY_PPO, load

    run = train(load([*TINY_PPO, "train.total_timesteps=768"], tmp_path / "runs")).run_dir
    recorded = {r["step"]: r for r in read_metrics(run)["/eval"]}
    replayed = dict(_experiment().replay_evaluations(run, every=256))
    assert sorted(replayed) == sorted(recorded) == [256, 512, 768]
    for step, summary in replayed.items():
        assert summary == {k: recorded[step][k] for k in summary}
    from pyflyt_cli.training.rundir import read_state

    kept = read_state(run)["best_step"]  # what the run itself kept (train.best_by: return)
    assert f"step {kept} with best_by=return" in capsys.readouterr().out

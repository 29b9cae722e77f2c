"""The landing probe of experiments/learn_rocket_velocity.py counts what it should (no training).

Known answers: the ``rocket_velocity_lander`` oracle lands the probe's first seeded drops
safely (it lands 49 of 50 seeded drops, experiments/results/rocket_landing_scripted.md;
the two used here are among them), and with the ignition permission 0 the booster is
never lit, so every drop falls from 450 m and hits at tens of m/s with the fuel untouched.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from .conftest import ROOT


def _experiment():
    spec = importlib.util.spec_from_file_location("learn_rocket_velocity", ROOT / "experiments" / "learn_rocket_velocity.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def exp():
    return _experiment()


@pytest.fixture()
def env(exp):
    from pyflyt_cli.training import compose_config
    from pyflyt_cli.training.envs import EnvFactory

    env = EnvFactory(compose_config(env=exp.ENV, algo="ppo").env, monitor=False)()
    yield env
    env.close()


def test_the_oracle_s_drops_count_as_safe_landings(exp, env):
    from pyflyt_cli.training.imitation import agent_units
    from pyflyt_engine.envs.oracles import make_oracle

    oracle, to_agent = make_oracle("rocket_velocity_lander", env), agent_units(env)
    probe = exp.rocket_probe(lambda obs, deterministic: (to_agent(oracle(obs)), None), None, env, episodes=2)
    assert probe["safe"] == 1.0 and probe["outcomes"] == {"safe": 2}
    for flight in probe["flights"]:
        assert 0.0 <= flight["touchdown_speed"] < 1.0  # the task's max_touchdown_speed
        assert flight["pad_distance"] < 2.0 + 0.5  # within the pad's radius (plus the standing height)
        assert 0.0 < flight["fuel_left_kg"] < 0.01 * exp.TANK_KG  # some of the 1 % tank burnt
        assert flight["offset_at_aim_height"] is not None
    assert [f["seed"] for f in probe["flights"]] == [exp.PROBE_SEED, exp.PROBE_SEED + 1]


def test_a_drop_that_never_lights_the_booster_is_no_landing(exp, env):
    idle = np.array([0.0, 0.0, 0.0, -1.0], dtype=np.float32)  # ignition -1 in agent units: 0, never lit
    probe = exp.rocket_probe(lambda obs, deterministic: (idle, None), None, env, episodes=2)
    assert probe["safe"] == 0.0
    assert sum(probe["outcomes"].get(k, 0) for k in ("fatal", "ground")) == 2
    for flight in probe["flights"]:
        assert flight["fuel_left_kg"] == pytest.approx(0.01 * exp.TANK_KG)  # untouched
        assert flight["touchdown_speed"] < 0.0 or flight["touchdown_speed"] > 50.0  # off the pad, or hit it falling


def test_outcome_names_the_first_ending_that_applies(exp):
    assert exp.outcome({"safe_landing": True, "fatal_landing": False}) == "safe"
    assert exp.outcome({"fatal_landing": True, "ground_contact": True}) == "fatal"
    assert exp.outcome({"ground_contact": True}) == "ground"
    assert exp.outcome({"out_of_bounds": True}) == "dome exit"
    assert exp.outcome({}) == "time limit"

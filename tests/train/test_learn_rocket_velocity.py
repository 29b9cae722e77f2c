"""The landing probe of experiments/learn_rocket_velocity.py counts what it should (no training).

Known answers: the mode landers (``rocket_velocity_lander``, ``rocket_descent_lander``) land
the probe's first seeded drops safely (experiments/results/rocket_landing_scripted.md;
the two used here are among their landings), and with the ignition permission 0 the booster is
never lit, so every drop falls from 450 m and hits at tens of m/s with the fuel untouched.
"""

from __future__ import annotations

import numpy as np
import pytest

from .conftest import experiment


def _experiment():
    return experiment("learn_rocket_velocity")


@pytest.fixture(scope="module")
def exp():
    return _experiment()


ENVS = ["rocket_landing_velocity", "rocket_landing_descent"]


@pytest.fixture(params=ENVS)
def env(request):
    from pyflyt_cli.training import compose_config
    from pyflyt_cli.training.envs import EnvFactory

    env = EnvFactory(compose_config(env=request.param, algo="ppo").env, monitor=False)()
    env.config_name = request.param
    yield env
    env.close()


def test_the_oracle_s_drops_count_as_safe_landings(exp, env):
    from pyflyt_cli.training.imitation import agent_units
    from pyflyt_engine.envs.oracles import make_oracle

    oracle, to_agent = make_oracle(exp.ORACLE[env.config_name], env), agent_units(env)
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


TINY = [
    "reward=rocket_landing_envelope",
    "train.total_timesteps=256",
    "algo.n_steps=256",
    "algo.batch_size=64",
    "algo.n_epochs=1",
    "train.eval_freq=0",
    "train.checkpoint_freq=0",
]


@pytest.mark.long  # two short training runs, ~12 s
def test_a_run_is_probed_at_its_start_and_end_and_stops_at_its_cpu_budget(exp, tmp_path):
    """No budget problem: probes after the start (step 0) and at the end; a zero CPU budget
    stops the run at its first step, which is then probed as the final policy; the report
    tables and the rliable summary take both rows."""
    full = exp.run(0, every=10**9, episodes=1, cpu_minutes=60.0, output=tmp_path / "a", extra=TINY)
    assert [p["step"] for p in full["history"]] == [0, 256] and full["steps"] == 256
    assert not full["stopped_by_budget"] and full["final"] is full["history"][-1]
    cut = exp.run(1, every=10**9, episodes=1, cpu_minutes=0.0, output=tmp_path / "b", extra=TINY)
    assert cut["stopped_by_budget"] and cut["steps"] == 1
    assert [p["step"] for p in cut["history"]] == [0, 1]
    lines = exp.table([full, cut]) + exp.rliable_summary([full, cut], reps=50)
    assert len([line for line in lines if line.startswith("| 0 |") or line.startswith("| 1 |")]) == 2
    assert any(line.startswith("| safe landings") for line in lines)

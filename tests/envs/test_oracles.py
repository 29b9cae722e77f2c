"""Scripted oracles (pyflyt_engine/envs/oracles.py): they fly their task and act on the observation alone.

Oracle for ``rocket_lander``: the landing task's own outcome (a safe landing is an upright
halt on the pad after a touchdown under 1 m/s), from seeded starts of the full start
distribution (450 m, +-20 m, +-5 m/s, +-0.3 rad, 1 % fuel).
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.envs.oracles import ORACLES, make_oracle
from pyflyt_engine.errors import ConfigError

ROCKET = "PyFlyt/Rocket-Landing-v0"


@pytest.mark.parametrize("seed", [0, 7])
def test_the_rocket_lander_lands_seeded_drops_safely(make, seed):
    env = make(ROCKET)
    oracle = make_oracle("rocket_lander", env)
    obs, _ = env.reset(seed=seed)
    start = obs.copy()
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(oracle(obs))
        done = terminated or truncated
    assert np.linalg.norm(start[10:12]) > 1.0  # the start was off the pad's axis: it had to aim
    assert info["safe_landing"] and info["success"] and terminated
    assert 0.0 <= info["touchdown_speed"] < 1.0 and info["pad_distance"] < 2.0


def test_the_rocket_lander_is_a_function_of_the_observation(make):
    """No state between calls: the same observation gives the same action, whatever came before."""
    env = make(ROCKET)
    first, second = make_oracle("rocket_lander", env), make_oracle("rocket_lander", env)
    obs, _ = env.reset(seed=3)
    seen = []
    for _ in range(200):
        seen.append(obs.copy())
        obs, *_ = env.step(first(obs))
    for o in reversed(seen):  # another order, another instance
        np.testing.assert_array_equal(second(o), first(o))
    assert any(second(o)[3] == 1.0 for o in seen)  # the booster is lit somewhere (aim pulses)


def test_an_oracle_refuses_another_env_and_unknown_names_are_listed(make):
    with pytest.raises(ConfigError, match="flies PyFlyt/Rocket-Landing-v0, not PyFlyt/QuadX-Hover-v0"):
        make_oracle("rocket_lander", make("PyFlyt/QuadX-Hover-v0"))
    with pytest.raises(ConfigError, match="unknown oracle 'lander'; oracles: " + ", ".join(sorted(ORACLES))):
        make_oracle("lander", None)
    with pytest.raises(ConfigError, match="quaternion"):
        make_oracle("rocket_lander", make(ROCKET, angle_representation="euler"))

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
VELOCITY = "PyFlyt/Rocket-Landing-Velocity-v0"
DESCENT = "PyFlyt/Rocket-Landing-Descent-v0"
#: the oracles that fly a rocket autopilot mode: the guidance alone
MODE_LANDERS = [(VELOCITY, "rocket_velocity_lander"), (DESCENT, "rocket_descent_lander")]


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
    assert any(second(o)[3] > 0.5 for o in seen)  # the booster is lit somewhere (aim pulses)


def test_the_graded_ignition_label_flies_the_switch(make):
    """The ignition value is graded by the burn margin (a target continuous across the switch
    for a learner), yet the flight is the one of a 0/1 switch on the same decision: the
    booster only reads > 0.5."""
    flights, labels = [], []
    for snap in (False, True):
        env = make(ROCKET)
        oracle = make_oracle("rocket_lander", env)
        obs, _ = env.reset(seed=5)
        states, done = [], False
        while not done:
            action = oracle(obs)
            if snap:
                action[3] = 1.0 if action[3] > 0.5 else 0.0
            else:
                labels.append(action[3])
            obs, _, terminated, truncated, info = env.step(action)
            # the state without the echo of the last command (entries 13-19)
            states.append(np.concatenate([obs[:13], obs[20:]]))
            done = terminated or truncated
        assert info["safe_landing"]
        flights.append(np.array(states))
    np.testing.assert_array_equal(flights[0], flights[1])
    labels = np.array(labels)
    assert ((labels > 0.05) & (labels < 0.5)).sum() > 10  # graded below the switch (approaching a burn)
    assert ((labels > 0.5) & (labels < 0.95)).sum() > 10  # and above it
    assert labels.min() >= 0.0 and labels.max() <= 1.0


def test_an_oracle_refuses_another_env_and_unknown_names_are_listed(make):
    with pytest.raises(ConfigError, match="flies PyFlyt/Rocket-Landing-v0, not PyFlyt/QuadX-Hover-v0"):
        make_oracle("rocket_lander", make("PyFlyt/QuadX-Hover-v0"))
    with pytest.raises(ConfigError, match="unknown oracle 'lander'; oracles: " + ", ".join(sorted(ORACLES))):
        make_oracle("lander", None)
    with pytest.raises(ConfigError, match="quaternion"):
        make_oracle("rocket_lander", make(ROCKET, angle_representation="euler"))


@pytest.mark.parametrize("seed", [0, 7])
@pytest.mark.parametrize(("env_id", "name"), MODE_LANDERS)
def test_the_mode_landers_land_seeded_drops_through_the_autopilot(make, env_id, name, seed):
    """The guidance alone (a velocity or descent setpoint and an ignition permission); the
    rocket autopilot does the attitude, the thrust vectoring and the booster's timing."""
    env = make(env_id)
    oracle = make_oracle(name, env)
    obs, _ = env.reset(seed=seed)
    start = obs.copy()
    done, lit = False, 0
    while not done:
        action = oracle(obs)
        assert env.action_space.contains(action)
        obs, _, terminated, truncated, info = env.step(action)
        lit += obs[-4] == 1.0  # the booster's ignited flag (aux)
        done = terminated or truncated
    assert np.linalg.norm(start[10:12]) > 1.0
    assert lit > 0  # the autopilot lit the booster on its own rule
    assert info["safe_landing"] and info["success"] and terminated
    assert 0.0 <= info["touchdown_speed"] < 1.0 and info["pad_distance"] < 2.0


@pytest.mark.parametrize(("env_id", "name"), MODE_LANDERS)
def test_the_mode_landers_are_functions_of_the_observation_and_refuse_the_raw_env(make, env_id, name):
    env = make(env_id)
    first = make_oracle(name, env)
    obs, _ = env.reset(seed=3)
    seen = []
    for _ in range(100):
        seen.append(obs.copy())
        obs, *_ = env.step(first(obs))
    second = make_oracle(name, env)  # built 100 steps (and some fuel) later
    for o in reversed(seen):
        np.testing.assert_array_equal(second(o), first(o))
    with pytest.raises(ConfigError, match=f"flies {env_id}, not PyFlyt/Rocket-Landing-v0"):
        make_oracle(name, make(ROCKET))

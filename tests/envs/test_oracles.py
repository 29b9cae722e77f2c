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
    with pytest.raises(
        ConfigError,
        match="unknown oracle 'lander'. Did you mean 'rocket_lander'[?] Oracles: " + ", ".join(sorted(ORACLES)),
    ):
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


# ----------------------------------------------------------------- QuadX oracles (rates_thrust)

OBSTACLES = "PyFlyt/QuadX-Obstacles-v0"


@pytest.fixture
def gates_state():
    """QuadX-Gates from state (conf/env/quadx_gates_state.yaml: the next gate's corners)."""
    from pyflyt_engine.envs import make_env

    made = []

    def _make(**overrides):
        env = make_env("quadx_gates_state", **overrides)
        made.append(env)
        return env

    yield _make
    for env in made:
        env.close()


def test_the_quadx_pilot_holds_a_level_hover_with_the_weight(make):
    """At rest and level, asked for no velocity, the pilot asks no rates and a thrust fraction
    equal to the weight over the full collective (0.125 for the 8:1 cf2x)."""
    from pyflyt_engine.constants import GRAVITY
    from pyflyt_engine.envs.oracles import QuadXVelocityPilot

    env = make(OBSTACLES)
    pilot = QuadXVelocityPilot(env)
    attitude = np.zeros(21)
    attitude[6] = 1.0  # quaternion (0, 0, 0, 1): level, heading +x
    attitude[10:13] = (0.0, 0.0, 1.0)
    action = pilot(attitude, (0.0, 0.0, 0.0), heading=0.0)
    controller = env.vehicle.controller
    np.testing.assert_allclose(action[:3], 0.0, atol=1e-12)
    assert action[3] == pytest.approx(controller.mass * GRAVITY / controller.mixer.max_collective, rel=1e-12)
    assert action[3] == pytest.approx(0.125, rel=0.02)
    # asked to move +x, level: pitch nose down (a positive body y rate tilts the thrust toward +x)
    ahead = pilot(attitude, (1.0, 0.0, 0.0))
    assert ahead[1] > 0.0 and ahead[0] == pytest.approx(0.0, abs=1e-12)
    # asked to climb: more thrust than the weight, no rates
    climb = pilot(attitude, (0.0, 0.0, 1.0))
    assert climb[3] > action[3] and np.allclose(climb[:3], 0.0, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 5])
def test_the_forest_navigator_reaches_the_goal_without_contact(make, seed):
    env = make(OBSTACLES)
    oracle = make_oracle("quadx_forest_navigator", env)
    obs, _ = env.reset(seed=seed)
    assert len(env.obstacles.generated_ids) == 12  # a forest to cross
    done, steps = False, 0
    while not done:
        action = oracle(obs)
        assert env.action_space.contains(action.astype(np.float32))
        obs, _, terminated, truncated, info = env.step(action)
        steps += 1
        done = terminated or truncated
    assert info["success"] and terminated and not info["obstacle_contact"]
    assert steps < 20 * 30  # before the time limit


@pytest.mark.parametrize("seed", [0, 3])
def test_the_gate_racer_passes_every_gate_in_order(gates_state, seed):
    env = gates_state()
    oracle = make_oracle("quadx_gate_racer", env)
    obs, _ = env.reset(seed=seed)
    done, passed = False, []
    while not done:
        obs, _, terminated, truncated, info = env.step(oracle(obs))
        passed.append(info["num_targets_reached"])
        done = terminated or truncated
    assert passed == sorted(passed) and passed[-1] == 5  # one at a time, all five
    assert info["success"] and terminated and not info["collision"]


def test_the_quadx_oracles_read_the_flat_observation_as_the_dict(make, gates_state):
    """An agent's flat vector (Gymnasium's FlattenObservation) and the env's Dict give the same
    action (two copies of the env, the same seed and actions); the same observation gives the
    same action whatever came before (no state)."""
    import gymnasium

    for pair, name in (
        ((make(OBSTACLES), make(OBSTACLES)), "quadx_forest_navigator"),
        ((gates_state(), gates_state()), "quadx_gate_racer"),
    ):
        as_dict, flat = pair[0], gymnasium.wrappers.FlattenObservation(pair[1])
        first, second = make_oracle(name, as_dict), make_oracle(name, flat)
        obs, _ = as_dict.reset(seed=2)
        vector, _ = flat.reset(seed=2)
        seen = []
        for _ in range(60):
            action = first(obs)
            np.testing.assert_array_equal(second(vector), action)
            seen.append((obs, action))
            obs, *_ = as_dict.step(action)
            vector, *_ = flat.step(action)
        assert any(abs(a[0]) > 1e-3 or abs(a[1]) > 1e-3 for _, a in seen)  # it steered
        for o, a in reversed(seen):
            np.testing.assert_array_equal(second(flat.observation(o)), a)


def test_the_quadx_oracles_refuse_envs_they_cannot_read(make, gates_state):
    with pytest.raises(ConfigError, match="quadx_gate_racer reads the next gate's corners"):
        make_oracle("quadx_gate_racer", gates_state(task={"observation": "relative_pose"}))
    with pytest.raises(ConfigError, match="quaternion"):
        make_oracle("quadx_forest_navigator", make(OBSTACLES, angle_representation="euler"))
    with pytest.raises(ConfigError, match="flies PyFlyt/QuadX-Obstacles-v0, not PyFlyt/QuadX-Hover-v0"):
        make_oracle("quadx_forest_navigator", make("PyFlyt/QuadX-Hover-v0"))

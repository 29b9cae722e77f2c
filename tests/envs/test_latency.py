"""Action and observation latency (env ``latency``): rounding to physics steps, a step
response shifted by exactly the delay, observations of the past, refusals, and episodes
that replay exactly."""

from __future__ import annotations

import json
import warnings

import gymnasium
import numpy as np
import pytest

import pyflyt_engine.envs  # noqa: F401
from pyflyt_engine.envs.config import LatencyConfig, load_env_config
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.telemetry import RecordEpisode, load_episode
from pyflyt_engine.telemetry.replay import verify
from pyflyt_engine.world import World
from tests.conftest import spec_variant


def make(**kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gymnasium.make("PyFlyt/QuadX-Hover-v0", **kwargs)


@pytest.mark.parametrize(
    ("delay", "steps"),
    [(0.0, 0), (0.0125, 3), (0.01, 2), (2.5 / 240, 3), (3.5 / 240, 4), (1.49 / 240, 1), (1 / 30, 8)],
)
def test_delays_round_to_the_nearest_physics_step_halves_up(delay, steps):
    assert LatencyConfig(action_delay=delay, observation_delay=delay).steps(240.0) == (steps, steps)


def _throttles(delay_steps: int, n: int = 40) -> np.ndarray:
    """Motor throttles at every physics step after a throttle step sent at step 0."""
    spec = spec_variant(**{"motors.noise_ratio": 0.0})
    world = World([dict(uav=spec, position=(0.0, 0.0, 1.0), mode="motors")], seed=0, agent_hz=240.0)
    vehicle = world.vehicles[0]
    vehicle.set_latency(delay_steps, 0)
    world.reset(seed=0)
    vehicle.set_setpoint([0.6, 0.5, 0.6, 0.5])
    out = []
    for _ in range(n):
        world.step()
        out.append(vehicle.motor_throttle)
    world.close()
    return np.array(out)


@pytest.mark.parametrize("delay", [2, 6, 10])
def test_a_step_response_is_shifted_by_exactly_the_delay(delay):
    """A delay of whole control periods (2 physics steps at 240 / 120 Hz) shifts the response exactly."""
    plain, late = _throttles(0), _throttles(delay)
    assert np.array_equal(late[delay:], plain[:-delay])
    assert not late[:delay].any()  # nothing arrived yet: the motors idle


def test_a_delay_between_control_ticks_waits_for_the_next_tick():
    """The controller reads the setpoint at its ticks: 3 physics steps act as 4 (the next tick)."""
    plain, late = _throttles(0), _throttles(3)
    assert np.array_equal(late[4:], plain[:-4])


def _episode(**latency):
    env = make(latency=latency or None, agent_hz=30.0)
    observations, rewards, states = [], [], []
    obs, _ = env.reset(seed=4)
    observations.append(obs)
    states.append(env.unwrapped.vehicle.state)
    for k in range(20):
        obs, reward, terminated, truncated, _ = env.step(np.array([0.1 * (k % 3 - 1), 0.05, 0.0, 0.13]))
        observations.append(obs)
        rewards.append(reward)
        states.append(env.unwrapped.vehicle.state)
        assert not (terminated or truncated)
    env.close()
    return np.array(observations), np.array(rewards), states


def test_the_observation_shows_the_vehicle_as_it_was_observation_delay_ago():
    plain, plain_rewards, _ = _episode()
    late, late_rewards, _ = _episode(observation_delay=2 / 30)  # two agent steps, 16 physics steps
    state, aux = slice(0, 13), slice(17, 21)  # ang_vel, quaternion, lin_vel, lin_pos | 4 throttles
    assert np.array_equal(late[2:, state], plain[:-2, state])
    assert np.array_equal(late[2:, aux], plain[:-2, aux])
    assert np.array_equal(late[:2, state], np.repeat(plain[:1, state], 2, axis=0))  # the spawn, until then
    assert np.array_equal(late[:, 13:17], plain[:, 13:17])  # the previous action is the agent's own: not delayed
    assert np.array_equal(late_rewards, plain_rewards)  # rewards and physics use the true state


def test_an_action_delay_changes_the_flight_and_an_observation_delay_does_not():
    _, _, plain = _episode()
    _, _, watched = _episode(observation_delay=0.05)
    _, _, late = _episode(action_delay=0.05)
    assert [s.lin_pos for s in watched] == [s.lin_pos for s in plain]
    assert [s.lin_pos for s in late] != [s.lin_pos for s in plain]


@pytest.mark.parametrize(
    ("latency", "message"),
    [
        ({"action_delay": -0.01}, "latency.action_delay"),
        ({"observation_delay": -1.0}, "latency.observation_delay"),
        ({"action_delay": 10.0}, "latency.action_delay: 10 s is not shorter than the episode"),
        ({"observation_delay": 12.0}, "latency.observation_delay: 12 s is not shorter than the episode"),
        ({"action_dealy": 0.01}, "action_dealy"),
    ],
)
def test_impossible_latency_is_refused_naming_the_key(latency, message):
    with pytest.raises(ConfigError, match=message):
        make(latency=latency)


def test_without_latency_the_config_dumps_as_before():
    config = load_env_config("quadx_hover")
    assert config.latency is None and "latency" not in config.model_dump(mode="json")
    env = make()
    assert "set_setpoint" not in env.unwrapped.vehicle.__dict__ and "apply_loads" not in env.unwrapped.vehicle.__dict__
    env.close()


def test_episodes_with_latency_record_it_and_verify_exactly(tmp_path):
    env = RecordEpisode(make(latency={"action_delay": 0.02, "observation_delay": 0.03}, wind="dryden_light"), tmp_path)
    for episode in range(2):
        env.reset(seed=2 if episode == 0 else None)
        for _ in range(25):
            *_, terminated, truncated, _ = env.step(np.array([0.05, -0.05, 0.0, 0.14]))
            if terminated or truncated:
                break
    env.close()
    for path in env.paths:
        episode = load_episode(path)
        config = json.loads(episode.contents.require_metadata("env")["config"])
        assert config["latency"] == {"action_delay": 0.02, "observation_delay": 0.03}
        result = verify(episode, tolerance=0.0)
        assert result.ok and result.max_deviation == 0.0 and result.max_reward_deviation == 0.0, result


def test_multi_agent_envs_delay_every_agent():
    from pyflyt_engine.envs.multi_agent.ma_quadx_hover_v0 import parallel_env

    env = parallel_env(latency={"action_delay": 0.025, "observation_delay": 0.0})
    env.reset(seed=0)
    assert all(v.latency == (6, 0) for v in env.vehicles)
    for _ in range(3):
        env.step({a: env.action_space(a).sample() * 0.0 for a in env.agents})
    env.close()

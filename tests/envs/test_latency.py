"""Action and observation latency (env ``latency``, and ``randomize.action_delay`` /
``observation_delay`` drawn per episode): rounding to physics steps, a step response
shifted by exactly the delay, observations of the past, refusals, and episodes that
replay exactly."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest

import pyflyt_engine.envs  # noqa: F401
from pyflyt_engine.envs.config import LatencyConfig, load_env_config
from pyflyt_engine.envs.quadx import QuadXHoverEnv
from pyflyt_engine.envs.randomization import delay_steps
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.telemetry import RecordEpisode, load_episode
from pyflyt_engine.telemetry.replay import verify
from pyflyt_engine.world import World
from tests.conftest import spec_variant
from tests.engine.vehicle_checks import NO_STAGES, shadowed_methods


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
    assert env.unwrapped.vehicle.stages == NO_STAGES
    assert not shadowed_methods(env.unwrapped.vehicle)
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


# ------------------------------------------------------------------ randomised latency


def _uniform(low: float, high: float) -> dict:
    return {"distribution": "uniform", "low": low, "high": high}


#: motor commands straight to the motors, every physics step an agent step and a control tick
MOTORS = {
    "action": {"mode": "motors", "names": ["m1", "m2", "m3", "m4"], "low": [0.0] * 4, "high": [1.0] * 4},
    "agent_hz": 240.0,
    "control_hz": 240.0,
}


def _drawn_steps(env, name: str) -> int:
    return delay_steps(env.last_randomization[name], env.world.physics_hz)


def _throttle_episode(seed: int, delay: dict, n: int = 30) -> tuple[np.ndarray, dict]:
    """Motor throttles after each agent (= physics) step of a throttle step sent from the reset."""
    quiet = spec_variant(**{"motors.noise_ratio": 0.0})
    env = QuadXHoverEnv(airframe=quiet, randomize={"action_delay": delay}, **MOTORS)
    _, info = env.reset(seed=seed)
    out = []
    for _ in range(n):
        env.step(np.array([0.6, 0.5, 0.6, 0.5]))
        out.append(env.vehicle.motor_throttle)
    steps = _drawn_steps(env, "action_delay")
    assert env.vehicle.latency == (steps, 0) and env.latency_steps == (steps, 0)
    env.close()
    return np.array(out), info["randomization"]


def test_a_randomised_action_delay_shifts_the_step_response_by_exactly_the_draw():
    """Reference: a draw of 0 s (one uniform draw too, so the seeded stream stays aligned)."""
    seen = set()
    for seed in (0, 1, 2):
        plain, _ = _throttle_episode(seed, _uniform(0.0, 0.0))
        late, drawn = _throttle_episode(seed, _uniform(0.0, 0.05))
        n = delay_steps(drawn["action_delay"], 240.0)
        assert 0 < n <= 12
        seen.add(n)
        assert np.array_equal(late[n:], plain[:-n]), (seed, n)
        assert not late[:n].any()  # nothing arrived yet: the motors idle
    assert len(seen) == 3  # three seeds, three delays


def _observed_episode(seed: int, delay: dict, n: int = 24):
    env = QuadXHoverEnv(randomize={"observation_delay": delay}, agent_hz=240.0)
    obs, _ = env.reset(seed=seed)
    observations, states = [obs], [env.vehicle.state]
    for _ in range(n):
        obs, *_ = env.step(np.array([0.1, -0.05, 0.0, 0.14]))
        observations.append(obs)
        states.append(env.vehicle.state)
    steps = _drawn_steps(env, "observation_delay")
    assert env.vehicle.latency == (0, steps) and env.latency_steps == (0, steps)
    env.close()
    return np.array(observations), states, steps


def test_a_randomised_observation_delay_shows_the_vehicle_exactly_the_draw_ago():
    state, aux = slice(0, 13), slice(17, 21)  # ang_vel, quaternion, lin_vel, lin_pos | 4 throttles
    seen = set()
    for seed in (0, 3):
        plain, plain_states, zero = _observed_episode(seed, _uniform(0.0, 0.0))
        late, late_states, n = _observed_episode(seed, _uniform(0.0, 0.05))
        assert zero == 0 and 0 < n <= 12
        seen.add(n)
        assert late_states == plain_states  # an observation delay does not change the flight
        assert np.array_equal(late[n:, state], plain[:-n, state])
        assert np.array_equal(late[n:, aux], plain[:-n, aux])
        assert np.array_equal(late[:n, state], np.repeat(plain[:1, state], n, axis=0))  # the spawn, until then
    assert len(seen) == 2


def latency_draws(seed: int) -> str:
    """The delays two resets draw (the second unseeded) and the steps every vehicle got."""
    env = make(randomize={"action_delay": _uniform(0.0, 0.05), "observation_delay": _uniform(0.0, 0.05)})
    out = []
    for s in (seed, None):
        _, info = env.reset(seed=s)
        out.append((info["randomization"], env.unwrapped.vehicle.latency))
    env.close()
    return json.dumps(out)  # floats written exactly (shortest round-trip form)


def test_a_seed_reproduces_its_delays_across_processes_and_seeds_differ():
    root = Path(__file__).resolve().parents[2]
    script = "import sys; from tests.envs.test_latency import latency_draws; print(latency_draws(int(sys.argv[1])))"
    other = subprocess.run([sys.executable, "-c", script, "6"], capture_output=True, text=True, cwd=root, check=True)
    first = latency_draws(6)
    assert first == other.stdout.strip().splitlines()[-1]
    assert first != latency_draws(7)
    (a, steps_a), (b, steps_b) = json.loads(first)
    assert list(a) == ["action_delay", "observation_delay"]  # declaration order
    assert a != b
    assert steps_a == [delay_steps(a[k], 240.0) for k in a] and steps_b == [delay_steps(b[k], 240.0) for k in b]


def test_a_drawn_delay_replaces_the_fixed_one_and_the_other_stays():
    fixed = {"action_delay": 0.025, "observation_delay": 0.0125}  # 6 and 3 physics steps
    env = make(latency=fixed, randomize={"observation_delay": _uniform(0.05, 0.05)})
    env.reset(seed=0)
    assert env.unwrapped.vehicle.latency == (6, 12) and env.unwrapped.latency_steps == (6, 12)
    env.close()
    env = make(latency=fixed, randomize={"action_delay": _uniform(0.0, 0.0)})
    env.reset(seed=0)
    vehicle = env.unwrapped.vehicle
    assert vehicle.latency == (0, 3)
    assert vehicle.stages == {  # no action delay: nothing queues the setpoints
        "before_control": ("deliver_setpoints",),
        "before_loads": ("record_observation", "count_step"),
    }
    env.close()


def _flight(randomize: dict) -> np.ndarray:
    env = QuadXHoverEnv(randomize=randomize)
    rows = [env.reset(seed=1)[0]]
    for _ in range(15):
        rows.append(env.step(np.array([0.1, -0.05, 0.0, 0.14]))[0])
    assert env.vehicle.stages == NO_STAGES and not shadowed_methods(env.vehicle)
    env.close()
    return np.array(rows)


def test_zero_drawn_delays_fly_the_plain_path_bit_for_bit():
    """Delays drawn as 0 against two no-op draws (same use of the seeded stream): the same flight."""
    zero = _flight({"action_delay": _uniform(0.0, 0.0), "observation_delay": _uniform(0.0, 0.0)})
    noop = _flight({"spawn_x": _uniform(0.0, 0.0), "spawn_y": _uniform(0.0, 0.0)})
    assert np.array_equal(zero, noop)


def test_a_vehicle_changes_its_delays_between_resets():
    """6 steps after 2: the response shifts by 6; back to 0 0: the plain methods again."""
    spec = spec_variant(**{"motors.noise_ratio": 0.0})
    world = World([dict(uav=spec, position=(0.0, 0.0, 1.0), mode="motors")], seed=0, agent_hz=240.0)
    vehicle = world.vehicles[0]

    def run() -> np.ndarray:
        world.reset(seed=0)
        vehicle.set_setpoint([0.6, 0.5, 0.6, 0.5])
        out = []
        for _ in range(30):
            world.step()
            out.append(vehicle.motor_throttle)
        return np.array(out)

    plain = run()
    vehicle.set_latency(2, 5)
    vehicle.set_latency(6, 0)
    late = run()
    assert np.array_equal(late[6:], plain[:-6]) and not late[:6].any()
    vehicle.set_latency(0, 0)
    assert vehicle.latency == (0, 0)
    assert vehicle.stages == NO_STAGES and not shadowed_methods(vehicle)
    assert np.array_equal(run(), plain)
    world.close()


@pytest.mark.parametrize(
    ("randomize", "message"),
    [
        ({"action_delay": _uniform(-0.01, 0.02)}, "'action_delay' is a delay"),
        ({"observation_delay": {"distribution": "normal", "mean": 0.01, "std": 0.01}}, "'observation_delay' is a del"),
        ({"action_delay": _uniform(0.0, 10.0)}, "'action_delay': high 10 s is not shorter than the episode"),
        ({"observation_delay": _uniform(0.0, 12.0)}, "'observation_delay': high 12 s is not shorter than the episode"),
        ({"action_delay": _uniform(0.02, 0.01)}, "low must not exceed high"),
    ],
)
def test_impossible_randomised_delays_are_refused_naming_the_key(randomize, message):
    with pytest.raises(ConfigError, match=message):
        make(randomize=randomize)
    from pyflyt_engine.envs.multi_agent.ma_quadx_hover_v0 import parallel_env

    with pytest.raises(ConfigError, match=message):
        parallel_env(randomize=randomize, max_duration_seconds=10.0)


def test_the_episode_length_bounds_a_randomised_delay():
    make(randomize={"action_delay": _uniform(0.0, 1.9)}, max_duration_seconds=2.0).close()
    message = "'action_delay': high 2 s is not shorter than the episode \\(max_duration_seconds 2 s\\)"
    with pytest.raises(ConfigError, match=message):
        make(randomize={"action_delay": _uniform(0.0, 2.0)}, max_duration_seconds=2.0)


def test_multi_agent_envs_apply_one_drawn_delay_to_every_agent():
    from pyflyt_engine.envs.multi_agent.ma_quadx_hover_v0 import parallel_env

    randomize = {"action_delay": _uniform(0.0, 0.05), "observation_delay": _uniform(0.01, 0.05)}
    env = parallel_env(agents=3, randomize=randomize, agent_hz=240.0)
    latencies = set()
    for seed in (0, 1):
        obs, infos = env.reset(seed=seed)
        drawn = env.last_randomization
        steps = tuple(delay_steps(drawn[k], 240.0) for k in ("action_delay", "observation_delay"))
        latencies.add(steps)
        assert steps[1] > 0 and env.latency_steps == steps
        assert all(v.latency == steps for v in env.vehicles)
        assert all(infos[a]["randomization"] == drawn for a in env.agents)
        rows = [obs]
        for _ in range(steps[1] + 3):
            obs, *_ = env.step({a: np.array([0.0, 0.0, 0.0, 0.3]) for a in env.agents})
            rows.append(obs)
        # every agent sees itself as it was the drawn delay ago: the spawn until then
        for agent in env.possible_agents:
            own = np.array([r[agent][:13] for r in rows])
            assert np.array_equal(own[: steps[1] + 1], np.repeat(own[:1], steps[1] + 1, axis=0))
            assert not np.array_equal(own[steps[1] + 1], own[0])
    assert len(latencies) == 2
    env.close()


def test_episodes_with_randomised_latency_record_it_and_verify_exactly(tmp_path):
    randomize = {"action_delay": _uniform(0.0, 0.05), "observation_delay": _uniform(0.0, 0.05)}
    env = RecordEpisode(make(randomize=randomize, latency={"action_delay": 0.01}, wind="dryden_light"), tmp_path)
    draws = []
    for episode in range(2):
        _, info = env.reset(seed=3 if episode == 0 else None)
        draws.append(info["randomization"])
        for _ in range(25):
            *_, terminated, truncated, _ = env.step(np.array([0.05, -0.05, 0.0, 0.14]))
            if terminated or truncated:
                break
    env.close()
    assert draws[0] != draws[1]
    for path, drawn in zip(env.paths, draws):
        episode = load_episode(path)
        assert json.loads(episode.contents.require_metadata("episode")["randomization"]) == drawn
        result = verify(episode, tolerance=0.0)
        assert result.ok and result.max_deviation == 0.0 and result.max_reward_deviation == 0.0, result
    from typer.testing import CliRunner

    from pyflyt_cli.main import app

    cli = CliRunner().invoke(app, ["replay", str(env.paths[1]), "--verify", "--tolerance", "0"])
    assert cli.exit_code == 0 and "verify    OK" in cli.output, cli.output

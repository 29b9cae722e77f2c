"""No env config key is accepted and ignored.

For every field of the env config models (and of the hover tasks' options), either a
non-default value changes what the env does -- its spaces, or the observations, rewards,
terminations and vehicle states of a short seeded flight under a fixed action -- or the
env refuses it at load with a message naming the key, or the key is in an allow-list
below with the reason it legitimately changes none of these.  A new key added to a model
without an entry here fails :func:`test_every_key_is_covered`, so it cannot be silently
ignored by one kind of env.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from pyflyt_engine.envs.config import EnvConfig, MAHoverOptions, MultiAgentEnvConfig
from pyflyt_engine.envs.tasks.hover import HoverOptions
from pyflyt_engine.errors import ConfigError

ACTION = np.array([0.2, -0.1, 0.05, 0.4])
STEPS = 10

PAYLOAD = [
    {
        "name": "ball",
        "body": {"shapes": [{"type": "sphere", "radius": 0.02, "mass": 0.01}]},
        "attach": {"to": "vehicle", "joint": "fixed"},
        "position": [0.0, 0.0, 0.05],
    }
]
CAMERA = {"camera": {"name": "eye", "width": 16, "height": 12}}
OBSTACLES = {"items": [{"type": "box", "size": [2.0, 2.0, 0.1], "position": [0.0, 0.0, 1.4]}]}
RANGE_SENSORS = [{"name": "lidar", "type": "lidar", "horizontal_beams": 8}]
SENSORS = {
    "imu": {"gyro": {"noise_density": 1e-3}},
    "position": {"noise_std": [0.01, 0.01, 0.01]},
    "barometer": {"noise_std": 0.1},
}
NO_DOME = {"contact": {}, "out_of_dome": None, "task_failure": {}, "task_complete": {}, "time_limit": {}}
STACKED = [
    {"spawn": {"position": [0.0, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
    {"spawn": {"position": [0.0, 0.0, 1.6], "position_noise": 0.0, "orientation_noise": 0.0}},
]

#: keys that change no space, observation, reward, termination or state, and why
ALLOWED = {
    "id": "the registered id the config is shipped under: a name",
    "description": "free text shown by `pyflyt envs`",
    "source": "the file the config was read from (not a key a file may set)",
    "render": "the render_mode camera only: what render() shows, nothing the env computes (tests/envs/test_multi_agent.py renders)",
    "name": "selects the task itself: every task has its own tests",
    "task": "holds the task options, each checked here by its own name",
    "backend": "what simulates training; the env classes always fly PyBullet (the batched backend: tests/batched)",
    "controller": "Betaflight's firmware in the loop: tests/firmware (marked firmware: it needs the built SITL)",
    "firmware_action": "what the action is to the firmware: tests/firmware (marked firmware)",
}
#: single-agent only: keys whose effect needs more than one vehicle
ALLOWED_SINGLE = {
    "downwash": "one vehicle has no other rotorcraft's wake to feel (the multi-agent test flies it)",
}

#: key -> (overrides that set the scene, the non-default value); the scene is in both runs
SINGLE: dict[str, tuple[dict[str, Any], Any]] = {
    "uav": ({}, "quadx_f450"),
    "physics_hz": ({}, 480.0),
    "control_hz": ({}, 60.0),
    "agent_hz": ({}, 60.0),
    "max_duration_seconds": ({}, 0.2),
    "flight_dome_size": ({}, 0.5),
    "angle_representation": ({}, "euler"),
    "drag": ({}, False),
    "wind": ({}, "constant"),
    "reward": ({}, "sparse"),
    "reward_presets": ({}, {"dense": "quadx_hover_sparse", "sparse": "quadx_hover_sparse"}),
    "action": (
        {},
        {
            "mode": "rates_thrust",
            "names": ["p", "q", "r", "thrust"],
            "low": [-3.0, -3.0, -3.0, 0.0],
            "high": [3.0, 3.0, 3.0, 0.3],
        },
    ),
    "camera_observation": ({}, CAMERA),
    "payloads": ({}, PAYLOAD),
    # a slab 0.4 m above the spawn point: the climbing vehicle hits it (a crash)
    "obstacles": ({}, OBSTACLES),
    "range_sensors": ({}, RANGE_SENSORS),
    "ground_effect": ({}, True),
    "randomize": ({}, "moderate"),
    "latency": ({}, {"action_delay": 0.02, "observation_delay": 0.02}),
    # the observation built from a noisy gyro, position fix and barometer
    "sensors": ({}, SENSORS),
    # the spawn is outside a 0.5 m dome: without the out_of_dome term the episode goes on
    "terminations": ({"flight_dome_size": 0.5}, NO_DOME),
    # task options
    "start_position": ({}, (0.0, 0.0, 1.5)),
    "start_position_noise": ({}, 0.0),
    "start_orientation": ({}, (0.1, 0.0, 0.0)),
    "start_orientation_noise": ({}, 0.0),
    "start_lin_vel": ({}, (0.5, 0.0, 0.0)),
    "hover_point": ({}, (0.0, 0.0, 2.0)),
}

MULTI: dict[str, tuple[dict[str, Any], Any]] = {
    **{
        k: v
        for k, v in SINGLE.items()
        if k
        not in (
            "start_position",
            "start_position_noise",
            "start_orientation",
            "start_orientation_noise",
            "start_lin_vel",
            "hover_point",
        )
    },
    "reward_presets": ({}, {"dense": "ma_quadx_hover_sparse", "sparse": "ma_quadx_hover_sparse"}),
    "flight_dome_size": ({}, 1.2),
    "downwash": ({"agents": STACKED}, True),
    "agents": ({}, 3),
    # task options (the layout places agents given by count)
    "layout": ({}, "grid"),
    "layout_radius": ({}, 0.5),
    "layout_spacing": ({"layout": "grid"}, 1.5),
    "layout_height": ({}, 1.5),
    "position_noise": ({}, 0.0),
    "orientation_noise": ({}, 0.0),
}
#: multi-agent keys refused at load (none: every key flies both loops, tests/envs/test_multi_agent_parity.py)
REFUSED_MULTI: set[str] = set()


def _fields(config_model: type, options_model: type) -> set[str]:
    return set(config_model.model_fields) | set(options_model.model_fields)


def test_every_key_is_covered():
    single = _fields(EnvConfig, HoverOptions) - set(ALLOWED) - set(ALLOWED_SINGLE)
    assert single == set(SINGLE), f"keys without a check: {sorted(single ^ set(SINGLE))}"
    multi = _fields(MultiAgentEnvConfig, MAHoverOptions) - set(ALLOWED)
    assert multi == set(MULTI), f"keys without a check: {sorted(multi ^ set(MULTI))}"


def _arrays(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _arrays(v) for k, v in sorted(value.items())}
    return np.asarray(value).tolist() if isinstance(value, np.ndarray) else value


def _single_outcome(**overrides: Any) -> list[Any]:
    from pyflyt_engine.envs.quadx import QuadXHoverEnv

    env = QuadXHoverEnv(info_reward_terms=False, **overrides)
    try:
        obs, _ = env.reset(seed=0)
        out: list[Any] = [repr(env.observation_space), repr(env.action_space), _arrays(obs)]
        for _ in range(STEPS):
            obs, reward, terminated, truncated, _ = env.step(ACTION)
            s = env.vehicle.state
            out.append((_arrays(obs), reward, terminated, truncated, [*s.lin_pos, *s.quaternion, *s.lin_vel]))
            if terminated or truncated:
                break
        return out
    finally:
        env.close()


def _multi_outcome(**overrides: Any) -> list[Any]:
    from pyflyt_engine.envs.multi_agent import ma_quadx_hover_v0

    env = ma_quadx_hover_v0.parallel_env(info_reward_terms=False, **overrides)
    try:
        obs, _ = env.reset(seed=0)
        first = env.possible_agents[0]
        out: list[Any] = [repr(env.observation_space(first)), repr(env.action_space(first)), _arrays(obs)]
        for _ in range(STEPS):
            if not env.agents:
                break
            obs, rewards, terminated, truncated, _ = env.step({name: ACTION for name in env.agents})
            states = [[*v.state.lin_pos, *v.state.quaternion, *v.state.lin_vel] for v in env.vehicles]
            out.append((_arrays(obs), _arrays(rewards), _arrays(terminated), _arrays(truncated), states))
        return out
    finally:
        env.close()


@pytest.mark.parametrize("key", sorted(SINGLE))
def test_a_single_agent_key_takes_effect(key):
    scene, value = SINGLE[key]
    assert _single_outcome(**scene, **{key: value}) != _single_outcome(**scene), f"'{key}' is accepted and ignored"


@pytest.mark.parametrize("key", sorted(MULTI))
def test_a_multi_agent_key_takes_effect_or_is_refused(key):
    scene, value = MULTI[key]
    if key in REFUSED_MULTI:
        with pytest.raises(ConfigError, match=key):
            _multi_outcome(**scene, **{key: value})
        return
    assert _multi_outcome(**scene, **{key: value}) != _multi_outcome(**scene), f"'{key}' is accepted and ignored"

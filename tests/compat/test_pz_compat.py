"""The reference-shaped PettingZoo envs: arguments, spaces and observation layout of PyFlyt 0.29.0."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces

from pyflyt_engine.compat.pz_envs import MAFixedwingDogfightEnvV2, MAQuadXHoverEnvV2


def test_ma_hover_defaults_spaces_and_layout():
    env = MAQuadXHoverEnvV2()
    try:
        assert env.possible_agents == ["uav_0", "uav_1", "uav_2", "uav_3"]
        assert env.observation_space("uav_0").shape == (24,)
        np.testing.assert_allclose(env.action_space("uav_0").high, [np.pi, np.pi, np.pi, 0.8])
        assert env.config.agent_hz == 40 and env.config.max_duration_seconds == 30.0
        obs, infos = env.reset(seed=0)
        assert infos == {name: {} for name in env.possible_agents}  # the reference's: empty
        # spawn exactly at the start positions, which close the observation; then, as the
        # reference's end_reset, 10 steps of 1/120 s with idle motors: 1/12 s of free fall
        fall = 0.5 * 9.81 * (1 / 12) ** 2
        for i, name in enumerate(env.possible_agents):
            np.testing.assert_allclose(obs[name][-3:], env.start_pos[i])
            expected = env.start_pos[i] - [0.0, 0.0, fall]
            np.testing.assert_allclose(obs[name][10:13], expected, atol=3e-3)  # lin_pos (quaternion)
        half = {a: np.array([0.0, 0.0, 0.0, 0.5]) for a in env.agents}
        obs, *_ = env.step(half)
        assert env.vehicles[0].setpoint[3] > 0.125  # mode 0 thrust is a motor command, 0.5 above hover
        # PyFlyt 0.29.0 MAQuadXBaseEnv observes past_actions: the action before the one just applied
        np.testing.assert_allclose(obs["uav_0"][17:21], [0.0, 0.0, 0.0, 0.0])
        obs, *_ = env.step(half)
        np.testing.assert_allclose(obs["uav_0"][17:21], [0.0, 0.0, 0.0, 0.5])
    finally:
        env.close()
    euler = MAQuadXHoverEnvV2(angle_representation="euler", start_pos=np.array([[0.0, 0.0, 1.0]]),
                              start_orn=np.zeros((1, 3)), flight_mode=7)
    try:
        assert euler.possible_agents == ["uav_0"] and euler.observation_space("uav_0").shape == (23,)
    finally:
        euler.close()


@pytest.mark.parametrize(
    "kwargs, shape, actions",
    [
        (dict(), (65,), 4),
        (dict(team_size=1), (23 + 14,), 4),
        (dict(team_size=3), (23 + 5 * 14,), 4),
        (dict(assisted_flight=False), (25 + 3 * 14,), 6),
    ],
)
def test_dogfight_spaces_are_the_references(kwargs, shape, actions):
    env = MAFixedwingDogfightEnvV2(**kwargs)
    try:
        assert len(env.possible_agents) == 2 * kwargs.get("team_size", 2)
        assert env.observation_space("uav_0").shape == shape
        assert env.action_space("uav_0").shape == (actions,)
        np.testing.assert_allclose(env.action_space("uav_0").low, -1.0)
        obs, infos = env.reset(seed=1)
        assert "received_hits" in infos["uav_0"]
        obs, *_ , infos = env.step({a: env.action_space(a).sample() for a in env.agents})
        assert {"health", "received_hits"} <= set(infos["uav_0"])
        assert obs["uav_0"].shape == shape
    finally:
        env.close()


def test_dogfight_dict_observation_and_damage_rate():
    env = MAFixedwingDogfightEnvV2(team_size=1, flatten_observation=False, damage_per_hit=0.01)
    try:
        space = env.observation_space("uav_0")
        assert isinstance(space, spaces.Dict) and space["self"].shape == (23,)
        obs, _ = env.reset(seed=0)
        assert obs["uav_0"]["others"].shape == (1, 14) and space.contains(obs["uav_0"])
        assert env.config.task.damage_per_second == pytest.approx(1.2)  # per 120 Hz step in the reference
    finally:
        env.close()
    with pytest.warns(UserWarning, match="aggressiveness"):
        MAFixedwingDogfightEnvV2(team_size=1, aggressiveness=0.9).close()

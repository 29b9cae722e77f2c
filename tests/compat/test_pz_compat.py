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
        assert env.env_step_ratio == 3 and env.max_steps == 40 * 30  # 40 Hz, 30 s
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
        # mode 0 thrust is a motor command: 0.5 is above the 0.3 hover command, so above the
        # native airframe's hover thrust fraction
        assert env.world.vehicles[0].setpoint[3] > 0.125
        # PyFlyt 0.29.0 MAQuadXBaseEnv observes past_actions: the action before the one just applied
        np.testing.assert_allclose(obs["uav_0"][17:21], [0.0, 0.0, 0.0, 0.0])
        obs, *_ = env.step(half)
        np.testing.assert_allclose(obs["uav_0"][17:21], [0.0, 0.0, 0.0, 0.5])
    finally:
        env.close()
    euler = MAQuadXHoverEnvV2(
        angle_representation="euler", start_pos=np.array([[0.0, 0.0, 1.0]]), start_orn=np.zeros((1, 3)), flight_mode=7
    )
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
        assert infos == {a: {} for a in env.possible_agents}  # PyFlyt 0.29.0: empty reset infos
        obs, *_, infos = env.step({a: env.action_space(a).sample() for a in env.agents})
        assert {"health", "received_hits"} <= set(infos["uav_0"])
        assert obs["uav_0"].shape == shape
    finally:
        env.close()


def test_ma_hover_is_the_references_base_env_and_a_subclass_reshapes_its_reward():
    from pyflyt_engine.compat.pz_envs.quadx_envs.ma_quadx_base_env import MAQuadXBaseEnv

    class StayLow(MAQuadXHoverEnvV2):
        def compute_term_trunc_reward_info_by_id(self, agent_id):
            term, trunc, _, info = super().compute_term_trunc_reward_info_by_id(agent_id)
            return term, trunc, -float(self.aviary.state(agent_id)[-1][2]), info

    env = StayLow()
    try:
        assert isinstance(env, MAQuadXBaseEnv)
        env.reset(seed=0)
        _, rewards, *_ = env.step({a: np.array([0.0, 0.0, 0.0, 0.3]) for a in env.agents})
        # summed over the 3 Aviary steps of the agent step: about -3 x the height (~0.9 m)
        for i, agent in enumerate(env.possible_agents):
            height = env.aviary.state(i)[-1][2]
            assert -3.0 * height - 0.1 < rewards[agent] < -3.0 * height + 0.1
    finally:
        env.close()


def test_dogfight_is_the_references_base_env_with_its_hooks():
    from pyflyt_engine.compat.pz_envs.fixedwing_envs.ma_fixedwing_base_env import MAFixedwingBaseEnv

    env = MAFixedwingDogfightEnvV2(team_size=1)
    try:
        assert isinstance(env, MAFixedwingBaseEnv)
        env.reset(seed=3)
        # spawned at 20 m/s along the nose (the reference's starting_velocity, a ground-frame
        # vector): after the 10 settling steps the body velocity is still nearly all forward
        for i in range(2):
            _, ang_pos, lin_vel, _ = env.aviary.state(i)
            assert lin_vel[0] > 19.0 and np.hypot(lin_vel[1], lin_vel[2]) < 0.5
            assert abs(ang_pos[2] - (env.start_orn[i, 2] + np.pi) % (2 * np.pi) + np.pi) < 0.05
        assert env.aviary.world is env.world
        rotation, forward = env.compute_rotation_forward(np.array([[0.0, 0.0, np.pi / 2], [0.0, -np.pi / 2, 0.0]]))
        np.testing.assert_allclose(forward, [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], atol=1e-12)
        np.testing.assert_allclose(rotation[:, :, 0], forward, atol=1e-12)  # the nose is the body x axis
    finally:
        env.close()


def _one_behind_the_other(env):
    """1 v 1 by hand: uav_0 at 100 m heading +x, uav_1 10 m ahead of it heading +x (uav_0 has it
    dead ahead, 10 m < lethal_distance; uav_1 has uav_0 behind it)."""
    attitudes = np.zeros((2, 4, 3))
    attitudes[0, 3] = [0.0, 0.0, 100.0]
    attitudes[1, 3] = [10.0, 0.0, 100.0]
    attitudes[:, 2, 0] = 20.0
    env.attitudes = attitudes
    (
        env.in_cone,
        env.in_range,
        env.chasing,
        env.current_hits,
        env.current_distances,
        env.current_angles,
        env.current_offsets,
        env.other_attitudes,
        env.distances_from_origin,
    ) = env._compute_combat_state()
    env.current_hits &= env.friendly_fire_mask


@pytest.mark.parametrize("aggressiveness", [0.5, 0.9])
def test_dogfight_hit_rewards_follow_the_references_formula(aggressiveness):
    env = MAFixedwingDogfightEnvV2(team_size=1, sparse_reward=True, aggressiveness=aggressiveness)
    try:
        env.reset(seed=0)
        _one_behind_the_other(env)
        np.testing.assert_array_equal(env.current_hits, [[False, True], [False, False]])
        np.testing.assert_allclose(env.current_angles[0, 1], 0.0, atol=1e-12)
        np.testing.assert_allclose(env.current_angles[1, 0], np.pi, atol=1e-12)
        np.testing.assert_allclose(env.current_distances[0, 1], 10.0)
        # uav_1 in uav_0's body frame: 10 m ahead; same velocity: no relative velocity
        np.testing.assert_allclose(env.other_attitudes[0, 1, 3], [10.0, 0.0, 0.0], atol=1e-12)
        np.testing.assert_allclose(env.other_attitudes[0, 1, 2], [0.0, 0.0, 0.0], atol=1e-12)
        # sparse (PyFlyt 0.29.0): 20 per hit given, -(1 - aggressiveness) 20 per hit taken,
        # + cooperativeness (0.5) x the hits its own team gave
        np.testing.assert_allclose(
            env._compute_engagement_rewards(), [20.0 + 0.5, -20.0 * (1.0 - aggressiveness)], rtol=1e-6
        )
        np.testing.assert_array_equal(env._compute_boundary_rewards(), [0.0, 0.0])
    finally:
        env.close()


def test_dogfight_dense_terms_follow_the_references_formula():
    env = MAFixedwingDogfightEnvV2(team_size=1)
    try:
        env.reset(seed=0)
        _one_behind_the_other(env)
        env.previous_distances = env.current_distances + 1.0  # closed 1 m, but already in range: no term
        env.previous_angles = env.current_angles.copy()
        aim = 3.0 / (0.0 + 0.1)  # uav_0 aims dead at uav_1, in range and ahead
        expected = [20.0 + 0.5 + aim, -10.0 - 0.5 * aim]
        np.testing.assert_allclose(env._compute_engagement_rewards(), expected, rtol=1e-6)
        # height 100 m, 100 m from the origin, 10 m apart (not too close)
        boundary = np.tanh(0.1 * 100.0 - 1.0) - np.tanh(0.0025 * np.array([100.0, np.hypot(10.0, 100.0)]) - 1.0)
        np.testing.assert_allclose(env._compute_boundary_rewards(), boundary, rtol=1e-6)
    finally:
        env.close()


class _Uav0AlwaysHits(MAFixedwingDogfightEnvV2):
    """The geometry as flown, but uav_0 has uav_1 in its sights at every 1/120 s step."""

    def _compute_combat_state(self):
        state = list(super()._compute_combat_state())
        state[3] = np.array([[False, True], [False, False]])
        return tuple(state)


def test_dogfight_damage_is_per_120_hz_step_and_ends_the_target():
    env = _Uav0AlwaysHits(team_size=1, flatten_observation=False, damage_per_hit=0.01)
    try:
        space = env.observation_space("uav_0")
        assert isinstance(space, spaces.Dict) and space["self"].shape == (23,)
        obs, _ = env.reset(seed=0)
        assert obs["uav_0"]["others"].shape == (1, 14) and space.contains(obs["uav_0"])
        # the reference's end_reset judges once after its 10 settling steps: one hit already
        assert env.received_hits.tolist() == [0, 1]
        steps = env.env_step_ratio  # 4 Aviary steps per agent step at 30 Hz
        level = {a: np.array([0.0, 0.0, 0.0, 0.5]) for a in env.agents}
        _, rewards, terms, _, infos = env.step(level)
        assert infos["uav_1"]["received_hits"] == 1 + steps
        assert infos["uav_1"]["health"] == pytest.approx(1.0 - 0.01 * (1 + steps), abs=1e-6)
        assert not any(terms.values())
        # health 0 after 100 hits (1 + 4 x 25 > 100): uav_1 is dead (terminated) and uav_0's
        # side wins (its reward set to 300), both in the 25th step
        while env.agents:
            _, rewards, terms, _, infos = env.step(level)
        assert env.step_count == 25 and env.received_hits[1] == 1 + 25 * steps
        assert terms == {"uav_0": True, "uav_1": True}
        assert infos["uav_1"]["dead"] and infos["uav_1"]["health"] == 0.0
        assert infos["uav_0"]["team_win"] and rewards["uav_0"] == 300.0
    finally:
        env.close()


def test_dogfight_truncates_once_step_count_exceeds_max_steps():
    # PyFlyt 0.29.0: update_states truncates when step_count > max_steps, and step_count counts
    # up after the Aviary steps: the episode's last step is step max_steps + 2
    env = MAFixedwingDogfightEnvV2(team_size=1, max_duration_seconds=1.0, flight_dome_size=5000.0)
    try:
        env.reset(seed=0)
        assert env.max_steps == 30
        steps = 0
        while env.agents:
            _, _, terms, truncs, _ = env.step({a: np.array([0.0, 0.0, 0.0, 0.5]) for a in env.agents})
            steps += 1
        assert steps == env.max_steps + 2 and all(truncs.values()) and not any(terms.values())
    finally:
        env.close()

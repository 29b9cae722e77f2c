"""MAQuadX-Formation and swarm layouts: grid slots, the spacing rule, neighbours, rewards, resets, 128 agents.

Oracles: the grid slot formula evaluated by hand; the spacing rule from the airframe's
collision box; the neighbour block and the shape error recomputed by brute force over all
pairs from the vehicles' states; the dense reward formula; seeded resets that restore
every number exactly.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from pyflyt_engine.envs.config import MAX_AGENTS, grid_layout, load_env_config
from pyflyt_engine.envs.multi_agent import ma_quadx_formation_v0, ma_quadx_hover_v0
from pyflyt_engine.errors import ConfigError

HOVER = np.array([0.0, 0.0, 0.0, 0.125])  # level, thrust = weight for the 8:1 cf2x
CF2X_RADIUS = math.sqrt(0.045**2 + 0.045**2 + 0.01**2)  # its collision box: 0.09 x 0.09 x 0.02 m


def test_grid_slots_by_hand():
    # 5 agents: 3 columns, 2 rows, centred on the z axis
    slots = [grid_layout(i, 5, 2.0, 1.5) for i in range(5)]
    assert slots == [(-2.0, -1.0, 1.5), (0.0, -1.0, 1.5), (2.0, -1.0, 1.5), (-2.0, 1.0, 1.5), (0.0, 1.0, 1.5)]
    assert grid_layout(0, 1, 1.0, 1.0) == (0.0, 0.0, 1.0)
    # 128 agents: 12 columns, 11 rows, every slot distinct and at least one spacing apart
    big = [grid_layout(i, 128, 0.7, 1.0) for i in range(128)]
    gaps = [math.dist(a, b) for a, b in itertools.combinations(big, 2)]
    assert min(gaps) == pytest.approx(0.7)
    assert max(abs(x) for x, _, _ in big) == pytest.approx(5.5 * 0.7)


def test_the_spacing_rule_refuses_layouts_whose_agents_could_touch():
    need = 2 * CF2X_RADIUS + 2 * math.sqrt(3) * 0.05
    with pytest.raises(ConfigError, match=r"task.layout_spacing to at least 0\.30"):
        ma_quadx_formation_v0.parallel_env(agents=4, layout_spacing=need * 0.99)
    env = ma_quadx_formation_v0.parallel_env(agents=4, layout_spacing=need * 1.01)
    env.close()
    # the hover ring: 64 agents on a 1 m ring are 0.098 m apart; the message gives both ways out
    with pytest.raises(ConfigError, match=r"task.layout_radius to at least .*layout: grid"):
        ma_quadx_hover_v0.parallel_env(agents=64)
    # listed agents are placed by the user and not checked (touching on purpose is allowed)
    touching = [{"spawn": {"position": [0.0, 0.0, 1.0]}}, {"spawn": {"position": [0.05, 0.0, 1.0]}}]
    ma_quadx_formation_v0.parallel_env(agents=touching).close()


def test_the_agent_limit():
    assert MAX_AGENTS == 128
    with pytest.raises(ConfigError, match="129 is more than the 128 agents"):
        load_env_config("ma_quadx_formation").with_overrides(agents=129)
    with pytest.raises(ConfigError, match="129 listed"):
        load_env_config("ma_quadx_formation").with_overrides(agents=[{"name": f"a{i}"} for i in range(129)])


def _brute_force(env, live):
    """Per live agent: the K nearest live neighbours (offsets, nearest first) within the
    radius, the nearest distance and the shape error, over all pairs."""
    opts = env.config.task
    pos = {i: np.array(env.vehicles[i].state.lin_pos) for i in live}
    slots0 = {i: np.array(env.agent_list[i].hover_point) for i in live}
    centroid = np.mean([pos[i] for i in live], axis=0)
    slot_centroid = np.mean([slots0[i] for i in live], axis=0)
    out = {}
    for i in live:
        others = sorted((float(np.sum((pos[j] - pos[i]) ** 2)), j) for j in live if j != i)
        near = [(d2, j) for d2, j in others if d2 <= opts.neighbour_radius**2][: opts.neighbours]
        block = np.zeros(4 * opts.neighbours)
        for k, (_, j) in enumerate(near):
            block[4 * k : 4 * k + 4] = [*(pos[j] - pos[i]), 1.0]
        nearest = math.sqrt(others[0][0]) if others else math.inf
        shape = float(np.sqrt(np.sum(((pos[i] - centroid) - (slots0[i] - slot_centroid)) ** 2)))
        out[i] = (block, nearest, shape)
    return out


def test_neighbours_shape_error_and_dense_reward_match_brute_force():
    # 9 agents 0.6 m apart, 2 m neighbour radius: each sees some but not all of the others
    env = ma_quadx_formation_v0.parallel_env(agents=9, layout_spacing=0.6, neighbour_radius=1.0, neighbours=4)
    obs, infos = env.reset(seed=3)
    rng = np.random.default_rng(0)
    opts = env.config.task
    for step in range(12):
        live = [env.agent_index[a] for a in env.agents]
        actions = {a: HOVER + np.array([*rng.uniform(-0.3, 0.3, 3), rng.uniform(-0.02, 0.02)]) for a in env.agents}
        obs, rewards, terminated, truncated, infos = env.step(actions)
        truth = _brute_force(env, live)
        t = (step + 1) / env.config.agent_hz
        for i in live:
            name = env.possible_agents[i]
            block, nearest, shape = truth[i]
            assert np.array_equal(obs[name][-4 * opts.neighbours :], block) or np.allclose(
                obs[name][-4 * opts.neighbours :], block, rtol=0, atol=1e-12
            )
            assert infos[name]["nearest_neighbour"] == pytest.approx(nearest, abs=1e-12)
            assert infos[name]["formation_error"] == pytest.approx(shape, abs=1e-12)
            slot = np.array(env.agent_list[i].hover_point) + np.array(opts.velocity) * t
            position = np.array(env.vehicles[i].state.lin_pos)
            assert obs[name][-4 * opts.neighbours - 6 : -4 * opts.neighbours - 3] == pytest.approx(slot - position)
            assert obs[name][-4 * opts.neighbours - 3 : -4 * opts.neighbours] == pytest.approx(opts.velocity)
            if not terminated[name]:
                roll, pitch = env.vehicles[i].state.ang_pos[:2]
                expected = (
                    1.0
                    - np.linalg.norm(slot - position)
                    - shape
                    - max(0.0, 1.0 - nearest / opts.separation)
                    - 0.1 * math.hypot(roll, pitch)
                )
                assert rewards[name] == pytest.approx(expected, abs=1e-9)
        if not env.agents:
            break
    env.close()


def test_sparse_reward_pays_only_in_formation():
    env = ma_quadx_formation_v0.parallel_env(agents=4, sparse_reward=True, position_noise=0.0, orientation_noise=0.0,
                                             velocity=(0.0, 0.0, 0.0))  # fmt: skip
    env.reset(seed=0)
    _, rewards, _, _, infos = env.step({a: HOVER for a in env.agents})
    for name, reward in rewards.items():
        inside = infos[name]["target_distance"] <= 0.25 and infos[name]["formation_error"] <= 0.25
        assert inside and reward == pytest.approx(0.1)
    env.close()
    # a formation moving at 5 m/s leaves hovering agents behind: no reward
    env = ma_quadx_formation_v0.parallel_env(agents=4, sparse_reward=True, velocity=(5.0, 0.0, 0.0))
    env.reset(seed=0)
    for _ in range(3):
        _, rewards, *_ = env.step({a: HOVER for a in env.agents})
    assert all(r == 0.0 for r in rewards.values())
    env.close()


def _snapshot(env, obs) -> bytes:
    rows = [np.asarray(obs[a], dtype=np.float64) for a in sorted(obs)]
    rows += [np.asarray(v.state.as_array(), dtype=np.float64).ravel() for v in env.vehicles]
    return b"".join(r.tobytes() for r in rows)


def test_128_agents_spawn_apart_and_reset_exactly():
    """The largest swarm: no two spawns closer than the spacing rule allows, no contact
    in the first steps, and a seeded reset after flying restores every number."""
    env = ma_quadx_formation_v0.parallel_env(agents=128, layout_spacing=0.5)
    obs, _ = env.reset(seed=11)
    first = _snapshot(env, obs)
    positions = np.array([v.state.lin_pos for v in env.vehicles])
    gaps = [math.dist(a, b) for a, b in itertools.combinations(positions.tolist(), 2)]
    assert min(gaps) >= 2 * CF2X_RADIUS  # the rule: even with the noise drawn, bounding spheres apart
    assert min(gaps) >= 0.5 - 2 * math.sqrt(3) * 0.05
    for _ in range(2):
        obs, _, terminated, _, infos = env.step({a: HOVER for a in env.agents})
    assert not any(info["collision"] for info in infos.values())
    assert len(env.agents) == 128
    again, _ = env.reset(seed=11)
    assert _snapshot(env, again) == first
    env.close()


def test_a_formation_with_downwash_is_deterministic_and_downwash_takes_effect():
    def run(**kw):
        env = ma_quadx_formation_v0.parallel_env(agents=[
            {"spawn": {"position": [0.0, 0.0, 1.0]}},
            {"spawn": {"position": [0.05, 0.0, 1.6]}},  # above the first: its wake reaches it
            {"spawn": {"position": [1.0, 0.0, 1.0]}},
        ], **kw)  # fmt: skip
        obs, _ = env.reset(seed=2)
        out = [_snapshot(env, obs)]
        for _ in range(10):
            obs, *_ = env.step({a: HOVER for a in env.agents})
            out.append(_snapshot(env, obs))
        env.close()
        return out

    assert run() == run()
    assert run() != run(downwash=False)


@pytest.mark.parametrize(
    ("neighbours", "angles", "size"), [(3, "quaternion", 39), (1, "quaternion", 31), (3, "euler", 38)]
)
def test_the_observation_is_as_long_as_the_manual_says(neighbours, angles, size):
    """The manual's ``Box(27 + 4 K,)`` (``26 + 4 K`` with Euler angles): the attitude vector's
    21 (20), the slot offset and the formation's velocity, 4 per neighbour."""
    from pyflyt_engine.envs.multi_agent.formation import MAQuadXFormationEnv

    cfg = load_env_config("ma_quadx_formation").with_overrides(
        agents=4, neighbours=neighbours, angle_representation=angles
    )
    env = MAQuadXFormationEnv(cfg)
    try:
        assert env.observation_space(env.possible_agents[0]).shape == (size,)
        assert size == (27 if angles == "quaternion" else 26) + 4 * neighbours
    finally:
        env.close()

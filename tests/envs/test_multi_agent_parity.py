"""Every env config key flies a multi-agent env as it flies a single-agent one, or is refused.

A multi-agent env with one agent spawned where ``QuadX-Hover-v0`` spawns, with the same
noise and seed, draws the same numbers in the same order and flies bit-identically; so
for each key that changes the physics, the one-agent multi-agent trajectory with the key
must equal the single-agent one with the key, and differ from the flight without it.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.envs.multi_agent import ma_quadx_hover_v0
from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv
from pyflyt_engine.envs.quadx import QuadXHoverEnv
from pyflyt_engine.errors import ConfigError

ACTION = np.array([0.2, -0.1, 0.05, 0.4])
STEPS = 12


def _row(vehicle) -> list[float]:
    s = vehicle.state
    return [*s.lin_pos, *s.quaternion, *s.lin_vel, *s.ang_vel, *vehicle.aux_state]


def single(**overrides) -> np.ndarray:
    env = QuadXHoverEnv(**overrides)
    try:
        env.reset(seed=3)
        rows = [_row(env.vehicle)]
        for _ in range(STEPS):
            env.step(ACTION)
            rows.append(_row(env.vehicle))
        return np.array(rows)
    finally:
        env.close()


def multi(agents=1, seed: int = 3, **overrides) -> np.ndarray:
    """Every vehicle's state per step, (steps + 1, N, fields)."""
    env = ma_quadx_hover_v0.parallel_env(agents=agents, **overrides)
    try:
        env.reset(seed=seed)
        rows = [[_row(v) for v in env.vehicles]]
        for _ in range(STEPS):
            env.step({name: ACTION for name in env.agents})
            rows.append([_row(v) for v in env.vehicles])
        return np.array(rows)
    finally:
        env.close()


@pytest.mark.parametrize(
    "key, value",
    [
        ("wind", "constant"),
        ("wind", "shear"),
        ("wind", "dryden_severe"),
        ("randomize", "moderate"),
        ("randomize", {"mass": {"distribution": "uniform", "low": 1.2, "high": 1.3}}),
        ("randomize", {"spawn_z": {"distribution": "uniform", "low": 0.2, "high": 0.3}}),
        ("randomize", {"action_delay": {"distribution": "uniform", "low": 0.02, "high": 0.05}}),
        ("ground_effect", True),
        ("drag", False),
    ],
    ids=lambda v: str(v)[:24],
)
def test_a_key_changes_one_agent_exactly_as_the_single_agent_env(key, value):
    alone = single(**{key: value})
    assert not np.array_equal(alone, single()), f"{key}={value!r} does not change the single-agent flight"
    together = multi(**{key: value})[:, 0]
    np.testing.assert_array_equal(together, alone)


def test_the_one_agent_flight_without_keys_is_the_single_agent_one():
    np.testing.assert_array_equal(multi()[:, 0], single())


def test_randomisation_applies_the_same_draws_to_every_agent_and_reports_them():
    env = ma_quadx_hover_v0.parallel_env(randomize={"mass": {"distribution": "uniform", "low": 1.2, "high": 1.3}})
    try:
        _, infos = env.reset(seed=0)
        drawn = env.last_randomization["mass"]
        assert 1.2 <= drawn <= 1.3
        for name, vehicle in zip(env.possible_agents, env.vehicles):
            assert infos[name]["randomization"] == {"mass": drawn}
            assert vehicle.dry_mass == pytest.approx(vehicle.parts.mass * drawn, rel=1e-12)
        free = multi(agents=4)
        assert not np.array_equal(multi(agents=4, randomize="moderate"), free)
    finally:
        env.close()


STACKED = [
    {"spawn": {"position": [0.0, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
    {"spawn": {"position": [0.0, 0.0, 1.6], "position_noise": 0.0, "orientation_noise": 0.0}},
]


def test_downwash_reaches_the_agent_below_and_leaves_a_lone_vehicle_alone():
    calm = multi(agents=STACKED)
    washed = multi(agents=STACKED, downwash=True)
    assert not np.array_equal(washed[:, 0], calm[:, 0]), "the lower agent does not feel the upper one's wake"
    np.testing.assert_array_equal(washed[:, 1], calm[:, 1])  # nothing above the upper one
    # one vehicle has no other rotorcraft's wake to feel, single- or multi-agent
    np.testing.assert_array_equal(single(downwash=True), single())
    np.testing.assert_array_equal(multi(downwash=True)[:, 0], single(downwash=True))


class _TouchingHover(MAQuadXHoverEnv):
    crash_on_contact = False


def test_crash_on_contact_false_keeps_touching_agents_in_the_episode():
    falling = np.zeros(4)  # motors off: every agent drops onto the ground
    for cls, retired in ((MAQuadXHoverEnv, True), (_TouchingHover, False)):
        env = cls(agents=2)
        try:
            env.reset(seed=0)
            touched = False
            for _ in range(40):
                if not env.agents:
                    break
                _, _, terminated, _, infos = env.step({name: falling for name in env.agents})
                touched |= any(info["collision"] for info in infos.values())
                if not retired:
                    assert not any(terminated.values())
            assert touched
            assert (not env.agents) == retired
        finally:
            env.close()


@pytest.mark.parametrize(
    "key, value",
    [
        (
            "payloads",
            [
                {
                    "name": "pole",
                    "body": {"shapes": [{"type": "sphere", "radius": 0.02, "mass": 0.01}]},
                    "attach": {"to": "vehicle", "joint": "fixed"},
                }
            ],
        ),
        ("camera_observation", {"camera": {"name": "eye"}}),
        ("obstacles", {"items": [{"type": "sphere", "radius": 0.2, "position": [2.0, 0.0, 1.0]}]}),
        ("range_sensors", [{"name": "lidar", "type": "lidar"}]),
    ],
)
def test_keys_a_multi_agent_env_cannot_fly_are_refused_at_load_by_name(key, value):
    with pytest.raises(ConfigError, match=key):
        ma_quadx_hover_v0.parallel_env(**{key: value})


def test_episode_options_are_refused_not_ignored():
    env = ma_quadx_hover_v0.parallel_env()
    try:
        with pytest.raises(ValueError, match="layout_radius"):
            env.reset(seed=0, options={"task": {"layout_radius": 2.0}})
        with pytest.warns(UserWarning, match="curriculum"):
            env.reset(seed=0, options={"curriculum": 1})
        env.reset(seed=0, options={"task": {}})  # no change is fine
    finally:
        env.close()


@pytest.mark.parametrize(
    "randomize",
    [
        "moderate",
        {
            "mass": {"distribution": "uniform", "low": 0.9, "high": 1.1},
            "action_delay": {"distribution": "uniform", "low": 0.0, "high": 0.05},
            "observation_delay": {"distribution": "uniform", "low": 0.0, "high": 0.05},
        },
    ],
    ids=["moderate", "latency"],
)
def test_a_recording_in_wind_with_randomisation_replays_exactly(tmp_path, randomize):
    from pyflyt_engine.envs import make_env
    from pyflyt_engine.telemetry import RecordEpisode, load_episode
    from pyflyt_engine.telemetry.replay import verify

    env = RecordEpisode(
        make_env("ma_quadx_hover", agents=STACKED, wind="dryden_moderate", randomize=randomize, downwash=True),
        tmp_path,
    )
    _, info = env.reset(seed=2)
    assert set(info["randomization"]) == set(env.unwrapped.last_randomization)
    for _ in range(20):
        *_, terminated, truncated, _ = env.step(np.tile(ACTION, (2, 1)))
        if terminated or truncated:
            break
    env.close()
    episode = load_episode(env.paths[0])
    assert episode.env_info["wind"] and "turbulence" in episode.env_info["wind"]
    result = verify(episode)
    assert result.ok and result.max_deviation == 0.0

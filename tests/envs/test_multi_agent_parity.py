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
from pyflyt_engine.envs.tasks.ma_hover import MAHoverTask
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


SENSORS = {
    "imu": {"gyro": {"noise_density": 1e-3}},
    "position": {"noise_std": [0.01, 0.01, 0.01]},
    "barometer": {"noise_std": 0.1},
}


def _observations(env, steps: int, multi_agent: bool) -> list[np.ndarray]:
    """The observations of one episode of ``steps`` steps (the first agent's when several fly)."""
    obs, _ = env.reset(seed=3)
    out = [obs[env.possible_agents[0]] if multi_agent else obs]
    for _ in range(steps):
        if multi_agent:
            obs, *_ = env.step({name: ACTION for name in env.agents})
            out.append(obs[env.possible_agents[0]])
        else:
            obs, *_ = env.step(ACTION)
            out.append(obs)
    return out


def test_noisy_sensors_build_one_agents_observation_as_the_single_agent_envs():
    """``sensors`` flies both loops alike: the one agent observes the gyro, the position fix
    and the barometer with the same draws as the single-agent env (its attitude vector, and
    the fix flag after its aux, bit for bit), and the observation differs from the true one."""
    flights = {}
    for sensors in (None, SENSORS):
        extra = {} if sensors is None else {"sensors": sensors}
        alone_env, multi_env = QuadXHoverEnv(**extra), ma_quadx_hover_v0.parallel_env(agents=1, **extra)
        try:
            alone = _observations(alone_env, STEPS, False)
            together = _observations(multi_env, STEPS, True)
            assert multi_env.observation_space(multi_env.possible_agents[0]).shape[0] == alone[0].size + 3
        finally:
            alone_env.close()
            multi_env.close()
        for a, m in zip(alone, together):
            np.testing.assert_array_equal(m[:-3], a)
        flights[sensors is None] = np.array(alone)
    true, sensed = flights[True], flights[False]
    assert sensed.shape[1] == true.shape[1] + 1  # the position fix's validity flag
    assert not np.array_equal(sensed[:, :3], true[:, :3]), "the gyro does not reach the observation"
    # a multi-agent observation with sensors keeps the layout: every agent its own sensors
    env = ma_quadx_hover_v0.parallel_env(agents=3, sensors=SENSORS)
    try:
        obs, _ = env.reset(seed=0)
        assert all(env.observation_space(n).contains(obs[n]) for n in env.possible_agents)
        assert all(v.sensors is not None for v in env.vehicles)
    finally:
        env.close()


def test_the_estimator_builds_one_agents_observation_as_the_single_agent_envs():
    """``sensors.estimator`` flies both loops alike: the one agent observes its estimator's
    attitude, velocity and position bit for bit as the single-agent env does, which differ
    from the sensed-only observation; with several agents each has its own estimator."""
    estimated = {**SENSORS, "estimator": {"type": "complementary"}}
    flights = {}
    for sensors in (SENSORS, estimated):
        alone_env = QuadXHoverEnv(sensors=sensors)
        multi_env = ma_quadx_hover_v0.parallel_env(agents=1, sensors=sensors)
        try:
            alone = _observations(alone_env, STEPS, False)
            together = _observations(multi_env, STEPS, True)
        finally:
            alone_env.close()
            multi_env.close()
        for a, m in zip(alone, together):
            np.testing.assert_array_equal(m[:-3], a)
        flights[sensors is estimated] = np.array(alone)
    # attitude (quaternion) and velocity: estimated, not true
    assert not np.array_equal(flights[True][1:, 3:10], flights[False][1:, 3:10])
    env = ma_quadx_hover_v0.parallel_env(agents=3, sensors=estimated)
    try:
        env.reset(seed=0)
        assert env.estimators is not None and len({id(e) for e in env.estimators}) == 3
        assert all(v.sensors.estimator is e for v, e in zip(env.vehicles, env.estimators))
    finally:
        env.close()


CAMERA = {"camera": {"name": "eye", "width": 16, "height": 12}}
LIDAR = [{"name": "lidar", "type": "lidar", "horizontal_beams": 8, "vertical_beams": 3, "vertical_fov_deg": 120.0}]


def _dict_observations(env, multi_agent: bool) -> list[dict]:
    out = []
    for obs in _observations(env, STEPS, multi_agent):
        out.append({k: np.array(v, copy=True) for k, v in obs.items()})
    return out


@pytest.mark.parametrize("key, value", [("range_sensors", LIDAR), ("camera_observation", CAMERA)])
def test_range_sensors_and_camera_images_reach_one_agent_as_the_single_agent_env(key, value):
    """The observation becomes a Dict in both loops: the readings (one seeded stream per
    sensor of each vehicle slot) and the camera image equal the single-agent env's bit for
    bit, and differ from step to step as the vehicle moves."""
    alone_env = QuadXHoverEnv(**{key: value})
    multi_env = ma_quadx_hover_v0.parallel_env(agents=1, **{key: value})
    try:
        alone = _dict_observations(alone_env, False)
        together = _dict_observations(multi_env, True)
        space = multi_env.observation_space(multi_env.possible_agents[0])
        assert set(space.spaces) == set(alone_env.observation_space.spaces)
    finally:
        alone_env.close()
        multi_env.close()
    name = "lidar" if key == "range_sensors" else "image"
    for a, m in zip(alone, together):
        np.testing.assert_array_equal(m[name], a[name])
        np.testing.assert_array_equal(m["attitude"][:-3], a["attitude"])
        assert space.contains(m)
    assert not all(np.array_equal(alone[0][name], a[name]) for a in alone[1:]), f"{key} readings never change"


def test_every_agent_observes_its_own_range_sensors():
    """Two agents at 1 m and 2 m, each with a beam looking straight down: each reads its own
    height above the ground (the rays skip every sensor-carrying vehicle, so neither sees
    the other: pyflyt_engine/components/range_sensor.py)."""
    stacked = [
        {"spawn": {"position": [0.0, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
        {"spawn": {"position": [1.0, 0.0, 2.0], "position_noise": 0.0, "orientation_noise": 0.0}},
    ]
    down = [
        {
            "name": "down",
            "type": "lidar",
            "horizontal_beams": 1,
            "horizontal_fov_deg": 1.0,
            "orientation_deg": [0.0, 90.0, 0.0],  # positive pitch looks down
            "max_range": 5.0,
        }
    ]
    env = ma_quadx_hover_v0.parallel_env(agents=stacked, range_sensors=down)
    try:
        obs, _ = env.reset(seed=0)
        assert obs["uav_0"]["down"][0] == pytest.approx(1.0, abs=1e-3)
        assert obs["uav_1"]["down"][0] == pytest.approx(2.0, abs=1e-3)
    finally:
        env.close()


def test_a_recording_with_range_sensors_and_camera_replays_exactly(tmp_path):
    from pyflyt_engine.envs import make_env
    from pyflyt_engine.telemetry import RecordEpisode, load_episode
    from pyflyt_engine.telemetry.replay import verify

    env = RecordEpisode(make_env("ma_quadx_hover", agents=2, range_sensors=LIDAR, camera_observation=CAMERA), tmp_path)
    obs, _ = env.reset(seed=1)
    assert obs["lidar"].shape == (2, 3, 8) and obs["image"].shape == (2, 12, 16, 3)
    for _ in range(10):
        obs, _, terminated, truncated, _ = env.step(np.tile(ACTION, (2, 1)))
        if terminated or truncated:
            break
    env.close()
    result = verify(load_episode(env.paths[0]))
    assert result.ok and result.max_deviation == 0.0


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


class _TouchingHoverTask(MAHoverTask):
    crash_on_contact = False


class _TouchingHover(MAQuadXHoverEnv):
    task_class = _TouchingHoverTask


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


SLAB = {"items": [{"type": "box", "size": [2.0, 2.0, 0.1], "position": [0.0, 0.0, 1.4]}]}


def test_obstacles_stop_one_agent_exactly_as_the_single_agent_env():
    """A slab 0.4 m above the spawn point: the climbing vehicle hits it and crashes, in both
    loops alike (the same states at every step, the same last step), with
    ``info["obstacle_contact"]`` (the rewards differ: each env has its own preset)."""
    climb = np.array([0.0, 0.0, 0.0, 0.8])
    outcomes = []
    builds = (
        (lambda: QuadXHoverEnv(obstacles=SLAB), False),
        (lambda: ma_quadx_hover_v0.parallel_env(agents=1, obstacles=SLAB), True),
    )
    for build, multi_agent in builds:
        env = build()
        try:
            env.reset(seed=3)
            rows = []
            for _ in range(40):
                if multi_agent:
                    _, _, terminated, _, infos = env.step({"uav_0": climb})
                    ended, info = terminated["uav_0"], infos["uav_0"]
                    vehicle = env.vehicles[0]
                else:
                    _, _, ended, _, info = env.step(climb)
                    vehicle = env.vehicle
                rows.append([*vehicle.state.lin_pos, *vehicle.state.quaternion, *vehicle.state.lin_vel])
                if ended:
                    break
            outcomes.append((np.array(rows), info["obstacle_contact"], ended))
        finally:
            env.close()
    (alone, touched_alone, ended_alone), (together, touched_together, ended_together) = outcomes
    assert touched_alone and ended_alone and touched_together and ended_together
    np.testing.assert_array_equal(together, alone)


def test_an_obstacle_ends_only_the_episode_of_the_agent_that_touches_it():
    apart = [
        {"spawn": {"position": [0.0, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
        {"spawn": {"position": [4.0, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
    ]
    env = ma_quadx_hover_v0.parallel_env(agents=apart, obstacles=SLAB)  # the slab is above agent 0 only
    try:
        _, infos = env.reset(seed=0)
        assert infos["uav_1"]["obstacle_contact"] is False
        for _ in range(40):
            _, _, terminated, _, infos = env.step({name: np.array([0.0, 0.0, 0.0, 0.8]) for name in env.agents})
            if terminated.get("uav_0"):
                break
        assert terminated["uav_0"] and infos["uav_0"]["obstacle_contact"]
        assert not terminated["uav_1"] and not infos["uav_1"]["obstacle_contact"]
    finally:
        env.close()


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


BALL = [
    {
        "name": "ball",
        "body": {"shapes": [{"type": "sphere", "radius": 0.02, "mass": 0.01}]},
        "attach": {"to": "vehicle", "joint": "fixed"},
        "position": [0.0, 0.0, 0.05],
    }
]


def test_payloads_change_one_agent_exactly_as_the_single_agent_env():
    alone = single(payloads=BALL)
    assert not np.array_equal(alone, single()), "the payload does not change the single-agent flight"
    np.testing.assert_array_equal(multi(payloads=BALL)[:, 0], alone)


def test_every_agent_carries_its_own_payloads_and_fails_on_its_own_ground_contact():
    hanging = [
        {
            "name": "weight",
            "body": {"shapes": [{"type": "sphere", "radius": 0.03, "mass": 0.005}]},
            "attach": {"to": "vehicle", "joint": "fixed"},
            "position": [0.0, 0.0, -0.25],
            "ground_contact_fails": True,
        }
    ]
    low_and_high = [
        {"spawn": {"position": [0.0, 0.0, 0.4], "position_noise": 0.0, "orientation_noise": 0.0}},
        {"spawn": {"position": [2.0, 0.0, 3.0], "position_noise": 0.0, "orientation_noise": 0.0}},
    ]
    env = ma_quadx_hover_v0.parallel_env(agents=low_and_high, payloads=hanging)
    try:
        _, infos = env.reset(seed=0)
        assert [p.spec.name for p in env.payloads] == ["uav_0-weight", "uav_1-weight"]
        assert all(info["payload_ground_contact"] is False for info in infos.values())
        for _ in range(30):  # motors off: both fall, the low one's weight reaches the ground first
            _, _, terminated, _, infos = env.step({name: np.zeros(4) for name in env.agents})
            if terminated.get("uav_0"):
                break
        assert terminated["uav_0"] and infos["uav_0"]["payload_ground_contact"]
        assert not infos["uav_0"]["collision"], "the vehicle itself touched the ground first"
        assert not terminated["uav_1"] and not infos["uav_1"]["payload_ground_contact"]
        assert env.agents == ["uav_1"]
    finally:
        env.close()


def test_a_payload_attached_to_the_world_is_refused_by_name():
    gate = [
        {
            "name": "post",
            "body": {"shapes": [{"type": "box", "size": [0.1, 0.1, 0.1], "mass": 0.1}]},
            "attach": {"to": "world", "joint": "fixed"},
            "position": [3.0, 0.0, 0.5],
        }
    ]
    with pytest.raises(ConfigError, match="payloads: 'post' is attached to the world"):
        ma_quadx_hover_v0.parallel_env(payloads=gate)


def test_a_recording_with_payloads_and_an_obstacle_layout_replays_exactly(tmp_path):
    from pyflyt_engine.envs import make_env
    from pyflyt_engine.telemetry import RecordEpisode, load_episode
    from pyflyt_engine.telemetry.replay import verify

    forest = {"kind": "forest", "x_range": [-3.0, 3.0], "y_range": [-3.0, 3.0], "density": 0.5, "keep_out": 1.0}
    env = RecordEpisode(
        make_env("ma_quadx_hover", agents=2, payloads=BALL, obstacles={"generators": [forest]}), tmp_path
    )
    env.reset(seed=4)
    for _ in range(10):
        *_, terminated, truncated, _ = env.step(np.tile(ACTION, (2, 1)))
        if terminated or truncated:
            break
    env.close()
    result = verify(load_episode(env.paths[0]))
    assert result.ok and result.max_deviation == 0.0


def test_a_dogfight_episode_flies_the_gun_options_a_curriculum_sets_then_the_configured_ones():
    """``reset(options={"task": ...})`` changes a multi-agent task's episode options as it
    changes a single-agent task's: a wide, long-range gun hits from the first steps (the
    teams spawn 100 m apart, facing each other); the next reset without options flies the
    configured 20 m, 0.07 rad gun, which hits nobody that far away."""
    from pyflyt_engine.envs.multi_agent import ma_fixedwing_dogfight_v0

    env = ma_fixedwing_dogfight_v0.parallel_env()
    cruise = np.array([0.0, 0.0, 0.0, 0.6])

    def hits(options=None) -> int:
        env.reset(seed=0, options=options)
        total = 0
        for _ in range(3):
            _, _, _, _, infos = env.step({name: cruise for name in env.agents})
            total += sum(info["hits_dealt"] for info in infos.values())
        return total

    try:
        assert hits({"task": {"lethal_distance": 300.0, "lethal_angle": 1.2}}) > 0
        assert env.task.options.lethal_distance == 300.0 and env.task.configured.lethal_distance == 20.0
        assert hits() == 0 and env.task.options.lethal_distance == 20.0
        with pytest.raises(ValueError, match="lethal_angle"):
            env.reset(seed=0, options={"task": {"lethal_angle": 2.0}})  # at most pi / 2
        with pytest.raises(ValueError, match="team_separation"):
            env.reset(seed=0, options={"task": {"team_separation": 50.0}})  # shapes the spawn: not per episode
    finally:
        env.close()

"""Ray-cast range sensors on the batched backend (pyflyt_engine.batched.ranges).

Oracles:

* PyBullet's ``rayTestBatch`` from the engine's sensor on its vehicle: at random poses
  (heights from below the ground to 5 m, positions up to 50 m from the origin, any attitude)
  the closed-form fraction of the ground plane's hit equals PyBullet's to ``1e-13``
  (measured: 1.0e-14; PyBullet intersects the ray with the two triangles it makes of the
  plane over the ray's bounding box, in double precision), hits and misses alike, and the
  float32 readings then agree to within one float32 spacing at ``max_range`` (the
  derivation: two float64 values ``1e-13`` apart round to the same float32 or to
  neighbours; one spacing at a reading ``r <= max_range`` is at most
  ``spacing(float32(max_range)) <= 2**-23 max_range``, relative ``1.2e-7`` of the max range).
  Measured: equal bit for bit at every pose of the test;
* the engine's noise: from the same stream state a scan draws the same normals (one per ray,
  in ray order), reads within that bound and leaves the stream where the engine leaves it;
* the PyBullet env: the same start, actions and sensor streams give the same observations
  over 2 s of flight, the state entries within test_crosscheck.py's bound (1e-6; measured
  ~1e-14 on the quiet quad) and each reading within one float32 spacing at its sensor's
  ``max_range``.  A reading's sensitivity to the pose is ``(1 + t) / c`` for a ray at
  distance ``t`` whose direction has downward component ``c``; the sensors flown here hit
  with ``c >= 0.1`` within ``6 m`` (70 x a ~1e-14 state difference ~ 1e-12, far inside the
  spacing), so the bound is the rounding's alone.  Measured: equal bit for bit.
"""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest

from pyflyt_engine.assembly import assemble
from pyflyt_engine.batched import BatchedUAVEnv, kernels
from pyflyt_engine.batched.env import CONTEXT_LENGTH
from pyflyt_engine.batched.model import UnsupportedByBatched
from pyflyt_engine.batched.ranges import BatchedRangeSensors
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.components.range_sensor import RAY_MASK
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.wrappers import FlattenWaypointEnv

from tests.batched.test_crosscheck import BOUND, _flat, quiet  # noqa: F401  (a fixture)

#: a scanning LiDAR over nearly the whole sphere (rays up, sideways and down), a tilted depth
#: camera, and a short LiDAR looking down whose range ends above the ground (it misses)
SENSORS = [
    {
        "name": "sphere",
        "type": "lidar",
        "horizontal_beams": 8,
        "vertical_beams": 5,
        "vertical_fov_deg": 150.0,
        "position": [0.01, 0.02, -0.01],
        "min_range": 0.1,
        "max_range": 6.0,
        "noise_std": 0.02,
        "rate_hz": 12.0,
    },
    {
        "name": "camera",
        "type": "depth",
        "width": 6,
        "height": 4,
        "fov": 80.0,
        "orientation_deg": [10.0, 60.0, 20.0],
        "position": [0.03, 0.0, 0.0],
        "min_range": 0.1,
        "max_range": 4.0,
        "noise_std": 0.01,
    },
    {
        "name": "short",
        "type": "lidar",
        "horizontal_beams": 3,
        "horizontal_fov_deg": 30.0,
        "orientation_deg": [0.0, 90.0, 0.0],
        "min_range": 0.06,
        "max_range": 0.5,
    },
]


def _quiet_sensors(noise: bool) -> list[dict]:
    return [s if noise else {**s, "noise_std": 0.0} for s in SENSORS]


def _spacing(max_range: float) -> float:
    """One float32 spacing at ``max_range``: the bound of a reading (module docstring)."""
    return float(np.spacing(np.float32(max_range)))


def _bounds(sensors: BatchedRangeSensors) -> np.ndarray:
    """Per ray, one float32 spacing at its sensor's max range."""
    out = np.empty(sensors.held.shape[1])
    for s in sensors.engine:
        out[sensors.columns[s.name]] = _spacing(s.max_range)
    return out


def _world(sensors: list[dict], uav: str = "quadx_cf2x"):
    env = make_env(load_env_config("quadx_hover").with_overrides(uav=uav, range_sensors=sensors))
    env.reset(seed=1)
    world = env.unwrapped.world
    vehicle = world.vehicles[0]
    ours = BatchedRangeSensors(vehicle.spec.range_sensors, assemble(vehicle.spec).com, 1, world.physics_dt)
    ours.seed([np.random.SeedSequence(0)])
    return env, vehicle, ours


def _poses(rng: np.random.Generator, count: int):
    for _ in range(count):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        yield [rng.uniform(-50.0, 50.0), rng.uniform(-50.0, 50.0), rng.uniform(-0.3, 5.0)], q.tolist()


def _place(vehicle, position, quaternion):
    client = vehicle._client
    p.resetBasePositionAndOrientation(vehicle.body_id, position, quaternion, physicsClientId=client)
    return p.getBasePositionAndOrientation(vehicle.body_id, physicsClientId=client)


def test_the_closed_form_is_pybullets_ray_test():
    """At random poses the ground plane's hit fraction in closed form is PyBullet's within
    1e-13 (hits and misses the same rays), and the kernel's float32 readings are the engine's
    within one float32 spacing at max_range."""
    env, vehicle, ours = _world(_quiet_sensors(noise=False))
    bounds = _bounds(ours)
    rotation = np.empty(9)
    rng = np.random.default_rng(3)
    worst_fraction = worst_reading = 0.0
    hits = misses = below = 0
    for position, quaternion in _poses(rng, 400):
        pos, quat = _place(vehicle, position, quaternion)
        below += pos[2] < 0.0
        readings = []
        for k, sensor in enumerate(vehicle.range_sensors):
            start, end = sensor._local
            results = p.rayTestBatch(
                start,
                end,
                collisionFilterMask=RAY_MASK,
                parentObjectUniqueId=vehicle.body_id,
                parentLinkIndex=-1,
                physicsClientId=vehicle._client,
            )
            theirs = np.array([r[2] for r in results])
            kernels.rotation_rows(*quat, rotation)
            sz = rotation[6] * start[:, 0] + rotation[7] * start[:, 1] + rotation[8] * start[:, 2] + pos[2]
            ez = rotation[6] * end[:, 0] + rotation[7] * end[:, 1] + rotation[8] * end[:, 2] + pos[2]
            with np.errstate(divide="ignore", invalid="ignore"):
                closed = np.where(sz * ez < 0.0, sz / (sz - ez), 1.0)
            closed = np.where(closed < 1.0, closed, 1.0)
            assert np.array_equal(theirs < 1.0, closed < 1.0)
            hit = theirs < 1.0
            hits, misses = hits + int(hit.sum()), misses + int((~hit).sum())
            if hit.any():
                worst_fraction = max(worst_fraction, float(np.max(np.abs(theirs - closed)[hit])))
            readings.append(vehicle.scan(k).ravel())
        ours.forget(np.array([0]))
        ours.scan(np.array([0]), np.array([pos]), np.array([quat]), np.zeros(1, dtype=np.int64))
        difference = np.abs(ours.held[0] - np.concatenate(readings).astype(np.float64))
        assert np.all(difference <= bounds), (position, quaternion)
        worst_reading = max(worst_reading, float(np.max(difference / bounds)))
    assert worst_fraction < 1e-13, worst_fraction
    assert hits > 1000 and misses > 1000 and below > 10  # both branches, and rays from below the ground
    print(f"fractions within {worst_fraction:.1e}, readings within {worst_reading:.2f} spacings")
    env.close()


def test_the_noise_is_the_engines():
    """From the same stream state, a noisy scan (a noise large enough to clip at both ends)
    reads the engine's readings within the bound and leaves the stream where the engine does."""
    loud = [{**s, "noise_std": 0.8} for s in SENSORS]
    env, vehicle, ours = _world(loud)
    bounds = _bounds(ours)
    for k, sensor in enumerate(vehicle.range_sensors):
        sensor.rng = np.random.default_rng(100 + k)
        ours.rngs[0][k] = np.random.default_rng(100 + k)
    rng = np.random.default_rng(5)
    clipped_low = clipped_high = 0
    for position, quaternion in _poses(rng, 100):
        pos, quat = _place(vehicle, [0.1 * position[0], 0.1 * position[1], abs(position[2])], quaternion)
        theirs = np.concatenate([vehicle.scan(k).ravel() for k in range(len(vehicle.range_sensors))])
        ours.forget(np.array([0]))
        ours.scan(np.array([0]), np.array([pos]), np.array([quat]), np.zeros(1, dtype=np.int64))
        assert np.all(np.abs(ours.held[0] - theirs) <= bounds)
        lidar = ours.held[0, ours.columns["sphere"]]
        clipped_low += int(np.sum(lidar == np.float32(0.1)))
        clipped_high += int(np.sum(lidar == np.float32(6.0)))
    for k, sensor in enumerate(vehicle.range_sensors):
        assert ours.rngs[0][k].bit_generator.state == sensor.rng.bit_generator.state
    assert clipped_low > 0 and clipped_high > 0
    env.close()


def test_the_noise_statistics():
    """The noise of a hit has the stated law: at a fixed pose, readings minus the noiseless
    reading have mean 0 and standard deviation noise_std (within 5 standard errors)."""
    sensor = {**SENSORS[0], "noise_std": 0.05, "vertical_beams": 1, "vertical_fov_deg": 0.0, "horizontal_beams": 1}
    sensor = {**sensor, "position": [0.0, 0.0, 0.0], "orientation_deg": [0.0, 45.0, 0.0]}  # one beam 45 deg down
    spec = load_env_config("quadx_hover").with_overrides(range_sensors=[sensor]).range_sensors
    ours = BatchedRangeSensors(spec, (0.0, 0.0, 0.0), 1, 1.0 / 240.0)
    ours.seed([np.random.SeedSequence(9)])
    pos, quat = np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 0.0, 1.0]])
    samples = []
    for _ in range(2000):
        ours.forget(np.array([0]))
        ours.scan(np.array([0]), pos, quat, np.zeros(1, dtype=np.int64))
        samples.append(ours.held[0].copy())
    errors = np.array(samples) - np.sqrt(2.0)  # 1 m up, 45 degrees down
    std = sensor["noise_std"]
    assert abs(errors.mean()) < 5 * std / np.sqrt(errors.size)
    assert abs(errors.std() - std) < 5 * std / np.sqrt(2 * errors.size)


#: the flights: the hover task (rates and thrust), a quaternion observation (the waypoints
#: task with range sensors is refused: test_refusals)
FLIGHTS = {
    "hover": ("quadx_hover", {}),
    "hover_quaternion": ("quadx_hover", {"angle_representation": "quaternion"}),
}


def _pair(env_name: str, uav: str, seed: int, **overrides):
    """The PyBullet env (wrapped as the agent sees it) and a one-env batched env at its start,
    the batched env's range sensor streams the ones the PyBullet world seeded at its reset and
    the reset's scan cast again from there at the same pose."""
    cfg = load_env_config(env_name).with_overrides(uav=uav, range_sensors=SENSORS, **overrides)
    raw = make_env(cfg)
    first, _ = raw.reset(seed=seed)
    be = BatchedUAVEnv(cfg, num_envs=1)
    be.reset(seed=seed)
    world = raw.unwrapped.world
    vehicle = world.vehicles[0]
    pos, quat = p.getBasePositionAndOrientation(vehicle.body_id, physicsClientId=vehicle._client)
    lin, ang = p.getBaseVelocity(vehicle.body_id, physicsClientId=vehicle._client)
    be.pos[0], be.quat[0], be.vel[0], be.angvel[0] = pos, quat, lin, ang
    if be._waypoints:
        be.targets[0] = raw.unwrapped.task.targets
    be._read()
    index = np.arange(1)
    be._last_position[0] = be.pos[0]
    be._last_distance[0] = be._target_distance(index, be.pos)[0]
    assert be.range_sensors is not None
    be.range_sensors.rngs = [world._sensor_rngs(0)]  # the streams the world gave its sensors at the reset
    be.range_sensors.forget(index)
    be.range_sensors.scan(index, be.pos, be.quat, be.physics_steps)
    return raw, be, first


def _flatten(raw, obs) -> np.ndarray:
    """The PyBullet env's observation as the batched env lays it out: FlattenWaypointEnv's
    vector under ``attitude`` (waypoints) with the readings, flattened in gymnasium's key order."""
    entries = {key: value for key, value in obs.items() if key != "target_deltas"}
    if "target_deltas" in obs:
        entries["attitude"] = _flat({"attitude": obs["attitude"], "target_deltas": obs["target_deltas"]})
    return np.concatenate([np.asarray(entries[k], dtype=np.float64).ravel() for k in sorted(entries)])


@pytest.mark.parametrize("flight", sorted(FLIGHTS))
def test_flights_match_pybullet(flight, quiet):  # noqa: F811
    """Same start, actions and sensor streams: the batched observation has the PyBullet env's
    space (the flattened Dict the agent sees), equals it at the reset, and over 2 s of flight
    stays within the bound (state entries 1e-6, each reading one float32 spacing at its max
    range); the sensors' streams end where the engine's do; rays hit and miss."""
    env_name, overrides = FLIGHTS[flight]
    raw, be, first = _pair(env_name, quiet["quadx_cf2x"], seed=5, **overrides)
    size = be.single_observation_space.shape[0]
    # the space the agent sees less the float32 cast (wrap_for_agent): the Dict flattened,
    # a waypoint env's after FlattenWaypointEnv
    space = FlattenWaypointEnv(raw).observation_space if be._waypoints else raw.observation_space
    assert be.single_observation_space == gymnasium.spaces.flatten_space(space)
    sensors = be.range_sensors
    readings_at = np.zeros(size, dtype=bool)
    bound = np.full(size, BOUND)
    max_range = np.zeros(size)
    offset = 0
    for key in be._entries:  # the readings' columns in the flat vector
        if key == "attitude":
            offset += be._attitude_size + (CONTEXT_LENGTH * 4 if be._waypoints else 0)
            continue
        sensor = next(s for s in sensors.engine if s.name == key)
        width = sensor.count
        readings_at[offset : offset + width] = True
        bound[offset : offset + width] = _spacing(sensor.max_range)
        max_range[offset : offset + width] = np.float32(sensor.max_range)
        offset += width
    assert offset == size
    max_range = max_range[readings_at]
    assert np.all(np.abs(_flatten(raw, first) - be._observe()[0]) <= bound)
    rng = np.random.default_rng(11)
    worst_state = worst_reading = 0.0
    hits = misses = 0
    for step in range(60):
        action = np.r_[rng.uniform(-0.8, 0.8, 3), be.model.hover_thrust_fraction * rng.uniform(0.97, 1.08)]
        o1, r1, t1, tr1, _ = raw.step(action)
        o2, r2, t2, tr2, info = be.step(action[None])
        final = info["final_obs"][0] if t2[0] or tr2[0] else o2[0]
        ours = _flatten(raw, o1)
        difference = np.abs(ours - final)
        assert np.all(difference <= bound), (step, np.nonzero(difference > bound))
        assert abs(r1 - r2[0]) < BOUND and (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        worst_state = max(worst_state, float(np.max(difference[~readings_at])))
        worst_reading = max(worst_reading, float(np.max(difference[readings_at])))
        shown = final[readings_at]
        hits += int(np.sum(shown < max_range - 1e-3))
        misses += int(np.sum(shown == max_range))
        if t1 or tr1:
            break
    assert step == 59 and not (t1 or tr1)  # it flew the 2 s (an autoreset would cast the next episode's scan)
    world = raw.unwrapped.world
    for k, sensor in enumerate(world.vehicles[0].range_sensors):
        assert sensors.rngs[0][k].bit_generator.state == sensor.rng.bit_generator.state
    assert hits > 0 and misses > 0
    print(f"{flight}: state within {worst_state:.1e}, readings within {worst_reading:.1e}")
    raw.close()


def test_scans_are_held_between_refreshes():
    """A sensor slower than the agent steps shows its last scan between refreshes, and casts
    (drawing its noise) only at a refresh: the engine's ``scan(time)``."""
    slow = [{**SENSORS[0], "rate_hz": 7.0}]
    env = BatchedUAVEnv(load_env_config("quadx_hover").with_overrides(range_sensors=slow), num_envs=1, seed=3)
    env.reset(seed=3)
    sensors = env.range_sensors
    casts, last = 0, sensors.held.copy()
    rng = np.random.default_rng(0)
    for _ in range(30):
        before = [r.bit_generator.state for row in sensors.rngs for r in row]
        _, _, terminated, truncated, _ = env.step(
            np.r_[rng.uniform(-0.2, 0.2, 3), env.model.hover_thrust_fraction][None]
        )
        assert not (terminated[0] or truncated[0])
        after = [r.bit_generator.state for row in sensors.rngs for r in row]
        moved = before != after
        changed = not np.array_equal(last, sensors.held)
        assert moved == changed
        casts += moved
        last = sensors.held.copy()
    # 30 agent steps at 30 Hz are 1 s: a refresh once 1/7 s has passed since the last, at
    # steps 5, 10, ..., 30 (5/30 s >= 1/7 s > 4/30 s): 6 after the reset's scan
    assert casts == 6, casts


def test_resume_is_exact():
    """A checkpoint mid-episode (BatchedVecEnv.episode_state) restored into a fresh batch
    continues bit for bit: the held readings, last cast times and streams are carried;
    without the streams the noise would differ."""
    from pyflyt_cli.training.batched import BatchedVecEnv

    cfg = load_env_config("quadx_hover").with_overrides(range_sensors=SENSORS)
    a = BatchedVecEnv(cfg, 3)
    a.env.reset(seed=4)
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-0.3, 0.3, (3, 4)) for _ in range(40)]
    for act in actions[:21]:
        a.step(act)
    saved = [a.episode_state(i) for i in range(3)]
    assert all({"range_held", "range_last"} <= set(state["batched"]) for state in saved)
    b = BatchedVecEnv(cfg, 3)
    b.env.reset(seed=999)
    for i in range(3):
        b.restore_episode(i, saved[i])
    assert np.array_equal(a.env._observe(), b.env._observe())
    for act in actions[21:]:
        oa, ra, da, _ = a.step(act)
        ob, rb, db, _ = b.step(act)
        assert np.array_equal(oa, ob) and np.array_equal(ra, rb) and np.array_equal(da, db)
    c = BatchedVecEnv(cfg, 3)  # the streams matter: without them the next noisy scan differs
    c.env.reset(seed=999)
    fresh = [[r.bit_generator.state for r in row] for row in c.env.range_sensors.rngs]
    for i in range(3):
        c.restore_episode(i, {**saved[i], "rng": {**saved[i]["rng"], "range_sensors": fresh[i]}})
    a2 = BatchedVecEnv(cfg, 3)
    a2.env.reset(seed=999)
    for i in range(3):
        a2.restore_episode(i, saved[i])
    assert not np.array_equal(a2.step(actions[21])[0], c.step(actions[21])[0])


def test_streams_are_per_env_and_seeded():
    """Env i's sensor noise depends on the seed and i alone."""
    cfg = load_env_config("quadx_hover").with_overrides(range_sensors=SENSORS)
    one, three = BatchedUAVEnv(cfg, num_envs=1), BatchedUAVEnv(cfg, num_envs=3)
    one.reset(seed=3)
    three.reset(seed=3)
    assert np.array_equal(one.range_sensors.held[0], three.range_sensors.held[0])
    assert one.range_sensors.rngs[0][0].bit_generator.state == three.range_sensors.rngs[0][0].bit_generator.state
    assert not np.array_equal(three._observe()[0], three._observe()[1])


def test_refusals(tmp_path):
    """In a multi-agent world the range sensors stay refused by name (a ray could hit another
    agent), the env config's and an airframe's alike; cameras stay refused everywhere."""
    import yaml

    from pyflyt_engine.batched import check_supported
    from pyflyt_engine.batched.env import resolve_backend
    from pyflyt_engine.paths import uav_dir

    check_supported(load_env_config("quadx_hover").with_overrides(range_sensors=SENSORS))
    with pytest.raises(UnsupportedByBatched, match="range_sensors in a multi-agent world"):
        check_supported(load_env_config("ma_quadx_hover").with_overrides(range_sensors=SENSORS))
    data = yaml.safe_load((uav_dir() / "quadx_cf2x.yaml").read_text())
    data["range_sensors"] = [SENSORS[0]]
    airframe = tmp_path / "quadx_cf2x_lidar.yaml"
    airframe.write_text(yaml.safe_dump(data))
    airframe = str(airframe)
    check_supported(load_env_config("quadx_hover").with_overrides(uav=airframe))
    with pytest.raises(UnsupportedByBatched, match="range sensors in a multi-agent world"):
        check_supported(load_env_config("ma_quadx_hover").with_overrides(uav=airframe))
    # on the waypoints task the PyBullet env gives the agent a Dict where the batched env gives
    # a flat vector: refused (env config and airframe), so `auto` trains such a config on PyBullet
    waypoints = load_env_config("quadx_waypoints").with_overrides(range_sensors=SENSORS)
    with pytest.raises(UnsupportedByBatched, match="range_sensors on the waypoints task"):
        check_supported(waypoints)
    assert resolve_backend(waypoints.with_overrides(backend="auto")) == "pybullet"
    with pytest.raises(UnsupportedByBatched, match="range sensors of .* on the waypoints task"):
        BatchedUAVEnv(load_env_config("quadx_waypoints").with_overrides(uav=airframe), num_envs=1)
    camera = {"camera": {"name": "eye", "width": 16, "height": 12}}
    with pytest.raises(UnsupportedByBatched, match="camera_observation"):
        check_supported(load_env_config("quadx_hover").with_overrides(camera_observation=camera))

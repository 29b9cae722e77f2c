"""Ray-cast range sensors against oracles: a box at a known pose gives the analytic range in
every beam that hits it and max range elsewhere; noise has the configured statistics; the
rate, the airframe's invisibility, and an unchanged flight."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pyflyt_engine.errors import PyFlytError
from pyflyt_engine.obstacles import ObstacleField, ObstaclesConfig
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.world import VehicleConfig, World

# float32 readings of ranges up to 5 m: 0.5 ulp is 2.4e-7 m; PyBullet's ray fraction adds ~1e-7
TOL = 2e-6


def _world(sensors, yaw: float = 0.0, ground: bool = False, boxes=()) -> World:
    spec = load_uav_spec("quadx_cf2x")
    spec = spec.model_copy(update={"range_sensors": [_parse(s) for s in sensors]})
    world = World([VehicleConfig(spec, (0.0, 0.0, 1.0), (0.0, 0.0, yaw))], ground=ground, seed=0)
    if boxes:
        ObstacleField(world, ObstaclesConfig(items=[{"type": "box", **b} for b in boxes]))
    world.reset(seed=0)
    return world


def _parse(sensor: dict):
    from pydantic import TypeAdapter

    from pyflyt_engine.spec import RangeSensorSpec

    return TypeAdapter(RangeSensorSpec).validate_python(sensor)


LIDAR = {"name": "lidar", "type": "lidar", "horizontal_beams": 64, "min_range": 0.1, "max_range": 5.0}
# a wall 2 m ahead of the sensor: its face is the plane x = 2, 2 m wide (|y| <= 1), 2 m tall
WALL = {"size": [1.0, 2.0, 2.0], "position": [2.5, 0.0, 1.0]}


def _azimuths(n: int, fov_deg: float = 360.0) -> np.ndarray:
    h = math.radians(fov_deg)
    return np.array([-0.5 * h + (k + 0.5) * h / n for k in range(n)])


@pytest.mark.parametrize("yaw", [0.0, 0.5])
def test_lidar_reads_the_analytic_range_of_a_wall_and_max_range_elsewhere(yaw):
    world = _world([LIDAR], yaw=yaw, boxes=[WALL])
    readings = world.scan(0, 0)
    assert readings.shape == (64,) and readings.dtype == np.float32  # one scan line: a vector
    # the wall's face x = 2 seen from the body at the origin turned by yaw: a beam at azimuth a
    # (body frame) points at ground bearing a + yaw and meets x = 2 at range 2 / cos(a + yaw)
    # if it crosses the face within |y| <= 1
    bearing = _azimuths(64) + yaw
    forward = np.cos(bearing) > 1e-9
    analytic = np.where(forward, 2.0 / np.where(forward, np.cos(bearing), 1.0), np.inf)
    y_at_face = np.where(forward, 2.0 * np.tan(bearing), np.inf)
    hits = forward & (np.abs(y_at_face) < 1.0 - 1e-3)
    misses = ~forward | (np.abs(y_at_face) > 1.0 + 1e-3)
    assert hits.sum() >= 8 and misses.sum() >= 40
    np.testing.assert_allclose(readings[hits], analytic[hits], rtol=0, atol=TOL)
    np.testing.assert_array_equal(readings[misses], 5.0)


def test_vertical_beams_and_a_mounted_sensor_follow_the_geometry():
    # 5 scan lines over 40 deg; mounted 0.02 m forward and 0.01 m up (spec coordinates)
    sensor = {**LIDAR, "vertical_beams": 5, "vertical_fov_deg": 40.0, "position": [0.02, 0.0, 0.01]}
    world = _world([sensor], boxes=[WALL])
    com = world.vehicles[0].parts.com
    origin = np.array([0.02, 0.0, 1.01]) - np.asarray(com)  # the body origin is the CoM at (0, 0, 1)
    readings = world.scan(0, 0)
    elevation = np.array([-20.0 + (j + 0.5) * 8.0 for j in range(5)]) * math.pi / 180
    k = 32  # azimuth +2.8 deg: crosses the face near y = 0.1
    a = _azimuths(64)[k]
    for j, e in enumerate(elevation):
        direction = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
        t = (2.0 - origin[0]) / direction[0]
        assert abs(readings[j, k] - t) < TOL


def test_depth_camera_reads_the_axial_depth_of_a_wall_filling_its_view():
    # a face perpendicular to the optical axis: every pixel reads the same depth, 2 m
    depth = {
        "name": "depth",
        "type": "depth",
        "width": 8,
        "height": 6,
        "fov": 60.0,
        "min_range": 0.1,
        "max_range": 10.0,
    }
    world = _world([depth], boxes=[{"size": [1.0, 8.0, 8.0], "position": [2.5, 0.0, 1.0]}])
    image = world.scan(0, 0)
    assert image.shape == (6, 8)
    np.testing.assert_allclose(image, 2.0, rtol=0, atol=TOL)


@pytest.mark.parametrize("width, height", [(128, 128), (130, 127)])
def test_a_large_image_is_cast_in_several_batches_in_order(width, height):
    # 16 384 and 16 510 rays: PyBullet casts fewer than 16 * 1024 rays a call and silently
    # drops the rest, so the sensor splits the rays; a wall filling the left half (+y) of the
    # view reads 2 m in every left column and max range in every right one
    depth = {"name": "depth", "type": "depth", "width": width, "height": height, "fov": 60.0, "max_range": 10.0}
    world = _world([depth], boxes=[{"size": [1.0, 8.0, 8.0], "position": [2.5, 4.0, 1.0]}])
    image = world.scan(0, 0)
    assert image.shape == (height, width)
    # the fraction of a 10 m ray at the image's corners is off by up to ~6e-7 (5.5e-6 m seen)
    np.testing.assert_allclose(image[:, : width // 2], 2.0, rtol=0, atol=1e-5)
    np.testing.assert_array_equal(image[:, width // 2 :], 10.0)


def test_depth_camera_image_rows_and_columns_follow_the_camera_convention():
    # a wall on the left (+y) only: column 0 (left) hits, the last column misses;
    # looking down at the ground from 1 m: the bottom row hits, the top row misses
    depth = {"name": "depth", "type": "depth", "width": 8, "height": 6, "fov": 60.0, "max_range": 10.0}
    world = _world([depth], boxes=[{"size": [1.0, 3.0, 1.0], "position": [2.5, 1.5, 1.0]}], ground=True)
    image = world.scan(0, 0)
    assert image[2, 0] < 10.0 and image[2, -1] == 10.0  # the wall (|z| <= 0.5 m at the face: the centre rows)
    assert image[-1, 4] < 10.0 and image[0, 4] == 10.0  # the ground below, the sky above
    # bottom row, pixel-centre elevation e below the axis: the ground plane z = 0 at depth 1 / tan(e)
    tv = math.tan(math.radians(30.0))
    z = tv * (1.0 - 2.0 * 5.5 / 6)
    assert abs(image[-1, 4] - 1.0 / -z) < TOL


def test_noise_has_the_configured_statistics_and_misses_stay_at_max_range():
    sigma = 0.05
    world = _world([{**LIDAR, "noise_std": sigma}], boxes=[WALL])
    clean = _world([LIDAR], boxes=[WALL]).scan(0, 0)
    hits = clean < 5.0
    errors, misses = [], []
    sensor, state = world.vehicles[0].range_sensors[0], world.state(0)
    for _ in range(300):  # the vehicle held still: a new scan at each call (no time given)
        readings = sensor.scan(world.client, state.lin_pos, state.quaternion)
        errors.append(readings[hits] - clean[hits])
        misses.append(readings[~hits])
    e = np.concatenate(errors)
    n = e.size
    assert n >= 3000
    assert abs(e.mean()) < 4 * sigma / math.sqrt(n)  # zero-mean
    assert abs(e.std() / sigma - 1.0) < 0.05  # standard deviation as configured (n >= 3000: ~1.3 % s.e.)
    np.testing.assert_array_equal(np.concatenate(misses), 5.0)


def test_noise_is_seeded_and_its_own_stream():
    sensor = {**LIDAR, "noise_std": 0.05}
    a, b = _world([sensor], boxes=[WALL]), _world([sensor], boxes=[WALL])
    np.testing.assert_array_equal(a.scan(0, 0), b.scan(0, 0))
    a.reset(seed=1)
    assert not np.array_equal(a.scan(0, 0), b.scan(0, 0))


def test_scans_refresh_at_the_sensor_rate():
    # agent 30 Hz, sensor 10 Hz: a new scan every third agent step (noise makes each one new)
    world = _world([{**LIDAR, "noise_std": 0.05, "rate_hz": 10.0}], boxes=[WALL])
    scans = [world.scan(0, 0)]
    for _ in range(6):
        world.step()
        scans.append(world.scan(0, 0))
    same = [np.array_equal(scans[i], scans[i + 1]) for i in range(6)]
    assert same == [True, True, False, True, True, False]


def test_the_airframe_never_sees_itself():
    # rays start inside the airframe's collision box (0.01 m from the centre): still max range
    world = _world([{**LIDAR, "min_range": 0.01, "vertical_beams": 9, "vertical_fov_deg": 170.0}])
    np.testing.assert_array_equal(world.scan(0, 0), 5.0)


def test_a_sensor_leaves_the_flight_unchanged():
    def fly(sensors):
        world = _world(sensors, ground=True)
        world.set_mode(0, "rates_thrust")
        rng = np.random.default_rng(0)
        out = []
        for _ in range(40):
            world.set_setpoint(0, [*rng.uniform(-0.5, 0.5, 3), rng.uniform(0.1, 0.16)])
            world.step()
            if sensors:
                world.scan(0, 0)
            s = world.state(0)
            out.append([*s.lin_pos, *s.quaternion, *s.lin_vel])
        return np.array(out)

    np.testing.assert_array_equal(fly([]), fly([{**LIDAR, "noise_std": 0.1}]))


def test_bad_sensor_specs_are_refused_by_name():
    with pytest.raises(PyFlytError, match="min_range < max_range"):
        load_uav_spec({**load_uav_spec("quadx_cf2x").model_dump(), "range_sensors": [{**LIDAR, "max_range": 0.05}]})
    with pytest.raises(PyFlytError, match="vertical_fov_deg"):
        load_uav_spec({**load_uav_spec("quadx_cf2x").model_dump(), "range_sensors": [{**LIDAR, "vertical_beams": 4}]})
    with pytest.raises(PyFlytError, match="range_sensors"):
        load_uav_spec({**load_uav_spec("quadx_cf2x").model_dump(), "range_sensors": [LIDAR, LIDAR]})


def test_rays_cast_from_the_body_frame_read_as_rays_placed_in_the_ground_frame():
    # a vehicle's sensor hands PyBullet body-frame rays with the body as their parent; the
    # same sensor without a body places them by the state's pose in NumPy: both must read
    # the same (bit for bit here; the hit fractions differ by rounding only) on a tilted,
    # turning flight past a wall, with a mounted, pitched scanner of several lines
    sensor = {
        **LIDAR,
        "vertical_beams": 3,
        "vertical_fov_deg": 20.0,
        "position": [0.03, -0.02, 0.01],
        "orientation_deg": [5.0, 10.0, 30.0],
    }
    world = _world([sensor], yaw=0.3, ground=True, boxes=[WALL])
    world.set_mode(0, "rates_thrust")
    lidar = world.vehicles[0].range_sensors[0]
    assert lidar.body == world.vehicles[0].body_id
    rng = np.random.default_rng(1)
    hits = 0
    for _ in range(30):
        world.set_setpoint(0, [*rng.uniform(-1.0, 1.0, 3), rng.uniform(0.1, 0.16)])
        world.step()
        state = world.state(0)
        from_body = lidar.scan(world.client, state.lin_pos, state.quaternion)
        lidar.body = None
        try:
            placed = lidar.scan(world.client, state.lin_pos, state.quaternion)
        finally:
            lidar.body = world.vehicles[0].body_id
        np.testing.assert_array_equal(from_body, placed)
        hits += int((from_body < 5.0).sum())
    assert hits > 100  # the wall and the ground were seen

"""Camera: pure maths against PyBullet's own matrix functions and scipy; rendering in DIRECT."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pybullet as p
import pytest
from scipy.spatial.transform import Rotation

from pyflyt_engine.components.camera import (
    CHANNELS,
    CameraParams,
    camera_pose,
    capture,
    linearise_depth,
    pixel_centred_projection,
    projection_matrix,
    view_matrix,
)


def quat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Body-to-ground quaternion (x, y, z, w) of Rz(yaw) Ry(pitch) Rx(roll), via scipy."""
    return Rotation.from_euler("xyz", [roll, pitch, yaw]).as_quat()


LEVEL = quat(0.0, 0.0, 0.0)


# ------------------------------------------------------------------ validation


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"width": 0}, r"width must be a whole number of pixels >= 1, got 0"),
        ({"height": -3}, r"height must be a whole number of pixels >= 1, got -3"),
        ({"width": 64.5}, r"width must be a whole number of pixels"),
        ({"height": True}, r"height must be a whole number of pixels"),
        ({"fov": 0.0}, r"fov .* 0 < fov < 180, got 0.0"),
        ({"fov": 180}, r"0 < fov < 180, got 180"),
        ({"fov": float("nan")}, r"0 < fov < 180"),
        ({"near": 0.0}, r"near clip distance must be a finite number > 0 m"),
        ({"far": float("inf")}, r"far clip distance must be a finite number > 0 m"),
        ({"near": 2.0, "far": 1.0}, r"near \(2 m\) must be less than far \(1 m\); swap them"),
        ({"near": 1.0, "far": 1.0}, r"near \(1 m\) must be less than far \(1 m\)"),
        ({"channels": ("rgb",)}, r"channel 'rgb' is unknown; choose from \('rgba', 'depth', 'segmentation'\)"),
        ({"channels": ()}, r"channels must name at least one of"),
        ({"channels": ("depth", "depth")}, r"channels list a channel twice"),
        ({"capture_hz": 0.0}, r"capture_hz must be a finite rate > 0 Hz, got 0.0"),
        ({"capture_hz": -5}, r"capture_hz must be a finite rate > 0 Hz, got -5"),
        ({"position": (0.0, 0.0)}, r"position must be 3 finite numbers"),
        ({"orientation": (0.0, float("nan"), 0.0)}, r"orientation must be 3 finite numbers"),
        ({"horizon_lock": "yes"}, r"horizon_lock must be True or False"),
    ],
)
def test_invalid_params_raise_value_error_naming_field(kwargs, message):
    with pytest.raises(ValueError, match=message):
        CameraParams(**kwargs)


def test_params_are_frozen_normalised_and_hashable():
    params = CameraParams(position=np.array([0.1, 0, 0]), channels=["depth"], width=np.int64(8))
    assert params.position == (0.1, 0.0, 0.0)
    assert params.channels == ("depth",)
    assert type(params.width) is int
    assert params == CameraParams(position=(0.1, 0, 0), channels=("depth",), width=8)
    hash(params)
    with pytest.raises(dataclasses.FrozenInstanceError):
        params.fov = 60.0  # type: ignore[misc]


# ------------------------------------------------------------------ matrices vs PyBullet


def test_view_matrix_matches_pybullet_compute_view_matrix():
    rng = np.random.default_rng(0)
    for _ in range(50):
        eye = rng.uniform(-20, 20, 3)
        forward = rng.standard_normal(3) * rng.uniform(0.1, 5.0)  # not unit: normalised inside
        up = rng.standard_normal(3)  # not orthogonal to forward, as PyBullet allows
        expected = p.computeViewMatrix(eye.tolist(), (eye + forward).tolist(), up.tolist())
        ours = view_matrix(eye, forward, up)
        assert len(ours) == 16
        np.testing.assert_allclose(ours, expected, rtol=1e-5, atol=1e-5)


def test_view_matrix_from_camera_pose_matches_pybullet():
    rng = np.random.default_rng(1)
    for _ in range(20):
        params = CameraParams(
            position=rng.uniform(-0.5, 0.5, 3),
            orientation=rng.uniform(-math.pi, math.pi, 3),
            horizon_lock=bool(rng.integers(2)),
        )
        eye, forward, up = camera_pose(params, rng.uniform(-10, 10, 3), Rotation.random(random_state=rng).as_quat())
        expected = p.computeViewMatrix(eye.tolist(), (eye + forward).tolist(), up.tolist())
        np.testing.assert_allclose(view_matrix(eye, forward, up), expected, rtol=1e-5, atol=1e-5)


def test_view_matrix_rejects_up_parallel_to_forward():
    with pytest.raises(ValueError, match="parallel"):
        view_matrix([0, 0, 0], [0, 0, 2], [0, 0, 1])


def test_projection_matrix_matches_pybullet_compute_projection_matrix_fov():
    rng = np.random.default_rng(2)
    for _ in range(50):
        near = rng.uniform(0.01, 1.0)
        params = CameraParams(
            fov=rng.uniform(1.0, 179.0),
            width=int(rng.integers(1, 2000)),
            height=int(rng.integers(1, 2000)),
            near=near,
            far=near + rng.uniform(0.5, 1000.0),
        )
        expected = p.computeProjectionMatrixFOV(params.fov, params.width / params.height, params.near, params.far)
        ours = projection_matrix(params)
        assert len(ours) == 16
        np.testing.assert_allclose(ours, expected, rtol=1e-5, atol=1e-6)


def test_pixel_centred_projection_shifts_half_a_pixel_only():
    params = CameraParams(width=64, height=32, fov=70.0, near=0.2, far=40.0)
    plain = np.array(projection_matrix(params))
    shifted = np.array(pixel_centred_projection(params))
    delta = shifted - plain
    np.testing.assert_allclose(delta[[8, 9]], [1 / 64, 1 / 32], rtol=1e-12)
    assert np.count_nonzero(delta) == 2
    # a point on the optical axis lands half a pixel left of and below the centre in NDC
    x_clip, y_clip, _, w_clip = shifted.reshape(4, 4).T @ [0.0, 0.0, -3.0, 1.0]
    np.testing.assert_allclose([x_clip / w_clip, y_clip / w_clip], [-1 / 64, -1 / 32], rtol=1e-12)


# ------------------------------------------------------------------ camera pose


def test_body_yawed_90_degrees_looks_along_ground_y():
    eye, forward, up = camera_pose(CameraParams(), [0, 0, 0], quat(0, 0, math.pi / 2))
    np.testing.assert_allclose(eye, [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(forward, [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(up, [0, 0, 1], atol=1e-12)


def test_mount_point_moves_with_the_body():
    params = CameraParams(position=(0.2, 0.0, 0.05))
    eye, _, _ = camera_pose(params, [1.0, 2.0, 3.0], quat(0, 0, math.pi / 2))
    np.testing.assert_allclose(eye, [1.0, 2.2, 3.05], atol=1e-12)


def test_horizon_lock_ignores_roll_and_pitch_and_follows_yaw():
    yaw = 0.7
    tilted = quat(math.radians(30), math.radians(20), yaw)
    _, forward, up = camera_pose(CameraParams(horizon_lock=True), [0, 0, 0], tilted)
    assert forward[2] == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(forward, [math.cos(yaw), math.sin(yaw), 0], atol=1e-12)
    np.testing.assert_allclose(up, [0, 0, 1], atol=1e-12)

    _, forward, up = camera_pose(CameraParams(horizon_lock=False), [0, 0, 0], tilted)
    assert abs(forward[2]) > 0.1
    assert up[2] < 0.99


def test_horizon_lock_keeps_the_mount_rotation():
    # gimbal-stabilised camera tilted 30 deg down, body yawed 90 deg and rolled/pitched
    params = CameraParams(orientation=(0.0, math.radians(30), 0.0), horizon_lock=True)
    _, forward, up = camera_pose(params, [0, 0, 0], quat(math.radians(30), math.radians(20), math.pi / 2))
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    np.testing.assert_allclose(forward, [0, c, -s], atol=1e-12)
    np.testing.assert_allclose(up, [0, s, c], atol=1e-12)


def test_body_fixed_camera_matches_scipy_composition():
    rng = np.random.default_rng(3)
    for _ in range(20):
        body = Rotation.random(random_state=rng)
        mount_euler = rng.uniform(-math.pi, math.pi, 3)
        params = CameraParams(orientation=mount_euler)
        _, forward, up = camera_pose(params, [0, 0, 0], body.as_quat())
        rotation = body * Rotation.from_euler("xyz", mount_euler)
        np.testing.assert_allclose(forward, rotation.apply([1, 0, 0]), atol=1e-12)
        np.testing.assert_allclose(up, rotation.apply([0, 0, 1]), atol=1e-12)


# ------------------------------------------------------------------ depth buffer


def test_linearise_depth_hand_computed():
    # near 0.1, far 100, d 0.5:  0.1 * 100 / (100 - 99.9 * 0.5) = 10 / 50.05
    assert float(linearise_depth(0.5, 0.1, 100.0)) == pytest.approx(0.19980019980019980, rel=1e-12)
    np.testing.assert_allclose(linearise_depth(np.array([0.0, 1.0]), 0.1, 100.0), [0.1, 100.0], rtol=1e-12)


def test_linearise_depth_inverts_the_projection():
    params = CameraParams(near=0.05, far=50.0)
    m = np.array(projection_matrix(params)).reshape(4, 4).T  # column-major -> row-major
    distances = np.array([0.05, 0.3, 2.0, 17.0, 50.0])
    clip = m @ np.stack([np.zeros(5), np.zeros(5), -distances, np.ones(5)])
    window_depth = (clip[2] / clip[3] + 1.0) / 2.0
    np.testing.assert_allclose(linearise_depth(window_depth, params.near, params.far), distances, rtol=1e-9)


# ------------------------------------------------------------------ rendering (DIRECT)

BODY_POSITION = (0.0, 0.0, 1.0)
MOUNT = (0.2, 0.0, 0.0)  # camera 0.2 m ahead of the body origin: eye at (0.2, 0, 1)


@pytest.fixture
def scene():
    """A headless client with a ground plane and a 1 m cube whose front face is 5 m ahead of the eye."""
    client = p.connect(p.DIRECT)
    plane = p.createMultiBody(0.0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client), physicsClientId=client)
    half = [0.5, 0.5, 0.5]
    box = p.createMultiBody(
        0.0,
        p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client),
        p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=[1, 0, 0, 1], physicsClientId=client),
        basePosition=[0.2 + 5.0 + 0.5, 0.0, 1.0],
        physicsClientId=client,
    )
    yield client, plane, box
    p.disconnect(client)


def square(size: int = 33, **kwargs) -> CameraParams:
    return CameraParams(width=size, height=size, fov=60.0, near=0.1, far=100.0, position=MOUNT, **kwargs)


def test_all_channels_shapes_dtypes_and_box_in_segmentation(scene):
    client, plane, box = scene
    assert box != 0  # a real id, not a default value
    images = capture(client, square(), BODY_POSITION, LEVEL)
    assert set(images) == set(CHANNELS)
    assert images["rgba"].shape == (33, 33, 4) and images["rgba"].dtype == np.uint8
    assert images["depth"].shape == (33, 33, 1) and images["depth"].dtype == np.float32
    seg = images["segmentation"]
    assert seg.shape == (33, 33, 1) and seg.dtype == np.int32
    assert seg[16, 16, 0] == box
    assert seg[0, 16, 0] == -1  # row 0 is the top of the image: sky
    assert seg[-1, 16, 0] == plane  # bottom row: the ground below the horizon
    r, g, b, a = images["rgba"][16, 16]
    assert r > 100 and g < 20 and b < 20 and a == 255  # the red cube


def test_only_requested_channels_are_returned(scene):
    client, _, box = scene
    for channels in [("rgba",), ("depth",), ("segmentation",), ("depth", "segmentation")]:
        images = capture(client, square(channels=channels), BODY_POSITION, LEVEL)
        assert set(images) == set(channels)
    # segmentation is still correct after a render that skipped it
    assert capture(client, square(channels=("segmentation",)), BODY_POSITION, LEVEL)["segmentation"][16, 16, 0] == box


def test_centre_depth_is_box_distance_and_grows_when_box_moves_away(scene):
    client, _, box = scene
    params = square(channels=("depth",))
    near_depth = capture(client, params, BODY_POSITION, LEVEL)["depth"][16, 16, 0]
    assert near_depth == pytest.approx(5.0, abs=0.03)

    p.resetBasePositionAndOrientation(box, [0.2 + 8.0 + 0.5, 0.0, 1.0], [0, 0, 0, 1], physicsClientId=client)
    far_depth = capture(client, params, BODY_POSITION, LEVEL)["depth"][16, 16, 0]
    assert far_depth == pytest.approx(8.0, abs=0.03)
    assert far_depth > near_depth


def test_depth_is_along_the_optical_axis_not_the_ray(scene):
    client, _, box = scene
    p.removeBody(box, physicsClientId=client)
    half = [0.5, 30.0, 30.0]  # a wall filling the view, its face 5 m ahead of the eye
    p.createMultiBody(
        0.0,
        p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client),
        basePosition=[0.2 + 5.0 + 0.5, 0.0, 10.0],
        physicsClientId=client,
    )
    # 10 m up, the ground is beyond the wall even along the lowest rays
    depth = capture(client, square(16, channels=("depth",)), [0.0, 0.0, 10.0], LEVEL)["depth"]
    np.testing.assert_allclose(depth, 5.0, atol=0.03)  # the corner rays are ~1.3x longer


def test_image_left_is_body_left(scene):
    client, _, box = scene
    # move the cube to the camera's left (+Y body = +Y ground for a level, unyawed body)
    p.resetBasePositionAndOrientation(box, [5.7, 2.0, 1.0], [0, 0, 0, 1], physicsClientId=client)
    seg = capture(client, square(channels=("segmentation",)), BODY_POSITION, LEVEL)["segmentation"][..., 0]
    columns = np.nonzero((seg == box).any(axis=0))[0]
    assert columns.size > 0 and columns.max() < 16


def test_horizon_lock_renders_the_level_view_from_a_tilted_body(scene):
    client, _, _ = scene
    locked = CameraParams(width=32, height=24, fov=60.0, horizon_lock=True, channels=("segmentation",))
    level = capture(client, locked, BODY_POSITION, LEVEL)["segmentation"]
    tilted = capture(client, locked, BODY_POSITION, quat(math.radians(30), math.radians(20), 0.0))["segmentation"]
    np.testing.assert_array_equal(tilted, level)
    unlocked = dataclasses.replace(locked, horizon_lock=False)
    fixed = capture(client, unlocked, BODY_POSITION, quat(math.radians(30), math.radians(20), 0.0))["segmentation"]
    assert not np.array_equal(fixed, level)


@pytest.mark.parametrize(("width", "height"), [(1, 1), (64, 32), (17, 40)])
def test_tiny_and_non_square_resolutions(scene, width, height):
    client, _, box = scene
    params = CameraParams(width=width, height=height, fov=60.0, position=MOUNT)
    images = capture(client, params, BODY_POSITION, LEVEL)
    assert images["rgba"].shape == (height, width, 4)
    assert images["depth"].shape == (height, width, 1)
    assert images["segmentation"].shape == (height, width, 1)
    if width == 1:  # the single pixel looks along the optical axis
        assert images["segmentation"][0, 0, 0] == box
        assert images["depth"][0, 0, 0] == pytest.approx(5.0, abs=0.03)
    else:  # pixels sample their centres: the centred cube is symmetric in the image
        hit = images["segmentation"][..., 0] == box
        assert hit.any()
        np.testing.assert_array_equal(hit, hit[:, ::-1])
        np.testing.assert_array_equal(hit, hit[::-1, :])

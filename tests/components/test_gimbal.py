"""Gimbal component against scipy's rotation (independent oracle) and the lag definition."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pyflyt_engine.components.gimbal import (
    GimbalParams,
    gimbal_constants,
    gimbal_step_scalar,
    rotate_vector_scalar,
)

DT = 1.0 / 240.0


def gimbal_rotation(params, angles):
    """(n, 3, 3) rotation matrices: column j is ``rotate_vector_scalar`` (what runs) of e_j."""
    basis = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    constants = gimbal_constants(params, DT)
    columns = [
        [rotate_vector_scalar(k, *eps, e) for e in basis] for k, eps in zip(constants, np.asarray(angles).tolist())
    ]
    return np.array(columns).transpose(0, 2, 1)


def gimbal_step(params, angles, command, dt):
    """(n, 2) angles after one ``gimbal_step_scalar`` (what runs) per gimbal."""
    constants = gimbal_constants(params, dt)
    steps = [
        gimbal_step_scalar(k, *eps, *xi)
        for k, eps, xi in zip(constants, np.asarray(angles).tolist(), np.asarray(command).tolist())
    ]
    return np.array(steps)


def rotate_axes(params, angles, axes):
    """(n, 3) vectors, each rotated by its gimbal with ``rotate_vector_scalar`` (what runs)."""
    constants = gimbal_constants(params, DT)
    return np.array(
        [
            rotate_vector_scalar(k, *eps, tuple(v))
            for k, eps, v in zip(constants, np.asarray(angles).tolist(), np.asarray(axes).tolist())
        ]
    )


def random_unit(rng, n):
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def make_params(n=1, **overrides):
    kwargs = dict(
        axis_a=np.tile([1.0, 0.0, 0.0], (n, 1)),
        axis_b=np.tile([0.0, 1.0, 0.0], (n, 1)),
        max_angle_a=math.radians(5.0),
        max_angle_b=math.radians(5.0),
        tau=0.01,
    )
    kwargs.update(overrides)
    return GimbalParams(**kwargs)


def test_single_axis_matches_scipy_rotvec():
    rng = np.random.default_rng(1)
    n = 200
    axes = random_unit(rng, n)
    angles = rng.uniform(-math.pi, math.pi, n)
    params = make_params(n, axis_a=axes, axis_b=random_unit(rng, n), max_angle_a=math.pi, max_angle_b=math.pi)
    R = gimbal_rotation(params, np.stack([angles, np.zeros(n)], axis=1))
    expected = Rotation.from_rotvec(axes * angles[:, None]).as_matrix()
    np.testing.assert_allclose(R, expected, atol=1e-12)
    # And the second axis alone.
    R_b = gimbal_rotation(params, np.stack([np.zeros(n), angles], axis=1))
    expected_b = Rotation.from_rotvec(params.axis_b * angles[:, None]).as_matrix()
    np.testing.assert_allclose(R_b, expected_b, atol=1e-12)


def test_composed_rotation_is_Ra_times_Rb_including_non_orthogonal_axes():
    rng = np.random.default_rng(2)
    n = 200
    axis_a = random_unit(rng, n)
    axis_b = random_unit(rng, n)
    axis_b[:10] = axis_a[:10]  # degenerate (parallel) pairs are allowed too
    angles = rng.uniform(-math.pi, math.pi, (n, 2))
    params = make_params(n, axis_a=axis_a, axis_b=axis_b)
    R = gimbal_rotation(params, angles)
    R_a = Rotation.from_rotvec(axis_a * angles[:, :1]).as_matrix()
    R_b = Rotation.from_rotvec(axis_b * angles[:, 1:]).as_matrix()
    np.testing.assert_allclose(R, R_a @ R_b, atol=1e-12)
    # The order matters for non-orthogonal, non-parallel axes: R_b @ R_a differs.
    assert not np.allclose(R[10:], (R_b @ R_a)[10:], atol=1e-6)


def test_rotations_are_orthonormal_and_zero_angles_give_identity():
    rng = np.random.default_rng(3)
    n = 100
    params = make_params(n, axis_a=random_unit(rng, n), axis_b=random_unit(rng, n))
    R = gimbal_rotation(params, rng.uniform(-math.pi, math.pi, (n, 2)))
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), (n, 3, 3)), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    R0 = gimbal_rotation(params, np.zeros((n, 2)))
    np.testing.assert_array_equal(R0, np.broadcast_to(np.eye(3), (n, 3, 3)))


def test_precomputed_skew_matrices_match_paper_definition():
    params = make_params(axis_a=[[0.6, 0.0, 0.8]], axis_b=[[0.0, 0.6, -0.8]])
    ux, uy, uz = 0.6, 0.0, 0.8
    W = np.array([[0.0, -uz, uy], [uz, 0.0, -ux], [-uy, ux, 0.0]])
    np.testing.assert_allclose(params.W_a[0], W, atol=1e-15)
    np.testing.assert_allclose(params.W_a2[0], W @ W, atol=1e-15)
    v = np.array([1.0, 2.0, 3.0])
    np.testing.assert_allclose(params.W_b[0] @ v, np.cross([0.0, 0.6, -0.8], v), atol=1e-15)


def test_step_reaches_63_percent_after_tau():
    tau = 12 * DT
    params = make_params(n=2, tau=tau, max_angle_a=[0.1, 0.2], max_angle_b=[0.3, 0.4])
    command = np.array([[1.0, -1.0], [0.5, -0.25]])
    target = np.array([[0.1, -0.3], [0.1, -0.1]])
    angles = np.zeros((2, 2))
    for _ in range(12):
        angles = gimbal_step(params, angles, command, DT)
    np.testing.assert_allclose(angles, (1.0 - math.exp(-1.0)) * target, rtol=1e-9)


def test_step_clips_command_to_max_angle():
    params = make_params(n=1, tau=0.01, max_angle_a=0.05, max_angle_b=0.08)
    angles = np.zeros((1, 2))
    for _ in range(480):
        angles = gimbal_step(params, angles, np.array([[7.0, -3.0]]), DT)
    np.testing.assert_allclose(angles, [[0.05, -0.08]], rtol=1e-12)
    assert np.all(np.abs(angles) <= np.array([[0.05, 0.08]]) + 1e-15)


def test_zero_tau_reaches_target_in_one_step():
    params = make_params(tau=0.0, max_angle_a=0.1, max_angle_b=0.1)
    angles = gimbal_step(params, np.zeros((1, 2)), np.array([[0.5, -1.0]]), DT)
    np.testing.assert_allclose(angles, [[0.05, -0.1]], rtol=1e-15)


@pytest.mark.parametrize("angle", [-0.3, -0.087, 0.01, 0.087, 0.5, 2.0])
def test_rotate_axes_tilts_thrust_axis_by_commanded_angle(angle):
    # Gimbal about +X (axis a) tilts a +Z thrust axis in the Y-Z plane; about +Y (axis b) in X-Z.
    params = make_params(n=2)
    thrust = np.tile([0.0, 0.0, 1.0], (2, 1))
    angles = np.array([[angle, 0.0], [0.0, angle]])
    out = rotate_axes(params, angles, thrust)
    cos_between = np.clip(np.sum(out * thrust, axis=1), -1.0, 1.0)
    np.testing.assert_allclose(np.arccos(cos_between), abs(angle), atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0, atol=1e-12)
    # Right-hand rule: +angle about +X sends +Z toward -Y; about +Y sends +Z toward +X.
    np.testing.assert_allclose(out[0], [0.0, -math.sin(angle), math.cos(angle)], atol=1e-12)
    np.testing.assert_allclose(out[1], [math.sin(angle), 0.0, math.cos(angle)], atol=1e-12)


@pytest.mark.parametrize(
    "overrides, message",
    [
        (dict(axis_a=[[1.0, 1.0, 0.0]]), "axis_a must be unit vectors.*normalise"),
        (dict(axis_b=[[0.0, 0.0, 1.0 + 1e-5]]), "axis_b must be unit vectors.*normalise"),
        (dict(max_angle_a=-0.1), "max_angle_a must be >= 0"),
        (dict(max_angle_b=-0.1), "max_angle_b must be >= 0"),
        (dict(tau=-1.0), "tau must be >= 0"),
        (dict(axis_b=np.tile([0.0, 1.0, 0.0], (2, 1))), r"axis_b has shape \(2, 3\), expected \(1, 3\)"),
        (dict(tau=[0.1, 0.1]), r"tau has shape \(2,\)"),
    ],
)
def test_validation_errors(overrides, message):
    with pytest.raises(ValueError, match=message):
        make_params(**overrides)


def test_unit_tolerance_accepts_tiny_rounding():
    make_params(axis_a=[[1.0 + 1e-9, 0.0, 0.0]])

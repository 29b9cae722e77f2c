"""Frame conventions: attitudes set directly read back as the paper defines them."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from pyflyt_engine.frames import euler_to_quaternion, ground_to_body_matrix, quaternion_to_matrix
from pyflyt_engine.world import World

ATTITUDES = [(0.3, -0.2, 1.1), (-0.5, 0.4, -2.5), (0.0, 0.0, math.pi / 2), (1.0, 0.2, 0.3)]


def paper_matrix(phi: float, theta: float, psi: float) -> np.ndarray:
    """The paper's printed ground-to-body matrix, entry by entry (with its (0, 1) entry)."""
    c, s = math.cos, math.sin
    return np.array(
        [
            [c(theta) * c(psi), s(phi) * c(theta), -s(theta)],
            [
                -s(psi) * c(phi) + c(psi) * s(theta) * s(phi),
                c(psi) * c(phi) + s(psi) * s(theta) * s(phi),
                c(theta) * s(phi),
            ],
            [
                s(psi) * s(phi) + c(psi) * s(theta) * c(phi),
                -c(psi) * s(phi) + s(psi) * s(theta) * c(phi),
                c(theta) * c(phi),
            ],
        ]
    )


@pytest.mark.parametrize("attitude", ATTITUDES)
def test_rotation_matches_paper_matrix_except_its_misprinted_entry(attitude):
    ours = ground_to_body_matrix(*attitude)
    paper = paper_matrix(*attitude)
    mask = np.ones((3, 3), dtype=bool)
    mask[0, 1] = False
    np.testing.assert_allclose(ours[mask], paper[mask], atol=1e-12)
    # the printed (0, 1) entry breaks orthonormality unless it equals c_theta s_psi
    np.testing.assert_allclose(ours @ ours.T, np.eye(3), atol=1e-12)
    phi, theta, psi = attitude
    assert ours[0, 1] == pytest.approx(math.cos(theta) * math.sin(psi))


@pytest.mark.parametrize("attitude", ATTITUDES)
def test_pybullet_quaternion_agrees_with_paper_rotation(attitude):
    quat = euler_to_quaternion(*attitude)
    body_to_ground = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)
    np.testing.assert_allclose(body_to_ground.T, ground_to_body_matrix(*attitude), atol=1e-9)
    np.testing.assert_allclose(quaternion_to_matrix(quat), body_to_ground, atol=1e-9)
    np.testing.assert_allclose(p.getEulerFromQuaternion(quat), attitude, atol=1e-9)


@pytest.mark.parametrize("attitude", ATTITUDES)
def test_state_readouts_in_paper_frames(attitude, quiet_cf2x):
    world = World(seed=0, ground=False)
    world.add_vehicle(quiet_cf2x, (1.0, 2.0, 3.0), attitude)
    vehicle = world.vehicles[0]
    v_ground = np.array([1.5, -0.7, 0.4])
    w_ground = np.array([0.2, 0.1, -0.3])
    p.resetBaseVelocity(vehicle.body_id, v_ground.tolist(), w_ground.tolist(), physicsClientId=world.client)
    state = vehicle.read_state()
    R = ground_to_body_matrix(*attitude)
    np.testing.assert_allclose(state.ang_pos, attitude, atol=1e-9)
    np.testing.assert_allclose(state.lin_pos, (1.0, 2.0, 3.0), atol=1e-12)
    np.testing.assert_allclose(state.lin_vel, R @ v_ground, atol=1e-9)
    np.testing.assert_allclose(state.ang_vel, R @ w_ground, atol=1e-9)
    np.testing.assert_allclose(state.lin_vel_ground, v_ground, atol=1e-12)
    np.testing.assert_allclose(np.abs(np.dot(state.quaternion, euler_to_quaternion(*attitude))), 1.0, atol=1e-9)
    assert state.as_array().shape == (4, 3)
    world.close()


def test_body_axes_are_forward_left_up():
    # yaw +90 deg: the nose points north (+y ground); a ground velocity north is body-forward
    R = ground_to_body_matrix(0.0, 0.0, math.pi / 2)
    np.testing.assert_allclose(R @ [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], atol=1e-12)
    # positive pitch tips the nose down in ENU: a body-forward axis points below the horizon
    R = ground_to_body_matrix(0.0, 0.3, 0.0)
    forward_in_ground = R.T @ [1.0, 0.0, 0.0]
    assert forward_in_ground[2] < 0

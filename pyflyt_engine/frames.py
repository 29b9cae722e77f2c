"""Frame conventions (paper, "Frame Conventions").

Ground frame: ENU (x east, y north, z up).  Body frame: x forward, y left, z up.
Euler angles are (roll phi, pitch theta, yaw psi), applied yaw, then pitch, then roll
(body = Rx(phi)^T Ry(theta)^T Rz(psi)^T ground), the same convention PyBullet's
``getEulerFromQuaternion`` returns.  Quaternions are (x, y, z, w) as in PyBullet.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pyflyt_engine import exact


def ground_to_body_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """The paper's rotation matrix R with v_body = R v_ground.

    The paper prints the (0, 1) entry as s_phi c_theta; the orthonormal matrix of this
    convention has c_theta s_psi there (every other entry is as printed).
    """
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cp * cy, cp * sy, -sp],
            [-sy * cr + cy * sp * sr, cy * cr + sy * sp * sr, cp * sr],
            [sy * sr + cy * sp * cr, -cy * sr + sy * sp * cr, cp * cr],
        ]
    )


def quaternion_to_matrix(quaternion: tuple[float, float, float, float]) -> np.ndarray:
    """Body-to-ground rotation matrix of a unit quaternion (x, y, z, w)."""
    return np.array(quaternion_to_rows(quaternion))


def quaternion_to_rows(quaternion: Sequence[float]) -> tuple[tuple[float, float, float], ...]:
    """:func:`quaternion_to_matrix` as three row tuples of floats (for the per-step
    arithmetic of :mod:`pyflyt_engine.exact`, without building an array)."""
    x, y, z, w = quaternion
    return (
        (1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
        (2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
        (2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)),
    )


def euler_to_quaternion(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of the body-to-ground rotation Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def wrap_angle(angle: float) -> float:
    """Angle wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def matrix_to_quaternion(m: np.ndarray) -> tuple[float, float, float, float]:
    """Rotation matrix -> unit quaternion (x, y, z, w) (Shepperd's method)."""
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = math.sqrt(trace + 1.0) * 2
        w, x, y, z = 0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        w, x, y, z = (m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        w, x, y, z = (m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        w, x, y, z = (m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s
    return (float(x), float(y), float(z), float(w))


def rpy_matrix(rpy: Sequence[float]) -> np.ndarray:
    """Rz(yaw) Ry(pitch) Rx(roll): the URDF ``rpy`` convention."""
    r, p, y = (float(a) for a in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rz = [[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]]
    ry = [[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]]
    rx = [[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]]
    return np.array(exact.matmul(exact.matmul(rz, ry), rx))

"""The batched state read-out (``kernels.read_out``) on tuples against the same law with arrays passed into its helper.

``read_out`` turns every env's state into the PyBullet engine's read-outs (body rates, Euler
angles, body velocity, PyBullet's quaternion).  Its per-row helper, ``read_state``, takes and
returns tuples (``kernels.quaternion_of``, ``kernels.euler_of``).  The form it replaced, kept
here as it was, passed scratch arrays through an inlined per-row helper and wrote Bullet's
matrix-to-quaternion result into one at the indices its branch picks at run time
(``out[i], out[j], out[k]``); that write makes most of the difference (the quaternion's
helper alone swapped back: ~130 of the old form's ~160 ns per env, on this 2-core VM).  Both forms give the same numbers (checked
here); this script times them interleaved on the same near-level states and prints CPU ns
per env.

    python experiments/speed_read_out.py [--envs 256] [--calls 3000]
"""

from __future__ import annotations

import argparse
import time

import math

import numpy as np

from pyflyt_engine.batched import kernels
from pyflyt_engine.batched.compiled import njit


@njit(cache=True, inline="always")
def _old_matrix_quaternion(r: np.ndarray, out: np.ndarray) -> None:
    """Quaternion (x, y, z, w) of a row-major rotation matrix: Bullet's
    ``btMatrix3x3::getRotation``, what PyBullet returns as a body's orientation (so the
    sign of the quaternion is the one it reports: w > 0 when the trace is positive, else
    the component of the largest diagonal entry)."""
    trace = r[0] + r[4] + r[8]
    if trace > 0.0:
        s = math.sqrt(trace + 1.0)
        out[3] = s * 0.5
        s = 0.5 / s
        out[0] = (r[7] - r[5]) * s
        out[1] = (r[2] - r[6]) * s
        out[2] = (r[3] - r[1]) * s
    else:
        if r[0] < r[4]:
            i = 2 if r[4] < r[8] else 1
        else:
            i = 2 if r[0] < r[8] else 0
        j = (i + 1) % 3
        k = (i + 2) % 3
        s = math.sqrt(r[4 * i] - r[4 * j] - r[4 * k] + 1.0)
        out[i] = s * 0.5
        s = 0.5 / s
        out[3] = (r[3 * k + j] - r[3 * j + k]) * s
        out[j] = (r[3 * j + i] + r[3 * i + j]) * s
        out[k] = (r[3 * k + i] + r[3 * i + k]) * s


@njit(cache=True, inline="always")
def _old_euler_from_quaternion(qx: float, qy: float, qz: float, qw: float, out: np.ndarray) -> None:
    """(roll, pitch, yaw) of a quaternion as PyBullet's ``getEulerFromQuaternion`` computes
    them (ZYX angles; at |sin(pitch)| >= 0.99999 the gimbal-lock branch)."""
    squ, sqx, sqy, sqz = qw * qw, qx * qx, qy * qy, qz * qz
    sarg = -2.0 * (qx * qz - qw * qy)
    if sarg <= -0.99999:
        out[0] = 0.0
        out[1] = -0.5 * math.pi
        out[2] = 2.0 * math.atan2(qx, -qy)
    elif sarg >= 0.99999:
        out[0] = 0.0
        out[1] = 0.5 * math.pi
        out[2] = 2.0 * math.atan2(-qx, qy)
    else:
        out[0] = math.atan2(2.0 * (qy * qz + qw * qx), squ - sqx - sqy + sqz)
        out[1] = math.asin(sarg)
        out[2] = math.atan2(2.0 * (qx * qy + qw * qz), squ + sqx - sqy - sqz)


@njit(cache=True, inline="always")
def _row_with_arrays(i, pos, quat, vel, angvel, ang_vel_body, ang_pos, lin_vel_body, quaternion, r, q, e):
    kernels.rotation_rows(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3], r)
    _old_matrix_quaternion(r, q)
    kernels.rotation_rows(q[0], q[1], q[2], q[3], r)
    _old_euler_from_quaternion(q[0], q[1], q[2], q[3], e)
    w0, w1, w2 = angvel[i, 0], angvel[i, 1], angvel[i, 2]
    v0, v1, v2 = vel[i, 0], vel[i, 1], vel[i, 2]
    ang_vel_body[i, 0] = r[0] * w0 + r[3] * w1 + r[6] * w2
    ang_vel_body[i, 1] = r[1] * w0 + r[4] * w1 + r[7] * w2
    ang_vel_body[i, 2] = r[2] * w0 + r[5] * w1 + r[8] * w2
    lin_vel_body[i, 0] = r[0] * v0 + r[3] * v1 + r[6] * v2
    lin_vel_body[i, 1] = r[1] * v0 + r[4] * v1 + r[7] * v2
    lin_vel_body[i, 2] = r[2] * v0 + r[5] * v1 + r[8] * v2
    ang_pos[i, 0], ang_pos[i, 1], ang_pos[i, 2] = e[0], e[1], e[2]
    quaternion[i, 0], quaternion[i, 1], quaternion[i, 2], quaternion[i, 3] = q[0], q[1], q[2], q[3]


@njit(cache=True)
def read_out_with_arrays(pos, quat, vel, angvel, ang_vel_body, ang_pos, lin_vel_body, quaternion):
    """The read-out as it was: the arrays passed into the inlined row helper."""
    r, q, e = np.empty(9), np.empty(4), np.empty(3)
    for i in range(pos.shape[0]):
        _row_with_arrays(i, pos, quat, vel, angvel, ang_vel_body, ang_pos, lin_vel_body, quaternion, r, q, e)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", type=int, default=256)
    parser.add_argument("--calls", type=int, default=3000, help="timed calls per form")
    args = parser.parse_args()
    n = args.envs
    rng = np.random.default_rng(0)
    # hover-like attitudes (within ~0.3 rad of level) and random velocities
    quat = np.concatenate([rng.normal(0, 0.08, (n, 3)), np.ones((n, 1))], axis=1)
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    state = (rng.normal(size=(n, 3)), quat, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)))
    outputs = {
        name: [np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 4))] for name in ("tuples", "arrays")
    }
    forms = {"tuples": kernels.read_out, "arrays": read_out_with_arrays}
    for name, fn in forms.items():
        fn(*state, *outputs[name])  # compiles
    same = all(np.array_equal(a, b) for a, b in zip(outputs["tuples"], outputs["arrays"]))
    times: dict[str, list[float]] = {name: [] for name in forms}
    for _ in range(args.calls):
        for name, fn in forms.items():
            start = time.process_time_ns()
            fn(*state, *outputs[name])
            times[name].append((time.process_time_ns() - start) / n)
    print(f"kernels.read_out, N = {n}, {args.calls} calls per form, interleaved")
    print(f"same numbers in both forms: {same}")
    print(f"{'form':<8} {'p10 ns/env':>11} {'median':>8}")
    for name, t in times.items():
        print(f"{name:<8} {np.percentile(t, 10):>11.1f} {np.median(t):>8.1f}")


if __name__ == "__main__":
    main()

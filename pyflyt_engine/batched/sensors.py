"""Noisy sensors and the state estimator on the batched backend: the PyBullet engine's laws
(:mod:`pyflyt_engine.components.sensors`, :mod:`pyflyt_engine.components.estimator`) on
arrays, one row per env, in compiled calls.

Each law is the engine's own, expression for expression in the same order of operations
(the IMU triads' bias walk, white noise, scale and range clip; the position fix with its
dropout; the barometer; Mahony's attitude filter and the position-velocity filter), at the
same sample instants (``floor(k dt rate + 1e-9) + 1`` samples due by physics step ``k``)
and with the same draws in the same order: per physics step the gyro's six normals (walk
x, y, z, then white x, y, z), the accelerometer's six, the fix's uniform (dropout) and three
normals, the barometer's normal; per reset the gyro's three, the accelerometer's three and
the barometer's one.  An episode of the PyBullet env puts the vehicle at its spawn twice
(the world's reset, then the task's spawn), each time drawing new initial biases, so a
reset here draws that set twice and keeps the second.

The draws come from each env's own generator through its bit generator's ``ctypes``
interface (as :func:`pyflyt_engine.batched.bookkeeping.spawn_rows` draws its uniforms):
``Generator.random()`` is ``next_double``, and ``Generator.standard_normal()`` is numpy's
ziggurat (``random_standard_normal`` in numpy's ``random/src/distributions/distributions.c``:
Marsaglia and Tsang, "The ziggurat method for generating random variables", J. Stat.
Softw. 5(8), 2000, with 256 layers and numpy's tables), written out in
:func:`pyflyt_engine.batched.normals.standard_normal`.  So given the same stream state and
the same true states, a row reads bit for bit what a :class:`SensorSuite` reads
(``tests/batched/test_sensors.py``).

State per env (:data:`STATE_SIZE` floats, :data:`COUNT_SIZE` integers): see the ``S_*``
and ``C_*`` offsets.  Parameters: the airframe's vector (:func:`parameters`), one row per
env, which a ``randomize`` section's sensor factors change per episode
(:func:`randomized_parameters`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pyflyt_engine.batched.compiled import njit
from pyflyt_engine.batched.kernels import rotation_rows as _rotation_rows
from pyflyt_engine.batched import normals
from pyflyt_engine.batched.normals import next_double_at, standard_normal
from pyflyt_engine.components.sensors import check_rates
from pyflyt_engine.errors import ConfigError

# ----------------------------------------------------------------- layouts

#: per-env float state: gyro bias and reading, accel bias and reading, the last velocity,
#: the position reading and its validity, the altitude and the barometer's bias, then the
#: estimator's quaternion (x, y, z, w), gyro-bias estimate, velocity and position
S_GYRO_BIAS, S_GYRO, S_ACCEL_BIAS, S_ACCEL, S_LAST_VEL = 0, 3, 6, 9, 12
S_POSITION, S_VALID, S_ALTITUDE, S_BARO_BIAS = 15, 18, 19, 20
S_EST_Q, S_EST_BIAS, S_EST_VEL, S_EST_POS = 21, 25, 28, 31
STATE_SIZE = 34
#: per-env integer state: samples taken since the reset (gyro, accel, position fix,
#: barometer), fixes due and fixes lost
C_GYRO, C_ACCEL, C_POS, C_BARO, C_FIXES, C_LOST = 0, 1, 2, 3, 4, 5
COUNT_SIZE = 6

# parameter vector: flags, then each sensor's values (parameters)
P_IMU, P_POS, P_BARO, P_EST = 0, 1, 2, 3
P_GYRO, P_ACCEL = 4, 11  # 7 each: noise density, bias random walk, bias, bias std, scale, range, rate
P_POS_STD, P_POS_RATE, P_DROPOUT = 18, 21, 22
P_BARO_STD, P_BARO_BIAS, P_BARO_BIAS_STD, P_BARO_RATE = 23, 24, 25, 26
P_KP, P_KI, P_ALPHA, P_VGAIN, P_EST_DT = 27, 28, 29, 30, 31
P_DT, P_GRAVITY = 32, 33
PARAMETER_SIZE = 34

#: the observation's sources: the true state, the sensors' readings, the estimator's state
OBSERVE_TRUE, OBSERVE_SENSED, OBSERVE_ESTIMATED = 0, 1, 2


def parameters(spec: Any, estimator: Any, physics_dt: float, gravity: float) -> np.ndarray:
    """The parameter vector of an airframe's ``sensors`` section (``spec``) and the env's
    estimator config (``estimator``; None or type ``none``: no estimator)."""
    p = np.zeros(PARAMETER_SIZE)
    imu, pos, baro = spec.imu, spec.position, spec.barometer
    if imu is not None:
        p[P_IMU] = 1.0
        for at, axis in ((P_GYRO, imu.gyro), (P_ACCEL, imu.accel)):
            p[at : at + 7] = (
                axis.noise_density,
                axis.bias_random_walk,
                axis.bias,
                axis.bias_initial_std,
                axis.scale,
                axis.range,
                axis.rate_hz,
            )
    if pos is not None:
        p[P_POS] = 1.0
        p[P_POS_STD : P_POS_STD + 3] = pos.noise_std
        p[P_POS_RATE], p[P_DROPOUT] = pos.rate_hz, pos.dropout
    if baro is not None:
        p[P_BARO] = 1.0
        p[P_BARO_STD], p[P_BARO_BIAS], p[P_BARO_BIAS_STD], p[P_BARO_RATE] = (
            baro.noise_std,
            baro.bias,
            baro.bias_initial_std,
            baro.rate_hz,
        )
    if estimator is not None and estimator.active:
        if imu is None or pos is None:
            raise ConfigError(f"the estimator needs sensors.{'imu' if imu is None else 'position'}")
        p[P_EST] = 1.0
        # as ComplementaryEstimator.__init__ derives them
        p[P_KP], p[P_KI], p[P_ALPHA] = float(estimator.k_p), float(estimator.k_i), float(estimator.alpha)
        p[P_VGAIN] = float(estimator.beta) * float(pos.rate_hz)
        p[P_EST_DT] = 1.0 / float(imu.gyro.rate_hz)
    p[P_DT], p[P_GRAVITY] = float(physics_dt), float(gravity)
    return p


#: the ``randomize`` entries that scale the sensors' parameters (pyflyt_engine.envs.randomization)
SENSOR_FACTORS = ("gyro_scale", "accel_scale", "gyro_noise", "accel_noise", "position_noise")


def randomized_parameters(nominal: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """The parameter vector of a vehicle whose ``randomize`` draws are ``values``, from the
    airframe's ``nominal`` one, as the PyBullet engine's randomiser sets its sensors
    (:meth:`pyflyt_engine.envs.randomization.Randomizer.sample`, each product the same): the
    triads' scale times ``<triad>_scale``, their noise density and bias random walk times
    ``<triad>_noise`` (where the vehicle has an IMU), the fix's noise per axis times
    ``position_noise`` (where it has a fix)."""
    p = nominal.copy()
    if p[P_IMU] != 0.0:
        for at, kind in ((P_GYRO, "gyro"), (P_ACCEL, "accel")):
            noise = values.get(f"{kind}_noise", 1.0)
            p[at + 4] = nominal[at + 4] * values.get(f"{kind}_scale", 1.0)
            p[at] = nominal[at] * noise
            p[at + 1] = nominal[at + 1] * noise
    if p[P_POS] != 0.0 and "position_noise" in values:
        for a in range(3):
            p[P_POS_STD + a] = nominal[P_POS_STD + a] * values["position_noise"]
    return p


def stream_interface(rngs: list[np.random.Generator]) -> tuple[np.ndarray, Any, Any]:
    """The state addresses of ``rngs``' bit generators and their common ``next_uint64`` and
    ``next_double`` (numpy's ctypes interface for compiled callers).

    Raises:
        ConfigError: the generators are not all of one kind of bit generator.
    """
    interfaces = [normals.interface(rng) for rng in rngs]
    first = interfaces[0]
    if any(c[1:] != first[1:] for c in interfaces):
        raise ConfigError("the sensors' generators must all be of one kind of numpy bit generator")
    return np.array([c[0] for c in interfaces], dtype=np.uintp), first[1], first[2]


# ----------------------------------------------------------------- the laws


@njit(cache=True)
def _triad_sample(p, at, row, bias_at, reading_at, v0, v1, v2, n, state, next_uint64, next_double):
    """InertialTriad.sample: the last of ``n`` due samples of the true value (v0, v1, v2)."""
    wx = standard_normal(state, next_uint64, next_double)
    wy = standard_normal(state, next_uint64, next_double)
    wz = standard_normal(state, next_uint64, next_double)
    ex = standard_normal(state, next_uint64, next_double)
    ey = standard_normal(state, next_uint64, next_double)
    ez = standard_normal(state, next_uint64, next_double)
    period = 1.0 / p[at + 6]
    walk = p[at + 1] * math.sqrt(n * period)
    white = p[at] / math.sqrt(period)
    s, r = p[at + 4], p[at + 5]
    bx = row[bias_at] + walk * wx
    by = row[bias_at + 1] + walk * wy
    bz = row[bias_at + 2] + walk * wz
    row[bias_at], row[bias_at + 1], row[bias_at + 2] = bx, by, bz
    x = s * v0 + bx + white * ex
    y = s * v1 + by + white * ey
    z = s * v2 + bz + white * ez
    row[reading_at] = r if x > r else -r if x < -r else x
    row[reading_at + 1] = r if y > r else -r if y < -r else y
    row[reading_at + 2] = r if z > r else -r if z < -r else z


@njit(cache=True)
def _estimator_reset(row, quaternion, position, velocity):
    """ComplementaryEstimator.reset: the pose normalised, the velocity, a zero bias estimate."""
    x, y, z, w = quaternion[0], quaternion[1], quaternion[2], quaternion[3]
    n = math.sqrt(x * x + y * y + z * z + w * w)
    row[S_EST_Q], row[S_EST_Q + 1], row[S_EST_Q + 2], row[S_EST_Q + 3] = x / n, y / n, z / n, w / n
    for a in range(3):
        row[S_EST_POS + a] = position[a]
        row[S_EST_VEL + a] = velocity[a]
        row[S_EST_BIAS + a] = 0.0


@njit(cache=True)
def _estimator_imu(p, row):
    """ComplementaryEstimator.imu with the held gyro and accel readings: one IMU sample."""
    dt = p[P_EST_DT]
    qx, qy, qz, qw = row[S_EST_Q], row[S_EST_Q + 1], row[S_EST_Q + 2], row[S_EST_Q + 3]
    bx, by, bz = row[S_EST_BIAS], row[S_EST_BIAS + 1], row[S_EST_BIAS + 2]
    fx, fy, fz = row[S_ACCEL], row[S_ACCEL + 1], row[S_ACCEL + 2]
    g0, g1, g2 = row[S_GYRO], row[S_GYRO + 1], row[S_GYRO + 2]
    ux, uy, uz = 2.0 * (qx * qz - qy * qw), 2.0 * (qy * qz + qx * qw), 1.0 - 2.0 * (qx * qx + qy * qy)
    norm = math.sqrt(fx * fx + fy * fy + fz * fz)
    if norm > 0.0:
        vx, vy, vz = fx / norm, fy / norm, fz / norm
        cx, cy, cz = vy * uz - vz * uy, vz * ux - vx * uz, vx * uy - vy * ux
        k_i = p[P_KI] * dt
        bx, by, bz = bx - k_i * cx, by - k_i * cy, bz - k_i * cz
        row[S_EST_BIAS], row[S_EST_BIAS + 1], row[S_EST_BIAS + 2] = bx, by, bz
        k_p = p[P_KP]
        wx, wy, wz = g0 - bx + k_p * cx, g1 - by + k_p * cy, g2 - bz + k_p * cz
    else:
        wx, wy, wz = g0 - bx, g1 - by, g2 - bz
    rate = math.sqrt(wx * wx + wy * wy + wz * wz)
    if rate > 0.0:
        half = 0.5 * rate * dt
        s = math.sin(half) / rate
        dx, dy, dz, dw = wx * s, wy * s, wz * s, math.cos(half)
        nx = qw * dx + qx * dw + qy * dz - qz * dy
        ny = qw * dy - qx * dz + qy * dw + qz * dx
        nz = qw * dz + qx * dy - qy * dx + qz * dw
        nw = qw * dw - qx * dx - qy * dy - qz * dz
        n = math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
        qx, qy, qz, qw = nx / n, ny / n, nz / n, nw / n
        row[S_EST_Q], row[S_EST_Q + 1], row[S_EST_Q + 2], row[S_EST_Q + 3] = qx, qy, qz, qw
    xx, yy, zz = qx * qx, qy * qy, qz * qz
    xy, xz, yz, xw, yw, zw = qx * qy, qx * qz, qy * qz, qx * qw, qy * qw, qz * qw
    ax = (1.0 - 2.0 * (yy + zz)) * fx + 2.0 * (xy - zw) * fy + 2.0 * (xz + yw) * fz
    ay = 2.0 * (xy + zw) * fx + (1.0 - 2.0 * (xx + zz)) * fy + 2.0 * (yz - xw) * fz
    az = 2.0 * (xz - yw) * fx + 2.0 * (yz + xw) * fy + (1.0 - 2.0 * (xx + yy)) * fz - p[P_GRAVITY]
    px, py, pz = row[S_EST_POS], row[S_EST_POS + 1], row[S_EST_POS + 2]
    vx0, vy0, vz0 = row[S_EST_VEL], row[S_EST_VEL + 1], row[S_EST_VEL + 2]
    h = 0.5 * dt * dt
    row[S_EST_POS], row[S_EST_POS + 1], row[S_EST_POS + 2] = (
        px + vx0 * dt + ax * h,
        py + vy0 * dt + ay * h,
        pz + vz0 * dt + az * h,
    )
    row[S_EST_VEL], row[S_EST_VEL + 1], row[S_EST_VEL + 2] = vx0 + ax * dt, vy0 + ay * dt, vz0 + az * dt


@njit(cache=True)
def _estimator_fix(p, row):
    """ComplementaryEstimator.fix with the position reading."""
    px, py, pz = row[S_EST_POS], row[S_EST_POS + 1], row[S_EST_POS + 2]
    ex, ey, ez = row[S_POSITION] - px, row[S_POSITION + 1] - py, row[S_POSITION + 2] - pz
    a, g = p[P_ALPHA], p[P_VGAIN]
    ux, uy, uz = row[S_EST_VEL], row[S_EST_VEL + 1], row[S_EST_VEL + 2]
    row[S_EST_POS], row[S_EST_POS + 1], row[S_EST_POS + 2] = px + a * ex, py + a * ey, pz + a * ez
    row[S_EST_VEL], row[S_EST_VEL + 1], row[S_EST_VEL + 2] = ux + g * ex, uy + g * ey, uz + g * ez


@njit(cache=True)
def _reset_draws(p, row, counts, state, next_uint64, next_double, position, velocity):
    """SensorSuite.reset's draws and readings (new initial biases: IMU, then barometer)."""
    for a in range(3):
        row[S_LAST_VEL + a] = velocity[a]
    if p[P_IMU] != 0.0:
        for at, bias_at, reading_at in ((P_GYRO, S_GYRO_BIAS, S_GYRO), (P_ACCEL, S_ACCEL_BIAS, S_ACCEL)):
            for a in range(3):
                row[bias_at + a] = p[at + 2] + p[at + 3] * standard_normal(state, next_uint64, next_double)
            for a in range(3):
                row[reading_at + a] = 0.0
    for a in range(3):
        row[S_POSITION + a] = position[a]
    row[S_VALID] = 0.0
    for k in range(COUNT_SIZE):
        counts[k] = 0
    if p[P_BARO] != 0.0:
        row[S_BARO_BIAS] = p[P_BARO_BIAS] + p[P_BARO_BIAS_STD] * standard_normal(state, next_uint64, next_double)
        row[S_ALTITUDE] = position[2] + row[S_BARO_BIAS]


@njit(cache=True)
def reset_rows(index, states, next_uint64, next_double, params, puts, pos, vel, quaternion, rows, counts):
    """The sensors (and estimator) of every env in ``index`` at time 0 of an episode started
    at ``pos``, ``vel`` (ground frame) and ``quaternion`` (body to ground, as read): ``puts``
    times new initial biases drawn, the last kept (the PyBullet env puts a vehicle at its
    spawn twice an episode, module docstring), the readings at the spawn, the estimator
    (if any) at the spawn's pose and velocity; ``params[i]`` env ``i``'s parameter vector."""
    for k in range(index.shape[0]):
        i = index[k]
        p = params[i]
        for _ in range(puts):
            _reset_draws(p, rows[i], counts[i], states[i], next_uint64, next_double, pos[i], vel[i])
        if p[P_EST] != 0.0:
            _estimator_reset(rows[i], quaternion[i], pos[i], vel[i])


@njit(cache=True)
def sample_row(p, row, counts, steps, state, next_uint64, next_double, pos, r, vel, angvel):
    """SensorSuite.step for one env: sample what is due at the start of physics step
    ``steps`` of its episode, given the body's position ``pos``, body-to-ground rotation
    ``r`` (9, row-major) and velocities ``vel``, ``angvel`` (ground frame); then the
    estimator takes the step's gyro samples and its fix."""
    time = steps * p[P_DT]
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8]
    updates = 0
    fix = False
    if p[P_IMU] != 0.0:
        lx, ly, lz = vel[0], vel[1], vel[2]
        px, py, pz = row[S_LAST_VEL], row[S_LAST_VEL + 1], row[S_LAST_VEL + 2]
        inv = 1.0 / p[P_DT]
        ax, ay, az = (lx - px) * inv, (ly - py) * inv, (lz - pz) * inv + p[P_GRAVITY]
        row[S_LAST_VEL], row[S_LAST_VEL + 1], row[S_LAST_VEL + 2] = lx, ly, lz
        taken = counts[C_GYRO]
        n = int(math.floor(time * p[P_GYRO + 6] + 1e-9)) + 1 - taken
        if n > 0:
            updates = n if taken else n - 1  # the sample at time 0 only starts the estimator
            wx, wy, wz = angvel[0], angvel[1], angvel[2]
            _triad_sample(
                p,
                P_GYRO,
                row,
                S_GYRO_BIAS,
                S_GYRO,
                r0 * wx + r3 * wy + r6 * wz,
                r1 * wx + r4 * wy + r7 * wz,
                r2 * wx + r5 * wy + r8 * wz,
                n,
                state,
                next_uint64,
                next_double,
            )
            counts[C_GYRO] = taken + n
        taken = counts[C_ACCEL]
        n = int(math.floor(time * p[P_ACCEL + 6] + 1e-9)) + 1 - taken
        if n > 0:
            _triad_sample(
                p,
                P_ACCEL,
                row,
                S_ACCEL_BIAS,
                S_ACCEL,
                r0 * ax + r3 * ay + r6 * az,
                r1 * ax + r4 * ay + r7 * az,
                r2 * ax + r5 * ay + r8 * az,
                n,
                state,
                next_uint64,
                next_double,
            )
            counts[C_ACCEL] = taken + n
    if p[P_POS] != 0.0:
        due = int(math.floor(time * p[P_POS_RATE] + 1e-9)) + 1
        if due > counts[C_POS]:
            counts[C_FIXES] += due - counts[C_POS]
            counts[C_POS] = due
            lost = next_double_at(next_double, state) < p[P_DROPOUT]
            e0 = standard_normal(state, next_uint64, next_double)
            e1 = standard_normal(state, next_uint64, next_double)
            e2 = standard_normal(state, next_uint64, next_double)
            if lost:
                counts[C_LOST] += 1
                row[S_VALID] = 0.0
            else:
                row[S_POSITION] = pos[0] + p[P_POS_STD] * e0
                row[S_POSITION + 1] = pos[1] + p[P_POS_STD + 1] * e1
                row[S_POSITION + 2] = pos[2] + p[P_POS_STD + 2] * e2
                row[S_VALID] = 1.0
                fix = True
    if p[P_BARO] != 0.0:
        due = int(math.floor(time * p[P_BARO_RATE] + 1e-9)) + 1
        if due > counts[C_BARO]:
            counts[C_BARO] = due
            eta = standard_normal(state, next_uint64, next_double)
            row[S_ALTITUDE] = pos[2] + row[S_BARO_BIAS] + p[P_BARO_STD] * eta
    if p[P_EST] != 0.0:
        for _ in range(updates):
            _estimator_imu(p, row)
        if fix:
            _estimator_fix(p, row)


@njit(cache=True)
def sample_rows(states, next_uint64, next_double, params, rows, counts, episode_steps, pos, quat, vel, angvel):
    """:func:`sample_row` for every env (its parameter vector ``params[i]``) at the start of its
    physics step ``episode_steps[i]``, the rotation from the body's quaternion
    (:func:`~pyflyt_engine.batched.kernels.rotation_rows`)."""
    r = np.empty(9)
    for i in range(pos.shape[0]):
        _rotation_rows(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3], r)
        sample_row(
            params[i],
            rows[i],
            counts[i],
            episode_steps[i],
            states[i],
            next_uint64,
            next_double,
            pos[i],
            r,
            vel[i],
            angvel[i],
        )


@njit(cache=True)
def observed_rows(
    p,
    source,
    rows,
    ang_vel_body,
    ang_pos,
    lin_vel_body,
    pos,
    quaternion,
    out_ang_vel,
    out_ang_pos,
    out_lin_vel,
    out_pos,
    out_quaternion,
):
    """The state an observation shows (``out_*``) from the state it would show without
    sensors: ``source`` :data:`OBSERVE_SENSED` (the engine's ``sensed_state``: rates from the
    gyro, position from the fix, height from the barometer) or :data:`OBSERVE_ESTIMATED`
    (``estimated_state``: rates from the gyro; attitude, velocity and position estimated, the
    body-frame velocity turned with the estimated attitude; Euler angles as
    ``estimator.quaternion_to_euler`` gives them)."""
    for i in range(pos.shape[0]):
        row = rows[i]
        for a in range(3):
            out_ang_vel[i, a] = row[S_GYRO + a] if p[P_IMU] != 0.0 else ang_vel_body[i, a]
        if source == OBSERVE_ESTIMATED:
            x, y, z, w = row[S_EST_Q], row[S_EST_Q + 1], row[S_EST_Q + 2], row[S_EST_Q + 3]
            out_quaternion[i, 0], out_quaternion[i, 1], out_quaternion[i, 2], out_quaternion[i, 3] = x, y, z, w
            out_ang_pos[i, 0] = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
            s = 2.0 * (w * y - z * x)
            out_ang_pos[i, 1] = math.asin(1.0 if s > 1.0 else -1.0 if s < -1.0 else s)
            out_ang_pos[i, 2] = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
            # frames.quaternion_to_rows, then exact.rotate_t
            a0, b0, c0 = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)
            d0, e0, f0 = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)
            g0, h0, i0 = 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)
            u, v, t = row[S_EST_VEL], row[S_EST_VEL + 1], row[S_EST_VEL + 2]
            out_lin_vel[i, 0] = a0 * u + d0 * v + g0 * t
            out_lin_vel[i, 1] = b0 * u + e0 * v + h0 * t
            out_lin_vel[i, 2] = c0 * u + f0 * v + i0 * t
            for a in range(3):
                out_pos[i, a] = row[S_EST_POS + a]
        else:
            for a in range(3):
                out_ang_pos[i, a] = ang_pos[i, a]
                out_lin_vel[i, a] = lin_vel_body[i, a]
                out_pos[i, a] = row[S_POSITION + a] if p[P_POS] != 0.0 else pos[i, a]
            for a in range(4):
                out_quaternion[i, a] = quaternion[i, a]
            if p[P_BARO] != 0.0:
                out_pos[i, 2] = row[S_ALTITUDE]


class BatchedSensors:
    """The noisy sensors (and estimator) of ``n`` envs of one airframe: their parameters,
    state rows, streams, and which state the observation shows.

    Args:
        spec: the airframe's ``sensors`` section (the env config's replacing it).
        config: the env config's ``sensors`` (None: the airframe's own, not observed).
        n: envs.
        physics_dt: the physics step [s].
        gravity: [m/s^2], positive.
    """

    def __init__(self, spec: Any, config: Any, n: int, physics_dt: float, gravity: float) -> None:
        check_rates(spec, 1.0 / physics_dt)
        observed = config is not None and bool(config.observe)
        estimator = config.estimator if observed else None
        #: the airframe's parameter vector (its flags say which sensors there are)
        self.params = parameters(spec, estimator, physics_dt, gravity)
        #: per env, the parameters its sensors sample with: the airframe's, with the noise and
        #: scale factors a ``randomize`` section draws (:func:`randomized_parameters`)
        self.param_rows = np.array(np.broadcast_to(self.params, (n, PARAMETER_SIZE)), order="C")
        #: what the observation shows: OBSERVE_TRUE, OBSERVE_SENSED or OBSERVE_ESTIMATED
        self.source = OBSERVE_TRUE if not observed else OBSERVE_ESTIMATED if self.params[P_EST] else OBSERVE_SENSED
        #: whether the fix's validity flag follows the auxiliary state in the observation
        self.fix_flag = observed and spec.position is not None
        #: per env, the float and integer state (S_* and C_* offsets)
        self.rows = np.zeros((n, STATE_SIZE))
        self.counts = np.zeros((n, COUNT_SIZE), dtype=np.int64)
        self.rngs: list[np.random.Generator] = []
        self._interface: tuple[np.ndarray, Any, Any] | None = None
        self._interface_of: list | None = None

    def seed(self, children: list[np.random.SeedSequence]) -> None:
        """Env ``i``'s stream from its seed sequence ``children[i]``: that sequence's child
        with spawn key 4 (the key of the PyBullet world's sensor streams; apart from the
        env's other draws and the turbulence's, its first child)."""
        self.rngs = [
            np.random.default_rng(np.random.SeedSequence(c.entropy, spawn_key=(*c.spawn_key, 4))) for c in children
        ]

    def seed_worlds(self, worlds: list[np.random.SeedSequence], agents: int) -> None:
        """Slot ``k agents + a``'s stream (agent ``a`` of world ``k``, the multi-agent worlds'
        layout) from world ``k``'s seed sequence ``worlds[k]``: that sequence's child with
        spawn key ``(4, a)``, as the PyBullet world seeds vehicle ``a``'s noisy sensors
        (``World._suite_rng``: spawn key 4, then the vehicle's index); apart from the world's
        other draws and its turbulence's (its first child)."""
        self.rngs = [
            np.random.default_rng(np.random.SeedSequence(w.entropy, spawn_key=(*w.spawn_key, 4, a)))
            for w in worlds
            for a in range(agents)
        ]

    def interface(self) -> tuple[np.ndarray, Any, Any]:
        if self._interface_of is not self.rngs:
            self._interface = stream_interface(self.rngs)
            self._interface_of = self.rngs
        assert self._interface is not None
        return self._interface

    def reset(self, index: np.ndarray, pos: np.ndarray, vel: np.ndarray, quaternion: np.ndarray) -> None:
        states, next_uint64, next_double = self.interface()
        reset_rows(
            index, states, next_uint64, next_double, self.param_rows, 2, pos, vel, quaternion, self.rows, self.counts
        )

    def sample(
        self, episode_steps: np.ndarray, pos: np.ndarray, quat: np.ndarray, vel: np.ndarray, angvel: np.ndarray
    ) -> None:
        states, next_uint64, next_double = self.interface()
        sample_rows(
            states,
            next_uint64,
            next_double,
            self.param_rows,
            self.rows,
            self.counts,
            episode_steps,
            pos,
            quat,
            vel,
            angvel,
        )

    def observed(self, seen: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``seen`` (the state an observation would show without sensors) as the sensors or
        the estimator show it."""
        if self.source == OBSERVE_TRUE:
            return seen
        n = self.rows.shape[0]
        out = dict(seen)
        out["ang_vel_body"], out["ang_pos"], out["lin_vel_body"], out["pos"] = (np.empty((n, 3)) for _ in range(4))
        out["quaternion"] = np.empty((n, 4))
        observed_rows(
            self.params,
            self.source,
            self.rows,
            np.ascontiguousarray(seen["ang_vel_body"]),
            np.ascontiguousarray(seen["ang_pos"]),
            np.ascontiguousarray(seen["lin_vel_body"]),
            np.ascontiguousarray(seen["pos"]),
            np.ascontiguousarray(seen["quaternion"]),
            out["ang_vel_body"],
            out["ang_pos"],
            out["lin_vel_body"],
            out["pos"],
            out["quaternion"],
        )
        return out

    def readings(self, i: int) -> dict[str, np.ndarray]:
        """Env ``i``'s readings by name, as :meth:`SensorSuite.readings` gives them."""
        row, p, out = self.rows[i], self.params, {}
        if p[P_IMU]:
            out["gyro"] = row[S_GYRO : S_GYRO + 3].copy()
            out["accel"] = row[S_ACCEL : S_ACCEL + 3].copy()
        if p[P_POS]:
            out["position"] = row[S_POSITION : S_POSITION + 3].copy()
            out["position_valid"] = row[S_VALID : S_VALID + 1].copy()
        if p[P_BARO]:
            out["altitude"] = row[S_ALTITUDE : S_ALTITUDE + 1].copy()
        return out

    def estimate(self, i: int) -> list[float]:
        """Env ``i``'s estimator state as :meth:`ComplementaryEstimator.values` lists it."""
        row = self.rows[i]
        q = row[S_EST_Q : S_EST_Q + 4].tolist()
        x, y, z, w = q
        from pyflyt_engine.components.estimator import quaternion_to_euler

        return [
            *q,
            *quaternion_to_euler((x, y, z, w)),
            *row[S_EST_VEL : S_EST_VEL + 3].tolist(),
            *row[S_EST_POS : S_EST_POS + 3].tolist(),
            *row[S_EST_BIAS : S_EST_BIAS + 3].tolist(),
        ]


__all__ = [
    "SENSOR_FACTORS",
    "BatchedSensors",
    "check_rates",
    "parameters",
    "randomized_parameters",
    "sample_row",
]

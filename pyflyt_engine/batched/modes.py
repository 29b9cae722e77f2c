"""The batched backend's outer control loops: every multirotor flight mode above the rate loop.

:class:`~pyflyt_engine.control.multirotor.MultirotorController` enters its cascade at the
level of each flight mode (position -> velocity -> tilt and thrust -> attitude -> body
rates -> mixer); the compiled forms here are its loops, one function per method, in the
same order of operations (``tests/batched/test_modes.py`` holds each to the scalar one
bit for bit on random inputs, integrators and limits included, for every multirotor the
backend flies):

* :func:`velocity_axis` -- one ground axis of ``_velocity_loop`` (conditional
  integration, the integral window, the saturation bounds);
* :func:`climb` -- ``_climb`` (and the altitude and position steps of ``_translate_command``);
* :func:`thrust_for` -- ``_thrust_for``; :func:`attitude_rates` -- ``_attitude_rates``
  (the yaw error wrapped by Python's float ``%``, which numba compiles with CPython's
  semantics: ``fmod``, then the sign of the divisor);
* :func:`tilt_for` -- ``_tilt_for`` (with the trim attitude of tilted thrust, a tricopter's tail);
* :func:`outer_loops` -- the laws ``_rates_z``, ``_attitude`` and ``_translate_command``
  (every translational mode: heading-frame velocity, position or ground velocity; yaw
  angle or rate; climb rate or altitude): the body-rate setpoint and collective thrust;
* :func:`control_tick` -- one control tick of every vehicle: the state as the PyBullet
  engine reads it (``Vehicle.read_state``: PyBullet's reported quaternion, its matrix and
  Euler angles), :func:`outer_loops`, the rate loop and the mixer
  (:func:`pyflyt_engine.batched.kernels.rate_loop`, :func:`~pyflyt_engine.batched.kernels.mixer_outputs`:
  with tilting motors, their servo commands after the throttles) into the mixer's outputs.

The env runs :func:`control_tick` at every control tick and the physics of the control
period in between through :func:`pyflyt_engine.batched.kernels.advance` in mode ``motors``
with those commands (a throttle in [0, 1] passes the motors' [-1, 1] limit unchanged), so a
cascade mode flies the same motor, drag and rigid-body step as every other multirotor mode.

The controller's memory between ticks is the rate loop's integral and last rates (the
env's ``integral``, ``previous``, ``has_previous``) and the velocity loop's integral
(``vel_integral``); all are cleared when an episode starts, as ``MultirotorController.reset``
clears them on ``Vehicle.reset``.  Gains, limits and the thrust-margin bounds are read out
of the engine's own controller (:func:`cascade_params`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pyflyt_engine.batched.compiled import njit
from pyflyt_engine.batched.kernels import (
    euler_from_quaternion,
    matrix_quaternion,
    mixer_outputs,
    rate_loop,
    rotation_rows,
    rotation_tuple,
)
from pyflyt_engine.control import multirotor as _mr

# the constants of pyflyt_engine.control.multirotor, the same doubles read from that module
_GRAVITY = _mr.GRAVITY
_MIN_LIFT = _mr._MIN_LIFT
_TWO_PI = _mr._TWO_PI
_PI = math.pi

#: mode codes of the compiled cascade (beside kernels.MODE_*), one per multirotor mode above the rate loop
CASCADE_MODES = {
    "rates_z": 10,
    "attitude_vz": 11,
    "attitude_z": 12,
    "heading_velocity_z": 13,
    "heading_velocity_vz": 14,
    "velocity_yawrate": 15,
    "velocity_yaw": 16,
    "position_yaw": 17,
    "position_yawrate": 18,
}
#: the laws of MultirotorController._select: rates_z, the attitude modes, the translational modes
LAW_RATES_Z, LAW_ATTITUDE, LAW_TRANSLATE = 0, 1, 2
#: rows of a CascadeParams table
_VEL_KP, _VEL_KI, _VEL_LO, _VEL_HI, _POS_KP, _MAX_VEL, _ATT_KP, _MAX_RATE = range(8)


def cascade_law(code: int) -> tuple[int, bool, bool, bool, bool]:
    """``(law, yaw_is_rate, heading_frame, position, altitude)`` of a cascade mode code, from
    the controller's own table (``multirotor._TRANSLATIONAL``) and ``_select``'s laws."""
    name = next(name for name, c in CASCADE_MODES.items() if c == code)
    if name == "rates_z":
        return LAW_RATES_Z, False, False, False, True
    if name in ("attitude_vz", "attitude_z"):
        return LAW_ATTITUDE, False, False, False, name == "attitude_z"
    yaw_is_rate, heading_frame, position, altitude = _mr._TRANSLATIONAL[name]
    return LAW_TRANSLATE, yaw_is_rate, heading_frame, position, altitude


@dataclass(frozen=True)
class CascadeParams:
    """The outer loops' parameters, read out of a :class:`MultirotorController`.

    Attributes:
        mass: the controller's mass [kg] (the spec's, as ``_thrust_for`` uses it).
        table: (8, 3) per axis: the velocity loop's kp, ki and lowest and highest integral
            term (``_velocity_axes``), the position loop's kp and velocity limit, the
            attitude loop's kp and rate limit.
        window: the velocity loop's integral window [m/s] (inf: none).
        max_tilt: the tilt limit [rad].
        trim: the (roll, pitch) [rad] ``_tilt_for`` adds where the mixer's thrust has a side
            force (``_trim``: tilted thrust, a tricopter's tail); trimmed: whether it has one.
    """

    mass: float
    table: np.ndarray
    window: float
    max_tilt: float
    trim: tuple[float, float] = (0.0, 0.0)
    trimmed: bool = False


def cascade_params(controller: _mr.MultirotorController) -> CascadeParams:
    """:class:`CascadeParams` of ``controller`` (its attributes as its loops read them)."""
    velocity = np.array(controller._velocity_axes, dtype=np.float64).T  # rows kp, ki, lo, hi
    rows = np.vstack(
        [velocity, controller._position_kp, controller._max_velocity, controller._attitude_kp, controller._max_rate]
    ).astype(np.float64)
    trim = controller._trim
    return CascadeParams(
        float(controller.mass),
        np.ascontiguousarray(rows),
        float(controller._window),
        float(controller._max_tilt),
        (float(trim[0]), float(trim[1])) if trim is not None else (0.0, 0.0),
        trim is not None,
    )


# ------------------------------------------------------------------ the loops


@njit(cache=True)
def velocity_axis(sp: float, v: float, i: float, kp: float, ki: float, lo: float, hi: float, window: float, dt: float):
    """One ground axis of ``MultirotorController._velocity_loop`` with a setpoint: returns the
    acceleration command and the advanced integral ``(a, i)``."""
    e = sp - v
    if ki > 0.0 and -window < e < window:
        trial = i + e * dt
        a = kp * e + ki * trial
        if not ((a > hi and e > 0.0) or (a < lo and e < 0.0)):
            term = ki * trial
            i = hi / ki if term > hi else lo / ki if term < lo else trial
    return kp * e + ki * i, i


@njit(cache=True)
def climb(kp: float, limit: float, target: float, now: float) -> float:
    """``MultirotorController._climb``: ``clip(kp (target - now), limit)`` (also the position
    and altitude steps of ``_translate_command``)."""
    value = kp * (target - now)
    return limit if value > limit else -limit if value < -limit else value


@njit(cache=True)
def thrust_for(mass: float, roll: float, pitch: float, az: float) -> float:
    """``MultirotorController._thrust_for``: ``max(m (g + az) / max(cos(roll) cos(pitch), 0.5), 0)``."""
    tilt = math.cos(roll) * math.cos(pitch)
    tilt = 0.5 if 0.5 > tilt else tilt
    thrust = mass * (_GRAVITY + az) / tilt
    return 0.0 if 0.0 > thrust else thrust


@njit(cache=True)
def attitude_rates(
    table: np.ndarray,
    roll_sp: float,
    pitch_sp: float,
    yaw_sp: float,
    hold_rate: bool,
    yaw_rate: float,
    roll: float,
    pitch: float,
    yaw: float,
):
    """``MultirotorController._attitude_rates``: body-rate setpoint ``(p, q, r)`` from an
    attitude setpoint (``hold_rate``: the scalar law's ``yaw is None``, hold ``yaw_rate``)."""
    p = table[_ATT_KP, 0] * (roll_sp - roll)
    q = table[_ATT_KP, 1] * (pitch_sp - pitch)
    r = yaw_rate if hold_rate else table[_ATT_KP, 2] * ((yaw_sp - yaw + _PI) % _TWO_PI - _PI)
    lx, ly, lz = table[_MAX_RATE, 0], table[_MAX_RATE, 1], table[_MAX_RATE, 2]
    return (
        lx if p > lx else -lx if p < -lx else p,
        ly if q > ly else -ly if q < -ly else q,
        lz if r > lz else -lz if r < -lz else r,
    )


@njit(cache=True)
def tilt_for(
    yaw: float, ax: float, ay: float, az: float, limit: float, trimmed: bool, trim_roll: float, trim_pitch: float
):
    """``MultirotorController._tilt_for``: ``(roll, pitch)`` pointing the thrust along the
    ground-frame acceleration, the trim added where the airframe has one (``trimmed``), both
    limited to ``limit``."""
    cy, sy = math.cos(yaw), math.sin(yaw)
    forward = cy * ax + sy * ay
    left = -sy * ax + cy * ay
    lift = _GRAVITY + az
    lift = _MIN_LIFT if _MIN_LIFT > lift else lift
    pitch = math.atan2(forward, lift)
    roll = math.atan2(-left * math.cos(pitch), lift)
    if trimmed:
        roll, pitch = roll + trim_roll, pitch + trim_pitch
    return (
        limit if roll > limit else -limit if roll < -limit else roll,
        limit if pitch > limit else -limit if pitch < -limit else pitch,
    )


@njit(cache=True)
def _vertical(table: np.ndarray, vz_sp: float, vz: float, vel_integral: np.ndarray, window: float, dt: float) -> float:
    """The vertical axis alone of the velocity loop (``_velocity_loop(state, (None, None, vz))[2]``:
    the horizontal integrals stay as they are)."""
    az, vel_integral[2] = velocity_axis(
        vz_sp,
        vz,
        vel_integral[2],
        table[_VEL_KP, 2],
        table[_VEL_KI, 2],
        table[_VEL_LO, 2],
        table[_VEL_HI, 2],
        window,
        dt,
    )
    return az


@njit(cache=True)
def outer_loops(
    law: int,
    yaw_is_rate: bool,
    heading_frame: bool,
    position: bool,
    altitude: bool,
    a: float,
    b: float,
    c: float,
    d: float,
    roll: float,
    pitch: float,
    yaw: float,
    x: float,
    y: float,
    z: float,
    vx: float,
    vy: float,
    vz: float,
    vel_integral: np.ndarray,
    table: np.ndarray,
    mass: float,
    window: float,
    max_tilt: float,
    dt: float,
    trimmed: bool,
    trim_roll: float,
    trim_pitch: float,
):
    """The body-rate setpoint and collective thrust ``(p, q, r, thrust)`` of a cascade mode's
    law for setpoint ``(a, b, c, d)`` and the state's attitude (roll, pitch, yaw), position and
    ground velocity; ``vel_integral`` (3,) advanced.

    ``LAW_RATES_Z`` (``_rates_z``): the rates as given, the altitude through the vertical
    velocity loop.  ``LAW_ATTITUDE`` (``_attitude``): the attitude loop, a climb rate or
    (``altitude``) an altitude.  ``LAW_TRANSLATE`` (``_translate_command``): a ground velocity
    from a heading-frame velocity, a position or as given, a climb rate or altitude, through
    the velocity, tilt (with the trim: ``trimmed``, ``trim_roll``, ``trim_pitch``) and attitude
    loops, a yaw angle or (``yaw_is_rate``) rate."""
    if law == LAW_RATES_Z:
        az = _vertical(table, climb(table[_POS_KP, 2], table[_MAX_VEL, 2], d, z), vz, vel_integral, window, dt)
        return a, b, c, thrust_for(mass, roll, pitch, az)
    if law == LAW_ATTITUDE:
        vz_sp = climb(table[_POS_KP, 2], table[_MAX_VEL, 2], d, z) if altitude else d
        az = _vertical(table, vz_sp, vz, vel_integral, window, dt)
        p, q, r = attitude_rates(table, a, b, c, False, 0.0, roll, pitch, yaw)
        return p, q, r, thrust_for(mass, roll, pitch, az)
    if heading_frame:
        ch, sh = math.cos(yaw), math.sin(yaw)
        vx_sp, vy_sp = ch * a - sh * b, sh * a + ch * b
    elif position:
        vx_sp = climb(table[_POS_KP, 0], table[_MAX_VEL, 0], a, x)
        vy_sp = climb(table[_POS_KP, 1], table[_MAX_VEL, 1], b, y)
    else:
        vx_sp, vy_sp = a, b
    vz_sp = climb(table[_POS_KP, 2], table[_MAX_VEL, 2], d, z) if altitude else d
    ax, vel_integral[0] = velocity_axis(
        vx_sp,
        vx,
        vel_integral[0],
        table[_VEL_KP, 0],
        table[_VEL_KI, 0],
        table[_VEL_LO, 0],
        table[_VEL_HI, 0],
        window,
        dt,
    )
    ay, vel_integral[1] = velocity_axis(
        vy_sp,
        vy,
        vel_integral[1],
        table[_VEL_KP, 1],
        table[_VEL_KI, 1],
        table[_VEL_LO, 1],
        table[_VEL_HI, 1],
        window,
        dt,
    )
    az, vel_integral[2] = velocity_axis(
        vz_sp,
        vz,
        vel_integral[2],
        table[_VEL_KP, 2],
        table[_VEL_KI, 2],
        table[_VEL_LO, 2],
        table[_VEL_HI, 2],
        window,
        dt,
    )
    roll_sp, pitch_sp = tilt_for(yaw, ax, ay, az, max_tilt, trimmed, trim_roll, trim_pitch)
    p, q, r = attitude_rates(table, roll_sp, pitch_sp, c, yaw_is_rate, c if yaw_is_rate else 0.0, roll, pitch, yaw)
    return p, q, r, thrust_for(mass, roll, pitch, az)


@njit(cache=True)
def control_tick(
    pos,
    quat,
    vel,
    angvel,
    setpoint,
    integral,
    previous,
    has_previous,
    vel_integral,
    law,
    yaw_is_rate,
    heading_frame,
    position,
    altitude,
    table,
    mass,
    window,
    max_tilt,
    rate_gains,
    derivative,
    control_inertia,
    gyro,
    mixer_rows,
    dt,
    command,
    lateral,
    trimmed,
    trim_roll,
    trim_pitch,
):
    """One control tick of every vehicle in a cascade mode: the mixer's outputs (N, n + t: the
    throttles of its n motors, then the servo commands of its t tilting motors, ``lateral``)
    into ``command``.

    Per vehicle ``i`` the state as ``Vehicle.read_state`` reads it (the quaternion PyBullet
    reports for ``quat[i]``, the body rates through its matrix, its Euler angles; position and
    ground velocity as they are), :func:`outer_loops` (``vel_integral[i]`` advanced), the rate
    loop (``integral[i]``, ``previous[i]``, ``has_previous[i]``, as ``kernels.advance`` keeps
    them) and the mixer.  ``table``, ``mass``, ``window``, ``max_tilt`` and the rate loop's and
    mixer's parameters one row per vehicle; the trim (``trimmed``, ``trim_roll``, ``trim_pitch``)
    the airframe's."""
    n = pos.shape[0]
    nm = mixer_rows.shape[1] + lateral.shape[0]  # the mixer's outputs (command may hold more columns after them)
    rm = np.empty(9)
    qr = np.empty(4)
    euler = np.empty(3)
    rates = np.empty(3)
    rates_sp = np.empty(3)
    torques = np.empty(3)
    out = np.empty(nm)
    parts = np.empty((mixer_rows.shape[1], 4))
    for i in range(n):
        rotation_rows(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3], rm)
        matrix_quaternion(rm, qr)
        euler_from_quaternion(qr[0], qr[1], qr[2], qr[3], euler)
        m0, m1, m2, m3, m4, m5, m6, m7, m8 = rotation_tuple(qr[0], qr[1], qr[2], qr[3])
        w0, w1, w2 = angvel[i, 0], angvel[i, 1], angvel[i, 2]
        bw0 = m0 * w0 + m3 * w1 + m6 * w2
        bw1 = m1 * w0 + m4 * w1 + m7 * w2
        bw2 = m2 * w0 + m5 * w1 + m8 * w2
        s = setpoint[i]
        p_sp, q_sp, r_sp, thrust = outer_loops(
            law,
            yaw_is_rate,
            heading_frame,
            position,
            altitude,
            s[0],
            s[1],
            s[2],
            s[3],
            euler[0],
            euler[1],
            euler[2],
            pos[i, 0],
            pos[i, 1],
            pos[i, 2],
            vel[i, 0],
            vel[i, 1],
            vel[i, 2],
            vel_integral[i],
            table[i],
            mass[i],
            window[i],
            max_tilt[i],
            dt,
            trimmed,
            trim_roll,
            trim_pitch,
        )
        rates[0], rates[1], rates[2] = bw0, bw1, bw2
        rates_sp[0], rates_sp[1], rates_sp[2] = p_sp, q_sp, r_sp
        if not has_previous[i]:
            previous[i, 0], previous[i, 1], previous[i, 2] = bw0, bw1, bw2
        rate_loop(
            rates_sp,
            rates,
            previous[i],
            integral[i],
            rate_gains[i],
            derivative,
            control_inertia[i],
            gyro[i],
            dt,
            torques,
        )
        previous[i, 0], previous[i, 1], previous[i, 2] = bw0, bw1, bw2
        has_previous[i] = True
        mixer_outputs(thrust, torques[0], torques[1], torques[2], mixer_rows[i], lateral, parts, out)
        for mo in range(nm):
            command[i, mo] = out[mo]

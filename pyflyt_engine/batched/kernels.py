"""The batched backend's compiled laws: N multirotors advanced one agent step by one call.

Every function here is compiled by numba (``nopython``, no fast-math: no reassociation,
no contraction into fused multiply-adds; NumPy's error model, :mod:`pyflyt_engine.batched.compiled`),
so each floating-point operation rounds exactly as the same expression in Python does.  The laws are the engine's own, written out in the
same order of operations as their scalar forms, which ``tests/batched/test_laws.py``
holds together bit for bit on random inputs for every airframe:

* motors (:meth:`pyflyt_engine.components.motor.Motors.step`): first-order lag, the
  multiplicative noise factor, the wrench columns times ``x |x|``;
* the optional motor models and the battery (:meth:`pyflyt_engine.components.motor_models.ModelledMotors.step`:
  asymmetric lag, axial inflow ``InflowRotor.ratios``, rotor drag, the rotors' speed on
  the pack's voltage; :meth:`pyflyt_engine.components.battery.Battery.step` and
  ``battery.supply``), in ``tests/batched/test_motor_models.py``;
* body drag (:meth:`pyflyt_engine.components.drag.BodyDrag.step`);
* the body-rate loop (``MultirotorController._rate_loop``) and the mixer
  (:meth:`pyflyt_engine.control.mixer.Mixer.throttles`: :func:`mix` without tilting motors,
  :func:`mix_tilted` with them, a tricopter's tail);
* the gimbals (:class:`pyflyt_engine.components.gimbal.Gimbals`: the servos' lag and the
  Rodrigues rotation ``R_a R_b``, the motor column they turn, ``Motors.turn``) and the routing
  of a multirotor's channels and mixer outputs to its motors, gimbals and flaps
  (``Motors.route``, ``Gimbals.route``), in ``tests/batched/test_vtol.py``;
* lifting surfaces (:mod:`pyflyt_engine.components.lifting_surface`: the Khan & Nahon
  profile ``_coefficients``, ``surface_wrench``, ``flap_deflection`` and
  ``Surfaces.step``), and the channel routing of a channel-driven airframe
  (``Vehicle.control_step`` in mode ``channels``, ``Motors.route``, ``Surfaces.route``)
  and the fixed-wing autopilot of mode ``attitude_airspeed``
  (:class:`pyflyt_engine.control.fixedwing.FixedwingAutopilot`);
* the state read-outs PyBullet gives the PyBullet engine (the quaternion from the body's
  rotation matrix, Euler angles from the quaternion), written from Bullet's formulas.

The rigid body is integrated as PyBullet integrates a free-floating single-link body
under an external wrench (measured against it: ``tests/batched/test_crosscheck.py``),
semi-implicit Euler with an exponential-map attitude update::

    a      = R F_b / m + g                       (ground frame)
    alpha  = J^-1 (tau_b - w_b x (J w_b))        (body frame, Euler's equations)
    v'     = v + a dt,        w' = w + R alpha dt
    p'     = p + v' dt,       q' = exp(w' dt / 2) q   (normalised)

The exponential map limits the rotation per step to pi/4 as Bullet does
(``ANGULAR_MOTION_THRESHOLD`` in Bullet's ``btMultiBody::stepPositionsMultiDof``) and
uses the same Taylor form below 0.001 rad/s.  Only the last bits differ from PyBullet's
(it works in the body frame and back), which is why the cross-check has a bound and not
an equality.
"""

from __future__ import annotations

import math

import numpy as np

from pyflyt_engine.batched.compiled import njit
from pyflyt_engine.batched import air as _air
from pyflyt_engine.components import lifting_surface as _ls

# Bullet: ANGULAR_MOTION_THRESHOLD = 0.5 * SIMD_HALF_PI (btMultiBody.cpp)
_ANGULAR_MOTION_THRESHOLD = 0.5 * (0.5 * math.pi)
#: vehicles per block of :func:`advance` (its physics steps go block by block)
_BLOCK = 128

#: mode codes of the compiled controller
MODE_MOTORS = -1
MODE_RATES_THRUST = 0
MODE_CHANNELS = 1
MODE_ATTITUDE_AIRSPEED = 2

# the Khan & Nahon profile's constants, as pyflyt_engine.components.lifting_surface names them
# (ICUAS 2015; REFERENCE.md "Lifting surface"): the same doubles, read from that module
_CP_BASE = _ls._CP_BASE
_CP_SHIFT = _ls._CP_SHIFT
_CD90_QUAD = _ls._CD90_QUAD
_CD90_LIN = _ls._CD90_LIN
_CD90_ZERO = _ls._CD90_ZERO
_CN_BASE = _ls._CN_BASE
_CN_SIN = _ls._CN_SIN
_CT_STALL = _ls._CT_STALL
_HALF_PI = _ls._HALF_PI
_TWO_OVER_PI = _ls._TWO_OVER_PI
#: a surface's row: the fields of lifting_surface.SurfaceConstants in order (25 values)
SURFACE_FIELDS = len(_ls.SurfaceConstants._fields)


@njit(cache=True, inline="always")
def rotation_tuple(qx: float, qy: float, qz: float, qw: float):
    """Body-to-ground rotation matrix of a quaternion, row-major, as a 9-tuple (the hot loop
    keeps it in registers): Bullet's ``btMatrix3x3::setRotation`` (``s = 2 / |q|^2``), which
    PyBullet's ``getMatrixFromQuaternion`` also runs."""
    d = qx * qx + qy * qy + qz * qz + qw * qw
    s = 2.0 / d
    xs, ys, zs = qx * s, qy * s, qz * s
    wx, wy, wz = qw * xs, qw * ys, qw * zs
    xx, xy, xz = qx * xs, qx * ys, qx * zs
    yy, yz, zz = qy * ys, qy * zs, qz * zs
    return (1.0 - (yy + zz), xy - wz, xz + wy, xy + wz, 1.0 - (xx + zz), yz - wx, xz - wy, yz + wx, 1.0 - (xx + yy))


@njit(cache=True, inline="always")
def rotation_rows(qx: float, qy: float, qz: float, qw: float, out: np.ndarray) -> None:
    """Body-to-ground rotation matrix of a quaternion, row-major into ``out`` (9,):
    :func:`rotation_tuple`'s entries."""
    r = rotation_tuple(qx, qy, qz, qw)
    for k in range(9):
        out[k] = r[k]


@njit(cache=True)
def rotations(quaternions: np.ndarray, out: np.ndarray) -> None:
    """:func:`rotation_rows` of every row of ``quaternions`` (N, 4) into ``out`` (N, 9)."""
    for i in range(quaternions.shape[0]):
        q = quaternions[i]
        rotation_rows(q[0], q[1], q[2], q[3], out[i])


@njit(cache=True, inline="always")
def quaternion_of(r):
    """Quaternion (x, y, z, w) of a row-major rotation matrix ``r`` (9-tuple): Bullet's
    ``btMatrix3x3::getRotation``, what PyBullet returns as a body's orientation (so the
    sign of the quaternion is the one it reports: w > 0 when the trace is positive, else
    the component of the largest diagonal entry).  On scalars, as the hot loops keep them
    (:func:`matrix_quaternion` is its array form)."""
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
    trace = r0 + r4 + r8
    if trace > 0.0:
        s = math.sqrt(trace + 1.0)
        w = s * 0.5
        s = 0.5 / s
        return (r7 - r5) * s, (r2 - r6) * s, (r3 - r1) * s, w
    # the largest diagonal entry i and the next two, j = i + 1 and k = i + 2 (mod 3)
    if r0 < r4:
        i = 2 if r4 < r8 else 1
    else:
        i = 2 if r0 < r8 else 0
    if i == 0:  # j, k = 1, 2
        s = math.sqrt(r0 - r4 - r8 + 1.0)
        x = s * 0.5
        s = 0.5 / s
        return x, (r3 + r1) * s, (r6 + r2) * s, (r7 - r5) * s
    if i == 1:  # j, k = 2, 0
        s = math.sqrt(r4 - r8 - r0 + 1.0)
        y = s * 0.5
        s = 0.5 / s
        return (r1 + r3) * s, y, (r7 + r5) * s, (r2 - r6) * s
    s = math.sqrt(r8 - r0 - r4 + 1.0)  # i = 2: j, k = 0, 1
    z = s * 0.5
    s = 0.5 / s
    return (r2 + r6) * s, (r5 + r7) * s, z, (r3 - r1) * s


@njit(cache=True, inline="always")
def matrix_quaternion(r: np.ndarray, out: np.ndarray) -> None:
    """:func:`quaternion_of` the row-major rotation matrix ``r`` (9,), into ``out`` (4,)."""
    out[0], out[1], out[2], out[3] = quaternion_of((r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8]))


@njit(cache=True, inline="always")
def euler_of(qx: float, qy: float, qz: float, qw: float):
    """(roll, pitch, yaw) of a quaternion as PyBullet's ``getEulerFromQuaternion`` computes
    them (ZYX angles; at |sin(pitch)| >= 0.99999 the gimbal-lock branch), a 3-tuple."""
    squ, sqx, sqy, sqz = qw * qw, qx * qx, qy * qy, qz * qz
    sarg = -2.0 * (qx * qz - qw * qy)
    if sarg <= -0.99999:
        return 0.0, -0.5 * math.pi, 2.0 * math.atan2(qx, -qy)
    if sarg >= 0.99999:
        return 0.0, 0.5 * math.pi, 2.0 * math.atan2(-qx, qy)
    return (
        math.atan2(2.0 * (qy * qz + qw * qx), squ - sqx - sqy + sqz),
        math.asin(sarg),
        math.atan2(2.0 * (qx * qy + qw * qz), squ + sqx - sqy - sqz),
    )


@njit(cache=True, inline="always")
def euler_from_quaternion(qx: float, qy: float, qz: float, qw: float, out: np.ndarray) -> None:
    """:func:`euler_of` into ``out`` (3,)."""
    out[0], out[1], out[2] = euler_of(qx, qy, qz, qw)


@njit(cache=True)
def motors_step(throttle: np.ndarray, command: np.ndarray, lag: np.ndarray, factors: np.ndarray, columns: np.ndarray):
    """One physics step of a vehicle's motors (``Motors.step``): ``x' = (x + a (c - x)) z``;
    ``throttle`` updated; returns the wrench ``sum_i column_i x'_i |x'_i|`` (6-tuple).
    :func:`motors_step_row` of one vehicle's arrays."""
    return motors_step_row(
        throttle[np.newaxis],
        command[np.newaxis],
        lag[np.newaxis],
        factors[np.newaxis, np.newaxis],
        columns[np.newaxis],
        0,
        0,
        0,
    )


@njit(cache=True, inline="always")
def motors_step_row(
    throttle: np.ndarray,
    command: np.ndarray,
    lag: np.ndarray,
    factors: np.ndarray,
    columns: np.ndarray,
    i: int,
    s: int,
    c: int,
):
    """:func:`motors_step` of vehicle ``i`` at physics step ``s`` of the batch's arrays
    (``throttle``, ``command``, ``lag`` (N, n), ``factors`` (N, count, n)), its wrench columns
    ``columns[c]`` ((., n, 6): the batch's, ``c = i``, or a vehicle's scratch).
    The hot loops index the batch's arrays instead of taking a view of a row: a view per
    vehicle and step costs a reference count's increment and decrement, more than the law."""
    fx = fy = fz = tx = ty = tz = 0.0
    for m in range(throttle.shape[1]):
        x = throttle[i, m]
        x = (x + lag[i, m] * (command[i, m] - x)) * factors[i, s, m]
        throttle[i, m] = x
        f = x * abs(x)
        fx += columns[c, m, 0] * f
        fy += columns[c, m, 1] * f
        fz += columns[c, m, 2] * f
        tx += columns[c, m, 3] * f
        ty += columns[c, m, 4] * f
        tz += columns[c, m, 5] * f
    return fx, fy, fz, tx, ty, tz


# ------------------------------------------------- modelled motors and battery

#: a modelled motor's row (``BatchedModel.motor_model``), read out of the engine's
#: ``ModelledMotors`` and its ``InflowRotor``: the spin-down lag, hub position, thrust
#: axis, static thrust and reaction torque at full throttle, top speed [rad/s], reaction
#: torque magnitude at full throttle, rotor drag coefficient (0: none), and the inflow
#: model's radius, C_T0, lambda_h, s = sigma a / 4, theta_tip and C_Q / C_T0 in hover
(
    M_LAG_FALL,
    M_PX,
    M_PY,
    M_PZ,
    M_AX,
    M_AY,
    M_AZ,
    M_THRUST,
    M_REACTION,
    M_OMEGA,
    M_TORQUE,
    M_ROTOR_DRAG,
    M_RADIUS,
    M_CT0,
    M_LAMBDA_H,
    M_S,
    M_THETA,
    M_CQ_HOVER,
) = range(18)
MOTOR_MODEL_FIELDS = 18
#: bits of ``BatchedModel.motor_laws``: 0 flies the static motors (:func:`motors_step`), any
#: other value :func:`modelled_motors_step` (``ModelledMotors``), with the laws its bits name
LAW_MODELLED, LAW_ROTOR_DRAG, LAW_INFLOW, LAW_BATTERY = 1, 2, 4, 8
#: the battery's state row (``BatchedUAVEnv.battery``): ``Battery.charge``, ``voltage``,
#: ``current``, ``speed_ratio``; its parameter row (``BatchedModel.battery``): capacity [C],
#: internal resistance [ohm], eta V_full^3 (``Battery._load_divisor``), avionics power [W], V_full [V]
BATTERY_STATE = 4
BATTERY_PARAMS = 5


@njit(cache=True)
def inflow_ratios(k: np.ndarray, climb: float, rotor_speed: float):
    """(thrust ratio, torque ratio) of a rotor (row ``k``) at axial air speed ``climb`` [m/s]
    and rotor speed ``rotor_speed`` [rad/s] (> 0): ``InflowRotor.ratios``."""
    radius, ct0, lambda_h, s, theta, cq_hover = k[M_RADIUS], k[M_CT0], k[M_LAMBDA_H], k[M_S], k[M_THETA], k[M_CQ_HOVER]
    lc = climb / (rotor_speed * radius)
    floor = -0.5 * lambda_h
    if lc < floor:
        lc = floor
    if lc >= theta:
        brake = 1.0 - lambda_h / cq_hover
        return 0.0, (brake if brake > 0.0 else 0.0)  # Python's max(0.0, brake)
    b = 2.0 * lc + s
    li = 0.25 * (math.sqrt(b * b + 8.0 * s * (theta - lc)) - b)
    kt = s * (theta - lc - li) / ct0
    if kt < 0.0:
        kt = 0.0
    kq = 1.0 + ((lc + li) * kt - lambda_h) / cq_hover
    return kt, (kq if kq > 0.0 else 0.0)


@njit(cache=True)
def modelled_motors_step(
    throttle: np.ndarray,
    command: np.ndarray,
    lag: np.ndarray,
    factors: np.ndarray,
    model: np.ndarray,
    laws: int,
    volt: float,
    ratio: np.ndarray,
    u: float,
    v: float,
    w: float,
    p: float,
    q: float,
    r: float,
):
    """One physics step of a vehicle's modelled motors (``ModelledMotors.step``): the
    asymmetric lag (``lag`` up, the row's spin-down lag down), the noise factor, each rotor
    at speed ``|x| volt`` (``volt``: the battery's ``speed_ratio``, 1 without one) with its
    inflow ratios and rotor drag at the hub's velocity through the air (body frame: the
    body's ``(u, v, w)``, ``(p, q, r)``), its thrust times ``ratio`` (ground effect, 1
    without); ``throttle`` updated.  ``model`` (n, :data:`MOTOR_MODEL_FIELDS`); ``laws`` the
    bits of :data:`LAW_ROTOR_DRAG`, :data:`LAW_INFLOW`, :data:`LAW_BATTERY`.  Returns the
    wrench (6 values) and the rotors' shaft power at full voltage [W] (0 without a battery)."""
    drag = (laws & LAW_ROTOR_DRAG) != 0
    inflow = (laws & LAW_INFLOW) != 0
    battery = (laws & LAW_BATTERY) != 0
    airy = drag or inflow
    volt2 = volt * volt
    fx = fy = fz = tx = ty = tz = 0.0
    power = 0.0
    for m in range(throttle.shape[0]):
        k = model[m]
        x = throttle[m]
        c = command[m]
        a = lag[m] if x * (c - x) >= 0.0 else k[M_LAG_FALL]  # speeding up (away from zero) or slowing down
        x = (x + a * (c - x)) * factors[m]
        throttle[m] = x
        ax_, ay_, az_ = k[M_AX], k[M_AY], k[M_AZ]
        px, py, pz = k[M_PX], k[M_PY], k[M_PZ]
        speed = abs(x) * volt
        kt = 1.0
        kq = 1.0
        if airy:  # the hub's velocity through the air: v + omega x p (body frame)
            hx, hy, hz = u + q * pz - r * py, v + r * px - p * pz, w + p * py - q * px
            axial = hx * ax_ + hy * ay_ + hz * az_
            if inflow and speed > 0.0:
                kt, kq = inflow_ratios(k, axial if x >= 0.0 else -axial, speed * k[M_OMEGA])
            if drag:
                kd = -k[M_ROTOR_DRAG] * speed
                gx, gy, gz = kd * (hx - axial * ax_), kd * (hy - axial * ay_), kd * (hz - axial * az_)
                fx, fy, fz = fx + gx, fy + gy, fz + gz
                tx, ty, tz = tx + (py * gz - pz * gy), ty + (pz * gx - px * gz), tz + (px * gy - py * gx)
        f = x * abs(x) * volt2
        thrust = k[M_THRUST] * f * kt * ratio[m]
        reaction = k[M_REACTION] * f * kq
        gx, gy, gz = thrust * ax_, thrust * ay_, thrust * az_
        fx, fy, fz = fx + gx, fy + gy, fz + gz
        tx += (py * gz - pz * gy) + reaction * ax_
        ty += (pz * gx - px * gz) + reaction * ay_
        tz += (px * gy - py * gx) + reaction * az_
        if battery:
            power += k[M_TORQUE] * abs(x) * x * x * kq * k[M_OMEGA]
    return fx, fy, fz, tx, ty, tz, power


@njit(cache=True)
def open_circuit_voltage(table: np.ndarray, charge: float) -> float:
    """V_oc at state of charge ``charge``: ``battery.open_circuit_voltage`` on ``table`` (k, 2)."""
    q0, v0 = table[0, 0], table[0, 1]
    if charge <= q0:
        return v0
    for j in range(1, table.shape[0]):
        q1, v1 = table[j, 0], table[j, 1]
        if charge <= q1:
            return v0 + (v1 - v0) * (charge - q0) / (q1 - q0)
        q0, v0 = q1, v1
    return v0


@njit(cache=True)
def battery_supply(ocv: float, resistance: float, cubic: float, constant: float):
    """Terminal voltage and current of the pack under ``P(V) = cubic V^3 + constant``:
    ``battery.supply`` (Newton's method from ``ocv``).  ``** 3.0``, not ``** 3``: numba
    turns an integer power into multiplications, CPython's ``v**3`` calls ``pow``."""
    if resistance <= 0.0:
        return ocv, (cubic * ocv**3.0 + constant) / ocv
    c = resistance * cubic
    r0 = resistance * constant
    v = ocv
    for _ in range(60):
        g = (c * v + 1.0) * v * v - ocv * v + r0
        slope = (3.0 * c * v + 2.0) * v - ocv
        if slope <= 0.0:  # past the minimum of g: no root
            break
        step = g / slope
        v -= step
        if step <= 1e-15 * v:
            return v, (cubic * v**3.0 + constant) / v
    v = (math.sqrt(4.0 + 12.0 * c * ocv) - 2.0) / (6.0 * c) if c > 0.0 else 0.5 * ocv
    return v, (ocv - v) / resistance


@njit(cache=True)
def battery_step(state: np.ndarray, params: np.ndarray, table: np.ndarray, dt: float, full_power: float) -> None:
    """One physics step of a pack (``Battery.step``) drawing ``full_power`` [W] at full
    voltage: ``state`` (:data:`BATTERY_STATE`) updated from ``params`` (:data:`BATTERY_PARAMS`)
    and the open-circuit ``table``."""
    ocv = open_circuit_voltage(table, state[0])
    v, current = battery_supply(ocv, params[1], full_power / params[2], params[3])
    charge = state[0] - current * dt / params[0]
    state[0] = charge if charge > 0.0 else 0.0
    state[1] = v
    state[2] = current
    state[3] = v / params[4]


@njit(cache=True)
def _body_air(r, v, w, bw0: float, bw1: float, bw2: float, windy: bool, tick: bool, sample):
    """The body's velocity through the air as :func:`advance` gives it to body drag (6-tuple,
    body frame): in the wind from the body-frame state on a control tick (``air_from_body``)
    and from the ground-frame motion ``v``, ``w`` between ticks (``air_from_motion``); in
    still air the body's own velocity, ``R^T v`` and the body rates ``bw``."""
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
    v0, v1, v2 = v
    if windy and not tick:
        return _air.air_from_motion(r, v0, v1, v2, w[0], w[1], w[2], sample)
    bv0 = r0 * v0 + r3 * v1 + r6 * v2
    bv1 = r1 * v0 + r4 * v1 + r7 * v2
    bv2 = r2 * v0 + r5 * v1 + r8 * v2
    if windy:
        return _air.air_from_body(r, bv0, bv1, bv2, bw0, bw1, bw2, sample)
    return bv0, bv1, bv2, bw0, bw1, bw2


@njit(cache=True)
def modelled_load(
    x_i,
    cmd_i,
    lag_i,
    factors,
    model,
    laws,
    battery,
    battery_params,
    battery_table,
    rotors,
    ground_effect,
    z,
    r6,
    r7,
    r8,
    min_height,
    ratio,
    air,
    physics_dt,
):
    """The modelled motors' wrench of one physics step (:func:`modelled_motors_step`) at the
    body's velocity through the air ``air`` (6-tuple, body frame), ground effect's ratios
    (``ratio`` (n,) scratch, set to 1 without ground effect), the pack ``battery`` (its
    state row) stepped after them with their power, as ``ModelledMotors.step`` steps it."""
    if ground_effect:
        _air.ground_effect_ratios(z, r6, r7, r8, rotors, min_height, ratio)
    else:
        for m in range(ratio.shape[0]):
            ratio[m] = 1.0
    with_battery = (laws & LAW_BATTERY) != 0
    volt = battery[3] if with_battery else 1.0
    fx, fy, fz, tx, ty, tz, power = modelled_motors_step(
        x_i, cmd_i, lag_i, factors, model, laws, volt, ratio, air[0], air[1], air[2], air[3], air[4], air[5]
    )
    if with_battery:
        battery_step(battery, battery_params, battery_table, physics_dt, power)
    return fx, fy, fz, tx, ty, tz


@njit(cache=True, inline="always")
def drag_wrench(
    vx: float, vy: float, vz: float, wx: float, wy: float, wz: float, kx: float, ky: float, kz: float, damping: float
):
    """Body drag (``BodyDrag.step``) at body-frame air velocity (v, w): factors
    ``k = 1/2 rho C_d A`` per axis and the rotational ``damping``; returns the 6-tuple."""
    return (
        -kx * vx * abs(vx),
        -ky * vy * abs(vy),
        -kz * vz * abs(vz),
        -damping * wx * abs(wx),
        -damping * wy * abs(wy),
        -damping * wz * abs(wz),
    )


@njit(cache=True, inline="always")
def summed(a, b):
    """``a + b`` component by component (``vehicle._summed``)."""
    return a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3], a[4] + b[4], a[5] + b[5]


@njit(cache=True)
def rate_loop(
    rates_sp: np.ndarray,
    rates: np.ndarray,
    previous: np.ndarray,
    integral: np.ndarray,
    gains: np.ndarray,
    derivative: bool,
    inertia: np.ndarray,
    gyro: np.ndarray,
    dt: float,
    out: np.ndarray,
) -> None:
    """The body-rate loop (``MultirotorController._rate_loop``): torques [N m] into ``out``
    (3,); ``integral`` advanced.  ``gains`` rows: kp, ki, kd, integral limit (per axis);
    ``previous`` the rates of the last tick (the rates themselves on the first).
    :func:`rate_loop_row` of one vehicle's arrays."""
    out[0], out[1], out[2] = rate_loop_row(
        rates_sp[np.newaxis],
        rates[0],
        rates[1],
        rates[2],
        previous[np.newaxis],
        integral[np.newaxis],
        gains[np.newaxis],
        derivative,
        inertia[np.newaxis],
        gyro[np.newaxis],
        dt,
        0,
    )


@njit(cache=True, inline="always")
def rate_loop_row(
    rates_sp: np.ndarray,
    wx: float,
    wy: float,
    wz: float,
    previous: np.ndarray,
    integral: np.ndarray,
    gains: np.ndarray,
    derivative: bool,
    inertia: np.ndarray,
    gyro: np.ndarray,
    dt: float,
    v: int,
):
    """:func:`rate_loop` of vehicle ``v`` of the batch's arrays (``rates_sp`` (N, >= 3),
    ``previous``, ``integral``, ``inertia``, ``gyro`` (N, 3), ``gains`` (N, 4, 3)) at body rates
    (wx, wy, wz); returns the torques (3-tuple).  Indexed, not viewed, as :func:`motors_step_row`."""
    a0 = a1 = a2 = 0.0
    for k in range(3):
        kp, ki, kd, limit = gains[v, 0, k], gains[v, 1, k], gains[v, 2, k], gains[v, 3, k]
        w = wx if k == 0 else wy if k == 1 else wz
        e = rates_sp[v, k] - w
        i = integral[v, k] + e * dt
        i = limit if i > limit else -limit if i < -limit else i
        integral[v, k] = i
        if derivative:
            alpha = kp * e + ki * i - kd * (w - previous[v, k]) / dt
        else:
            alpha = kp * e + ki * i
        if k == 0:
            a0 = alpha
        elif k == 1:
            a1 = alpha
        else:
            a2 = alpha
    return (
        inertia[v, 0] * a0 + gyro[v, 0] * wy * wz,
        inertia[v, 1] * a1 + gyro[v, 1] * wz * wx,
        inertia[v, 2] * a2 + gyro[v, 2] * wx * wy,
    )


@njit(cache=True, inline="always")
def _lower(current: float, candidate: float) -> float:
    candidate = candidate if candidate > 0.0 else 0.0
    return candidate if candidate < current else current


@njit(cache=True, inline="always")
def _throttle(force: float, full: float) -> float:
    return 0.0 if force <= 0.0 else 1.0 if force >= full else math.sqrt(force / full)


@njit(cache=True)
def mix(thrust: float, tx: float, ty: float, tz: float, rows: np.ndarray, parts: np.ndarray, out: np.ndarray) -> None:
    """Motor throttles for [thrust, tau_x, tau_y, tau_z] (``Mixer.throttles`` without tilting
    motors) into ``out`` (n,).  ``rows`` (n, 5): the pseudo-inverse's row and the full
    thrust per motor; ``parts`` (n, 4) scratch.  :func:`mix_row` of one vehicle's arrays."""
    mix_row(thrust, tx, ty, tz, rows[np.newaxis], parts, out[np.newaxis], 0)


@njit(cache=True, inline="always")
def mix_row(
    thrust: float, tx: float, ty: float, tz: float, rows: np.ndarray, parts: np.ndarray, out: np.ndarray, v: int
) -> None:
    """:func:`mix` of vehicle ``v`` of the batch's arrays (``rows`` (N, n, 5), ``out`` (N, n));
    ``parts`` (n, 4) scratch.  Indexed, not viewed, as :func:`motors_step_row`."""
    n = rows.shape[1]
    yaw_scale = 1.0
    fits = True
    for m in range(n):
        r0, r1, r2, r3, fm = rows[v, m, 0], rows[v, m, 1], rows[v, m, 2], rows[v, m, 3], rows[v, m, 4]
        ft = r0 * thrust
        b = ft + r1 * tx + r2 * ty
        y = r3 * tz
        if y > 0.0 and b + y > fm:
            yaw_scale = _lower(yaw_scale, (fm - b) / y)
        elif y < 0.0 and b + y < 0.0:
            yaw_scale = _lower(yaw_scale, -b / y)
        from_roll_pitch = b - ft
        f = ft + (from_roll_pitch + y)
        if f > fm and ft > 0.0:
            fits = False
        parts[m, 0], parts[m, 1], parts[m, 2], parts[m, 3] = ft, from_roll_pitch, y, fm
        out[v, m] = 0.0 if f <= 0.0 else 1.0 if f >= fm else math.sqrt(f / fm)
    if fits and yaw_scale == 1.0:
        return
    scale = 1.0
    for m in range(n):
        ft, fq, fm = parts[m, 0], parts[m, 1] + yaw_scale * parts[m, 2], parts[m, 3]
        parts[m, 1] = fq
        if ft + fq > fm and ft > 0.0:
            scale = _lower(scale, (fm - fq) / ft)
    for m in range(n):
        out[v, m] = _throttle(scale * parts[m, 0] + parts[m, 1], parts[m, 3])


@njit(cache=True)
def mix_tilted(
    thrust: float,
    tx: float,
    ty: float,
    tz: float,
    rows: np.ndarray,
    lateral: np.ndarray,
    parts: np.ndarray,
    out: np.ndarray,
) -> None:
    """``Mixer.throttles`` with tilting motors: the throttle per mixer motor, then one servo
    command per tilting motor, into ``out`` (n + t,).  ``rows`` (n, 5) as in :func:`mix`;
    ``lateral`` (t, :data:`LATERAL_FIELDS`) per tilting motor its index among the mixer's
    motors, its servo limit [rad] and its lateral row of the pseudo-inverse; ``parts`` (n, 4)
    scratch.  The scalar law always takes its second and third passes with tilting motors."""
    n = rows.shape[0]
    yaw_scale = 1.0
    for m in range(n):
        r0, r1, r2, r3, fm = rows[m, 0], rows[m, 1], rows[m, 2], rows[m, 3], rows[m, 4]
        ft = r0 * thrust
        b = ft + r1 * tx + r2 * ty
        y = r3 * tz
        if y > 0.0 and b + y > fm:
            yaw_scale = _lower(yaw_scale, (fm - b) / y)
        elif y < 0.0 and b + y < 0.0:
            yaw_scale = _lower(yaw_scale, -b / y)
        parts[m, 0], parts[m, 1], parts[m, 2], parts[m, 3] = ft, b - ft, y, fm
    scale = 1.0
    for m in range(n):
        ft, fq, fm = parts[m, 0], parts[m, 1] + yaw_scale * parts[m, 2], parts[m, 3]
        parts[m, 1] = fq
        if ft + fq > fm and ft > 0.0:
            scale = _lower(scale, (fm - fq) / ft)
    for m in range(n):
        parts[m, 2] = scale * parts[m, 0] + parts[m, 1]  # the force of each motor
    for t in range(lateral.shape[0]):
        motor, limit = int(lateral[t, 0]), lateral[t, 1]
        r0, r1, r2, r3 = lateral[t, 2], lateral[t, 3], lateral[t, 4], lateral[t, 5]
        side = scale * r0 * thrust + r1 * tx + r2 * ty + yaw_scale * r3 * tz
        nominal = parts[motor, 2]
        angle = math.atan2(side, nominal) if nominal > 0.0 else 0.0
        angle = limit if angle > limit else -limit if angle < -limit else angle
        parts[motor, 2] = nominal / math.cos(angle)
        out[n + t] = angle / limit
    for m in range(n):
        out[m] = _throttle(parts[m, 2], parts[m, 3])


#: a tilting motor's row (``BatchedModel.lateral``): its index among the mixer's motors, the
#: servo's limit [rad], its lateral row of the mixer's pseudo-inverse (4)
LATERAL_FIELDS = 6


@njit(cache=True)
def mixer_outputs(
    thrust: float,
    tx: float,
    ty: float,
    tz: float,
    rows: np.ndarray,
    lateral: np.ndarray,
    parts: np.ndarray,
    out: np.ndarray,
) -> None:
    """The mixer's outputs (``Mixer.throttles``): :func:`mix` without tilting motors, else
    :func:`mix_tilted`."""
    if lateral.shape[0] == 0:
        mix(thrust, tx, ty, tz, rows, parts, out)
    else:
        mix_tilted(thrust, tx, ty, tz, rows, lateral, parts, out)


# ------------------------------------------------------------------- gimbals

#: a gimbal's row (``BatchedModel.gimbals``): ``gimbal.GimbalConstants`` (lag, the two limits,
#: W_a, W_a2, W_b, W_b2 row-major), then its target motor's nominal thrust axis (3), hub
#: position (3), full thrust [N] and reaction torque at full throttle [N m] (``Motors.turn``)
(G_LAG, G_MAX_A, G_MAX_B) = range(3)
G_W_A, G_W_A2, G_W_B, G_W_B2 = 3, 12, 21, 30
G_AXIS, G_POSITION, G_THRUST, G_REACTION = 39, 42, 45, 46
GIMBAL_FIELDS = 47
#: a gimbal's sources (``BatchedModel.gimbal_source``): its target motor, the channels of its
#: axes a and b (-1: none) and the mixer output of axis a (-1: not flown by the mixer)
GS_MOTOR, GS_CHANNEL_A, GS_CHANNEL_B, GS_OUTPUT = range(4)


@njit(cache=True)
def gimbal_servo(eps: float, target: float, lag: float) -> float:
    """One servo axis one physics step (``gimbal.gimbal_step_scalar``): toward
    ``clip(command, -1, 1) * limit`` (``target`` the clipped command times the limit)."""
    return eps + lag * (target - eps)


@njit(cache=True)
def rodrigues(k: np.ndarray, w: int, w2: int, eps: float, x: float, y: float, z: float):
    """``(I + sin(eps) W + 2 sin^2(eps / 2) W^2) v`` with W, W^2 the row's entries from ``w``,
    ``w2`` (``gimbal._rodrigues``; ``** 2.0``: CPython's ``** 2`` calls ``pow``)."""
    s = math.sin(eps)
    vers = 2.0 * math.sin(0.5 * eps) ** 2.0
    return (
        x + s * (k[w] * x + k[w + 1] * y + k[w + 2] * z) + vers * (k[w2] * x + k[w2 + 1] * y + k[w2 + 2] * z),
        y + s * (k[w + 3] * x + k[w + 4] * y + k[w + 5] * z) + vers * (k[w2 + 3] * x + k[w2 + 4] * y + k[w2 + 5] * z),
        z + s * (k[w + 6] * x + k[w + 7] * y + k[w + 8] * z) + vers * (k[w2 + 6] * x + k[w2 + 7] * y + k[w2 + 8] * z),
    )


@njit(cache=True)
def gimbals_step(angles: np.ndarray, command: np.ndarray, gimbals: np.ndarray, source: np.ndarray, columns: np.ndarray):
    """One physics step of a vehicle's gimbals (``Gimbals.step``): each servo lags toward its
    command (``angles``, ``command`` (2 g,): (a, b) per gimbal), and its target motor's wrench
    column (``columns`` (n, 6)) is turned to the thrust axis ``R_a R_b n`` the new angles give
    (``gimbal.rotate_vector_scalar``, ``Motors.turn``: ``motor.wrench_column``)."""
    for g in range(gimbals.shape[0]):
        k = gimbals[g]
        lag = k[G_LAG]
        xa, xb = command[2 * g], command[2 * g + 1]
        xa = -1.0 if -1.0 > xa else xa  # min(max(xi, -1.0), 1.0)
        xa = 1.0 if 1.0 < xa else xa
        xb = -1.0 if -1.0 > xb else xb
        xb = 1.0 if 1.0 < xb else xb
        ea = gimbal_servo(angles[2 * g], xa * k[G_MAX_A], lag)
        eb = gimbal_servo(angles[2 * g + 1], xb * k[G_MAX_B], lag)
        angles[2 * g], angles[2 * g + 1] = ea, eb
        bx, by, bz = rodrigues(k, G_W_B, G_W_B2, eb, k[G_AXIS], k[G_AXIS + 1], k[G_AXIS + 2])
        ax, ay, az = rodrigues(k, G_W_A, G_W_A2, ea, bx, by, bz)
        px, py, pz = k[G_POSITION], k[G_POSITION + 1], k[G_POSITION + 2]
        thrust, reaction = k[G_THRUST], k[G_REACTION]
        fx, fy, fz = ax * thrust, ay * thrust, az * thrust
        c = columns[source[g, GS_MOTOR]]
        c[0], c[1], c[2] = fx, fy, fz
        c[3] = (py * fz - pz * fy) + reaction * ax
        c[4] = (pz * fx - px * fz) + reaction * ay
        c[5] = (px * fy - py * fx) + reaction * az


@njit(cache=True)
def route_gimbals(channels: np.ndarray, outputs: np.ndarray, source: np.ndarray, out: np.ndarray) -> None:
    """Each gimbal's (a, b) command into ``out`` (2 g,) (``Gimbals.route``): its channels limited
    to [-1, 1] ((0, 0) without), or for a gimbal the mixer flies (output limited, 0)."""
    for g in range(source.shape[0]):
        ca, cb, k = source[g, GS_CHANNEL_A], source[g, GS_CHANNEL_B], source[g, GS_OUTPUT]
        if k >= 0:
            value = outputs[k]
            out[2 * g], out[2 * g + 1] = 1.0 if value > 1.0 else -1.0 if value < -1.0 else value, 0.0
        elif ca >= 0:
            a, b = channels[ca], channels[cb]
            out[2 * g] = 1.0 if a > 1.0 else -1.0 if a < -1.0 else a
            out[2 * g + 1] = 1.0 if b > 1.0 else -1.0 if b < -1.0 else b
        else:
            out[2 * g], out[2 * g + 1] = 0.0, 0.0


@njit(cache=True, inline="always")
def integrate_state(p, q, v, w, r, load, mass, jx, jy, jz, gravity, dt):
    """One physics step of the free rigid body (the module docstring) under the body-frame
    wrench ``load`` (6-tuple) at the centre of mass and gravity along -z, on tuples:
    ``p, v, w`` (3) ground frame, ``q`` (4) and ``r`` (9, the rotation of ``q`` at the
    start of the step).  Returns the new ``(p, q, v, w)``."""
    fx, fy, fz, tx, ty, tz = load
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
    ax = (r0 * fx + r1 * fy + r2 * fz) / mass
    ay = (r3 * fx + r4 * fy + r5 * fz) / mass
    az = (r6 * fx + r7 * fy + r8 * fz) / mass - gravity
    w0, w1, w2 = w
    bx = r0 * w0 + r3 * w1 + r6 * w2
    by = r1 * w0 + r4 * w1 + r7 * w2
    bz = r2 * w0 + r5 * w1 + r8 * w2
    # Euler's equations in the body frame: J alpha = tau - w x (J w)
    gx = by * (jz * bz) - bz * (jy * by)
    gy = bz * (jx * bx) - bx * (jz * bz)
    gz = bx * (jy * by) - by * (jx * bx)
    ex, ey, ez = (tx - gx) / jx, (ty - gy) / jy, (tz - gz) / jz
    v0 = v[0] + ax * dt
    v1 = v[1] + ay * dt
    v2 = v[2] + az * dt
    w0 = w0 + (r0 * ex + r1 * ey + r2 * ez) * dt
    w1 = w1 + (r3 * ex + r4 * ey + r5 * ez) * dt
    w2 = w2 + (r6 * ex + r7 * ey + r8 * ez) * dt
    p0 = p[0] + v0 * dt
    p1 = p[1] + v1 * dt
    p2 = p[2] + v2 * dt
    # exponential map, ground-frame angular velocity, left-multiplied
    angle = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if angle * dt > _ANGULAR_MOTION_THRESHOLD:
        angle = _ANGULAR_MOTION_THRESHOLD / dt
    # half the turn, sin and cos of one value so that the compiler makes them one sincos call
    # (glibc's sincos is its sin and cos, bit for bit; tests/batched/test_laws.py); Bullet's
    # sin(0.5 angle dt) is the sine of this value: halving commutes with rounding
    half = angle * dt * 0.5
    dw = math.cos(half)
    c = math.sin(half) / angle  # computed on both paths, so that it sits beside the cosine
    if angle < 0.001:
        c = 0.5 * dt - (dt * dt * dt) * 0.020833333333 * angle * angle
    dx, dy, dz = w0 * c, w1 * c, w2 * c
    qx, qy, qz, qw = q
    nx = dw * qx + dx * qw + dy * qz - dz * qy
    ny = dw * qy - dx * qz + dy * qw + dz * qx
    nz = dw * qz + dx * qy - dy * qx + dz * qw
    nw = dw * qw - dx * qx - dy * qy - dz * qz
    norm = math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
    return (p0, p1, p2), (nx / norm, ny / norm, nz / norm, nw / norm), (v0, v1, v2), (w0, w1, w2)


@njit(cache=True)
def integrate(
    pos: np.ndarray,
    quat: np.ndarray,
    vel: np.ndarray,
    angvel: np.ndarray,
    r: np.ndarray,
    load: np.ndarray,
    mass: float,
    inertia: np.ndarray,
    gravity: float,
    dt: float,
) -> None:
    """:func:`integrate_state` on arrays (updates pos, quat, vel, angvel in place)."""
    p, q, v, w = integrate_state(
        (pos[0], pos[1], pos[2]),
        (quat[0], quat[1], quat[2], quat[3]),
        (vel[0], vel[1], vel[2]),
        (angvel[0], angvel[1], angvel[2]),
        (r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8]),
        (load[0], load[1], load[2], load[3], load[4], load[5]),
        mass,
        inertia[0],
        inertia[1],
        inertia[2],
        gravity,
        dt,
    )
    pos[0], pos[1], pos[2] = p
    quat[0], quat[1], quat[2], quat[3] = q
    vel[0], vel[1], vel[2] = v
    angvel[0], angvel[1], angvel[2] = w


@njit(cache=True)
def lowest_corner(pos: np.ndarray, r: np.ndarray, corners: np.ndarray) -> float:
    """Lowest height [m] of the collision features (``BatchedModel.corners``: a point, less a
    sphere's radius, less a disc's radius times the sine of its normal's tilt from vertical)."""
    return _lowest(pos[2], r[6], r[7], r[8], corners)


@njit(cache=True)
def _lowest(z0: float, r6: float, r7: float, r8: float, corners: np.ndarray) -> float:
    return lowest_row(z0, r6, r7, r8, corners[np.newaxis], 0)


@njit(cache=True, inline="always")
def lowest_row(z0: float, r6: float, r7: float, r8: float, corners: np.ndarray, v: int) -> float:
    """:func:`lowest_corner` of vehicle ``v`` (``corners`` (N, c, 8)) at height ``z0`` and the
    rotation's last row; indexed, not viewed, as :func:`motors_step_row`."""
    low = math.inf
    for c in range(corners.shape[1]):
        x, y, z = corners[v, c, 0], corners[v, c, 1], corners[v, c, 2]
        height = z0 + r6 * x + r7 * y + r8 * z - corners[v, c, 3]
        disc = corners[v, c, 4]
        if disc > 0.0:
            nz = r6 * corners[v, c, 5] + r7 * corners[v, c, 6] + r8 * corners[v, c, 7]
            rim = 1.0 - nz * nz
            height -= disc * math.sqrt(rim if rim > 0.0 else 0.0)
        if height < low:
            low = height
    return low


@njit(cache=True, inline="always")
def lowest_reach(corners: np.ndarray, v: int) -> float:
    """How far below its centre of mass any collision feature of vehicle ``v`` can reach in
    any attitude [m], with a margin over the rounding (so ``p_z > reach`` guarantees
    :func:`lowest_row` ``> 0``): the largest ``|corner| + sphere radius + disc radius``."""
    reach = 0.0
    for c in range(corners.shape[1]):
        x, y, z = corners[v, c, 0], corners[v, c, 1], corners[v, c, 2]
        far = math.sqrt(x * x + y * y + z * z) + abs(corners[v, c, 3]) + abs(corners[v, c, 4])
        reach = far if far > reach else reach
    return reach * (1.0 + 1e-9)


@njit(cache=True)
def feature_reaches(corners: np.ndarray) -> np.ndarray:
    """:func:`lowest_reach` of every vehicle of ``corners`` (N, features, .): computed once per
    airframe (:func:`advance` takes them), not in every agent step (~16 ns per env)."""
    out = np.empty(corners.shape[0])
    for v in range(corners.shape[0]):
        out[v] = lowest_reach(corners, v)
    return out


@njit(cache=True)
def advance(
    pos,
    quat,
    vel,
    angvel,
    throttle,
    command,
    integral,
    previous,
    has_previous,
    setpoint,
    factors,
    rates,
    mass,
    inertia,
    control_inertia,
    gyro,
    lag,
    columns,
    mixer_rows,
    max_collective,
    rate_gains,
    derivative,
    drag_factors,
    damping,
    drag,
    corners,
    reaches,
    contact,
    gravity,
    physics_dt,
    control_dt,
    start,
    count,
    per_control,
    wind,
    episode_steps,
    rotors,
    ground_effect,
    min_height,
    turbulence,
    turbulence_normals,
    dryden,
    motor_model,
    motor_laws,
    battery,
    battery_params,
    battery_table,
    wind_on,
):
    """Advance every vehicle ``count`` physics steps from physics step ``start`` (control
    ticks where ``(start + s) % per_control == 0``).

    Per vehicle i (rows of every array): state ``pos, quat, vel, angvel`` (ground frame,
    the quaternion continuous, not PyBullet's canonical sign), motor ``throttle`` and
    ``command``, the rate loop's ``integral``, ``previous`` rates and ``has_previous``;
    ``setpoint`` (4 values: the rate loop's rates and thrust with ``rates`` on, mode
    rates_thrust; else the motors' throttles, mode motors), ``factors`` (N, count, n)
    motor noise factors per physics step.  Parameters per vehicle: mass, inertia (the
    body's) and the controller's inertia, gyroscopic coefficients, motor lag and wrench
    columns, the mixer, rate gains (4, 3), drag factors and damping (with ``drag`` on), collision
    ``corners`` and how far their features reach from the centre (``reaches``, :func:`feature_reaches`).  ``contact[i]`` is set when the lowest corner is below the ground at a
    sample (the end of each control period or of the step), as the PyBullet engine
    samples contacts.  Per physics step, in the PyBullet engine's order: on a control
    tick the controller (rate loop, mixer) sets the motor commands; the motors step; the
    drag at the body's velocity through the air; the rigid body integrates the sum.

    The air (:mod:`pyflyt_engine.batched.air`): where env ``i``'s row of the wind parameters
    ``wind[i]`` (N, :data:`~pyflyt_engine.batched.air.WIND_FIELDS`) is on, the wind at the
    vehicle's height at physics step ``episode_steps[i] + s`` of its episode is taken off
    its velocity (:func:`~pyflyt_engine.batched.air.air_from_body` on a tick, from the state
    read; :func:`~pyflyt_engine.batched.air.air_from_motion` between ticks); with
    ``ground_effect`` each motor's thrust takes its ground-effect ratio (``rotors`` (N, n, 5)
    per motor: hub, prop radius, reaction per newton; the clamp ``min_height``).  With
    turbulence (``wind``'s, :func:`~pyflyt_engine.batched.air.dryden_output`) each env's filter
    state ``turbulence[i]`` moves on one step per physics step, driven by the standard normal
    draws ``turbulence_normals[i, s]``; ``dryden`` the envs' filters, each array of
    :attr:`~pyflyt_engine.batched.air.Dryden.arrays` with a leading env axis (env ``i``'s
    filter its rows ``[i]``: a randomised wind gives each env its own).

    The modelled motors (``motor_laws`` not None: :func:`modelled_load`, ``motor_model``
    (N, n, :data:`MOTOR_MODEL_FIELDS`)) take the body's velocity through the air (as body
    drag does) and drive from the pack ``battery[i]`` (its state, :data:`BATTERY_STATE`;
    ``battery_params[i]`` and ``battery_table`` its parameters and open-circuit table).

    The switches are types, so that numba compiles each combination a run flies (cached)
    with the code of the others pruned: ``rates``, ``drag``, ``ground_effect`` and
    ``wind_on`` are True or None (:func:`switch`; ``wind_on`` None: no env's wind is on,
    ``wind[:, 0]`` all 0), ``motor_laws`` is None for the static motors.  A hover's physics
    steps then test nothing for the mode, the drag, the wind, the motor models or the ground
    effect (a bool would be tested at every physics step; ``experiments/speed_advance.py``).

    The vehicles go in blocks of :data:`_BLOCK`, each physics step of the span for the whole
    block before the next (vehicle by vehicle where a turbulence filter exists): the order
    of the independent vehicles' work, not of any vehicle's own operations, so the numbers
    are those of one vehicle at a time (``tests/batched/test_blocks.py``).
    """
    n = pos.shape[0]
    nm = throttle.shape[1]
    ratio = np.empty(nm)
    parts = np.empty((nm, 4))
    scaled = np.empty((1, nm, 6))  # ground effect's columns of the vehicle at hand
    calm = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    sample = calm
    scratch = np.empty(turbulence.shape[1])
    rot = np.empty((n, 9))  # each vehicle's rotation at the start of its next physics step
    for i in range(n):
        contact[i] = False
        r = rotation_tuple(quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
        for k in range(9):
            rot[i, k] = r[k]
    # a block of vehicles at a time, each physics step of the span for the whole block: the
    # vehicles' steps are independent, so the processor overlaps one vehicle's step with the
    # next one's (a vehicle's own steps are one chain of dependent operations); the block
    # keeps their state in the first-level cache (experiments/speed_advance.py).  With a
    # turbulence filter, vehicle by vehicle (blocks of one): the views of its filter's rows,
    # made once per vehicle, cost less than the overlap gains.
    block = 1 if turbulence.shape[1] else _BLOCK
    for b0 in range(0, n, block):
        b1 = min(b0 + block, n)
        # with a turbulence filter, the block's one vehicle's filter and state (its rows)
        dryden_i = (dryden[0][b0], dryden[1][b0], dryden[2][b0], dryden[3][b0], dryden[4][b0])
        turbulence_i = turbulence[b0]
        for s in range(count):
            phase = (start + s) % per_control  # of physics step start + s in its control period
            tick = phase == 0
            # contact sampled at the end of each control period and of the span
            sampled = phase + 1 == per_control or s == count - 1
            for i in range(b0, b1):
                p = (pos[i, 0], pos[i, 1], pos[i, 2])
                q = (quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
                v = (vel[i, 0], vel[i, 1], vel[i, 2])
                w = (angvel[i, 0], angvel[i, 1], angvel[i, 2])
                r = (rot[i, 0], rot[i, 1], rot[i, 2], rot[i, 3], rot[i, 4], rot[i, 5], rot[i, 6], rot[i, 7], rot[i, 8])
                r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
                w0, w1, w2 = w
                bw0 = r0 * w0 + r3 * w1 + r6 * w2
                bw1 = r1 * w0 + r4 * w1 + r7 * w2
                bw2 = r2 * w0 + r5 * w1 + r8 * w2
                if tick:  # control tick
                    if rates is not None:
                        if not has_previous[i]:
                            previous[i, 0], previous[i, 1], previous[i, 2] = bw0, bw1, bw2
                        t0, t1, t2 = rate_loop_row(
                            setpoint,
                            bw0,
                            bw1,
                            bw2,
                            previous,
                            integral,
                            rate_gains,
                            derivative,
                            control_inertia,
                            gyro,
                            control_dt,
                            i,
                        )
                        previous[i, 0], previous[i, 1], previous[i, 2] = bw0, bw1, bw2
                        has_previous[i] = True
                        mix_row(setpoint[i, 3] * max_collective[i], t0, t1, t2, mixer_rows, parts, command, i)
                    else:  # motors: the setpoint is the throttles, clamped to [-1, 1]
                        for mo in range(nm):
                            c = setpoint[i, mo]
                            command[i, mo] = 1.0 if c > 1.0 else -1.0 if c < -1.0 else c
                windy = wind_on is not None and wind[i, 0] != 0.0
                if windy:  # the wind at this physics step; the turbulence moves on
                    wind_i = wind[i]  # this env's wind (its row)
                    gusts = calm
                    if wind_i[17] != 0.0:
                        gusts = _air.dryden_output(dryden_i, turbulence_i, wind_i[18], wind_i[19])
                        _air.dryden_step(dryden_i, turbulence_i, turbulence_normals[i, s], scratch)
                    sample = _air.wind_sample(wind_i, episode_steps[i] + s, p[2], physics_dt, gusts)
                if (
                    motor_laws is not None
                ):  # ModelledMotors, at the body's velocity through the air as body drag takes it
                    a = calm
                    if (motor_laws & (LAW_ROTOR_DRAG | LAW_INFLOW)) != 0:
                        a = _body_air(r, v, w, bw0, bw1, bw2, windy, tick, sample)
                    load = modelled_load(
                        throttle[i],
                        command[i],
                        lag[i],
                        factors[i, s],
                        motor_model[i],
                        motor_laws,
                        battery[i],
                        battery_params[i],
                        battery_table,
                        rotors[i],
                        ground_effect,
                        p[2],
                        r6,
                        r7,
                        r8,
                        min_height,
                        ratio,
                        a,
                        physics_dt,
                    )
                elif ground_effect is not None:
                    _air.ground_effect_columns(p[2], r6, r7, r8, rotors[i], columns[i], min_height, scaled[0])
                    load = motors_step_row(throttle, command, lag, factors, scaled, i, s, 0)
                else:
                    load = motors_step_row(throttle, command, lag, factors, columns, i, s, i)
                if drag is not None:  # summed after the motors, as the PyBullet engine sums its groups
                    kx, ky, kz, c_i = drag_factors[i, 0], drag_factors[i, 1], drag_factors[i, 2], damping[i]
                    v0, v1, v2 = v
                    if windy:
                        if tick:
                            bv0 = r0 * v0 + r3 * v1 + r6 * v2
                            bv1 = r1 * v0 + r4 * v1 + r7 * v2
                            bv2 = r2 * v0 + r5 * v1 + r8 * v2
                            a = _air.air_from_body(r, bv0, bv1, bv2, bw0, bw1, bw2, sample)
                        else:
                            a = _air.air_from_motion(r, v0, v1, v2, w0, w1, w2, sample)
                        load = summed(load, drag_wrench(a[0], a[1], a[2], a[3], a[4], a[5], kx, ky, kz, c_i))
                    else:
                        bv0 = r0 * v0 + r3 * v1 + r6 * v2
                        bv1 = r1 * v0 + r4 * v1 + r7 * v2
                        bv2 = r2 * v0 + r5 * v1 + r8 * v2
                        load = summed(load, drag_wrench(bv0, bv1, bv2, bw0, bw1, bw2, kx, ky, kz, c_i))
                m_i = mass[i]
                p, q, v, w = integrate_state(
                    p, q, v, w, r, load, m_i, inertia[i, 0], inertia[i, 1], inertia[i, 2], gravity, physics_dt
                )
                r = rotation_tuple(q[0], q[1], q[2], q[3])  # the next step's, and the contact's
                # a body whose centre is higher than any of its features reaches cannot touch
                # (a NaN height is not higher: it goes on to lowest_row, which finds no contact in it)
                if sampled and not p[2] > reaches[i]:
                    if lowest_row(p[2], r[6], r[7], r[8], corners, i) < 0.0:
                        contact[i] = True
                pos[i, 0], pos[i, 1], pos[i, 2] = p
                quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3] = q
                vel[i, 0], vel[i, 1], vel[i, 2] = v
                angvel[i, 0], angvel[i, 1], angvel[i, 2] = w
                for k in range(9):
                    rot[i, k] = r[k]


def switch(on: bool) -> bool | None:
    """An optional law's switch as :func:`advance` takes it: True, or None (off), whose type
    numba compiles in (a ``bool`` would be tested at run time)."""
    return True if on else None


def wind_on(wind: np.ndarray) -> bool | None:
    """:func:`advance`'s ``wind_on``: whether a row of the wind parameters ``wind`` (N, fields) is on."""
    return switch(bool(np.count_nonzero(wind[:, 0])))


@njit(cache=True)
def read_out(pos, quat, vel, angvel, ang_vel_body, ang_pos, lin_vel_body, quaternion):
    """The state read-outs of the PyBullet engine (``Vehicle.read_state``) for every vehicle:
    body rates, Euler angles, body velocity, and PyBullet's quaternion (its sign)."""
    for i in range(pos.shape[0]):
        read = read_state(
            (quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3]),
            (vel[i, 0], vel[i, 1], vel[i, 2]),
            (angvel[i, 0], angvel[i, 1], angvel[i, 2]),
        )
        store_read(i, read, ang_vel_body, ang_pos, lin_vel_body, quaternion)


@njit(cache=True, inline="always")
def read_state(quat, vel, angvel):
    """:func:`read_out` of one vehicle (its state's tuples ``quat`` (4), ``vel``, ``angvel``
    (3)): the tuples ``(body rates, Euler angles, body velocity, PyBullet's quaternion)``.

    On tuples, which the compiler keeps in registers: the form it replaced wrote PyBullet's
    quaternion into a scratch array at the indices Bullet's branch picks at run time and
    read it back, ~3x the time of the whole read-out (``experiments/speed_read_out.py``)."""
    q = quaternion_of(rotation_tuple(quat[0], quat[1], quat[2], quat[3]))
    # getMatrixFromQuaternion of what PyBullet reports
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = rotation_tuple(q[0], q[1], q[2], q[3])
    w0, w1, w2 = angvel[0], angvel[1], angvel[2]
    v0, v1, v2 = vel[0], vel[1], vel[2]
    body_rates = (r0 * w0 + r3 * w1 + r6 * w2, r1 * w0 + r4 * w1 + r7 * w2, r2 * w0 + r5 * w1 + r8 * w2)
    body_vel = (r0 * v0 + r3 * v1 + r6 * v2, r1 * v0 + r4 * v1 + r7 * v2, r2 * v0 + r5 * v1 + r8 * v2)
    return body_rates, euler_of(q[0], q[1], q[2], q[3]), body_vel, q


@njit(cache=True, inline="always")
def store_read(i, read, ang_vel_body, ang_pos, lin_vel_body, quaternion):
    """:func:`read_state`'s tuples ``read`` into row ``i`` of the read-out arrays."""
    body_rates, euler, body_vel, q = read
    ang_vel_body[i, 0], ang_vel_body[i, 1], ang_vel_body[i, 2] = body_rates
    ang_pos[i, 0], ang_pos[i, 1], ang_pos[i, 2] = euler
    lin_vel_body[i, 0], lin_vel_body[i, 1], lin_vel_body[i, 2] = body_vel
    quaternion[i, 0], quaternion[i, 1], quaternion[i, 2], quaternion[i, 3] = q


# ----------------------------------------------------------- lifting surfaces


@njit(cache=True)
def surface_coefficients(k: np.ndarray, alpha: float, deflection: float):
    """``(C_L, C_D, C_M)`` of a surface (row ``k``: its ``SurfaceConstants``) at angle of
    attack ``alpha`` in [-pi, pi] and flap ``deflection`` [rad]: ``lifting_surface._coefficients``.

    The scalar law first wraps alpha with ``math.remainder(alpha, 2 pi)``, which is alpha
    itself on [-pi, pi] (the quotient rounds to 0, ties to even at +-pi); ``surface_wrench``
    only passes ``atan2``'s values, which lie there, so the wrap is left out here."""
    cl_alpha, pi_ar, delta_cl_per_rad, flap_to_chord = k[15], k[16], k[17], k[18]
    cl_max_pos_base, cl_max_neg_base, alpha_0_base, cd_0, cn_ar = k[19], k[20], k[21], k[22], k[23]
    # _shifted_angles
    delta_cl = delta_cl_per_rad * deflection
    delta_cl_max = flap_to_chord * delta_cl
    cl_max_pos = cl_max_pos_base + delta_cl_max
    cl_max_neg = cl_max_neg_base + delta_cl_max
    alpha_0 = alpha_0_base - delta_cl / cl_alpha
    stall_pos = alpha_0 + cl_max_pos / cl_alpha
    stall_neg = alpha_0 + cl_max_neg / cl_alpha
    reverse = abs(alpha) > _HALF_PI
    if reverse:
        alpha = alpha - math.pi if alpha > 0.0 else alpha + math.pi
    if stall_neg < alpha < stall_pos:
        cl = cl_alpha * (alpha - alpha_0)
        alpha_eff = alpha - alpha_0 - cl / pi_ar
        cos_e, sin_e = math.cos(alpha_eff), math.sin(alpha_eff)
        ct = cd_0 * cos_e
        cn = (cl + ct * sin_e) / cos_e
        lever = _CP_BASE - _CP_SHIFT * (1.0 - _TWO_OVER_PI * alpha_eff)
    else:
        if alpha >= stall_pos:
            alpha_i = cl_alpha * (stall_pos - alpha_0) / pi_ar * (_HALF_PI - alpha) / (_HALF_PI - stall_pos)
        else:
            alpha_i = cl_alpha * (stall_neg - alpha_0) / pi_ar * (_HALF_PI + alpha) / (_HALF_PI + stall_neg)
        alpha_eff = alpha - alpha_0 - alpha_i
        cos_e, sin_e = math.cos(alpha_eff), math.sin(alpha_eff)
        cd_90 = _CD90_QUAD * deflection * deflection + _CD90_LIN * deflection + _CD90_ZERO
        shape = 1.0 / (_CN_BASE + _CN_SIN * abs(sin_e)) - cn_ar
        cn = cd_90 * sin_e * shape
        ct = _CT_STALL * cd_0 * cos_e
        cl = cn * cos_e - ct * sin_e
        lever = _CP_BASE - _CP_SHIFT * (1.0 - _TWO_OVER_PI * abs(alpha_eff))
    cd = cn * sin_e + ct * cos_e
    cm = cn * (0.5 - lever) if reverse else -cn * lever
    return cl, cd, cm


@njit(cache=True)
def surface_wrench(
    k: np.ndarray,
    deflection: float,
    vx: float,
    vy: float,
    vz: float,
    wx: float,
    wy: float,
    wz: float,
    air_density: float,
):
    """One surface's body-frame force and torque about the centre of mass (6-tuple) at the
    body's velocity through the air (v, w): ``lifting_surface.surface_wrench``."""
    px, py, pz, cx, cy, cz, nx, ny, nz = k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7], k[8]
    sx, sy, sz, area, chord = k[9], k[10], k[11], k[12], k[13]
    vx = vx + (wy * pz - wz * py)
    vy = vy + (wz * px - wx * pz)
    vz = vz + (wx * py - wy * px)
    u = vx * cx + vy * cy + vz * cz
    w = vx * nx + vy * ny + vz * nz
    speed_sq = u * u + w * w
    if speed_sq == 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    cl, cd, cm = surface_coefficients(k, math.atan2(-w, u), deflection)
    q_area = 0.5 * air_density * speed_sq * area
    scale = q_area / math.sqrt(speed_sq)
    f_c = -scale * (cl * w + cd * u)
    f_n = scale * (cl * u - cd * w)
    fx = f_c * cx + f_n * nx
    fy = f_c * cy + f_n * ny
    fz = f_c * cz + f_n * nz
    moment = cm * q_area * chord
    return (
        fx,
        fy,
        fz,
        py * fz - pz * fy + moment * sx,
        pz * fx - px * fz + moment * sy,
        px * fy - py * fx + moment * sz,
    )


@njit(cache=True)
def surfaces_step(
    deflection: np.ndarray,
    command: np.ndarray,
    lag: np.ndarray,
    surfaces: np.ndarray,
    vx: float,
    vy: float,
    vz: float,
    wx: float,
    wy: float,
    wz: float,
    air_density: float,
):
    """One physics step of a vehicle's lifting surfaces (``Surfaces.step``): every flap
    follows its command (``flap_deflection``: clipped to [-1, 1] times its limit, first-order
    lag), ``deflection`` updated; returns the summed wrench (6-tuple)."""
    fx = fy = fz = tx = ty = tz = 0.0
    for j in range(deflection.shape[0]):
        k = surfaces[j]
        c = command[j]
        clipped = -1.0 if c < -1.0 else 1.0 if c > 1.0 else c
        d = deflection[j]
        d = d + lag[j] * (clipped * k[24] - d)
        deflection[j] = d
        sfx, sfy, sfz, stx, sty, stz = surface_wrench(k, d, vx, vy, vz, wx, wy, wz, air_density)
        fx, fy, fz = fx + sfx, fy + sfy, fz + sfz
        tx, ty, tz = tx + stx, ty + sty, tz + stz
    return fx, fy, fz, tx, ty, tz


@njit(cache=True)
def clip_channels(setpoint: np.ndarray, low: np.ndarray, high: np.ndarray, out: np.ndarray) -> None:
    """The channel vector of mode ``channels``: the setpoint limited to each channel's range
    (``Vehicle.control_step``'s ``setpoint.clip(channel_low, channel_high)``), into ``out``."""
    for c in range(out.shape[0]):
        value = setpoint[c]
        lo, hi = low[c], high[c]
        out[c] = hi if value > hi else lo if value < lo else value


@njit(cache=True)
def route_channels(channels: np.ndarray, index: np.ndarray, weight: np.ndarray, out: np.ndarray) -> None:
    """Each actuator's command from the channel vector: the weighted sum of the channels its
    mix names (``routing.mixed``: (index, weight) pairs in order, index -1 ends a row),
    limited to [-1, 1] (``Motors.route``, ``Surfaces.route``), into ``out``."""
    for a in range(out.shape[0]):
        value = 0.0
        for m in range(index.shape[1]):
            j = index[a, m]
            if j < 0:
                break
            value += weight[a, m] * channels[j]
        out[a] = 1.0 if value > 1.0 else -1.0 if value < -1.0 else value


@njit(cache=True)
def route_motors(
    channels: np.ndarray,
    outputs: np.ndarray,
    source: np.ndarray,
    index: np.ndarray,
    weight: np.ndarray,
    out: np.ndarray,
) -> None:
    """Each motor's command (``Motors.route``): a motor the mixer flies (``source[m]`` its
    output, -1 for none) takes that output, any other its channel mix (:func:`route_channels`,
    then the mixer's outputs over its motors' rows); limited to [-1, 1]."""
    route_channels(channels, index, weight, out)
    for a in range(out.shape[0]):
        k = source[a]
        if k >= 0:
            value = outputs[k]
            out[a] = 1.0 if value > 1.0 else -1.0 if value < -1.0 else value


@njit(cache=True)
def _autopilot_loop(error: float, rate: float, gains: np.ndarray, k: int, integral: np.ndarray, dt: float) -> float:
    """One loop of the fixed-wing autopilot (``control.fixedwing._Loop``): gains row ``k``
    is kp, ki, kd, integral limit; ``integral[k]`` advanced (clamped to limit / ki)."""
    kp, ki, kd, integral_limit = gains[k, 0], gains[k, 1], gains[k, 2], gains[k, 3]
    if ki > 0:
        limit = integral_limit / ki
        value = integral[k] + error * dt
        value = -limit if -limit > value else value  # max(value, -limit)
        integral[k] = limit if limit < value else value  # min(value, limit)
    return kp * error + ki * integral[k] - kd * rate


@njit(cache=True)
def fixedwing_autopilot(
    setpoint: np.ndarray,
    p: float,
    q: float,
    r: float,
    roll: float,
    pitch: float,
    u: float,
    integral: np.ndarray,
    gains: np.ndarray,
    cruise_thrust: float,
    index: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    dt: float,
    out: np.ndarray,
) -> None:
    """The channel vector of mode ``attitude_airspeed`` (``FixedwingAutopilot.__call__``) into
    ``out``: setpoint [roll, pitch, yaw rate, airspeed]; the state's body rates (p, q, r),
    roll and pitch and forward body speed u; ``index`` the roll, pitch, yaw and thrust
    channels; the other channels 0; all limited to the channels' ranges."""
    for c in range(out.shape[0]):
        out[c] = 0.0
    out[index[0]] = _autopilot_loop(setpoint[0] - roll, p, gains, 0, integral, dt)
    out[index[1]] = _autopilot_loop(setpoint[1] - pitch, q, gains, 1, integral, dt)
    out[index[2]] = _autopilot_loop(setpoint[2] - r, 0.0, gains, 2, integral, dt)
    out[index[3]] = cruise_thrust + _autopilot_loop(setpoint[3] - u, 0.0, gains, 3, integral, dt)
    for c in range(out.shape[0]):
        value = out[c]
        lo, hi = low[c], high[c]
        out[c] = hi if value > hi else lo if value < lo else value


@njit(cache=True)
def multirotor_tick(
    mode,
    q,
    w,
    setpoint,
    previous,
    has_previous,
    i,
    integral,
    rate_gains,
    derivative,
    control_inertia,
    gyro,
    control_dt,
    thrust,
    mixer_rows,
    lateral,
    parts,
    rates,
    torques,
    outputs,
) -> None:
    """The mixer's outputs of a routed multirotor's tick into ``outputs``: in ``rates_thrust`` the
    rate loop on the body rates of ``q``, ``w`` (as :func:`advance` reads them; ``previous``,
    ``has_previous[i]``, ``integral`` advanced) and the mixer (:func:`mixer_outputs`) for the
    collective ``thrust``; in ``motors`` the setpoint's first values."""
    if mode == MODE_RATES_THRUST:
        m0, m1, m2, m3, m4, m5, m6, m7, m8 = rotation_tuple(q[0], q[1], q[2], q[3])
        w0, w1, w2 = w
        rates[0] = m0 * w0 + m3 * w1 + m6 * w2
        rates[1] = m1 * w0 + m4 * w1 + m7 * w2
        rates[2] = m2 * w0 + m5 * w1 + m8 * w2
        if not has_previous[i]:
            previous[0], previous[1], previous[2] = rates[0], rates[1], rates[2]
        rate_loop(
            setpoint[:3], rates, previous, integral, rate_gains, derivative, control_inertia, gyro, control_dt, torques
        )
        previous[0], previous[1], previous[2] = rates[0], rates[1], rates[2]
        has_previous[i] = True
        mixer_outputs(thrust, torques[0], torques[1], torques[2], mixer_rows, lateral, parts, outputs)
    else:  # motors: the head is the mixer's outputs
        for k in range(outputs.shape[0]):
            outputs[k] = setpoint[k]


@njit(cache=True)
def advance_channels(
    pos,
    quat,
    vel,
    angvel,
    throttle,
    command,
    deflection,
    flap_command,
    setpoint,
    factors,
    mass,
    inertia,
    lag,
    columns,
    motor_index,
    motor_weight,
    channel_low,
    channel_high,
    surfaces,
    surface_lag,
    surface_index,
    surface_weight,
    drag_factors,
    damping,
    drag_on,
    corners,
    contact,
    gravity,
    air_density,
    physics_dt,
    start,
    count,
    per_control,
    mode,
    autopilot_integral,
    autopilot_gains,
    cruise_thrust,
    autopilot_index,
    control_dt,
    wind,
    episode_steps,
    rotors,
    ground_effect,
    min_height,
    turbulence,
    turbulence_normals,
    dryden,
    motor_model,
    motor_laws,
    battery,
    battery_params,
    battery_table,
    head,
    integral,
    previous,
    has_previous,
    rate_gains,
    derivative,
    control_inertia,
    gyro,
    mixer_rows,
    max_collective,
    lateral,
    motor_source,
    gimbal_angles,
    gimbal_command,
    gimbals,
    gimbal_source,
):
    """Advance every vehicle whose actuators the channels drive ``count`` physics steps from
    physics step ``start``, as :func:`advance` does a multirotor whose motors the mixer alone
    flies: a fixed-wing (mode ``channels`` or ``attitude_airspeed``), or a multirotor with
    channels, lifting surfaces, gimbals or motors outside the mixer (a VTOL, a tricopter: mode
    ``rates_thrust`` or ``motors``; the cascade modes fly their ticks' outputs in ``motors``).

    On a control tick (``Vehicle.control_step``) the channel vector is, in mode ``channels``,
    the setpoint limited to the channels' ranges; in mode ``attitude_airspeed`` the
    autopilot's output (:func:`fixedwing_autopilot`, ``autopilot_integral`` advanced) from
    the state the PyBullet engine reads (rates, attitude and velocity through the quaternion
    PyBullet reports, as :func:`read_out`).  Every motor and flap takes it through its mix
    (:func:`route_channels`).  Per physics step, in the PyBullet engine's step order
    (motors, lifting surfaces, body drag; the wrenches summed in it): the motors step, the
    flaps move and the surfaces load the body at its velocity through the air, body drag
    at the same, and the rigid body integrates the sum.  ``contact``, the wind and ground
    effect (``wind``, ``episode_steps``, ``rotors``, ``ground_effect``, ``min_height``) and
    the turbulence (``turbulence``, ``turbulence_normals``, ``dryden``) and the modelled motors
    and battery (``motor_model``, ``motor_laws``, ``battery``, ``battery_params``,
    ``battery_table``) as in :func:`advance`.

    A multirotor's tick (``Vehicle.control_step`` with a controller): the setpoint's first
    ``head`` values are its mode's, the rest the channels, limited to their ranges; in
    ``rates_thrust`` the rate loop (``integral``, ``previous``, ``has_previous``, as
    :func:`advance` keeps them) and the mixer (:func:`mixer_outputs`: ``mixer_rows``, the
    tilting motors' ``lateral`` rows) give the mixer's outputs, in ``motors`` the head is
    them.  Each motor takes its output or its channel mix (:func:`route_motors`,
    ``motor_source``), each gimbal its output or channels (:func:`route_gimbals`,
    ``gimbal_source``).  The gimbals step first in each physics step (:func:`gimbals_step`:
    ``gimbal_angles``, ``gimbal_command`` (N, 2 g), ``gimbals`` (g, :data:`GIMBAL_FIELDS`)),
    turning their motors' rows of ``columns``, as ``Gimbals.step`` turns ``Motors.columns``.
    """
    n = pos.shape[0]
    nc = channel_low.shape[0]
    ng = gimbals.shape[0]
    outputs = np.zeros(mixer_rows.shape[1] + lateral.shape[0])
    parts = np.empty((mixer_rows.shape[1], 4))
    rates = np.empty(3)
    torques = np.empty(3)
    modelled = motor_laws != 0
    ratio = np.empty(throttle.shape[1])
    channels = np.empty(nc)
    rm = np.empty(9)
    qr = np.empty(4)
    euler = np.empty(3)
    scaled = np.empty((1, throttle.shape[1], 6))  # ground effect's columns of the vehicle at hand
    calm = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    scratch = np.empty(turbulence.shape[1])
    for i in range(n):
        contact[i] = False
        wind_i = wind[i]  # this env's wind and turbulence filter (its rows)
        windy = wind_i[0] != 0.0
        turbulent = wind_i[17] != 0.0
        dryden_i = (dryden[0][i], dryden[1][i], dryden[2][i], dryden[3][i], dryden[4][i])
        p = (pos[i, 0], pos[i, 1], pos[i, 2])
        q = (quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3])
        v = (vel[i, 0], vel[i, 1], vel[i, 2])
        w = (angvel[i, 0], angvel[i, 1], angvel[i, 2])
        m_i, jx, jy, jz = mass[i], inertia[i, 0], inertia[i, 1], inertia[i, 2]
        kx, ky, kz, c_i = drag_factors[i, 0], drag_factors[i, 1], drag_factors[i, 2], damping[i]
        x_i, cmd_i, lag_i, col_i = throttle[i], command[i], lag[i], columns[i]
        d_i, f_i, s_i, sl_i = deflection[i], flap_command[i], surfaces[i], surface_lag[i]
        ga_i, gc_i = gimbal_angles[i], gimbal_command[i]
        for s in range(count):
            step = start + s
            if step % per_control == 0:  # control tick: the channels, routed
                if mode == MODE_ATTITUDE_AIRSPEED:  # the state as Vehicle.read_state reads it
                    rotation_rows(q[0], q[1], q[2], q[3], rm)
                    matrix_quaternion(rm, qr)
                    euler_from_quaternion(qr[0], qr[1], qr[2], qr[3], euler)
                    m0, m1, m2, m3, m4, m5, m6, m7, m8 = rotation_tuple(qr[0], qr[1], qr[2], qr[3])
                    w0, w1, w2 = w
                    fixedwing_autopilot(
                        setpoint[i],
                        m0 * w0 + m3 * w1 + m6 * w2,
                        m1 * w0 + m4 * w1 + m7 * w2,
                        m2 * w0 + m5 * w1 + m8 * w2,
                        euler[0],
                        euler[1],
                        m0 * v[0] + m3 * v[1] + m6 * v[2],
                        autopilot_integral[i],
                        autopilot_gains,
                        cruise_thrust,
                        autopilot_index,
                        channel_low,
                        channel_high,
                        control_dt,
                        channels,
                    )
                elif mode == MODE_CHANNELS:
                    clip_channels(setpoint[i], channel_low, channel_high, channels)
                else:  # a multirotor: the mixer's outputs from the head, the channels after it
                    multirotor_tick(
                        mode,
                        q,
                        w,
                        setpoint[i],
                        previous[i],
                        has_previous,
                        i,
                        integral[i],
                        rate_gains[i],
                        derivative,
                        control_inertia[i],
                        gyro[i],
                        control_dt,
                        setpoint[i, 3] * max_collective[i],
                        mixer_rows[i],
                        lateral,
                        parts,
                        rates,
                        torques,
                        outputs,
                    )
                    clip_channels(setpoint[i, head:], channel_low, channel_high, channels)
                if mode > MODE_RATES_THRUST:  # a fixed-wing's motors: their mixes alone
                    route_channels(channels, motor_index, motor_weight, cmd_i)
                else:
                    route_motors(channels, outputs, motor_source, motor_index, motor_weight, cmd_i)
                route_channels(channels, surface_index, surface_weight, f_i)
                if ng:
                    route_gimbals(channels, outputs, gimbal_source, gc_i)
            r = rotation_tuple(q[0], q[1], q[2], q[3])
            r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
            w0, w1, w2 = w
            v0, v1, v2 = v
            bw0 = r0 * w0 + r3 * w1 + r6 * w2
            bw1 = r1 * w0 + r4 * w1 + r7 * w2
            bw2 = r2 * w0 + r5 * w1 + r8 * w2
            bv0 = r0 * v0 + r3 * v1 + r6 * v2
            bv1 = r1 * v0 + r4 * v1 + r7 * v2
            bv2 = r2 * v0 + r5 * v1 + r8 * v2
            if windy:  # the velocity through the air, as the PyBullet engine's world forms it
                gusts = calm
                if turbulent:
                    gusts = _air.dryden_output(dryden_i, turbulence[i], wind_i[18], wind_i[19])
                    _air.dryden_step(dryden_i, turbulence[i], turbulence_normals[i, s], scratch)
                sample = _air.wind_sample(wind_i, episode_steps[i] + s, p[2], physics_dt, gusts)
                if step % per_control == 0:
                    a = _air.air_from_body(r, bv0, bv1, bv2, bw0, bw1, bw2, sample)
                else:
                    a = _air.air_from_motion(r, v0, v1, v2, w0, w1, w2, sample)
                bv0, bv1, bv2, bw0, bw1, bw2 = a
            if ng:  # the gimbals first: they turn their motors' thrust axes
                gimbals_step(ga_i, gc_i, gimbals, gimbal_source, col_i)
            if modelled:
                load = modelled_load(
                    x_i,
                    cmd_i,
                    lag_i,
                    factors[i, s],
                    motor_model[i],
                    motor_laws,
                    battery[i],
                    battery_params[i],
                    battery_table,
                    rotors[i],
                    ground_effect,
                    p[2],
                    r6,
                    r7,
                    r8,
                    min_height,
                    ratio,
                    (bv0, bv1, bv2, bw0, bw1, bw2),
                    physics_dt,
                )
            elif ground_effect:
                _air.ground_effect_columns(p[2], r6, r7, r8, rotors[i], col_i, min_height, scaled[0])
                load = motors_step_row(throttle, command, lag, factors, scaled, i, s, 0)
            else:
                load = motors_step_row(throttle, command, lag, factors, columns, i, s, i)
            load = summed(load, surfaces_step(d_i, f_i, sl_i, s_i, bv0, bv1, bv2, bw0, bw1, bw2, air_density))
            if drag_on:
                load = summed(load, drag_wrench(bv0, bv1, bv2, bw0, bw1, bw2, kx, ky, kz, c_i))
            p, q, v, w = integrate_state(p, q, v, w, r, load, m_i, jx, jy, jz, gravity, physics_dt)
            if (step + 1) % per_control == 0 or s == count - 1:
                rr = rotation_tuple(q[0], q[1], q[2], q[3])
                if lowest_row(p[2], rr[6], rr[7], rr[8], corners, i) < 0.0:
                    contact[i] = True
        pos[i, 0], pos[i, 1], pos[i, 2] = p
        quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3] = q
        vel[i, 0], vel[i, 1], vel[i, 2] = v
        angvel[i, 0], angvel[i, 1], angvel[i, 2] = w

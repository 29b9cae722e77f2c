"""One vehicle's physics step -- velocity read-out, motors, drag, net wrench -- as one function.

A multirotor with fixed motors and body drag only (no gimbals, lifting surfaces or
boosters) does the same work at every physics step between control ticks: read its
velocity, rotate it into the body frame, step every motor's lag and noise, sum the
motors' wrench and the drag, apply the net force and torque.  :func:`compile_physics_step`
writes that work out as straight-line Python for one vehicle -- one statement per motor,
its lag coefficient and wrench-map entries as literals, zero entries left out -- and
compiles it once, when the vehicle is built.  For a quadcopter the motor and drag
arithmetic then costs well under half of the same run through loops over per-motor
tuples, and the step makes two Python calls fewer.

The arithmetic is exactly that of the reference functions, operation for operation and
in the same order: :func:`~pyflyt_engine.components.motor.motor_step_wrench` for the
motors, then :func:`~pyflyt_engine.components.drag.drag_wrench` added to the motor
wrench, with the body-frame velocity ``R^T v`` from PyBullet's rotation matrix (the
tests check the results agree bit for bit).  Leaving out a zero term can only change the
sign of a zero sum, which no force or torque sees.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import pybullet as p

_ORIGIN = (0.0, 0.0, 0.0)

StepFunctions = tuple[Callable[[], None], Callable[[], None]]


def _literal(value: float) -> str:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"cannot compile the non-finite constant {value!r}")
    return repr(value)  # repr round-trips a float exactly


def _sum(terms: Sequence[str]) -> str:
    return " + ".join(terms) if terms else "0.0"


def physics_step_source(
    lag: Sequence[float],
    columns: Sequence[Sequence[float]],
    noise: bool,
    drag: Sequence[float] | None,
) -> str:
    """Source of the factory behind :func:`compile_physics_step` (see there for arguments)."""
    n = len(lag)
    if len(columns) != n or n == 0:
        raise ValueError(f"need one wrench column per motor: {n} lags, {len(columns)} columns")
    xs = [f"x{i}" for i in range(n)]
    # drag[k] is the coefficient of v_k |v_k| in wrench component k (v = u, v, w, p, q, r)
    drag = [0.0] * 6 if drag is None else [float(d) for d in drag]
    velocity_names = ("vx", "vy", "vz", "wx", "wy", "wz")
    used = [d != 0.0 for d in drag]

    loads = [
        f"{', '.join(xs)}, = vehicle._throttle",
        f"{', '.join(f'c{i}' for i in range(n))}, = vehicle._command",
    ]
    if noise:
        zs = ", ".join(f"z{i}" for i in range(n))
        loads.append(f"{zs}, = next(vehicle._noise_rows, None) or vehicle._refill_noise()")
    for i in range(n):
        step = f"x{i} + {_literal(lag[i])} * (c{i} - x{i})"
        loads.append(f"x{i} = ({step}) * z{i}" if noise else f"x{i} = {step}")
    loads.append(f"vehicle._throttle = [{', '.join(xs)}]")
    wrench = []
    for k in range(6):
        terms = [f"{_literal(columns[i][k])} * f{i}" for i in range(n) if columns[i][k] != 0.0]
        if used[k]:
            v = velocity_names[k]
            terms.append(f"{_literal(drag[k])} * {v} * abs({v})")
        wrench.append(_sum(terms))
    for i in range(n):
        if any(float(c) != 0.0 for c in columns[i]):
            loads.append(f"f{i} = x{i} * abs(x{i})")
    loads.append(f"apply_force(body, -1, ({wrench[0]}, {wrench[1]}, {wrench[2]}), ORIGIN, FRAME, cid)")
    loads.append(f"apply_torque(body, -1, ({wrench[3]}, {wrench[4]}, {wrench[5]}), FRAME, cid)")

    linear, angular = any(used[:3]), any(used[3:])
    stored = []
    if linear or angular:
        stored.append("(vx, vy, vz), (wx, wy, wz) = vehicle._velocity_body")
    read = []
    if linear or angular:
        read += [
            "quat = get_pose(body, cid)[1]",
            "(lx, ly, lz), (ax, ay, az) = get_velocity(body, cid)",
            "r0, r1, r2, r3, r4, r5, r6, r7, r8 = get_matrix(quat, cid)",
        ]
        # body frame = R^T ground frame, R body-to-ground (row-major): component k is
        # column k of R dotted with the ground-frame vector
        for k, name in enumerate(velocity_names):
            if used[k]:
                gx, gy, gz = ("lx", "ly", "lz") if k < 3 else ("ax", "ay", "az")
                c = k % 3
                read.append(f"{name} = r{c} * {gx} + r{c + 3} * {gy} + r{c + 6} * {gz}")

    def body(lines: list[str]) -> str:
        return "\n".join("        " + line for line in lines)

    return (
        "def factory(vehicle, body, cid, ORIGIN, FRAME,\n"
        "            get_pose, get_velocity, get_matrix, apply_force, apply_torque):\n"
        "    def apply_loads():\n"
        f"{body(stored + loads)}\n"
        "    def substep():\n"
        f"{body(read + loads)}\n"
        "    return apply_loads, substep\n"
    )


def compile_physics_step(
    vehicle: object,
    client: int,
    body_id: int,
    lag: Sequence[float],
    columns: Sequence[Sequence[float]],
    noise: bool,
    drag: Sequence[float] | None,
) -> StepFunctions:
    """The two per-physics-step functions of one vehicle with fixed motors and drag only.

    Args:
        vehicle: holds the state the functions step: ``_throttle`` and ``_command``
            (per-motor lists), ``_velocity_body`` (body-frame linear and angular velocity,
            set by its full state read-out), and with ``noise`` ``_noise_rows`` (an
            iterator over per-motor noise factors) and ``_refill_noise()`` (draws the next
            block and returns its first row).
        client, body_id: the PyBullet client and body.
        lag: per-motor lag coefficient (see :func:`~pyflyt_engine.components.motor.motor_lag`).
        columns: per-motor column of the wrench map (see
            :func:`~pyflyt_engine.components.motor.motor_wrench_matrix`).
        noise: whether the motors' throttle noise is on.
        drag: per wrench component (Fx, Fy, Fz, Tx, Ty, Tz), the coefficient of
            ``v |v|`` of the matching body velocity (u, v, w, p, q, r): the negated
            :attr:`~pyflyt_engine.components.drag.DragParams.factors`, then the negated
            angular damping three times; None for no drag.

    Returns:
        ``(apply_loads, substep)``: ``apply_loads()`` steps the motors and applies the
        net wrench with the velocity of the last full read-out (at control ticks);
        ``substep()`` first reads the velocity from PyBullet (between ticks).  Without
        drag neither reads a velocity.
    """
    source = physics_step_source(lag, columns, noise, drag)
    namespace: dict = {}
    exec(compile(source, "<pyflyt_engine physics step>", "exec"), namespace)  # noqa: S102 - our own source
    return namespace["factory"](
        vehicle, body_id, client, _ORIGIN, p.LINK_FRAME,
        p.getBasePositionAndOrientation, p.getBaseVelocity, p.getMatrixFromQuaternion,
        p.applyExternalForce, p.applyExternalTorque,
    )  # fmt: skip

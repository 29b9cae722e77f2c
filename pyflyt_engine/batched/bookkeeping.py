"""A batched step's bookkeeping on arrays, in compiled calls: the episodes' ends and the resets.

A step of :class:`~pyflyt_engine.batched.env.BatchedUAVEnv` resets every env whose episode
ended; with random actions that is one env in ~13 per step, so a reset that is Python work
per env (a generator call, a ``Spawn``, a quaternion, a rotation) costs more than the
physics.  Here the same laws run on the rows of the ended envs at once:

* :func:`spawn_rows` is :meth:`~pyflyt_engine.envs.tasks.base.Task.spawn` (the mean pose plus
  ``U(-noise, noise)`` per coordinate, then per Euler angle; moving at ``start_lin_vel`` in
  the body frame, not rotating) followed by what the env does with a spawn
  (:func:`~pyflyt_engine.frames.euler_to_quaternion`, the body-frame velocities turned to
  the ground frame by ``exact.rotate``), each expression in the same order of operations.
  The uniform draws come from each env's own generator: numpy's ``Generator.uniform(low,
  high)`` is ``low + (high - low) * next_double`` of its bit generator (numpy's
  ``random_uniform`` in ``distributions.c``), and the compiled loop calls that
  ``next_double`` (the ``bit_generator.ctypes`` interface numpy exposes for compiled
  callers) on each env's state, so every env draws the same numbers in the same order
  from the same stream as ``Task.spawn`` would;
* :func:`zero_rows` starts the controller, motors and counters of those rows from zero;
* :func:`read_rows` and :func:`distance_rows`: the read-outs and the target distance of
  those rows, as a step computes them for every row;
* :func:`stack_columns`: an observation's parts side by side (``np.concatenate`` on axis 1).

And per step, for every env: :func:`ends` (the contact, the flight dome, the time limit: what
ended the episode and how) and :func:`progress` (the distance to a fixed goal and its rate),
the env's former NumPy expressions element by element, in the same order of operations.

``tests/batched/test_bookkeeping.py`` holds each against its Python form bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from pyflyt_engine.batched.compiled import njit
from pyflyt_engine.batched.kernels import read_state, rotation_rows, store_read


def stream_addresses(rngs: list[np.random.Generator]) -> tuple[np.ndarray, object] | None:
    """The state addresses of ``rngs``' bit generators and their common ``next_double``
    (numpy's ctypes interface), or None when they are not all of one kind of bit generator
    (then the caller draws through ``Generator.uniform``, env by env)."""
    if not rngs:
        return None
    interfaces = [rng.bit_generator.ctypes for rng in rngs]
    import ctypes

    address = ctypes.cast(interfaces[0].next_double, ctypes.c_void_p).value
    if any(ctypes.cast(c.next_double, ctypes.c_void_p).value != address for c in interfaces):
        return None
    return np.array([c.state_address for c in interfaces], dtype=np.uintp), interfaces[0].next_double


@njit(cache=True)
def spawn_rows(
    index,
    states,
    next_double,
    start_position,
    position_noise,
    start_orientation,
    orientation_noise,
    lin_vel,
    ang_vel,
    pos,
    quat,
    vel,
    angvel,
    offsets,
    shifted,
):
    """The spawn of every env in ``index`` (``Task.spawn`` and the env's use of it, module
    docstring): env ``i`` draws from the bit generator state at ``states[i]``, three numbers
    for its position when ``position_noise`` is not 0, then three for its attitude when
    ``orientation_noise`` is not 0; its ``pos``, ``quat``, ``vel`` and ``angvel`` rows are set
    (``lin_vel``, ``ang_vel``: the body-frame velocities of the spawn).  With ``shifted``,
    row ``i`` of ``offsets`` (x, y, z, roll, pitch, yaw: the drawn ``spawn_*`` offsets) is
    added to the spawn's position and Euler angles, as ``Randomizer.spawn`` adds them."""
    p_low, o_low = -position_noise, -orientation_noise
    p_range, o_range = position_noise - p_low, orientation_noise - o_low  # Generator.uniform's high - low
    e = np.empty(3)
    r = np.empty(9)
    for k in range(index.shape[0]):
        i = index[k]
        state = states[i]
        for a in range(3):
            d = p_low + p_range * next_double(state) if position_noise != 0.0 else 0.0
            pos[i, a] = start_position[a] + d
            if shifted:
                pos[i, a] = pos[i, a] + offsets[i, a]
        for a in range(3):
            d = o_low + o_range * next_double(state) if orientation_noise != 0.0 else 0.0
            e[a] = start_orientation[a] + d
            if shifted:
                e[a] = e[a] + offsets[i, 3 + a]
        # frames.euler_to_quaternion
        cr, sr = math.cos(e[0] / 2), math.sin(e[0] / 2)
        cp, sp = math.cos(e[1] / 2), math.sin(e[1] / 2)
        cy, sy = math.cos(e[2] / 2), math.sin(e[2] / 2)
        qx = sr * cp * cy - cr * sp * sy
        qy = cr * sp * cy + sr * cp * sy
        qz = cr * cp * sy - sr * sp * cy
        qw = cr * cp * cy + sr * sp * sy
        quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3] = qx, qy, qz, qw
        rotation_rows(qx, qy, qz, qw, r)
        # exact.rotate(rows, v): body to ground, as Vehicle.reset turns the spawn's velocities
        x, y, z = lin_vel[0], lin_vel[1], lin_vel[2]
        vel[i, 0] = r[0] * x + r[1] * y + r[2] * z
        vel[i, 1] = r[3] * x + r[4] * y + r[5] * z
        vel[i, 2] = r[6] * x + r[7] * y + r[8] * z
        x, y, z = ang_vel[0], ang_vel[1], ang_vel[2]
        angvel[i, 0] = r[0] * x + r[1] * y + r[2] * z
        angvel[i, 1] = r[3] * x + r[4] * y + r[5] * z
        angvel[i, 2] = r[6] * x + r[7] * y + r[8] * z


@njit(cache=True)
def zero_rows(index, tables, columns, counts, flags):
    """Rows ``index`` of every array set to zero: ``tables`` (2-D float arrays), ``columns``
    (1-D float), ``counts`` (1-D int), ``flags`` (1-D bool), each a tuple of one kind."""
    for k in range(index.shape[0]):
        i = index[k]
        for a in tables:
            for j in range(a.shape[1]):
                a[i, j] = 0.0
        for a in columns:
            a[i] = 0.0
        for a in counts:
            a[i] = 0
        for a in flags:
            a[i] = False


@njit(cache=True)
def zero_unless(table, mask):
    """Every row ``i`` of ``table`` (2-D) where ``mask[i]`` is False set to zero (one compiled
    pass: numpy's boolean-mask assignment costs ~3.7 us at N = 256, this ~0.5)."""
    for i in range(table.shape[0]):
        if not mask[i]:
            for j in range(table.shape[1]):
                table[i, j] = 0.0


@njit(cache=True)
def read_rows(index, pos, quat, vel, angvel, ang_vel_body, ang_pos, lin_vel_body, quaternion):
    """:func:`~pyflyt_engine.batched.kernels.read_out` of the rows ``index`` only."""
    for k in range(index.shape[0]):
        i = index[k]
        read = read_state(
            (quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3]),
            (vel[i, 0], vel[i, 1], vel[i, 2]),
            (angvel[i, 0], angvel[i, 1], angvel[i, 2]),
        )
        store_read(i, read, ang_vel_body, ang_pos, lin_vel_body, quaternion)


@njit(cache=True)
def distance_rows(index, pos, goals, last_position, last_distance):
    """Rows ``index``: ``last_position`` the position, ``last_distance`` its distance to the
    row's goal (``goals`` (N, 3); the env's ``_target_distance``: ``sqrt(dx dx + dy dy + dz dz)``)."""
    for k in range(index.shape[0]):
        i = index[k]
        dx, dy, dz = pos[i, 0] - goals[i, 0], pos[i, 1] - goals[i, 1], pos[i, 2] - goals[i, 2]
        last_position[i, 0], last_position[i, 1], last_position[i, 2] = pos[i, 0], pos[i, 1], pos[i, 2]
        last_distance[i] = math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True)
def ends(pos, contact, complete, steps, max_steps, dome2, crash_on_contact, succeeds_at_time_limit, dome_ends,
         complete_ends, time_ends):  # fmt: skip
    """How each env's step ended, from its position, ``contact``, ``complete`` (the task done)
    and ``steps`` taken: ``(collision, out_of_bounds, crashed, terminated, truncated,
    steps_remaining, success)``, new arrays.  Out of bounds: ``x x + y y + z z > dome2``; a
    crash: out of bounds where ``dome_ends``, or a contact where the task crashes on one;
    terminated: a crash, or complete where ``complete_ends``; truncated: not terminated at
    ``max_steps`` where ``time_ends``; success: complete without a crash, or truncated where
    the task succeeds at its time limit (the termination terms, :mod:`pyflyt_engine.envs.terminations`)."""
    n = pos.shape[0]
    collision = np.empty(n, dtype=np.bool_)
    out = np.empty(n, dtype=np.bool_)
    crashed = np.empty(n, dtype=np.bool_)
    terminated = np.empty(n, dtype=np.bool_)
    truncated = np.empty(n, dtype=np.bool_)
    success = np.empty(n, dtype=np.bool_)
    remaining = np.empty(n, dtype=np.int64)
    for i in range(n):
        x, y, z = pos[i, 0], pos[i, 1], pos[i, 2]
        o = x * x + y * y + z * z > dome2
        c = contact[i]
        crash = (o and dome_ends) or (c and crash_on_contact)
        end = crash or (complete[i] and complete_ends)
        cut = time_ends and (not end) and steps[i] >= max_steps
        left = max_steps - steps[i]
        collision[i], out[i], crashed[i], terminated[i], truncated[i] = c, o, crash, end, cut
        remaining[i] = left if left > 0 else 0
        success[i] = (complete[i] and not crash) or (cut and succeeds_at_time_limit)
    return collision, out, crashed, terminated, truncated, remaining, success


@njit(cache=True)
def progress(pos, goals, last_distance, dt):
    """Each env's distance to its goal (``goals`` (N, 3): ``sqrt(dx dx + dy dy + dz dz)``) and
    its rate since ``last_distance``, ``(distance - last) / dt``: two new arrays."""
    n = pos.shape[0]
    distance = np.empty(n)
    rate = np.empty(n)
    for i in range(n):
        dx, dy, dz = pos[i, 0] - goals[i, 0], pos[i, 1] - goals[i, 1], pos[i, 2] - goals[i, 2]
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        distance[i] = d
        rate[i] = (d - last_distance[i]) / dt
    return distance, rate


_FLOAT = np.dtype(np.float64)


@njit(cache=True)
def _stack_columns(parts, out) -> None:
    n = out.shape[0]
    at = 0
    for part in parts:
        k = part.shape[1]
        for i in range(n):
            for j in range(k):
                out[i, at + j] = part[i, j]
        at += k


@njit(cache=True, inline="always")
def _put(out, i, part, at):
    """Row ``i`` of ``part`` into row ``i`` of ``out`` from column ``at``; the next free
    column (``part`` None: absent, none taken)."""
    if part is None:
        return at
    for j in range(part.shape[1]):
        out[i, at + j] = part[i, j]
    return at + part.shape[1]


@njit(cache=True)
def _stack_few(out, p0, p1, p2, p3, p4, p5, p6, p7) -> None:
    """:func:`_stack_columns` of up to 8 parts given one by one (None: absent), row by row
    (each of ``out``'s rows written once, in order).  The call unboxes them as fast as
    single arrays; a tuple of arrays is unboxed element by element through a slower path."""
    for i in range(out.shape[0]):
        at = _put(out, i, p0, 0)
        at = _put(out, i, p1, at)
        at = _put(out, i, p2, at)
        at = _put(out, i, p3, at)
        at = _put(out, i, p4, at)
        at = _put(out, i, p5, at)
        at = _put(out, i, p6, at)
        _put(out, i, p7, at)


#: the most parts :func:`_stack_few` takes
_FEW = 8


def stack_columns(parts: list[np.ndarray]) -> np.ndarray:
    """``np.concatenate(parts, axis=1)`` of 2-D arrays with one row per env (an observation's
    parts), copied row by row by one compiled call: a hover observation's six parts take
    ~4.9 us at N = 256 and ~45 us at N = 4096 against numpy's ~6.2 and ~83 (up to 8 parts,
    :func:`_stack_few`; more, a tuple of them, whose unboxing is slower).  A copy either way:
    the same values.  Parts of one compiled type only (2-D float64, C-contiguous, aligned,
    writeable); any other mix is numpy's."""
    if not all(
        p.dtype == _FLOAT and p.ndim == 2 and p.flags.carray for p in parts
    ):  # carray: C-contiguous, aligned, writeable
        return np.concatenate(parts, axis=1)
    out = np.empty((parts[0].shape[0], sum(p.shape[1] for p in parts)))
    if len(parts) <= _FEW:
        _stack_few(out, *parts, *(None,) * (_FEW - len(parts)))
    else:
        _stack_columns(tuple(parts), out)
    return out


__all__ = [
    "distance_rows",
    "ends",
    "progress",
    "read_rows",
    "spawn_rows",
    "stack_columns",
    "stream_addresses",
    "zero_rows",
    "zero_unless",
]

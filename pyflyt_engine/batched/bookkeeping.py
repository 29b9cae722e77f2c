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
* :func:`stack_columns`: an observation's parts side by side (``np.concatenate`` on axis 1);
* :func:`clip_rows`: a step's actions clipped to the action space.

And per step, for every env: :func:`ends` (the contact, the flight dome, the time limit: what
ended the episode and how), :func:`progress` (the distance to a fixed goal and its rate),
:func:`waypoint_progress` and :func:`waypoint_context` (the waypoints reached, and the next
ones the observation shows), :func:`zero_unless` (the last observations of the envs that
ended) and :func:`episode_ends` (with their episodes' statistics), the env's former NumPy
expressions element by element, in the same order of operations.  :func:`plain_step` runs a plain env's whole step (noise, physics, read-out,
progress, ends, reward, observation) through these and the laws in one call.

``tests/batched/test_bookkeeping.py`` holds each against its Python form bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from pyflyt_engine.batched import kernels as _kernels
from pyflyt_engine.batched import normals as _normals
from pyflyt_engine.batched import terms as _terms
from pyflyt_engine.batched.compiled import njit
from pyflyt_engine.batched.kernels import read_state, rotation_rows, rotation_tuple, store_read


def stream_addresses(rngs: list[np.random.Generator]) -> tuple[np.ndarray, int] | None:
    """The state addresses of ``rngs``' bit generators and the address of their common
    ``next_double`` (numpy's ctypes interface, :func:`~pyflyt_engine.batched.normals.interface`),
    or None when they are not all of one kind of bit generator (then the caller draws through
    ``Generator.uniform``, env by env)."""
    if not rngs:
        return None
    interfaces = [_normals.interface(rng) for rng in rngs]
    if any(c[2] != interfaces[0][2] for c in interfaces):
        return None
    return np.array([c[0] for c in interfaces], dtype=np.uintp), interfaces[0][2]


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
            d = p_low + p_range * _normals.next_double_at(next_double, state) if position_noise != 0.0 else 0.0
            pos[i, a] = start_position[a] + d
            if shifted:
                pos[i, a] = pos[i, a] + offsets[i, a]
        for a in range(3):
            d = o_low + o_range * _normals.next_double_at(next_double, state) if orientation_noise != 0.0 else 0.0
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
def clip_rows(actions, low, high, out):
    """``out = np.minimum(np.maximum(actions, low), high)`` (``actions``, ``out`` (N, k);
    ``low``, ``high`` (k,)) in one compiled pass: the actions clipped to the action space.
    Element by element as numpy's vector loops compute it here: a NaN goes through, and a
    value equal to a bound (``-0.0`` at a bound of ``0.0``) gives the bound; two ufunc calls
    with their broadcasting cost ~3.3 us at N = 256, this ~0.3."""
    for i in range(actions.shape[0]):
        for j in range(actions.shape[1]):
            x, lo, hi = actions[i, j], low[j], high[j]
            x = x if x > lo or x != x else lo
            out[i, j] = x if x < hi or x != x else hi


@njit(cache=True)
def zero_unless(table, mask):
    """Every row ``i`` of ``table`` (2-D) where ``mask[i]`` is False set to zero (one compiled
    pass: numpy's boolean-mask assignment costs ~3.7 us at N = 256, this ~0.5)."""
    for i in range(table.shape[0]):
        if not mask[i]:
            for j in range(table.shape[1]):
                table[i, j] = 0.0


@njit(cache=True)
def episode_ends(obs, done, episode_return, episode_length):
    """The end of a step whose episodes ended in the envs ``done``: ``obs``'s other rows set to
    zero (:func:`zero_unless`: the last observations), and the ended episodes' statistics
    ``(returns, lengths)``, 0 in the rows that go on (``np.where(done, episode_return, 0.0)``
    and ``np.where(done, episode_length, 0)``), in one call instead of three (~2 us at N = 256)."""
    zero_unless(obs, done)
    n = done.shape[0]
    returns = np.zeros(n)
    lengths = np.zeros(n, dtype=np.int64)
    for i in range(n):
        if done[i]:
            returns[i] = episode_return[i]
            lengths[i] = episode_length[i]
    return returns, lengths


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


@njit(cache=True)
def waypoint_progress(pos, last_position, last_distance, targets, num_reached, reach, dt):
    """Each env's progress along its waypoints in this step: the distance to its current
    target (the next not reached) and its rate since ``last_distance``, whether the path from
    ``last_position`` to ``pos`` passed within ``reach`` of that target (``segment_point_distance``
    of :mod:`pyflyt_engine.envs.waypoints`), and whether that was the last one.  Returns
    ``(distance, rate, reached, complete)``, new arrays (distance and rate 0 where every target
    was reached before the step); ``num_reached`` counts the reached one, ``last_distance``
    becomes the distance to the target the env flies to next.  The env's former NumPy
    expressions row by row, in the same order of operations."""
    n = pos.shape[0]
    k = targets.shape[1]
    distance = np.empty(n)
    rate = np.empty(n)
    reached = np.empty(n, dtype=np.bool_)
    complete = np.empty(n, dtype=np.bool_)
    for i in range(n):
        all_done = num_reached[i] >= k
        nxt = num_reached[i] if num_reached[i] < k - 1 else k - 1
        tx, ty, tz = targets[i, nxt, 0], targets[i, nxt, 1], targets[i, nxt, 2]
        px, py, pz = pos[i, 0], pos[i, 1], pos[i, 2]
        dx, dy, dz = px - tx, py - ty, pz - tz
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        r = (d - last_distance[i]) / dt
        # the segment last_position -> pos against the target
        sx, sy, sz = last_position[i, 0], last_position[i, 1], last_position[i, 2]
        ex, ey, ez = px - sx, py - sy, pz - sz
        qx, qy, qz = tx - sx, ty - sy, tz - sz
        length2 = ex * ex + ey * ey + ez * ez
        t = (qx * ex + qy * ey + qz * ez) / length2
        if length2 == 0.0:
            t = 0.0
        else:  # np.minimum(np.maximum(t, 0), 1), a NaN kept (a zero's sign cannot change the distance)
            t = t if (t >= 0.0 or t != t) else 0.0
            t = t if (t <= 1.0 or t != t) else 1.0
        fx, fy, fz = qx - t * ex, qy - t * ey, qz - t * ez
        hit = math.sqrt(fx * fx + fy * fy + fz * fz) < reach[i] and not all_done
        if hit:
            num_reached[i] += 1
        last = hit and num_reached[i] >= k
        if hit and not last:  # moved on: the distance to the next target
            nxt = num_reached[i] if num_reached[i] < k - 1 else k - 1
            dx, dy, dz = px - targets[i, nxt, 0], py - targets[i, nxt, 1], pz - targets[i, nxt, 2]
            last_distance[i] = math.sqrt(dx * dx + dy * dy + dz * dz)
        else:
            last_distance[i] = d
        distance[i] = 0.0 if all_done else d
        rate[i] = 0.0 if all_done else r
        reached[i] = hit
        complete[i] = last
    return distance, rate, reached, complete


@njit(cache=True)
def waypoint_context(quaternion, pos, targets, num_reached, deltas, mask):
    """The waypoints an observation shows (``WaypointsTask.observe``): per env, its next
    ``mask.shape[1]`` targets from the reached count on, each the target minus ``pos`` turned
    into the body frame of ``quaternion`` (``R^T d``, the rotation of the quaternion PyBullet
    reports), into ``deltas`` (N, 3 per slot) and 1 in ``mask`` (N, slots); 0 in both past the
    last target."""
    k = targets.shape[1]
    for i in range(pos.shape[0]):
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = rotation_tuple(
            quaternion[i, 0], quaternion[i, 1], quaternion[i, 2], quaternion[i, 3]
        )
        for slot in range(mask.shape[1]):
            j = num_reached[i] + slot
            valid = j < k
            j = j if j < k - 1 else k - 1
            d0, d1, d2 = targets[i, j, 0] - pos[i, 0], targets[i, j, 1] - pos[i, 1], targets[i, j, 2] - pos[i, 2]
            if valid:
                deltas[i, 3 * slot] = r0 * d0 + r3 * d1 + r6 * d2
                deltas[i, 3 * slot + 1] = r1 * d0 + r4 * d1 + r7 * d2
                deltas[i, 3 * slot + 2] = r2 * d0 + r5 * d1 + r8 * d2
            else:
                deltas[i, 3 * slot] = deltas[i, 3 * slot + 1] = deltas[i, 3 * slot + 2] = 0.0
            mask[i, slot] = 1.0 if valid else 0.0


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
def stack_few(out, p0, p1, p2, p3, p4, p5, p6, p7) -> None:
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


#: the most parts :func:`stack_few` takes
_FEW = 8


def stack_columns(parts: list[np.ndarray]) -> np.ndarray:
    """``np.concatenate(parts, axis=1)`` of 2-D arrays with one row per env (an observation's
    parts), copied row by row by one compiled call: a hover observation's six parts take
    ~4.9 us at N = 256 and ~45 us at N = 4096 against numpy's ~6.2 and ~83 (up to 8 parts,
    :func:`stack_few`; more, a tuple of them, whose unboxing is slower).  A copy either way:
    the same values.  Parts of one compiled type only (2-D float64, C-contiguous, aligned,
    writeable); any other mix is numpy's."""
    if not all(
        p.dtype == _FLOAT and p.ndim == 2 and p.flags.carray for p in parts
    ):  # carray: C-contiguous, aligned, writeable
        return np.concatenate(parts, axis=1)
    out = np.empty((parts[0].shape[0], sum(p.shape[1] for p in parts)))
    if len(parts) <= _FEW:
        stack_few(out, *parts, *(None,) * (_FEW - len(parts)))
    else:
        _stack_columns(tuple(parts), out)
    return out


@njit(cache=True)
def plain_step(actions, noise, advance_args, counters, read_args, judge, waypoints, program, parts):
    """One agent step of a plain single-agent env after its actions are clipped, in one call:
    what :meth:`~pyflyt_engine.batched.env.BatchedUAVEnv.step` does in the separate calls
    below when nothing sits between them (no latency, no noisy sensors, no range sensors, the
    physics through :func:`~pyflyt_engine.batched.kernels.advance`, a compiled reward preset,
    an observation of the state's own arrays).  Each part is the same compiled function the
    separate path calls, in the same order, so the numbers are the same
    (``tests/batched/test_bookkeeping.py``); one call instead of ~10 saves their dispatch and
    the Python between them (``docs/batched.md``, Speed).

    ``actions``: ``(actions, low, high)``, clipped (:func:`clip_rows`) into ``advance_args``'
    setpoints; ``noise``: :func:`~pyflyt_engine.batched.normals.fill_factors`' arguments (the motor noise
    drawn into the factors ``advance_args`` holds), or None; ``advance_args``: those of
    :func:`~pyflyt_engine.batched.kernels.advance`; ``counters``: ``(physics_steps,
    per_agent, steps, episode_length)``, advanced; ``read_args``: those of
    :func:`~pyflyt_engine.batched.kernels.read_out`; ``judge``: ``(goals, last_distance,
    last_position, max_steps, dome2, crash_on_contact, succeeds_at_time_limit, dome_ends,
    complete_ends, time_ends, agent_dt)``, the distance to the goal (:func:`progress`) and the
    ends (:func:`ends`), ``last_distance`` and ``last_position`` updated in place;
    ``waypoints``: None (the goal fixed), or ``(targets, num_reached, reach, deltas, mask)``:
    the progress along them (:func:`waypoint_progress`, instead of :func:`progress`) and the
    next ones into ``deltas`` and ``mask`` (:func:`waypoint_context`, parts of the observation);
    ``program``: :func:`~pyflyt_engine.batched.terms.reward_rows`' preset arrays, then the
    episode returns (added to); ``parts``: the observation's parts (up to 8, None-padded:
    :func:`stack_few`) and the array it is written into.

    Returns ``(reward, terminated, truncated, collision, out_of_bounds, crashed, success,
    complete, done)``, new arrays (``done``: ``terminated | truncated``), and whether an
    episode ended (``done.any()``)."""
    clip_rows(actions[0], actions[1], actions[2], advance_args[9])
    if noise is not None:
        _normals.fill_factors(*noise)
    _kernels.advance(*advance_args)
    physics_steps, per_agent, steps, episode_length = counters
    for i in range(steps.shape[0]):
        physics_steps[i] += per_agent
        steps[i] += 1
        episode_length[i] += 1
    _kernels.read_out(*read_args)
    pos = read_args[0]
    ang_vel_body, ang_pos, lin_vel_body = read_args[4], read_args[5], read_args[6]
    goals, last_distance, last_position, max_steps, dome2, crash_on_contact = judge[:6]
    succeeds_at_time_limit, dome_ends, complete_ends, time_ends, dt = judge[6:]
    n = pos.shape[0]
    if waypoints is None:
        distance, rate = progress(pos, goals, last_distance, dt)
        for i in range(n):
            last_distance[i] = distance[i]
        complete = np.zeros(n, dtype=np.bool_)
        reached = np.zeros(n, dtype=np.bool_)
    else:
        targets, num_reached, reach = waypoints[0], waypoints[1], waypoints[2]
        distance, rate, reached, complete = waypoint_progress(
            pos, last_position, last_distance, targets, num_reached, reach, dt
        )
    for i in range(n):
        last_position[i, 0], last_position[i, 1], last_position[i, 2] = pos[i, 0], pos[i, 1], pos[i, 2]
    contact = advance_args[27]
    collision, out, crashed, terminated, truncated, remaining, success = ends(
        pos,
        contact,
        complete,
        steps,
        max_steps,
        dome2,
        crash_on_contact,
        succeeds_at_time_limit,
        dome_ends,
        complete_ends,
        time_ends,
    )
    terms, params, weights, conditions, negate, episode_return = program
    reward = np.empty(n)
    breakdown = np.empty((terms.shape[0], n))
    _terms.reward_rows(
        terms,
        params,
        weights,
        conditions,
        negate,
        ang_vel_body,
        ang_pos,
        lin_vel_body,
        pos,
        collision,
        collision,
        out,
        crashed,
        complete,
        distance,
        rate,
        reached,
        remaining,
        dt,
        breakdown,
        reward,
    )
    for i in range(n):
        episode_return[i] += reward[i]
    if waypoints is not None:
        waypoint_context(read_args[7], pos, waypoints[0], waypoints[1], waypoints[3], waypoints[4])
    stack_few(*parts)
    done = np.empty(n, dtype=np.bool_)
    ended = False
    for i in range(n):
        done[i] = terminated[i] or truncated[i]
        ended = ended or done[i]
    return reward, terminated, truncated, collision, out, crashed, success, complete, done, ended


__all__ = [
    "clip_rows",
    "distance_rows",
    "ends",
    "episode_ends",
    "plain_step",
    "progress",
    "read_rows",
    "spawn_rows",
    "stack_columns",
    "stack_few",
    "stream_addresses",
    "waypoint_context",
    "waypoint_progress",
    "zero_rows",
    "zero_unless",
]

"""The compiled resets (pyflyt_engine.batched.bookkeeping) against their Python forms, bit for bit.

A reset draws each env's spawn from its own generator through the bit generator's
``next_double`` in compiled code; these tests hold that to ``Task.spawn`` on the same
generators (the same numbers, the generators left in the same state), the row read-outs to
the full ``read_out``, and a whole env's reset to the env-by-env path it replaced.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine import exact
from pyflyt_engine.batched import BatchedUAVEnv, kernels, bookkeeping
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.randomization import SPAWN, Randomizer
from pyflyt_engine.envs.tasks import get_task
from pyflyt_engine.frames import euler_to_quaternion


def _python_spawn(task, rng, offsets=None):
    """What the env did with a spawn before the compiled form: Task.spawn (with ``offsets``,
    the randomiser's spawn offsets added by ``Randomizer.spawn``), the quaternion, the
    velocities turned to the ground frame."""
    spawn = task.spawn(rng)
    position, orientation = spawn.position, spawn.orientation
    if offsets is not None:
        position, orientation = Randomizer.spawn(dict(zip(SPAWN, offsets.tolist())), position, orientation)
    q = euler_to_quaternion(*orientation)
    r = np.empty(9)
    kernels.rotation_rows(q[0], q[1], q[2], q[3], r)
    rot = r.reshape(3, 3).tolist()
    return (
        np.array(position),
        np.array(q),
        np.array(exact.rotate(rot, [float(v) for v in spawn.lin_vel])),
        np.array(exact.rotate(rot, [float(v) for v in spawn.ang_vel])),
    )


@pytest.mark.parametrize("shifted", [False, True])
@pytest.mark.parametrize("position_noise, orientation_noise", [(0.1, 0.1), (0.0, 0.7), (2.5, 0.0), (0.0, 0.0)])
def test_spawn_rows_draw_and_place_as_task_spawn(position_noise, orientation_noise, shifted):
    """Every row equals Task.spawn on the same generator (start pose, noise and a body-frame
    start velocity drawn at random; ``shifted``: plus random spawn offsets per row, as the
    randomiser adds them), and each generator is left where Task.spawn leaves it."""
    rng = np.random.default_rng(0)
    cfg = load_env_config("quadx_hover")
    options = cfg.task.model_copy(
        update={
            "start_position": tuple(rng.uniform(-3, 3, 3)),
            "start_position_noise": position_noise,
            "start_orientation": tuple(rng.uniform(-1, 1, 3)),
            "start_orientation_noise": orientation_noise,
            "start_lin_vel": tuple(rng.uniform(-5, 5, 3)),
        }
    )
    task = get_task("hover")(options, flight_dome_size=cfg.flight_dome_size, agent_hz=cfg.agent_hz)
    n = 40
    seeds = np.random.SeedSequence(9).spawn(n)
    ours = [np.random.default_rng(s) for s in seeds]
    theirs = [np.random.default_rng(s) for s in seeds]
    states, next_double = bookkeeping.stream_addresses(ours)
    index = np.array([3, 0, 17, 39, 5, 22])
    pos, quat, vel, angvel = (
        np.full((n, 3), np.nan),
        np.full((n, 4), np.nan),
        np.full((n, 3), np.nan),
        np.full((n, 3), np.nan),
    )
    for _ in range(3):  # three episodes in a row: the streams move on as Task.spawn's do
        offsets = rng.uniform(-0.5, 0.5, (n, 6))
        bookkeeping.spawn_rows(
            index,
            states,
            next_double,
            np.asarray(options.start_position, dtype=np.float64),
            float(position_noise),
            np.asarray(options.start_orientation, dtype=np.float64),
            float(orientation_noise),
            np.asarray(options.start_lin_vel, dtype=np.float64),
            np.zeros(3),
            pos,
            quat,
            vel,
            angvel,
            offsets,
            shifted,
        )
        for i in index:
            expected = _python_spawn(task, theirs[i], offsets[i] if shifted else None)
            for got, want in zip((pos[i], quat[i], vel[i], angvel[i]), expected):
                assert got.tobytes() == want.tobytes()
    untouched = np.setdiff1d(np.arange(n), index)
    assert np.isnan(pos[untouched]).all()
    for a, b in zip(ours, theirs):
        assert a.bit_generator.state == b.bit_generator.state


def test_stream_addresses_refuses_mixed_bit_generators():
    """Generators of two kinds have two ``next_double``: no compiled draw (the env draws env by env)."""
    assert bookkeeping.stream_addresses([np.random.default_rng(1), np.random.Generator(np.random.MT19937(1))]) is None
    assert bookkeeping.stream_addresses([]) is None
    states, _ = bookkeeping.stream_addresses([np.random.default_rng(1), np.random.default_rng(2)])
    assert states.shape == (2,) and states[0] != states[1]


def test_read_rows_and_distance_rows_are_the_full_forms_on_their_rows():
    rng = np.random.default_rng(2)
    n = 64
    pos, vel, angvel = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 3, rng.normal(size=(n, 3)) * 5
    quat = rng.normal(size=(n, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    full = [np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 4))]
    kernels.read_out(pos, quat, vel, angvel, *full)
    rows = [np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 4))]
    index = np.array([1, 7, 8, 63, 30])
    bookkeeping.read_rows(index, pos, quat, vel, angvel, *rows)
    for a, b in zip(full, rows):
        assert a[index].tobytes() == b[index].tobytes()
        assert not np.delete(b, index, axis=0).any()
    goals = rng.normal(size=(n, 3))
    last_position, last_distance = np.zeros((n, 3)), np.zeros(n)
    bookkeeping.distance_rows(index, pos, goals, last_position, last_distance)
    d = pos - goals
    expected = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
    assert last_distance[index].tobytes() == expected[index].tobytes()
    assert last_position[index].tobytes() == pos[index].tobytes()


@pytest.mark.parametrize("config", ["quadx_hover", "quadx_waypoints", "fixedwing_waypoints"])
def test_an_env_reset_is_the_env_by_env_python_reset(config, monkeypatch):
    """The same env stepped with the compiled spawn and with the env-by-env path (which the
    env takes for generators it cannot draw from in compiled code) gives the same numbers,
    through the autoresets of ended episodes and a seeded reset of every env midway (the
    fixed-wing spawns moving, 14 m/s along its body axis)."""
    runs = []
    for compiled in (True, False):
        env = BatchedUAVEnv(config, num_envs=24, seed=4)
        if not compiled:
            monkeypatch.setattr(env, "_streams", lambda: None)
        obs, _ = env.reset(seed=4)
        rng = np.random.default_rng(1)
        low, high = env.single_action_space.low, env.single_action_space.high
        trail = [obs]
        for t in range(60):
            if t == 30:
                trail.append(env.reset(seed=6)[0])
            obs, reward, terminated, truncated, info = env.step(rng.uniform(low, high, (24, low.size)))
            trail += [obs, reward, terminated, truncated, info.get("final_obs", np.zeros(0))]
        runs.append((trail, env.env_rngs))
    (a, rngs_a), (b, rngs_b) = runs
    if config.startswith("quadx"):  # random rates and thrust crash within the 60 steps: autoresets ran
        assert sum(int(x.any()) for x in a[3:150:5]) > 5
    assert all(x.tobytes() == y.tobytes() for x, y in zip(a, b))
    assert [r.bit_generator.state for r in rngs_a] == [r.bit_generator.state for r in rngs_b]


def test_stack_columns_is_concatenate():
    """The observation's parts side by side: np.concatenate on axis 1, for contiguous parts
    (the compiled copy) and for a strided slice among them (numpy's own)."""
    rng = np.random.default_rng(4)
    parts = [rng.normal(size=(37, k)) for k in (3, 4, 0, 1)]
    got = bookkeeping.stack_columns(parts)
    assert got.dtype == np.float64 and got.flags.c_contiguous
    assert np.array_equal(got, np.concatenate(parts, axis=1))
    strided = [*parts, rng.normal(size=(37, 9))[:, 2:3]]
    assert np.array_equal(bookkeeping.stack_columns(strided), np.concatenate(strided, axis=1))
    assert not np.shares_memory(got, parts[0])
    many = [rng.normal(size=(37, k)) for k in (3, 1, 4, 2, 3, 1, 4, 2, 3, 5)]  # more than 8: a tuple of them
    for count in (1, 6, 8, 9, 10):
        assert np.array_equal(bookkeeping.stack_columns(many[:count]), np.concatenate(many[:count], axis=1)), count
    frozen = parts[1].copy()
    frozen.flags.writeable = False  # another compiled type in the mix: numpy's path
    mixed = [parts[0], frozen]
    assert np.array_equal(bookkeeping.stack_columns(mixed), np.concatenate(mixed, axis=1))


def test_zero_unless_zeroes_exactly_the_rows_that_go_on():
    rng = np.random.default_rng(9)
    table = rng.normal(size=(50, 7))
    table[3, 2] = np.nan  # a NaN in a row that goes on is zeroed too, as the mask assignment does
    done = rng.random(50) < 0.3
    done[3] = False
    expected = table.copy()
    expected[~done] = 0.0
    bookkeeping.zero_unless(table, done)
    assert table.tobytes() == expected.tobytes()

"""The compiled resets (pyflyt_engine.batched.bookkeeping) against their Python forms, bit for bit.

A reset draws each env's spawn from its own generator through the bit generator's
``next_double`` in compiled code; these tests hold that to ``Task.spawn`` on the same
generators (the same numbers, the generators left in the same state), the row read-outs to
the full ``read_out``, and a whole env's reset to the env-by-env path it replaced.
"""

from __future__ import annotations

from pathlib import Path

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


def test_clip_rows_is_numpys_clip_and_gives_the_bound_at_a_tie():
    rng = np.random.default_rng(4)
    low, high = np.array([-1.0, 0.0, -2.0, 0.0]), np.array([1.0, 1.0, 3.0, 0.0])
    actions = rng.uniform(-4.0, 4.0, (300, 4))
    actions[:5] = [np.nan, np.inf, -np.inf, -0.0]
    out = np.empty_like(actions)
    bookkeeping.clip_rows(actions, low, high, out)
    untied = (actions != low) & (actions != high)  # numpy's tie rule differs between its loops
    expected = np.minimum(np.maximum(actions, low), high)
    assert out[untied].tobytes() == expected[untied].tobytes()
    assert np.isnan(out[:5, 0]).all() and (out[:5, 1] == 1.0).all() and (out[:5, 2] == -2.0).all()
    # -0.0 against the bounds 0.0 of the last action (low and high): the bound, +0.0
    assert (out[:5, 3] == 0.0).all() and not np.signbit(out[:5, 3]).any()
    assert ((out >= low) & (out <= high) | np.isnan(out)).all()


def _plain_config(name: str):
    from tests.batched.test_randomization import DRAWS

    cfg = load_env_config("quadx_hover")
    if name == "dryden":
        return cfg.with_overrides(wind={"preset": "dryden_severe", "mean": {"speed": 3.0, "direction": 45.0}})
    if name == "randomized":  # the airframe's and the spawn's draws (an observation delay is latency: not plain)
        return cfg.with_overrides(randomize={k: v for k, v in DRAWS.items() if k != "observation_delay"})
    if name == "battery":  # the modelled motors on a pack, its charge in the observation
        return cfg.with_overrides(uav=str(Path(__file__).parents[2] / "conf/uav/examples/quadx_cf2x_battery.yaml"))
    if name == "ground_effect":
        return cfg.with_overrides(uav="quadx_f450", ground_effect=True)
    if name == "waypoints":
        return load_env_config("quadx_waypoints")
    if name == "waypoints_quaternion":  # the observation's attitude as a quaternion, waypoints close to reach
        return load_env_config("quadx_waypoints").with_overrides(
            angle_representation="quaternion", task={"goal_reach_distance": 0.6}
        )
    return cfg


@pytest.mark.parametrize(
    "name", ["hover", "dryden", "randomized", "battery", "ground_effect", "waypoints", "waypoints_quaternion"]
)
def test_a_plain_step_in_one_call_equals_the_separate_calls(name):
    """A plain env's step (bookkeeping.plain_step: noise, physics, read-out, ends, reward and
    observation in one compiled call) gives what the separate calls give, bit for bit:
    observations, rewards, ends, infos (the last observations and episode statistics of the
    envs that reset along the way) and the state left behind."""
    cfg = _plain_config(name)
    one = BatchedUAVEnv(cfg, num_envs=6, seed=2)
    separate = BatchedUAVEnv(cfg, num_envs=6, seed=2)
    assert one._plain
    separate._plain = False
    rng = np.random.default_rng(8)
    for env in (one, separate):
        env.reset(seed=2)
    ended = 0
    low, high = one.single_action_space.low, one.single_action_space.high
    for _ in range(150):
        action = rng.uniform(1.5 * low - 0.5 * high, 1.5 * high - 0.5 * low, (6, low.size))  # some clipped
        a, b = one.step(action), separate.step(action)
        for x, y in zip(a[:4], b[:4]):
            assert x.tobytes() == y.tobytes()
        assert a[4].keys() == b[4].keys()
        for key in a[4]:
            if key == "episode":
                assert all(a[4][key][k].tobytes() == b[4][key][k].tobytes() for k in ("r", "l"))
            elif isinstance(a[4][key], np.ndarray):
                assert a[4][key].tobytes() == b[4][key].tobytes(), key
        ended += int(np.count_nonzero(a[2] | a[3]))
    assert ended > 3, "episodes ended and reset along the way"
    for attr in (
        "pos",
        "quat",
        "vel",
        "angvel",
        "throttle",
        "actions",
        "physics_steps",
        "steps",
        "episode_return",
        "_last_distance",
    ):
        assert getattr(one, attr).tobytes() == getattr(separate, attr).tobytes(), attr


def test_what_is_not_plain_takes_the_separate_calls():
    """Latency, sensors, the fixed-wing's channels and the velocity mode's cascade are stepped
    by the separate calls (their parts sit between them)."""
    for name in ("quadx_waypoints_velocity", "fixedwing_waypoints", "quadx_hover_sensors"):
        assert not BatchedUAVEnv(load_env_config(name), num_envs=2)._plain, name


def _numpy_waypoint_progress(pos, last_position, last_distance, targets, num_reached, reach, dt):
    """The env's former NumPy form of the waypoints' progress (the reference)."""
    n, k = len(pos), targets.shape[1]
    index = np.arange(n)

    def distance_to_next(reached_count):
        d = pos - targets[index, np.minimum(reached_count, k - 1)]
        return np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])

    all_done = num_reached >= k
    target = targets[index, np.minimum(num_reached, k - 1)]
    distance = distance_to_next(num_reached)
    rate = (distance - last_distance) / dt
    d, p = pos - last_position, target - last_position
    length2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (p[:, 0] * d[:, 0] + p[:, 1] * d[:, 1] + p[:, 2] * d[:, 2]) / length2
    t = np.where(length2 == 0.0, 0.0, np.minimum(np.maximum(t, 0.0), 1.0))
    e = p - t[:, None] * d
    reached = (np.sqrt(e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1] + e[:, 2] * e[:, 2]) < reach) & ~all_done
    counts = num_reached + reached
    complete = reached & (counts >= k)
    new_distance = np.where(reached & ~complete, distance_to_next(counts), distance)
    return np.where(all_done, 0.0, distance), np.where(all_done, 0.0, rate), reached, complete, counts, new_distance


def test_waypoint_progress_is_the_numpy_form():
    """Row by row as the env's former NumPy expressions: the distance and its rate, a target
    reached on the way (the segment's closest point, within the reach), the last one, the
    count and the next distance; including a standing env (a zero-length segment), every
    target already reached, a target passed through and a NaN position."""
    rng = np.random.default_rng(12)
    n, k = 64, 4
    targets = rng.uniform(-2, 2, (n, k, 3))
    last_position = rng.uniform(-2, 2, (n, 3))
    pos = last_position + rng.normal(0, 0.4, (n, 3))
    num_reached = rng.integers(0, k + 1, n)
    pos[0] = last_position[0]  # standing still
    num_reached[1] = k  # all reached before the step
    nxt = np.minimum(num_reached, k - 1)
    pos[2] = 2 * targets[2, nxt[2]] - last_position[2]  # straight through the target
    num_reached[3], pos[3] = k - 1, targets[3, k - 1] + 0.01  # onto the last one
    pos[4] = np.nan
    reach = np.full(n, 0.5)
    last_distance = rng.uniform(0, 3, n)
    expected = _numpy_waypoint_progress(pos, last_position, last_distance, targets, num_reached, reach, 1 / 30)
    counts, distances = num_reached.copy(), last_distance.copy()
    got = bookkeeping.waypoint_progress(pos, last_position, distances, targets, counts, reach, 1 / 30)
    for a, b in zip((*got, counts, distances), expected):
        assert a.tobytes() == b.tobytes()
    assert got[2][2] and got[3][3] and not got[2][1] and not got[2][4]  # passed through; the last; neither


def test_waypoint_context_is_the_numpy_form():
    rng = np.random.default_rng(13)
    n, k, slots = 40, 3, 2
    quaternion = rng.normal(size=(n, 4))
    quaternion /= np.linalg.norm(quaternion, axis=1, keepdims=True)
    pos, targets = rng.normal(size=(n, 3)), rng.normal(size=(n, k, 3))
    num_reached = rng.integers(0, k + 1, n)
    deltas, mask = np.full((n, 3 * slots), 7.0), np.full((n, slots), 7.0)
    bookkeeping.waypoint_context(quaternion, pos, targets, num_reached, deltas, mask)
    r = np.empty((n, 9))
    kernels.rotations(quaternion, r)
    for slot in range(slots):
        j = num_reached + slot
        d = targets[np.arange(n), np.minimum(j, k - 1)] - pos
        body = np.stack(
            [
                r[:, 0] * d[:, 0] + r[:, 3] * d[:, 1] + r[:, 6] * d[:, 2],
                r[:, 1] * d[:, 0] + r[:, 4] * d[:, 1] + r[:, 7] * d[:, 2],
                r[:, 2] * d[:, 0] + r[:, 5] * d[:, 1] + r[:, 8] * d[:, 2],
            ],
            axis=1,
        )
        assert deltas[:, 3 * slot : 3 * slot + 3].tobytes() == np.where((j < k)[:, None], body, 0.0).tobytes()
        assert mask[:, slot].tobytes() == (j < k).astype(np.float64).tobytes()

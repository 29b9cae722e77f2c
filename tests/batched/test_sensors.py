"""Noisy sensors and the estimator on the batched backend (pyflyt_engine.batched.sensors).

Oracles:

* numpy's ``Generator.standard_normal``: the compiled ziggurat draws the same numbers, bit
  for bit, and leaves the bit generator in the same state (the tail beyond ``r = 3.654``,
  taken about once in 3 900 draws, is reached many times in the draws compared);
* the engine's :class:`~pyflyt_engine.components.sensors.SensorSuite` (and its
  :class:`~pyflyt_engine.components.estimator.ComplementaryEstimator`): fed the same true
  states from the same stream state, a compiled row reads the same readings, biases and
  estimate bit for bit at every physics step ("one law per model"; no tolerance: every
  expression is the engine's in the same order of operations, with the same draws);
* the PyBullet env: the same start, actions and sensor stream give the same observations
  and rewards within test_crosscheck.py's bound, 1e-6, derived there for the true state.
  Its derivation carries over: the readings are the true state (differing by ~eps |x| a
  step between the backends) scaled by ``s`` plus noise drawn identically, and the
  estimator is a contraction in its inputs over these 2 s (gains < 1 per fix, the attitude
  filter's time constant 1 s), so its difference stays of the order of the state's.  The
  accelerometer differences the velocity over one physics step, dividing a ~eps |v| difference
  by dt = 1/240 s: ~240 x 2.2e-16 x 1 m/s ~ 5e-14 m/s^2, still far inside the bound.
"""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.batched import BatchedUAVEnv, kernels
from pyflyt_engine.batched import sensors as bs
from pyflyt_engine.batched.model import UnsupportedByBatched
from pyflyt_engine.components.sensors import SensorSuite
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.spec import SensorsSpec

from tests.batched.test_crosscheck import AUTOPILOT_ACTION, BOUND, _flat, quiet  # noqa: F401  (a fixture)

PHYSICS_HZ = 240.0
GRAVITY = 9.81

#: sensor sections covering each branch of the laws: an IMU faster than the physics (several
#: samples a step), one slower, a range that clips, a dropout, a barometer, each alone
SUITES = {
    "fast_imu_fix_baro": {
        "imu": {
            "gyro": {
                "noise_density": 2e-3,
                "bias_random_walk": 1e-3,
                "bias": 0.01,
                "bias_initial_std": 0.02,
                "scale": 1.01,
                "range": 30.0,
                "rate_hz": 1000.0,
            },
            "accel": {
                "noise_density": 2e-2,
                "bias_random_walk": 1e-2,
                "bias_initial_std": 0.1,
                "scale": 0.99,
                "range": 200.0,
                "rate_hz": 1000.0,
            },
        },
        "position": {"noise_std": [0.01, 0.02, 0.03], "rate_hz": 100.0, "dropout": 0.3},
        "barometer": {"noise_std": 0.05, "bias": 0.2, "bias_initial_std": 0.1, "rate_hz": 50.0},
    },
    "slow_clipped_imu": {
        "imu": {
            "gyro": {"noise_density": 1e-2, "bias_random_walk": 1e-2, "range": 0.5, "rate_hz": 100.0},
            "accel": {"noise_density": 1e-1, "range": 3.0, "rate_hz": 70.0},
        },
        "position": {"noise_std": [0.1, 0.1, 0.1], "rate_hz": 240.0},
    },
    "position_only": {"position": {"noise_std": [0.5, 0.0, 0.2], "rate_hz": 7.0, "dropout": 0.5}},
    "barometer_only": {"barometer": {"noise_std": 0.3, "bias_initial_std": 1.0, "rate_hz": 240.0}},
}


class _Gains:
    """An estimator config (EstimatorConfig's fields)."""

    active = True
    k_p, k_i, alpha, beta = 1.5, 0.4, 0.27, 0.043


def _true_states(rng: np.random.Generator, steps: int):
    """A random flight's true states at physics resolution: positions, rotations (rows of a
    unit quaternion), ground-frame velocities and rates, smooth enough to be a flight."""
    q = rng.normal(size=4)
    pos, vel, ang = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    out = []
    r = np.empty(9)
    for _ in range(steps):
        q = q + 0.01 * rng.normal(size=4)
        q /= np.linalg.norm(q)
        vel = vel + 0.05 * rng.normal(size=3)
        ang = ang + 0.2 * rng.normal(size=3)
        pos = pos + vel / PHYSICS_HZ
        kernels.rotation_rows(q[0], q[1], q[2], q[3], r)
        out.append((pos.copy(), r.copy(), vel.copy(), ang.copy(), q.copy()))
    return out


#: (suite, with the estimator): every suite alone, and the estimator on each suite it runs on (an IMU and a fix)
LAW_CASES = [(name, False) for name in sorted(SUITES)] + [
    (name, True) for name in sorted(SUITES) if {"imu", "position"} <= set(SUITES[name])
]


@pytest.mark.parametrize(("name", "estimator"), LAW_CASES)
def test_one_law_per_model(name, estimator):
    """Fed the same true states from the same stream state, the compiled row and the engine's
    SensorSuite (reset twice, as an episode of the env resets it) read the same, bit for bit,
    at every physics step of three episodes; the streams end in the same state."""
    spec = SensorsSpec.model_validate(SUITES[name])
    dt = 1.0 / PHYSICS_HZ
    suite = SensorSuite(spec, dt, GRAVITY, np.random.default_rng(7))
    if estimator:
        suite.attach_estimator(_Gains())
    params = bs.parameters(spec, _Gains() if estimator else None, dt, GRAVITY)
    rng = np.random.default_rng(7)
    suite.reseed(np.random.default_rng(99))
    ours = np.random.default_rng(99)
    states, next_uint64, next_double = bs.stream_interface([ours])
    rows, counts = np.zeros((1, bs.STATE_SIZE)), np.zeros((1, bs.COUNT_SIZE), dtype=np.int64)
    for _episode in range(3):
        flight = _true_states(rng, 300)
        p0, _, v0, _, q0 = flight[0]
        for _ in range(2):
            suite.reset(tuple(p0.tolist()), tuple(v0.tolist()), tuple(q0.tolist()))
        bs.reset_rows(
            np.array([0]), states, next_uint64, next_double, params[None], 2, p0[None], v0[None], q0[None], rows, counts
        )
        for k, (p, r, v, w, _) in enumerate(flight):
            suite.step(tuple(p.tolist()), tuple(r.tolist()), tuple(v.tolist()), tuple(w.tolist()))
            bs.sample_row(params, rows[0], counts[0], k, states[0], next_uint64, next_double, p, r, v, w)
            flat, got = suite.values(), []
            readings = {key: value.tolist() for key, value in _readings(rows[0], params).items()}
            for key in suite.names:
                got += readings[key]
            assert got == flat, (k, suite.names)
            if suite.gyro is not None:
                assert rows[0, bs.S_GYRO_BIAS : bs.S_GYRO_BIAS + 3].tolist() == suite.gyro.bias
                assert rows[0, bs.S_ACCEL_BIAS : bs.S_ACCEL_BIAS + 3].tolist() == suite.accel.bias
            if suite.estimator is not None:
                e = suite.estimator
                assert rows[0, bs.S_EST_Q : bs.S_EST_Q + 4].tolist() == list(e.quaternion), k
                assert rows[0, bs.S_EST_VEL : bs.S_EST_VEL + 3].tolist() == list(e.velocity), k
                assert rows[0, bs.S_EST_POS : bs.S_EST_POS + 3].tolist() == list(e.position), k
                assert rows[0, bs.S_EST_BIAS : bs.S_EST_BIAS + 3].tolist() == list(e.bias), k
        assert (counts[0, bs.C_FIXES], counts[0, bs.C_LOST]) == (suite.fixes, suite.fixes_lost)
        assert ours.bit_generator.state == suite.rng.bit_generator.state
    if spec.position is not None and spec.position.dropout > 0:
        assert suite.fixes_lost > 0  # the dropout branch was taken


def _readings(row: np.ndarray, params: np.ndarray) -> dict[str, np.ndarray]:
    sensors = bs.BatchedSensors.__new__(bs.BatchedSensors)
    sensors.rows, sensors.params = row[None], params
    return sensors.readings(0)


#: env configs flown against the PyBullet env: the shipped estimator config, its sensed
#: variant with a barometer (no estimator), the waypoints task on the sensed pose, a
#: quaternion observation, and latency (the delayed state with the current readings)
_SENSED = {
    "observe": True,
    "imu": SUITES["fast_imu_fix_baro"]["imu"],
    "position": {"noise_std": [0.01, 0.01, 0.01], "rate_hz": 100.0, "dropout": 0.2},
    "barometer": SUITES["fast_imu_fix_baro"]["barometer"],
}
_ESTIMATED = {**_SENSED, "estimator": "complementary"}
FLIGHTS = {
    "estimated": ("quadx_hover_sensors", "quadx_cf2x", {}),
    "estimated_quaternion": ("quadx_hover_sensors", "quadx_cf2x", {"angle_representation": "quaternion"}),
    "sensed_baro": ("quadx_hover", "quadx_cf2x", {"sensors": _SENSED}),
    "sensed_waypoints": ("quadx_waypoints", "quadx_cf2x", {"sensors": _SENSED}),
    "estimated_latency": (
        "quadx_hover_sensors",
        "quadx_cf2x",
        {"latency": {"action_delay": 3 / 240, "observation_delay": 5 / 240}},
    ),
    # the sensors' randomize factors (fixed values, so both envs fly the same): each env's
    # parameter row (test_randomised_sensor_factors_are_the_engines below)
    "sensed_randomized": ("quadx_hover", "quadx_cf2x", {"sensors": _SENSED, "randomize": "_SENSOR_FACTORS"}),
    # a cascade mode (the controller's tick, then a period of physics steps in mode motors)
    "estimated_velocity_mode": ("quadx_waypoints_velocity", "quadx_cf2x", {"sensors": _ESTIMATED}),
    # the fixed-wing on its channels and through its autopilot (the other compiled step)
    "estimated_fixedwing": ("fixedwing_waypoints", "fixedwing", {"sensors": _ESTIMATED}),
    "sensed_fixedwing_autopilot": (
        "fixedwing_waypoints",
        "fixedwing",
        {"sensors": _SENSED, "action": AUTOPILOT_ACTION},
    ),
}


def _fixed(value: float) -> dict[str, object]:
    return {"distribution": "uniform", "low": value, "high": value}


#: every sensor factor of a randomize section, each at a fixed value
SENSOR_FACTORS = {
    "gyro_scale": _fixed(1.3),
    "gyro_noise": _fixed(2.5),
    "accel_scale": _fixed(0.7),
    "accel_noise": _fixed(3.0),
    "position_noise": _fixed(4.0),
}


def _sensor_pair(env_name: str, uav: str, seed: int, **overrides):
    """The PyBullet env and a one-env batched env of the same config at the PyBullet env's
    start, the batched env's sensor stream put where the PyBullet world's was at its reset
    and its sensors reset from there (so both drew their initial biases alike)."""
    if overrides.get("randomize") == "_SENSOR_FACTORS":
        overrides = {**overrides, "randomize": SENSOR_FACTORS}
    cfg = load_env_config(env_name).with_overrides(uav=uav, **overrides)
    pb = make_env(cfg)
    first, _ = pb.reset(seed=seed)
    be = BatchedUAVEnv(cfg, num_envs=1)
    be.reset(seed=seed)
    vehicle = pb.unwrapped.world.vehicles[0]
    from pyflyt_engine.bullet import pybullet as p

    pos, quat = p.getBasePositionAndOrientation(vehicle.body_id, physicsClientId=vehicle._client)
    lin, ang = p.getBaseVelocity(vehicle.body_id, physicsClientId=vehicle._client)
    be.pos[0], be.quat[0], be.vel[0], be.angvel[0] = pos, quat, lin, ang
    if be._waypoints:
        be.targets[0] = pb.unwrapped.task.targets
    be._read()
    index = np.arange(1)
    be._last_position[0] = be.pos[0]
    be._last_distance[0] = be._target_distance(index, be.pos)[0]
    if be.latency is not None:
        be.latency.restart(be, index)
    world = pb.unwrapped.world
    be.sensors.rngs = [world._suite_rng(0)]  # the stream the world gave the suite at its seeded reset
    be.sensors.reset(index, be.pos, be.vel, be.quaternion)
    return pb, be, first


@pytest.mark.parametrize("flight", sorted(FLIGHTS))
def test_observations_match_pybullet(flight, quiet):  # noqa: F811
    """Same start, actions and sensor stream: the batched observation has the PyBullet env's
    layout and space, equals it at the reset, and stays within the cross-check bound over
    2 s of random flight (readings bit for bit would need bit-equal true states)."""
    env_name, uav, overrides = FLIGHTS[flight]
    pb, be, first = _sensor_pair(env_name, quiet[uav], seed=5, **overrides)
    vehicle = pb.unwrapped.world.vehicles[0]
    suite = vehicle.sensors
    assert be.sensor_readings(0).keys() == suite.readings().keys()
    for key, value in suite.readings().items():
        assert be.sensor_readings(0)[key].tolist() == value.tolist(), key
    first = _flat(first)
    assert first.shape == be.single_observation_space.shape
    if not be._waypoints:  # the same Box (a waypoint observation is the flattened Dict)
        assert be.single_observation_space == pb.observation_space
    assert np.max(np.abs(first - be._observe()[0])) < BOUND
    rng = np.random.default_rng(11)
    worst = noise = 0.0
    for step in range(60):
        if be.config.action.mode == "rates_thrust":  # around hover
            action = np.r_[rng.uniform(-0.5, 0.5, 3), be.model.hover_thrust_fraction * rng.uniform(0.97, 1.08)]
        else:
            action = rng.uniform(np.array(be.config.action.low), np.array(be.config.action.high))
        o1, r1, t1, tr1, _ = pb.step(action)
        o2, r2, t2, tr2, info = be.step(action[None])
        final = info["final_obs"][0] if t2[0] or tr2[0] else o2[0]
        worst = max(worst, float(np.max(np.abs(_flat(o1) - final))), abs(r1 - r2[0]))
        noise = max(noise, float(np.max(np.abs(final[:3] - be.ang_vel_body[0]))))  # the rates shown are the gyro's
        assert (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        if t1 or tr1:
            break
    assert worst < BOUND, worst
    assert noise > 1e3 * BOUND  # the observation is the sensors', not the true state
    assert step > 30  # it flew
    print(f"{flight}: worst {worst:.2e}, gyro noise seen {noise:.2e}")


def test_randomised_sensor_factors_are_the_engines(quiet):  # noqa: F811
    """The sensors' ``randomize`` factors set each batched env's parameter row to what the
    engine's randomiser sets on its vehicle's sensors, product for product: the triads' scale,
    white-noise density and bias random walk, the fix's noise per axis; the flight with them
    is ``test_observations_match_pybullet[sensed_randomized]``."""
    pb, be, _ = _sensor_pair("quadx_hover", quiet["quadx_cf2x"], seed=5, sensors=_SENSED, randomize=SENSOR_FACTORS)
    suite = pb.unwrapped.world.vehicles[0].sensors
    row, nominal = be.sensor_params[0], be.sensors.params
    for at, triad, kind in ((bs.P_GYRO, suite.gyro, "gyro"), (bs.P_ACCEL, suite.accel, "accel")):
        assert row[at + 4] == triad.scale and row[at] == triad.noise_density, kind
        assert row[at + 1] == triad.bias_random_walk, kind
        factor = SENSOR_FACTORS[f"{kind}_noise"]["low"]
        assert (
            row[at] == nominal[at] * factor and row[at + 4] == nominal[at + 4] * SENSOR_FACTORS[f"{kind}_scale"]["low"]
        )
    assert row[bs.P_POS_STD : bs.P_POS_STD + 3].tolist() == list(suite.position_noise_std)
    assert (row[bs.P_POS_STD : bs.P_POS_STD + 3] == 4.0 * nominal[bs.P_POS_STD : bs.P_POS_STD + 3]).all()
    # what is not a factor stays the airframe's (rates, ranges, initial biases, the barometer)
    changed = {bs.P_GYRO, bs.P_GYRO + 1, bs.P_GYRO + 4, bs.P_ACCEL, bs.P_ACCEL + 1, bs.P_ACCEL + 4}
    changed |= {bs.P_POS_STD, bs.P_POS_STD + 1, bs.P_POS_STD + 2}
    kept = [k for k in range(bs.PARAMETER_SIZE) if k not in changed]
    assert np.array_equal(row[kept], nominal[kept])
    pb.close()


def test_drawn_sensor_factors_differ_per_env_and_resume_exactly():
    """Drawn per env and episode from each env's generator (the engine's draws: tests of the
    randomiser), the factors give every env its own row, which a checkpoint carries: a restore
    into a fresh batch continues bit for bit."""
    from pyflyt_cli.training.batched import BatchedVecEnv

    drawn = {name: {"distribution": "uniform", "low": 0.5, "high": 2.0} for name in SENSOR_FACTORS}
    cfg = load_env_config("quadx_hover_sensors").with_overrides(randomize=drawn)
    a = BatchedVecEnv(cfg, 3)
    a.env.reset(seed=4)
    rows = a.env.sensor_params
    assert not np.array_equal(rows[0], rows[1]) and not np.array_equal(rows[1], rows[2])
    values = a.env.randomized_values
    names = a.env.randomizer.names
    for i in range(3):
        gyro = values[i, names.index("gyro_noise")]
        assert rows[i, bs.P_GYRO] == a.env.sensors.params[bs.P_GYRO] * gyro
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, (3, 4)) for _ in range(40)]
    for act in actions[:20]:
        a.step(act)
    saved = [a.episode_state(i) for i in range(3)]
    assert all("sensor_params" in state["batched"] for state in saved)
    b = BatchedVecEnv(cfg, 3)
    b.env.reset(seed=999)
    for i in range(3):
        b.restore_episode(i, saved[i])
    assert np.array_equal(a.env.sensor_params, b.env.sensor_params)
    for act in actions[20:]:
        oa, ra, da, _ = a.step(act)
        ob, rb, db, _ = b.step(act)
        assert np.array_equal(oa, ob) and np.array_equal(ra, rb) and np.array_equal(da, db)


def test_resume_is_exact(tmp_path):
    """A checkpoint mid-episode (BatchedVecEnv.episode_state) restored into a fresh env
    continues bit for bit: biases, held readings, sample counts, estimator and sensor streams
    are carried (without them the noise would restart and the observations differ)."""
    from pyflyt_cli.training.batched import BatchedVecEnv

    cfg = load_env_config("quadx_hover_sensors")
    a = BatchedVecEnv(cfg, 3)
    a.env.reset(seed=4)
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, (3, 4)) for _ in range(40)]
    for act in actions[:20]:
        a.step(act)
    saved = [a.episode_state(i) for i in range(3)]
    b = BatchedVecEnv(cfg, 3)
    b.env.reset(seed=999)
    for i in range(3):
        b.restore_episode(i, saved[i])
    assert np.array_equal(a.env._observe(), b.env._observe())
    for act in actions[20:]:
        oa, ra, da, _ = a.step(act)
        ob, rb, db, _ = b.step(act)
        assert np.array_equal(oa, ob) and np.array_equal(ra, rb) and np.array_equal(da, db)
    # and the state carried matters: a restore without the sensors' stream diverges
    c = BatchedVecEnv(cfg, 3)
    c.env.reset(seed=999)
    for i in range(3):
        state = {**saved[i], "rng": {**saved[i]["rng"], "sensors": c.env.sensors.rngs[i].bit_generator.state}}
        c.restore_episode(i, state)
    a2 = BatchedVecEnv(cfg, 3)
    a2.env.reset(seed=999)
    for i in range(3):
        a2.restore_episode(i, saved[i])
    oa, _, _, _ = a2.step(actions[20])
    oc, _, _, _ = c.step(actions[20])
    assert not np.array_equal(oa, oc)


def test_streams_are_per_env_and_seeded():
    """Env i's sensor noise depends on the seed and i alone: env 0 of a 1-env batch reads what
    env 0 of a 3-env batch reads; other envs and other seeds read otherwise."""
    one = BatchedUAVEnv("quadx_hover_sensors", num_envs=1, seed=3)
    three = BatchedUAVEnv("quadx_hover_sensors", num_envs=3, seed=3)
    other = BatchedUAVEnv("quadx_hover_sensors", num_envs=1, seed=4)
    one.reset(seed=3)
    three.reset(seed=3)
    other.reset(seed=4)
    assert np.array_equal(one.sensor_state[0], three.sensor_state[0])
    assert not np.array_equal(three.sensor_state[0], three.sensor_state[1])
    assert not np.array_equal(one.sensor_state[0], other.sensor_state[0])


def test_refusals_and_errors():
    """What stays refused is refused by name; a bad sensors section fails as in the PyBullet engine."""
    from pyflyt_engine.batched import check_supported

    check_supported(load_env_config("quadx_hover_sensors"))  # simulated now
    # and in the multi-agent worlds (tests/batched/test_swarm_sensors.py)
    check_supported(load_env_config("ma_quadx_hover").with_overrides(sensors=_SENSED))
    from pyflyt_engine.paths import uav_dir

    airframe = str(uav_dir() / "examples" / "quadx_cf2x_sensors.yaml")
    check_supported(load_env_config("ma_quadx_hover").with_overrides(uav=airframe))
    BatchedUAVEnv(load_env_config("quadx_hover").with_overrides(uav=airframe))
    with pytest.raises(UnsupportedByBatched, match="range_sensors in a multi-agent world"):  # refused in worlds
        check_supported(
            load_env_config("ma_quadx_hover").with_overrides(
                range_sensors=load_env_config("quadx_obstacles").range_sensors
            )
        )
    bad = load_env_config("quadx_hover").with_overrides(
        sensors={"observe": True, "imu": SUITES["fast_imu_fix_baro"]["imu"], "estimator": "complementary"}
    )
    with pytest.raises(ConfigError, match="sensors.position") as batched:
        BatchedUAVEnv(bad)
    with pytest.raises(ConfigError) as pybullet:
        make_env(bad)
    assert str(batched.value) == str(pybullet.value)
    fast = load_env_config("quadx_hover").with_overrides(sensors={"observe": True, "barometer": {"rate_hz": 1000.0}})
    with pytest.raises(ConfigError, match="sensors.barometer.rate_hz"):
        BatchedUAVEnv(fast)


_FLY = """
import hashlib, numpy as np
from pyflyt_engine.batched import BatchedUAVEnv
env = BatchedUAVEnv("quadx_hover_sensors", num_envs=4, seed=21)
obs, _ = env.reset(seed=21)
digest = hashlib.sha256(obs.tobytes())
rng = np.random.default_rng(1)
for _ in range(30):
    obs = env.step(rng.uniform(-1, 1, (4, 4)))[0]
    digest.update(obs.tobytes())
print(digest.hexdigest())
"""


def test_same_seed_same_numbers_in_another_process():
    """The same seed gives the same sensed, estimated observations bit for bit in a fresh process."""
    import os
    import subprocess
    import sys

    here = {}
    exec(_FLY.replace("print(digest.hexdigest())", "here['digest'] = digest.hexdigest()"), {"here": here})
    from pathlib import Path

    root = str(Path(__file__).resolve().parents[2])  # this checkout's code, whatever is installed
    env = {**os.environ, "PYTHONHASHSEED": "123", "PYTHONPATH": root}
    out = subprocess.run([sys.executable, "-c", _FLY], capture_output=True, text=True, check=True, env=env, cwd=root)
    assert out.stdout.strip() == here["digest"]

"""Noisy sensors (components/sensors.py): the IMU's Allan deviation against its noise
density and bias random walk, saturation, sample-and-hold, dropout, specific force at
rest and in free fall, refusals naming the key, off by default, a flight unchanged by
adding sensors, the observation built from them, and episodes that replay exactly."""

from __future__ import annotations

import hashlib
import math
import os
import subprocess
import sys
import warnings
from pathlib import Path
from types import SimpleNamespace

import gymnasium
import numpy as np
import pytest

import pyflyt_engine.envs  # noqa: F401
from pyflyt_engine.components.sensors import InertialTriad, SensorSuite
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.errors import PyFlytError
from pyflyt_engine.paths import uav_dir
from pyflyt_engine.spec import SensorsSpec, load_uav_spec
from pyflyt_engine.telemetry import RecordEpisode, load_episode, read_mcap, schemas
from pyflyt_engine.telemetry.replay import verify
from pyflyt_engine.world import World

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = str(uav_dir() / "examples" / "quadx_cf2x_sensors.yaml")
ALL = {
    "imu": {"gyro": {"noise_density": 2e-3, "bias_initial_std": 0.01}, "accel": {"noise_density": 2e-2}},
    "position": {"noise_std": [0.05, 0.05, 0.05], "rate_hz": 10.0, "dropout": 0.2},
    "barometer": {"noise_std": 0.1, "bias_initial_std": 0.3},
}


def make(**kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gymnasium.make("PyFlyt/QuadX-Hover-v0", **kwargs)


def _with_sensors(sensors: dict, name: str = "quadx_cf2x"):
    return load_uav_spec({**load_uav_spec(name).model_dump(), "sensors": sensors})


def _triad(**values) -> InertialTriad:
    base = dict(
        noise_density=0.0, bias_random_walk=0.0, bias=0.0, bias_initial_std=0.0, scale=1.0, range=1e9, rate_hz=100.0
    )
    return InertialTriad(SimpleNamespace(**{**base, **values}))


def _stationary(triad: InertialTriad, seconds: float, seed: int) -> np.ndarray:
    """(n, 3) readings of a stationary triad (true value 0), one sample each period."""
    rng = np.random.default_rng(seed)
    triad.reset(rng)
    out = []
    for _ in range(int(seconds * triad.rate_hz)):
        triad.sample((0.0, 0.0, 0.0), 1, rng)
        out.append(triad.reading)
    return np.array(out)


def _adev(series: np.ndarray, rate: float, tau: float) -> tuple[float, int]:
    """Non-overlapping Allan deviation at ``tau`` pooled over the columns, and the number of
    cluster differences it averages."""
    m = int(round(tau * rate))
    k = series.shape[0] // m
    means = series[: k * m].reshape(k, m, -1).mean(axis=1)
    diffs = np.diff(means, axis=0)
    return float(np.sqrt(0.5 * np.mean(diffs**2))), diffs.size


def test_white_noise_density_is_the_allan_deviation_at_one_second():
    # sigma(tau) = N / sqrt(tau) (IEEE Std 952-1997, Annex C): sigma(1 s) = N.  The estimate
    # from M cluster differences has a relative standard deviation ~ 1 / sqrt(2 M); with
    # 3 x 999 differences that is 1.3 %: 5 of them allowed.
    n = 2.4435e-4  # the BMI088's 0.014 deg/s/sqrt(Hz) in rad/s/sqrt(Hz)
    series = _stationary(_triad(noise_density=n), 1000.0, seed=1)
    sigma, count = _adev(series, 100.0, 1.0)
    bound = 5.0 / math.sqrt(2.0 * count)
    assert abs(sigma / n - 1.0) < bound, (sigma, n, bound)
    # and the -1/2 slope: at 0.1 s it is sqrt(10) times larger
    sigma_short, count_short = _adev(series, 100.0, 0.1)
    assert abs(sigma_short / (n / math.sqrt(0.1)) - 1.0) < 5.0 / math.sqrt(2.0 * count_short)


def test_bias_random_walk_shows_its_half_slope_at_long_tau():
    # a bias driven by white noise of density K: sigma(tau) = K sqrt(tau / 3) (the +1/2
    # slope); noise density N adds N^2 / tau to the variance.  At tau = 20 s from 1500 s,
    # 3 x 74 differences, whose random-walk terms are correlated: 20 % allowed (the
    # estimate's relative standard deviation is ~ 5 %, about twice 1 / sqrt(2 M) for
    # random-walk noise).
    n, k = 1e-3, 2e-3
    series = _stationary(_triad(noise_density=n, bias_random_walk=k), 1500.0, seed=2)
    for tau in (5.0, 20.0):
        sigma, _ = _adev(series, 100.0, tau)
        expected = math.sqrt(n * n / tau + k * k * tau / 3.0)
        assert abs(sigma / expected - 1.0) < 0.2, (tau, sigma, expected)
    long, short = _adev(series, 100.0, 20.0)[0], _adev(series, 100.0, 0.05)[0]
    slope_long = math.log(long / _adev(series, 100.0, 5.0)[0]) / math.log(4.0)
    assert 0.3 < slope_long < 0.7, slope_long  # the random walk's +1/2
    assert short > long * 0.5 and _adev(series, 100.0, 0.05)[0] > _adev(series, 100.0, 0.5)[0]  # white noise's -1/2


def test_initial_bias_scale_and_saturation():
    triad = _triad(bias=0.5, bias_initial_std=0.0, scale=1.1, range=2.0)
    rng = np.random.default_rng(0)
    triad.reset(rng)
    triad.sample((1.0, -1.0, 5.0), 1, rng)
    assert triad.reading == (1.1 + 0.5, -1.1 + 0.5, 2.0)  # exact: no noise, the third clipped
    triad.sample((0.0, -9.0, 0.0), 1, rng)
    assert triad.reading[1] == -2.0
    # the initial bias is drawn per reset with the given spread
    biases = []
    spread = _triad(bias_initial_std=0.3)
    for seed in range(400):
        spread.reset(np.random.default_rng(seed))
        biases += spread.bias
    assert abs(float(np.std(biases)) / 0.3 - 1.0) < 5.0 / math.sqrt(2 * len(biases))


def _suite(sensors: dict, physics_hz: float = 240.0) -> SensorSuite:
    suite = SensorSuite(SensorsSpec(**sensors), 1.0 / physics_hz, GRAVITY, np.random.default_rng(3))
    suite.reset((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    return suite


IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


def test_readings_are_held_between_samples_at_the_configured_rate():
    suite = _suite(
        {
            "imu": {"gyro": {"noise_density": 1e-2, "rate_hz": 60.0}, "accel": {"rate_hz": 240.0}},
            "position": {"noise_std": [0.1, 0.1, 0.1], "rate_hz": 10.0},
            "barometer": {"noise_std": 0.1, "rate_hz": 25.0},
        }
    )
    gyro, pos, alt = [], [], []
    for _ in range(240):  # one second of physics at 240 Hz
        suite.step((0.0, 0.0, 1.0), IDENTITY, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        gyro.append(suite.gyro.reading)
        pos.append(suite.position)
        alt.append(suite.altitude)
    changes = lambda xs: sum(a != b for a, b in zip(xs, xs[1:])) + 1  # noqa: E731
    assert (changes(gyro), changes(pos), changes(alt)) == (60, 10, 25)
    assert all(gyro[4 * k] == gyro[4 * k + 3] for k in range(60))  # held for 4 physics steps each


def test_dropout_rate_matches_its_probability_and_holds_the_last_fix():
    p = 0.3
    suite = _suite({"position": {"noise_std": [0.1, 0.1, 0.1], "rate_hz": 240.0, "dropout": p}})
    last, held_ok, n = None, True, 20000
    for step in range(n):
        suite.step((float(step), 0.0, 1.0), IDENTITY, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        if suite.position_valid == 0.0 and last is not None:
            held_ok &= suite.position == last
        last = suite.position
    rate = suite.fixes_lost / suite.fixes
    assert suite.fixes == n and held_ok
    assert abs(rate - p) < 5.0 * math.sqrt(p * (1 - p) / n), rate  # binomial: 5 standard deviations


def test_accelerometer_reads_specific_force_at_rest_and_in_free_fall():
    sensors = {"imu": {"gyro": {}, "accel": {}}}
    # on the ground, motors idle: the ground holds the body up, f = R^T (0, 0, +g) (the body
    # rests a few 1e-5 rad off level on its collision box)
    world = World([dict(uav=_with_sensors(sensors), position=(0.0, 0.0, 0.0), mode="motors")], seed=0)
    world.reset(seed=0)
    for _ in range(30):
        world.step()
    r = np.array(world.vehicles[0].rotation).reshape(3, 3)
    np.testing.assert_allclose(world.vehicles[0].sensors.accel.reading, r.T.dot([0.0, 0.0, GRAVITY]), atol=1e-6)
    world.close()
    # in free fall without drag (no ground): f = 0 (contact forces and gravity cancel out of
    # the velocity difference exactly but for the float round-off)
    world = World(
        [dict(uav=_with_sensors(sensors), position=(0.0, 0.0, 50.0), mode="motors")], seed=0, ground=False, drag=False
    )
    world.reset(seed=0)
    for _ in range(10):
        world.step()
    np.testing.assert_allclose(world.vehicles[0].sensors.accel.reading, (0.0, 0.0, 0.0), atol=1e-9)
    world.close()


def test_gyro_reads_the_body_rates():
    # one physics step per agent step: the sample taken at its start sees the state before it
    world = World(
        [dict(uav=_with_sensors({"imu": {}}), position=(0.0, 0.0, 50.0), mode="motors")],
        seed=0,
        ground=False,
        drag=False,
        agent_hz=240.0,
    )
    world.reset(seed=0)
    vehicle = world.vehicles[0]
    vehicle.reset(ang_vel=(0.3, -0.2, 0.1))
    for _ in range(5):
        before = vehicle.state.ang_vel
        world.step()
        assert vehicle.sensors.gyro.reading == before  # noise-free: exactly the body rates
    assert vehicle.state.ang_vel != before  # and they change (gyroscopic coupling, Izz != Ixx)
    world.close()


@pytest.mark.parametrize(
    ("sensors", "message"),
    [
        ({"imu": {"gyro": {"noise_density": -1.0}}}, r"sensors\.imu\.gyro\.noise_density"),
        ({"imu": {"accel": {"rate_hz": 0.0}}}, r"sensors\.imu\.accel\.rate_hz"),
        ({"imu": {"gyro": {"range": -2.0}}}, r"sensors\.imu\.gyro\.range"),
        ({"position": {"dropout": 1.0}}, r"sensors\.position\.dropout"),
        ({"position": {"noise_std": [0.1, -0.1, 0.1]}}, r"sensors\.position\.noise_std"),
        ({"barometer": {"rate_hz": -5}}, r"sensors\.barometer\.rate_hz"),
        ({"barometer": {"noise": 0.1}}, r"sensors\.barometer\.noise"),
    ],
)
def test_bad_sensor_values_are_refused_naming_the_key(sensors, message):
    with pytest.raises(PyFlytError, match=message):
        _with_sensors(sensors)


def test_a_position_fix_faster_than_the_physics_is_refused():
    with pytest.raises(PyFlytError, match=r"sensors\.position\.rate_hz.*physics"):
        World([dict(uav=_with_sensors({"position": {"rate_hz": 500.0}}))], physics_hz=240.0)


def test_observing_sensors_the_airframe_lacks_is_refused():
    with pytest.raises(PyFlytError, match="sensors.observe"):
        make(sensors={"observe": True})


def test_off_by_default_the_spec_and_config_dump_as_before():
    from pyflyt_engine.envs.config import load_env_config

    assert "sensors" not in load_uav_spec("quadx_cf2x").model_dump(mode="json")
    assert "sensors" not in load_env_config("quadx_hover").model_dump(mode="json")
    env = make()
    vehicle = env.unwrapped.vehicle
    assert vehicle.sensors is None and vehicle.stages["before_loads"] == ()
    env.close()


def _flight(spec, steps: int = 40) -> list[tuple]:
    world = World([dict(uav=spec, position=(0.0, 0.0, 1.0), mode="position_yaw")], seed=5, wind="dryden_light")
    world.reset(seed=5)
    world.set_setpoint(0, [0.3, -0.2, 0.5, 1.4])
    out = []
    for _ in range(steps):
        world.step()
        s = world.state(0)
        out.append((*s.lin_pos, *s.quaternion, *s.lin_vel, *s.ang_vel, *world.aux_state(0).tolist()))
    world.close()
    return out


def test_adding_sensors_leaves_the_flight_bit_identical():
    assert _flight(load_uav_spec(EXAMPLE)) == _flight(load_uav_spec("quadx_cf2x"))


def test_the_observation_is_built_from_the_readings():
    env = make(sensors={**ALL, "observe": True})
    obs, _ = env.reset(seed=4)
    for _ in range(20):
        obs, *_ = env.step(np.array([0.0, 0.0, 0.0, 0.5]))
    base = env.unwrapped
    suite, state = base.vehicle.sensors, base.vehicle.state
    assert obs.shape == base.observation_space.shape == (22,)
    assert tuple(obs[0:3]) == suite.gyro.reading  # body rates: the gyro's
    assert tuple(obs[3:7]) == state.quaternion and tuple(obs[7:10]) == state.lin_vel  # attitude, velocity: true
    assert tuple(obs[10:13]) == (*suite.position[:2], suite.altitude)  # x, y: position fix; z: barometer
    assert obs[-1] == suite.position_valid
    assert tuple(obs[10:13]) != state.lin_pos
    env.close()


def test_gyro_scale_is_randomised():
    env = make(uav=EXAMPLE, randomize={"gyro_scale": {"distribution": "uniform", "low": 0.8, "high": 1.2}})
    _, info = env.reset(seed=0)
    assert env.unwrapped.vehicle.sensors.gyro.scale == info["randomization"]["gyro_scale"]
    env.close()
    with pytest.raises(PyFlytError, match="randomize.gyro_scale: the airframe has no 'sensors.imu'"):
        make(randomize={"gyro_scale": {"distribution": "uniform", "low": 0.8, "high": 1.2}})


def _readings(factor: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gyro, accelerometer and position readings of one seeded episode with every noise
    scaled by ``factor`` through domain randomisation (fixed actions: the flight is the same)."""
    fixed = {"distribution": "uniform", "low": factor, "high": factor}
    names = ("gyro_noise", "accel_noise", "position_noise")
    sensors = {**ALL, "position": {**ALL["position"], "dropout": 0.0}}
    sensors["imu"] = {k: {**v, "bias_random_walk": 1e-3} for k, v in ALL["imu"].items()}
    env = make(sensors=sensors, randomize={name: fixed for name in names})
    _, info = env.reset(seed=5)
    assert [info["randomization"][name] for name in names] == [factor] * 3
    suite, rows = env.unwrapped.vehicle.sensors, []
    for _ in range(30):
        env.step(np.array([0.1, -0.1, 0.0, 0.5]))
        rows.append((suite.gyro.reading, suite.accel.reading, suite.position))
    env.close()
    return tuple(np.array([r[k] for r in rows]) for k in range(3))  # type: ignore[return-value]


def test_sensor_noise_is_randomised_as_a_factor_on_every_noise_term():
    """A reading is scale x truth + bias + noise, with the noise terms (white noise, bias walk,
    position noise) linear in the drawn factor: factors 1, 2, 3 give equally spaced readings."""
    one, two, three = _readings(1.0), _readings(2.0), _readings(3.0)
    for a, b, c in zip(one, two, three):
        step = b - a
        assert np.abs(step).max() > 0.0  # the noise is there and is scaled
        np.testing.assert_allclose(c - b, step, rtol=0, atol=1e-9 * (1 + np.abs(c).max()))
    with pytest.raises(PyFlytError, match="randomize.position_noise: the airframe has no 'sensors.position'"):
        make(
            uav=EXAMPLE,
            sensors={"imu": ALL["imu"]},
            randomize={"position_noise": {"distribution": "uniform", "low": 0.8, "high": 1.2}},
        )


def test_episodes_with_sensors_record_them_and_verify_exactly(tmp_path):
    env = RecordEpisode(make(uav=EXAMPLE, sensors={**ALL, "observe": True}, wind="dryden_light"), tmp_path)
    readings = []
    for episode in range(2):
        env.reset(seed=7 if episode == 0 else None)
        for _ in range(20):
            *_, terminated, truncated, _ = env.step(np.array([0.05, -0.05, 0.0, 0.5]))
            if terminated or truncated:
                break
        readings.append(env.unwrapped.vehicle.sensors.values())
    env.close()
    for path, last in zip(env.paths, readings):
        episode = load_episode(path)
        track = episode.vehicles[0]
        assert track.sensor_layout == [
            ("gyro", 3),
            ("accel", 3),
            ("position", 3),
            ("position_valid", 1),
            ("altitude", 1),
        ]
        assert track.sensors.shape == (len(track.time), 11) and track.sensors[-1].tolist() == last
        result = verify(episode, tolerance=0.0)
        assert result.ok and result.max_deviation == 0.0 and result.per_field["sensors"] == 0.0, result
        jsonschema = pytest.importorskip("jsonschema")
        for message in [m.data for m in read_mcap(path).messages if m.topic == "/uav/0/sensors"][:5]:
            jsonschema.validate(message, schemas.SENSORS)
        tampered = track.sensors.copy()
        tampered[3, 0] += 1e-9
        track.sensors = tampered
        assert verify(episode, tolerance=0.0).worst_field == "uav 0 sensors"


def episode_hash(uav: str) -> str:
    """SHA-256 of the observations and sensor readings of a seeded 30-step episode."""
    warnings.simplefilter("ignore")
    env = gymnasium.make("PyFlyt/QuadX-Hover-v0", uav=uav, sensors={"observe": True})
    h = hashlib.sha256()
    obs, _ = env.reset(seed=9)
    h.update(obs.tobytes())
    for _ in range(30):
        obs, *_ = env.step(np.array([0.1, 0.0, -0.1, 0.45]))
        h.update(obs.tobytes())
        h.update(np.array(env.unwrapped.vehicle.sensors.values()).tobytes())
    env.close()
    return h.hexdigest()


def test_a_seeded_episode_is_bit_identical_across_processes():
    code = f"from tests.components.test_sensors import episode_hash; print(episode_hash({str(EXAMPLE)!r}))"
    other = subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert other.returncode == 0, other.stderr[-2000:]
    assert other.stdout.strip().splitlines()[-1] == episode_hash(str(EXAMPLE))


@pytest.mark.parametrize("env_id", ["PyFlyt/QuadX-Hover-v0", "PyFlyt/QuadX-Waypoints-v0"])
@pytest.mark.parametrize("angles", ["euler", "quaternion"])
def test_the_sensor_observation_passes_the_env_checkers(env_id, angles):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    from pyflyt_engine.envs.wrappers import FlattenWaypointEnv

    options = dict(uav=EXAMPLE, sensors={"observe": True}, angle_representation=angles)
    env = gymnasium.make(env_id, **options)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*symmetric and normalized.*")
        warnings.filterwarnings("ignore", message=".*infinity.*")
        check_env(env.unwrapped, skip_render_check=True)
    env.close()
    env = gymnasium.make(env_id, **options)
    if env_id.endswith("Waypoints-v0"):
        env = FlattenWaypointEnv(env, context_length=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*(symmetric|float32|float64).*")
        sb3_check_env(env, warn=True)
    env.close()

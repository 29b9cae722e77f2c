"""The flight controller's state estimator (pyflyt_engine/components/estimator.py) against
analytic oracles: the complementary filter's first-order tilt decay and bias recovery, the
position-velocity filter's ramp tracking and step response, the gains against the Riccati
fixed point; and the env option ``sensors.estimator`` end to end."""

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
from pyflyt_engine.components.estimator import ComplementaryEstimator, alpha_beta_gains, quaternion_to_euler
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.envs.config import EnvSensorsConfig
from pyflyt_engine.errors import PyFlytError
from pyflyt_engine.frames import euler_to_quaternion, quaternion_to_rows
from pyflyt_engine.paths import uav_dir
from pyflyt_engine.telemetry import RecordEpisode, load_episode, read_mcap, schemas
from pyflyt_engine.telemetry.replay import verify

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = str(uav_dir() / "examples" / "quadx_cf2x_sensors.yaml")
#: noiseless sensors: the estimator's errors are its own dynamics only
PERFECT = {"imu": {"gyro": {"rate_hz": 1000.0}, "accel": {"rate_hz": 1000.0}}, "position": {"rate_hz": 100.0}}
POSITION_HOLD = {"mode": "position_yaw", "names": ["x", "y", "yaw", "z"], "low": [-2, -2, -3, 0], "high": [2, 2, 3, 2]}


def make(**kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gymnasium.make("PyFlyt/QuadX-Hover-v0", **kwargs)


def _estimator(k_p=1.0, k_i=0.0, alpha=0.3, beta=0.05, gyro_hz=1000.0, fix_hz=100.0) -> ComplementaryEstimator:
    return ComplementaryEstimator(SimpleNamespace(k_p=k_p, k_i=k_i, alpha=alpha, beta=beta), gyro_hz, fix_hz, GRAVITY)


def _up_angle(q_true, q_est) -> float:
    """Angle between the true and the estimated "up" seen in the body frame [rad]."""
    a = quaternion_to_rows(q_true)[2]
    b = quaternion_to_rows(q_est)[2]
    return math.atan2(math.hypot(*np.cross(a, b)), float(np.dot(a, b)))


def _specific_force_at_rest(q) -> tuple[float, float, float]:
    r = quaternion_to_rows(q)
    return tuple(GRAVITY * r[2][k] for k in range(3))  # R^T (0, 0, g)


# ------------------------------------------------------------ attitude filter


@pytest.mark.parametrize("tilt", [(0.3, 0.0, 0.0), (0.0, -0.5, 0.0), (0.4, 0.6, 1.0), (1.2, -0.3, -2.0)])
def test_tilt_error_decays_first_order_with_time_constant_one_over_k_p(tilt):
    """Held at a fixed tilt with a true gyro (zero) and accelerometer, started level: the
    angle e between true and estimated "up" obeys e' = -k_P sin e, so
    tan(e/2) = tan(e0/2) exp(-k_P t); per sample exactly e <- e - k_P T sin e."""
    k_p, rate = 2.0, 1000.0
    q = euler_to_quaternion(*tilt)
    est = _estimator(k_p=k_p, gyro_hz=rate)
    est.reset(euler_to_quaternion(0.0, 0.0, tilt[2]), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    f = _specific_force_at_rest(q)
    e0 = _up_angle(q, est.quaternion)
    e_discrete = e0
    for k in range(1, 3001):
        est.imu((0.0, 0.0, 0.0), f)
        e_discrete -= k_p / rate * math.sin(e_discrete)
        if k % 250 == 0:
            e = _up_angle(q, est.quaternion)
            assert e == pytest.approx(e_discrete, rel=1e-9, abs=1e-12)
            continuous = 2.0 * math.atan(math.tan(e0 / 2.0) * math.exp(-k_p * k / rate))
            # the discretisation: the decay rate is off by O(k_P T), i.e. k_P^2 T t in the log
            assert e == pytest.approx(continuous, rel=k_p * k_p * (k / rate) / rate)
    roll, pitch, _ = est.euler
    left = 2.0 * e0 * math.exp(-k_p * 3.0)  # three seconds: six time constants
    assert roll == pytest.approx(tilt[0], abs=left) and pitch == pytest.approx(tilt[1], abs=left)


def test_a_constant_gyro_bias_is_learnt_and_the_tilt_error_vanishes():
    """Level and still, gyro bias b: the linearised roll and pitch errors obey
    e'' + k_P e' + k_I e = 0 with e(0) = 0, e'(0) = -b; at k_I = k_P^2 / 4 (critical)
    e(t) = -b t exp(-k_P t / 2).  The bias about x and y is recovered; the one about the
    vertical is unobservable from gravity: yaw drifts at b_z."""
    k_p, k_i, rate = 1.0, 0.25, 1000.0
    f = (0.0, 0.0, GRAVITY)
    for axis in (0, 1):  # one axis at a time: the linearised error of that angle alone
        b = (0.004, 0.0, 0.0) if axis == 0 else (0.0, -0.003, 0.0)
        est = _estimator(k_p=k_p, k_i=k_i, gyro_hz=rate)
        est.reset((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
        for k in range(1, 12001):
            est.imu(b, f)
            if k % 1000 == 0:
                t = k / rate
                oracle = -b[axis] * t * math.exp(-k_p * t / 2.0)  # true minus estimated angle
                assert -est.euler[axis] == pytest.approx(oracle, rel=5e-3, abs=1e-6 * abs(b[axis]))
    b = (0.004, -0.003, 0.01)
    est = _estimator(k_p=k_p, k_i=k_i, gyro_hz=rate)
    est.reset((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    for _ in range(60000):
        est.imu(b, f)
    roll, pitch, yaw = est.euler
    assert abs(roll) < 1e-9 and abs(pitch) < 1e-9  # steady-state error -> 0
    assert est.bias[0] == pytest.approx(b[0], abs=1e-9) and est.bias[1] == pytest.approx(b[1], abs=1e-9)
    assert est.bias[2] == 0.0
    assert yaw == pytest.approx(b[2] * 60.0, rel=1e-6)  # yaw has no reference: it drifts with the bias


def test_without_specific_force_the_gyro_is_integrated_alone():
    est = _estimator(k_p=5.0, k_i=1.0)
    est.reset((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    for _ in range(500):
        est.imu((0.0, 0.0, 0.2), (0.0, 0.0, 0.0))
    assert est.euler[2] == pytest.approx(0.1, rel=1e-12) and est.bias == (0.0, 0.0, 0.0)


def test_euler_angles_match_the_frames_convention():
    rng = np.random.default_rng(0)
    for roll, pitch, yaw in rng.uniform([-3, -1.5, -3], [3, 1.5, 3], (50, 3)):
        back = quaternion_to_euler(euler_to_quaternion(roll, pitch, yaw))
        assert back == pytest.approx((roll, pitch, yaw), abs=1e-12)


# ------------------------------------------------------------ velocity filter


def _riccati_gains(lam: float) -> tuple[float, float]:
    """Steady-state Kalman gains of the DWNA model (T = 1, sigma_p = 1, sigma_a = lam) by
    iterating the Riccati recursion."""
    q = lam * lam * np.array([[0.25, 0.5], [0.5, 1.0]])
    f = np.array([[1.0, 1.0], [0.0, 1.0]])
    p = np.eye(2)
    for _ in range(20000):
        m = f @ p @ f.T + q
        k = m[:, 0] / (m[0, 0] + 1.0)
        p = m - np.outer(k, m[0, :])
    return float(k[0]), float(k[1])


@pytest.mark.parametrize("lam", [0.01, 0.05, 0.5, 3.0])
def test_default_gains_are_the_steady_state_kalman_gains(lam):
    alpha, beta = alpha_beta_gains(lam)
    assert (alpha, beta) == pytest.approx(_riccati_gains(lam), rel=1e-9)
    assert beta == pytest.approx(2.0 * (2.0 - alpha) - 4.0 * math.sqrt(1.0 - alpha), rel=1e-9)
    config = EnvSensorsConfig(estimator="complementary").estimator
    assert (config.alpha, config.beta) == alpha_beta_gains(0.05)


def _run(est, truth, seconds, gyro_hz=1000.0, fix_hz=100.0, accel=(0.0, 0.0, 0.0)):
    """Feed a level, non-rotating estimator: every gyro sample the specific force of
    ``accel``, every ``gyro_hz / fix_hz`` samples the fix ``truth(t)``; the position
    errors (estimate - truth) just before each fix."""
    every = round(gyro_hz / fix_hz)
    f = (accel[0], accel[1], accel[2] + GRAVITY)
    errors = []
    for k in range(1, round(seconds * gyro_hz) + 1):
        est.imu((0.0, 0.0, 0.0), f)
        if k % every == 0:
            t = k / gyro_hz
            p = truth(t)
            errors.append([est.position[i] - p[i] for i in range(3)] + [est.velocity[i] for i in range(3)])
            est.fix(p)
    return np.array(errors)


def test_constant_velocity_is_tracked_with_zero_steady_state_error():
    v = (0.8, -0.5, 0.3)
    est = _estimator(alpha=0.2708671189926285, beta=0.042694639037219054)
    est.reset((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0))  # starts at rest: a velocity step
    errors = _run(est, lambda t: (v[0] * t, v[1] * t, 1.0 + v[2] * t), 6.0)
    assert np.abs(errors[-1, :3]).max() < 1e-9
    assert errors[-1, 3:] == pytest.approx(v, abs=1e-9)
    # a constant vertical acceleration the accelerometer measures is tracked too
    est.reset((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    a = (0.0, 0.0, -0.2)
    errors = _run(est, lambda t: (0.0, 0.0, 1.0 + 0.5 * a[2] * t * t), 6.0, accel=a)
    assert np.abs(errors[-1, :3]).max() < 1e-8


def test_a_constant_acceleration_error_leaves_the_analytic_steady_state_offsets():
    """Estimated acceleration off by d (truth at rest): the fixed point of the error
    recursion is, just before a fix, position d T^2 / beta and velocity d T (alpha / beta + 1/2)."""
    d, fix_hz, alpha, beta = 0.3, 100.0, 0.2708671189926285, 0.042694639037219054
    est = _estimator(alpha=alpha, beta=beta, fix_hz=fix_hz)
    est.reset((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    errors = _run(est, lambda t: (0.0, 0.0, 1.0), 8.0, fix_hz=fix_hz, accel=(0.0, 0.0, d))
    period = 1.0 / fix_hz
    assert errors[-1, 2] == pytest.approx(d * period**2 / beta, rel=1e-6)
    assert errors[-1, 5] == pytest.approx(d * period * (alpha / beta + 0.5), rel=1e-6)


def test_a_sustained_horizontal_acceleration_tilts_the_estimate_toward_the_specific_force():
    """The accelerometer measures specific force, not gravity: held level while accelerating
    at a_x, the filter settles where its "up" is along f, a pitch of -atan(a_x / (g + a_z))."""
    a = (0.4, 0.0, -0.2)
    est = _estimator(k_p=1.0, k_i=0.0)
    est.reset((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    for _ in range(20000):
        est.imu((0.0, 0.0, 0.0), (a[0], a[1], a[2] + GRAVITY))
    assert est.euler[1] == pytest.approx(-math.atan2(a[0], GRAVITY + a[2]), rel=1e-6)


@pytest.mark.parametrize("alpha, beta", [(0.2708671189926285, 0.042694639037219054), (0.5, 0.2), (0.9, 0.9)])
def test_the_step_response_is_the_gains_analytic_response(alpha, beta):
    """Position estimate off by d at rest: just before fix k the error is
    c1 z1^k + c2 z2^k, the roots of z^2 - (2 - alpha - beta) z + (1 - alpha)."""
    d, fix_hz = 0.7, 100.0
    est = _estimator(alpha=alpha, beta=beta, fix_hz=fix_hz)
    est.reset((0.0, 0.0, 0.0, 1.0), (d, 0.0, 1.0), (0.0, 0.0, 0.0))
    errors = _run(est, lambda t: (0.0, 0.0, 1.0), 1.0, fix_hz=fix_hz)[:, 0]
    b, c = 2.0 - alpha - beta, 1.0 - alpha
    root = (b * b - 4.0 * c + 0j) ** 0.5
    z1, z2 = (b + root) / 2.0, (b - root) / 2.0
    # e[1] (after the first fix at t = T) = d, e[2] = (1 - alpha - beta) d
    e1, e2 = d, (1.0 - alpha - beta) * d
    c2 = (e2 - z1 * e1) / (z2 - z1)
    c1 = e1 - c2
    for k, e in enumerate(errors[:60]):
        oracle = (c1 * z1**k + c2 * z2**k).real
        assert e == pytest.approx(oracle, abs=1e-12 * d)
    assert abs(errors[-1]) < 1e-3 * d


# ---------------------------------------------------------------------- config


@pytest.mark.parametrize(
    "sensors, message",
    [
        ({"observe": False, "estimator": "complementary"}, "sensors.observe"),
        ({"estimator": "kalman"}, "complementary"),
        ({"estimator": {"type": "complementary", "k_p": 0.0}}, "k_p"),
        ({"estimator": {"type": "complementary", "alpha": -0.1}}, "alpha"),
        ({"estimator": {"type": "complementary", "gain": 1.0}}, "gain"),
        ({"estimator": {"type": "complementary", "alpha": 1.5, "beta": 1.2}}, "2 alpha + beta < 4"),
        ({"estimator": {"type": "none", "k_p": 2.0}}, "type: complementary"),
        ({"position": {"rate_hz": 10.0}, "estimator": "complementary"}, "sensors.imu"),
        ({"imu": {}, "estimator": "complementary"}, "sensors.position"),
    ],
)
def test_bad_estimator_configs_are_refused_naming_the_key(sensors, message):
    with pytest.raises(PyFlytError, match=message.replace("+", r"\+")) as info:
        make(sensors=sensors)
    assert "sensors" in str(info.value)


def test_off_by_default_observations_and_dump_are_unchanged():
    assert "estimator" not in EnvSensorsConfig(observe=True).model_dump()
    assert "estimator" not in EnvSensorsConfig(estimator="none").model_dump()
    runs = []
    for sensors in ({"observe": True}, {"observe": True, "estimator": "none"}):
        env = make(uav=EXAMPLE, sensors=sensors)
        obs, _ = env.reset(seed=4)
        out = [obs.tobytes()]
        for _ in range(10):
            out.append(env.step(np.array([0.1, -0.1, 0.0, 0.4]))[0].tobytes())
        assert env.unwrapped.estimator is None
        env.close()
        runs.append(out)
    assert runs[0] == runs[1]


# ------------------------------------------------------------------------- env


def test_the_observation_is_the_estimate_and_the_truth_stays_in_the_state():
    env = make(uav=EXAMPLE, sensors={"observe": True, "estimator": "complementary"}, angle_representation="euler")
    obs, _ = env.reset(seed=2)
    base = env.unwrapped
    for _ in range(15):
        obs, *_ = env.step(np.array([0.2, -0.1, 0.1, 0.45]))
    est = base.estimator
    r = quaternion_to_rows(est.quaternion)
    body_velocity = [sum(r[i][k] * est.velocity[i] for i in range(3)) for k in range(3)]
    assert obs[:3].tolist() == list(base.vehicle.sensors.gyro.reading)
    assert obs[3:6].tolist() == list(est.euler)
    assert obs[6:9].tolist() == pytest.approx(body_velocity, abs=1e-15)
    assert obs[9:12].tolist() == list(est.position)
    truth = base.state
    assert obs[3:6].tolist() != list(truth.ang_pos) and obs[6:9].tolist() != list(truth.lin_vel)
    assert np.abs(obs[3:5] - truth.ang_pos[:2]).max() < 0.05  # a useful estimate
    env.close()


def test_hovering_the_tilt_estimate_converges_with_the_gains_time_constant():
    """A hovering vehicle (the position controller flies the true state), noiseless IMU,
    the estimate knocked 0.3 rad off in roll once it hovers: the tilt error decays as
    tan(e/2) = tan(e0/2) exp(-k_P t) up to the hover's small accelerations."""
    k_p = 2.0
    env = make(
        sensors={**PERFECT, "observe": True, "estimator": {"type": "complementary", "k_p": k_p, "k_i": 0.0}},
        action=POSITION_HOLD,
        start_orientation_noise=0.0,
        start_position_noise=0.0,
    )
    env.reset(seed=0)
    for _ in range(30):  # one second to settle into the hover
        env.step(np.array([0.0, 0.0, 0.0, 1.0]))
    base = env.unwrapped
    est = base.estimator
    roll, pitch, yaw = quaternion_to_euler(base.state.quaternion)
    est.reset(euler_to_quaternion(roll + 0.3, pitch, yaw), est.position, est.velocity)
    e0 = _up_angle(base.state.quaternion, est.quaternion)
    apparent = 0.0  # largest angle between the specific force and the true "up": the hover's accelerations
    for k in range(1, 46):
        env.step(np.array([0.0, 0.0, 0.0, 1.0]))
        f = base.vehicle.sensors.accel.reading
        up = quaternion_to_rows(base.state.quaternion)[2]
        apparent = max(apparent, math.atan2(math.hypot(*np.cross(f, up)), float(np.dot(f, up))))
        if k % 15 == 0:
            t = k / 30.0
            e = _up_angle(base.state.quaternion, est.quaternion)
            oracle = 2.0 * math.atan(math.tan(e0 / 2.0) * math.exp(-k_p * t))
            assert e == pytest.approx(oracle, rel=0.01, abs=apparent)
    assert apparent < 0.05  # a hover (2 % motor noise): the accelerometer is nearly a gravity reference
    env.close()


def episode_hash(uav: str) -> str:
    """SHA-256 of the observations and estimates of a seeded 30-step episode."""
    warnings.simplefilter("ignore")
    env = gymnasium.make("PyFlyt/QuadX-Hover-v0", uav=uav, sensors={"observe": True, "estimator": "complementary"})
    h = hashlib.sha256()
    obs, _ = env.reset(seed=9)
    h.update(obs.tobytes())
    for _ in range(30):
        obs, *_ = env.step(np.array([0.1, 0.0, -0.1, 0.45]))
        h.update(obs.tobytes())
        h.update(np.array(env.unwrapped.estimator.values()).tobytes())
    env.close()
    return h.hexdigest()


def test_a_seeded_episode_is_bit_identical_across_processes():
    code = f"from tests.components.test_estimator import episode_hash; print(episode_hash({EXAMPLE!r}))"
    other = subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert other.returncode == 0, other.stderr[-2000:]
    first = episode_hash(EXAMPLE)
    assert other.stdout.strip().splitlines()[-1] == first
    assert episode_hash(EXAMPLE) == first  # and again after a reset in the same process


def test_episodes_record_the_estimate_and_verify_exactly(tmp_path):
    env = RecordEpisode(make(uav=EXAMPLE, sensors={"observe": True, "estimator": "complementary"}), tmp_path)
    env.reset(seed=5)
    for _ in range(20):
        *_, terminated, truncated, _ = env.step(np.array([0.05, -0.05, 0.0, 0.14]))
        assert not (terminated or truncated)
    last = env.unwrapped.estimator.values()
    env.close()
    episode = load_episode(env.paths[0])
    track = episode.vehicles[0]
    assert set(track.estimate) == {"quaternion", "ang_pos", "lin_vel_ground", "lin_pos", "gyro_bias"}
    assert np.concatenate([track.estimate[k][-1] for k in track.estimate]).tolist() == last
    result = verify(episode, tolerance=0.0)
    assert result.ok and result.per_field["estimate"] == 0.0, result
    jsonschema = pytest.importorskip("jsonschema")
    for message in [m.data for m in read_mcap(env.paths[0]).messages if m.topic == "/uav/0/estimate"][:5]:
        jsonschema.validate(message, schemas.ESTIMATE)
    tampered = track.estimate["lin_pos"].copy()
    tampered[4, 1] += 1e-9
    track.estimate["lin_pos"] = tampered
    assert verify(episode, tolerance=0.0).worst_field == "uav 0 estimate"


@pytest.mark.parametrize("env_id", ["PyFlyt/QuadX-Hover-v0", "PyFlyt/QuadX-Waypoints-v0"])
@pytest.mark.parametrize("angles", ["euler", "quaternion"])
def test_the_estimated_observation_passes_the_env_checkers(env_id, angles):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    from pyflyt_engine.envs.wrappers import FlattenWaypointEnv

    options = dict(uav=EXAMPLE, sensors={"observe": True, "estimator": "complementary"}, angle_representation=angles)
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

"""The batched backend flies what the PyBullet engine flies: same airframe, mode, start and
actions give the same trajectory, observations and rewards within a stated bound.

The bound, and why it is not zero: the rigid body is integrated by the same scheme as
PyBullet's (semi-implicit Euler, exponential-map attitude, Bullet's limits: see
:mod:`pyflyt_engine.batched.kernels`) and every law is the engine's own (``test_laws.py``),
so the two agree in exact arithmetic.  PyBullet computes in the body frame and rotates
back, and reports the attitude through its rotation matrix, so the last bits differ at
each step (~1e-16); the mixer's square root amplifies such a difference where a motor
idles near zero thrust (``sqrt(f)`` at ``f ~ 1e-20``).  Over 2 s of random flight the
largest position difference measured is ~1e-9 m (hexacopter) and ~1e-15 m (the quads);
the tests hold it to 1e-6 m, and observations and rewards to 1e-6.

The fixed-wing (mode ``channels``: motors and flaps routed from the channels, the lifting
surfaces, body drag; and mode ``attitude_airspeed``, its autopilot writing the channels)
is held to the same bound, derived for it: every law is bit for bit
the engine's (``test_laws.py``), so the two differ only by the rigid body's last bits,
at most ~eps |x| per physics step with eps = 2.2e-16 and |x| <= ~100 m (positions and the
observation's waypoint deltas): ~2.2e-14 per step.  A difference made at one step grows
with the flight's sensitivity to its state: a 1e-9 nudge of the spawn's position,
velocity or rates grows at most 22-fold over 2 s of these random actions (measured, 8
seeds, both fixed-wings: experiments/batched_fixedwing_sensitivity.py; 5.5-fold under the
autopilot), so 480 steps give at most 480 x 2.2e-14 x 22 ~ 2.3e-10, well
inside 1e-6.  Only an angle of attack within that much of a stall angle would flip the
profile's branch (its abrupt stall) and break the bound; over random flight that has a
probability of order 1e-10 per surface and step.  Measured over 2 s of random actions on
the whole action range (the test's seeds): positions within 9e-15 m, observations within
1.3e-13 (the waypoint deltas, ~100 m), rewards within 1.1e-14, dense and sparse, either mode.

The multirotor modes above the rate loop (rates_z, attitude, heading-velocity, velocity and
position modes: the controller's outer loops, bit for bit the engine's in ``test_modes.py``)
are held to the same bound, derived for them: the two backends start each control tick
from states whose last bits differ (~eps |x|), and the loops are continuous in the state
except where the mixer's square root meets a motor asked for almost no thrust: a force
``f`` computed with an error of ~eps f_max gives throttles ``sqrt(f / f_max)`` that differ
by up to ``sqrt(eps) ~ 1.5e-8``.  That difference enters the lagging throttle (at most
itself) and the thrust as ``2 x dx f_max`` <= 3e-8 f_max for one tick; were every tick of the
2 s to push the same way, the position would move by at most ``3e-8 (f_max / m) t^2 / 2``
~ 3e-8 x 5 m/s^2 x 2 s^2 ~ 3e-7 m for these airframes (f_max / m <= ~5 m/s^2 per motor),
within 1e-6; the throttles in the observation differ by at most the 1.5e-8 itself.  (The
velocity loop's conditional integration and window and the tilt's limits switch
discontinuously, but only where a value lies within its last bits of the switch:
probability ~1e-15 per tick.)  Measured over 2 s of random setpoints for every airframe
and mode (the test's seeds): motor commands within 1.3e-8, positions within 3.5e-10 m,
observations within 6.8e-9 (the throttles and body rates), rewards within 6.5e-11, the
velocity and rate integrals within 9e-10; about a third of the cases stay at ~1e-15
throughout (no motor near zero thrust); experiments/batched_modes_crosscheck.py prints
them per airframe and mode.

Ground contact: the batched backend crashes when the collision geometry's lowest point is
below the ground at the PyBullet engine's contact samples; PyBullet reports a contact
from its contact threshold on, so the crash step may come one agent step earlier there.
"""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
import yaml

from pyflyt_engine.batched import BatchedUAVEnv, check_supported
from pyflyt_engine.batched.model import UnsupportedByBatched, batched_model
from pyflyt_engine.batched import kernels
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.paths import uav_dir
from pyflyt_engine.spec import load_uav_spec
from pyflyt_engine.urdf import urdf_path

from tests.batched.test_laws import FIXEDWINGS, FLOWN, MULTIROTORS

BOUND = 1e-6


@pytest.fixture(scope="module")
def quiet(tmp_path_factory):
    """Each flown airframe with its motor noise off (the two backends draw their noise apart)."""
    folder = tmp_path_factory.mktemp("quiet")
    paths = {}
    for name in FLOWN:
        data = yaml.safe_load((uav_dir() / f"{name}.yaml").read_text())
        data["motors"]["noise_ratio"] = 0.0
        path = folder / f"{name}.yaml"
        path.write_text(yaml.safe_dump(data))
        paths[name] = str(path)
    return paths


@pytest.mark.parametrize("name", FLOWN)
def test_the_free_body_integrates_as_pybullet(name):
    """Random body-frame wrenches for 2 s on a spinning, moving body: position, attitude and
    velocities within 1e-12 of PyBullet's."""
    spec = load_uav_spec(name)
    model = batched_model(spec, 1 / 240, 1 / 120)
    cid = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        p.setTimeStep(1 / 240, physicsClientId=cid)
        body = p.loadURDF(
            str(urdf_path(spec)),
            [0, 0, 5],
            p.getQuaternionFromEuler([0.3, -0.2, 1.0]),
            flags=p.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=cid,
        )
        p.changeDynamics(body, -1, linearDamping=0.0, angularDamping=0.0, physicsClientId=cid)
        p.resetBaseVelocity(body, [1.0, -2.0, 0.5], [3.0, -5.0, 8.0], physicsClientId=cid)
        pos, quat = (np.array(v, dtype=np.float64) for v in p.getBasePositionAndOrientation(body, physicsClientId=cid))
        vel, ang = (np.array(v, dtype=np.float64) for v in p.getBaseVelocity(body, physicsClientId=cid))
        scale = model.mass * 9.81
        rng = np.random.default_rng(0)
        r, q = np.empty(9), np.empty(4)
        for _ in range(480):
            load = np.r_[rng.normal(0, scale, 3), rng.normal(0, 20.0, 3) * model.inertia]  # ~20 rad/s^2
            p.applyExternalForce(body, -1, load[:3].tolist(), [0, 0, 0], p.LINK_FRAME, physicsClientId=cid)
            p.applyExternalTorque(body, -1, load[3:].tolist(), p.LINK_FRAME, physicsClientId=cid)
            p.stepSimulation(cid)
            kernels.rotation_rows(*quat, r)
            kernels.integrate(pos, quat, vel, ang, r, load, model.mass, model.inertia, 9.81, 1 / 240)
        expected_pos, expected_quat = p.getBasePositionAndOrientation(body, physicsClientId=cid)
        expected_vel, expected_ang = p.getBaseVelocity(body, physicsClientId=cid)
        kernels.rotation_rows(*quat, r)
        kernels.matrix_quaternion(r, q)
        for got, expected in ((pos, expected_pos), (q, expected_quat), (vel, expected_vel), (ang, expected_ang)):
            assert np.max(np.abs(got - np.asarray(expected))) < 1e-12
        assert np.linalg.norm(ang) > 1.0  # it spun the whole time
    finally:
        p.disconnect(cid)


def _pair(env_name: str, uav: str, seed: int, **overrides):
    cfg = load_env_config(env_name).with_overrides(uav=uav, **overrides)
    pb = make_env(cfg)
    pb.reset(seed=seed)
    be = BatchedUAVEnv(cfg, num_envs=1)
    be.reset(seed=seed)
    vehicle = pb.unwrapped.world.vehicles[0]
    pos, quat = p.getBasePositionAndOrientation(vehicle.body_id, physicsClientId=vehicle._client)
    lin, ang = p.getBaseVelocity(vehicle.body_id, physicsClientId=vehicle._client)
    be.pos[0], be.quat[0], be.vel[0], be.angvel[0] = pos, quat, lin, ang
    if be._waypoints:
        be.targets[0] = pb.unwrapped.task.targets
    be._read()
    if be.latency is not None:  # the copied start is the state its delays start from
        be.latency.restart(be, np.arange(1))
    be._last_position[:] = be.pos
    be._last_distance[:] = be._target_distance(np.arange(1), be.pos)
    return pb, be


def _flat(obs) -> np.ndarray:
    if isinstance(obs, dict):  # waypoints: FlattenWaypointEnv's layout for the next two
        deltas = np.zeros((2, 3))
        d = np.asarray(obs["target_deltas"]).reshape(-1, 3)[:2]
        deltas[: len(d)] = d
        mask = np.zeros(2)
        mask[: len(d)] = 1.0
        return np.r_[obs["attitude"], deltas.ravel(), mask]
    return np.asarray(obs)


def _motors_action(uav: str) -> dict:
    n = batched_model(load_uav_spec(uav), 1 / 240, 1 / 120).motors
    return {
        "mode": "motors",
        "names": [f"m{i}" for i in range(n)],
        "units": ["1"] * n,
        "low": [0.0] * n,
        "high": [1.0] * n,
    }


@pytest.mark.parametrize("env_name", ["quadx_hover", "quadx_waypoints"])
@pytest.mark.parametrize("mode", ["rates_thrust", "motors"])
@pytest.mark.parametrize("name", MULTIROTORS)
def test_trajectories_agree_with_the_pybullet_engine(quiet, name, mode, env_name):
    """2 s of random actions around hover: positions, observations and rewards within 1e-6."""
    overrides = {} if mode == "rates_thrust" else {"action": _motors_action(quiet[name])}
    pb, be = _pair(env_name, quiet[name], seed=3, **overrides)
    rng = np.random.default_rng(7)
    hover = be.model.hover_thrust_fraction
    worst = {"position": 0.0, "observation": 0.0, "reward": 0.0}
    for steps in range(1, 61):
        if mode == "rates_thrust":
            action = np.r_[rng.uniform(-1.0, 1.0, 3), hover * rng.uniform(0.95, 1.15)]
        else:
            action = np.sqrt(hover) * rng.uniform(0.97, 1.05, be.model.motors)
        o1, r1, t1, tr1, _ = pb.step(action)
        o2, r2, t2, tr2, info = be.step(action[None])
        assert (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        final = info["final_obs"][0] if t2[0] or tr2[0] else o2[0]  # before the autoreset
        worst["position"] = max(worst["position"], np.abs(_flat(o1)[10:13] - final[10:13]).max())
        worst["observation"] = max(worst["observation"], np.abs(_flat(o1) - final).max())
        worst["reward"] = max(worst["reward"], abs(r1 - r2[0]))
        if t1:
            break
    assert max(worst.values()) < BOUND, worst
    assert steps >= 15, "the flight crashed too soon to compare much"
    pb.close()


#: per cascade mode, the range of its random setpoints: around the spawn (1 m up), tilts within
#: +-0.3 rad, rates within +-1 rad/s, velocities within +-1.5 m/s (velocity_yawrate: the
#: velocity variant's own action, conf/env/quadx_waypoints_velocity.yaml)
CASCADE_ACTIONS = {
    "rates_z": ([-1.0, -1.0, -1.0, 0.6], [1.0, 1.0, 1.0, 1.6]),
    "attitude_vz": ([-0.3, -0.3, -3.0, -1.0], [0.3, 0.3, 3.0, 1.0]),
    "attitude_z": ([-0.3, -0.3, -3.0, 0.6], [0.3, 0.3, 3.0, 1.6]),
    "heading_velocity_z": ([-1.5, -1.5, -1.0, 0.6], [1.5, 1.5, 1.0, 1.6]),
    "heading_velocity_vz": ([-1.5, -1.5, -1.0, -1.0], [1.5, 1.5, 1.0, 1.0]),
    "velocity_yawrate": None,
    "velocity_yaw": ([-1.5, -1.5, -3.0, -1.0], [1.5, 1.5, 3.0, 1.0]),
    "position_yaw": ([-1.0, -1.0, -3.0, 0.6], [1.0, 1.0, 3.0, 1.6]),
    "position_yawrate": ([-1.0, -1.0, -1.0, 0.6], [1.0, 1.0, 1.0, 1.6]),
}


def fly_cascade_pair(uav: str, mode: str, seed: int = 3, steps: int = 60) -> tuple[dict[str, float], int]:
    """Both backends fly QuadX-Waypoints on airframe file ``uav`` in cascade mode ``mode``
    (its range in :data:`CASCADE_ACTIONS`; velocity_yawrate: the velocity variant) from one
    start for ``steps`` agent steps of random setpoints; returns the largest differences
    (motor commands, positions, observations, rewards, the controller's velocity and rate
    integrals) and the steps flown.  The test below and
    ``experiments/batched_modes_crosscheck.py`` (the documented figures) fly it."""
    from pyflyt_engine.control.modes import MULTIROTOR_MODES

    if CASCADE_ACTIONS[mode] is None:
        pb, be = _pair("quadx_waypoints_velocity", uav, seed=seed)
    else:
        low, high = CASCADE_ACTIONS[mode]
        layout = list(MULTIROTOR_MODES[mode].setpoint)
        action = {"mode": mode, "names": layout, "units": ["1"] * 4, "low": low, "high": high}
        pb, be = _pair("quadx_waypoints", uav, seed=seed, action=action)
    assert be.action_space == gymnasium.vector.utils.batch_space(pb.action_space, 1)
    low, high = np.array(be.config.action.low), np.array(be.config.action.high)
    vehicle = pb.unwrapped.world.vehicles[0]
    controller = vehicle.controller
    assert controller.mode.name == mode
    rng = np.random.default_rng(8)
    worst = {"command": 0.0, "position": 0.0, "observation": 0.0, "reward": 0.0, "integral": 0.0}
    for flown in range(1, steps + 1):
        action = rng.uniform(low, high)
        o1, r1, t1, tr1, _ = pb.step(action)
        o2, r2, t2, tr2, info = be.step(action[None])
        assert (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        final = info["final_obs"][0] if t2[0] or tr2[0] else o2[0]
        flat = _flat(o1)
        assert flat.shape == final.shape
        worst["position"] = max(worst["position"], np.abs(flat[10:13] - final[10:13]).max())
        worst["observation"] = max(worst["observation"], np.abs(flat - final).max())
        worst["reward"] = max(worst["reward"], abs(r1 - r2[0]))
        if t1 or tr1:
            break
        commands = np.subtract(vehicle.actuators.motors.command, be.command[0])
        worst["command"] = max(worst["command"], np.abs(commands).max())
        integrals = np.r_[
            np.subtract(controller._vel_integral, be.vel_integral[0]),
            np.subtract(controller._rate_integral, be.integral[0]),
        ]
        worst["integral"] = max(worst["integral"], np.abs(integrals).max())
    pb.close()
    return {k: float(v) for k, v in worst.items()}, flown


@pytest.mark.parametrize("mode", list(CASCADE_ACTIONS))
@pytest.mark.parametrize("name", MULTIROTORS)
def test_cascade_modes_agree_with_the_pybullet_engine(quiet, name, mode):
    """Every multirotor mode above the rate loop, QuadX-Waypoints (the velocity mode: its
    velocity variant), 2 s of random setpoints drawn anew at every agent step: positions,
    observations and rewards within the module docstring's 1e-6, and the controller's
    integrators where the PyBullet engine's are."""
    worst, flown = fly_cascade_pair(quiet[name], mode)
    assert max(worst.values()) < BOUND, worst
    assert flown == 60, "the flight ended before 2 s"


#: the fixed-wing autopilot's action: bank and pitch within +-0.6 and +-0.3 rad, yaw rate, airspeed 10-20 m/s
AUTOPILOT_ACTION = {
    "mode": "attitude_airspeed",
    "names": ["roll", "pitch", "yaw_rate", "airspeed"],
    "units": ["rad", "rad", "rad/s", "m/s"],
    "low": [-0.6, -0.3, -0.5, 10.0],
    "high": [0.6, 0.3, 0.5, 20.0],
}


@pytest.mark.parametrize(
    ("mode", "reward"), [("channels", "dense"), ("channels", "sparse"), ("attitude_airspeed", "dense")]
)
@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("name", FIXEDWINGS)
def test_fixedwing_trajectories_agree_with_the_pybullet_engine(quiet, name, seed, mode, reward):
    """Fixedwing-Waypoints, 2 s of random actions over the whole action range (channels:
    aileron, elevator, rudder in [-1, 1], thrust in [0, 1]; or the autopilot's setpoints):
    positions, observations (flap deflections and waypoint deltas included) and rewards
    within the module docstring's 1e-6."""
    overrides = {"action": AUTOPILOT_ACTION} if mode == "attitude_airspeed" else {}
    pb, be = _pair("fixedwing_waypoints", quiet[name], seed=seed, reward=reward, **overrides)
    low, high = (np.array(be.config.action.low), np.array(be.config.action.high))
    rng = np.random.default_rng(20 + seed)
    worst = {"position": 0.0, "observation": 0.0, "reward": 0.0}
    flaps = 0.0
    for steps in range(1, 61):
        action = rng.uniform(low, high)
        o1, r1, t1, tr1, _ = pb.step(action)
        o2, r2, t2, tr2, info = be.step(action[None])
        assert (t1, tr1) == (bool(t2[0]), bool(tr2[0]))
        final = info["final_obs"][0] if t2[0] or tr2[0] else o2[0]
        flat = _flat(o1)
        assert flat.shape == final.shape
        worst["position"] = max(worst["position"], np.abs(flat[10:13] - final[10:13]).max())
        worst["observation"] = max(worst["observation"], np.abs(flat - final).max())
        worst["reward"] = max(worst["reward"], abs(r1 - r2[0]))
        flaps = max(flaps, np.abs(final[18:23]).max())  # the surfaces' aux moved
        if t1:
            break
    assert max(worst.values()) < BOUND, worst
    assert steps == 60, "the flight ended before 2 s"
    assert flaps > 0.1
    pb.close()


def test_a_fixedwing_dive_into_the_ground_crashes_in_both(quiet):
    """Thrust off, elevator full down: the Fixedwing dives from 20 m into the ground; both
    backends end the episode on the crash within one agent step of each other."""
    ends = []
    pb, be = _pair("fixedwing_waypoints", quiet["fixedwing"], seed=0)
    action = np.array([0.0, 1.0, 0.0, 0.0])
    for backend in ("pybullet", "batched"):
        for k in range(600):
            if backend == "pybullet":
                _, reward, terminated, _, info = pb.step(action)
                collided = info["collision"]
            else:
                _, rewards, term, _, info = be.step(action[None])
                reward, terminated, collided = rewards[0], bool(term[0]), bool(info["collision"][0])
            if terminated:
                ends.append((k, collided, reward))
                break
    (k1, c1, r1), (k2, c2, r2) = ends
    assert c1 and c2 and r1 == r2 == -100.0
    assert 0 <= k2 - k1 <= 1, ends
    pb.close()


@pytest.mark.parametrize("name", MULTIROTORS)
def test_a_fall_to_the_ground_crashes_in_both(quiet, name):
    """Motors off from the spawn: both backends end the episode on a crash within one agent
    step of each other (the module docstring), with the crash reward."""
    ends = []
    pb, be = _pair("quadx_hover", quiet[name], seed=0)
    for backend in ("pybullet", "batched"):
        for k in range(200):
            if backend == "pybullet":
                _, reward, terminated, _, info = pb.step(np.zeros(4))
                collided = info["collision"]
            else:
                _, rewards, term, _, info = be.step(np.zeros((1, 4)))
                reward, terminated, collided = rewards[0], bool(term[0]), bool(info["collision"][0])
            if terminated:
                ends.append((k, collided, reward))
                break
    (k1, c1, r1), (k2, c2, r2) = ends
    assert c1 and c2 and r1 == r2 == -100.0
    assert 0 <= k2 - k1 <= 1, ends
    pb.close()


@pytest.mark.parametrize(
    ("env_name", "overrides", "named"),
    [
        ("quadx_hover", {"downwash": True}, "downwash"),
        ("quadx_hover", {"uav": "rocket"}, "channel-driven airframe rocket"),
        ("quadx_obstacles", {}, "task 'goal'"),
        ("quadx_pole_balance", {}, "task"),
        (
            "fixedwing_waypoints",
            {
                "action": {
                    "mode": "rates_thrust",
                    "names": ["p", "q", "r", "thrust"],
                    "units": ["rad/s", "rad/s", "rad/s", "1"],
                    "low": [-1.0, -1.0, -1.0, 0.0],
                    "high": [1.0, 1.0, 1.0, 1.0],
                }
            },
            "flight mode rates_thrust",
        ),
        ("fixedwing_waypoints", {"downwash": True}, "downwash"),
        ("rocket_landing", {}, "task"),
        ("ma_fixedwing_dogfight", {}, "multi-agent task 'dogfight'"),
    ],
)
def test_what_it_cannot_simulate_is_refused_by_name(env_name, overrides, named):
    """By the batched env when it is built, and by a training run's configuration at load."""
    cfg = load_env_config(env_name).with_overrides(backend="batched", **overrides)
    with pytest.raises(ConfigError) as info:
        BatchedUAVEnv(cfg, num_envs=2)
    message = str(info.value)
    assert "env.backend=batched does not simulate" in message and named in message, message
    if env_name == "quadx_hover":
        from tests.train.conftest import load

        with pytest.raises(ConfigError) as info:
            load([f"env={env_name}", "env.backend=batched", *_hydra(overrides)], ".")
        assert "env.backend=batched does not simulate" in str(info.value) and named in str(info.value)


def _hydra(overrides: dict) -> list[str]:
    """Env overrides as Hydra writes them (a ``randomize`` mapping entry by entry, each new key
    with ``+``, as docs/batched.md gives them)."""
    out = []
    for key, value in overrides.items():
        if isinstance(value, dict):
            for name, entry in value.items():
                fields = ", ".join(f"{k}: {v}" for k, v in entry.items())
                out.append(f"+env.{key}.{name}={{{fields}}}")
        else:
            out.append(f"env.{key}={value}")
    return out


def test_the_shipped_batched_tasks_are_supported():
    for env_name in ("quadx_hover", "quadx_waypoints", "quadx_waypoints_velocity", "fixedwing_waypoints"):
        cfg = load_env_config(env_name).with_overrides(backend="batched")
        check_supported(cfg)
        assert cfg.backend == "batched"
    with pytest.raises(UnsupportedByBatched):
        check_supported(load_env_config("quadx_hover").with_overrides(downwash=True))

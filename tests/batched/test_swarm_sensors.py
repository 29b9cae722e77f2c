"""Noisy sensors in the batched multi-agent worlds (pyflyt_engine.batched.swarm with
pyflyt_engine.batched.sensors) against the PyBullet engine's multi-agent envs.

Each vehicle of a PyBullet world has its own sensor stream (``World._suite_rng``: spawn key
4, then its index), reset twice an episode (the world's reset, then the spawn), and sampled
at the start of every physics step before its loads, retired vehicles too; so the draws of
every vehicle are the same in number and order whatever it flies.  A batched world gives
agent ``a`` of world ``k`` the stream of spawn key ``(4, a)`` under the world's seed
sequence and runs the single-agent backend's compiled laws on a row per agent, sampling
every vehicle at the start of every physics step.  An observed suite replaces the agent's
own state in its observation (the formation's neighbour displacements start from it; the
neighbours stay true, or delayed), the fix's validity flag after the throttles.

Oracles: from the same generators (the world's copied, as tests/batched/test_swarm_latency.py
pairs them, and each vehicle's sensor stream where the PyBullet world put it at its seeded
reset), the same spawns, initial biases and readings; flown with the same random actions,
every live agent's observation, reward, true position and sensor readings within
tests/batched/test_swarm.py's bound, 1e-6 (tests/batched/test_sensors.py derives why the
sensors' and the estimator's differences stay of the order of the true state's, which the
multi-agent cross-checks hold to the bound); the observation is the sensors' (it differs
from the true state's by far more than the bound).
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from pyflyt_engine.batched import UnsupportedByBatched, check_supported, resolve_backend, swarm
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.paths import uav_dir
from tests.batched.test_sensors import SUITES
from tests.batched.test_swarm import BOUND, STACKED
from tests.batched.test_swarm_latency import FIXED

SENSORS_AIRFRAME = uav_dir() / "examples" / "quadx_cf2x_sensors.yaml"

#: the env's own suite, observed: a fast IMU, a fix with dropout and a barometer (every branch
#: of the laws a step takes), and the same with the flight controller's estimator
SENSED = {
    "observe": True,
    "imu": SUITES["fast_imu_fix_baro"]["imu"],
    "position": {"noise_std": [0.01, 0.01, 0.01], "rate_hz": 100.0, "dropout": 0.2},
    "barometer": SUITES["fast_imu_fix_baro"]["barometer"],
}
ESTIMATED = {**SENSED, "barometer": None, "estimator": "complementary"}


@pytest.fixture(scope="module")
def quiet_sensors_cf2x(tmp_path_factory):
    """The shipped example airframe with sensors (conf/uav/examples/quadx_cf2x_sensors.yaml),
    its motors without noise (the batched motor noise is off in the cross-checks)."""
    data = yaml.safe_load(SENSORS_AIRFRAME.read_text())
    data["motors"]["noise_ratio"] = 0.0
    path = tmp_path_factory.mktemp("quiet_sensors") / "quadx_cf2x_sensors.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


FLIGHTS = {
    # the airframe's own section, not observed: simulated, the observation the true state's
    "airframe_hover": ("ma_quadx_hover", {"agents": STACKED, "downwash": True}),
    # observed: rates from the gyro, position from the fix, height from the barometer
    "sensed_hover": ("ma_quadx_hover", {"agents": STACKED, "downwash": True, "sensors": SENSED}),
    # observed with the airframe's section (the env's sensors.observe alone)
    "airframe_observed_formation": (
        "ma_quadx_formation",
        {"agents": 4, "downwash": True, "sensors": {"observe": True}},
    ),
    # the estimator's attitude, velocity and position; the neighbours' displacements from its position
    "estimated_formation": ("ma_quadx_formation", {"agents": 4, "downwash": True, "sensors": ESTIMATED}),
    # the sensors' randomize factors, one draw per world for all its vehicles (each vehicle's row)
    "sensed_randomized_hover": (
        "ma_quadx_hover",
        {
            "agents": STACKED,
            "downwash": True,
            "sensors": SENSED,
            "randomize": {
                name: {"distribution": "uniform", "low": 0.5, "high": 2.0}
                for name in ("gyro_scale", "gyro_noise", "accel_scale", "accel_noise", "position_noise")
            },
        },
    ),
    # the delayed states with the current readings
    "estimated_hover_latency": (
        "ma_quadx_hover",
        {"agents": STACKED, "downwash": True, "sensors": ESTIMATED, "latency": FIXED},
    ),
}


def _paired(cfg, seed: int):
    """The PyBullet env of ``cfg`` reset with ``seed`` and one batched world drawing from a
    copy of its generator (the same spawns), each vehicle's sensor stream put where the
    PyBullet world put it at its seeded reset and the sensors reset from there; their first
    observations."""
    from gymnasium.utils import seeding

    from pyflyt_engine.envs.multi_agent.formation import MAQuadXFormationEnv
    from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv

    pb = {"ma_hover": MAQuadXHoverEnv, "ma_formation": MAQuadXFormationEnv}[cfg.task.name](cfg)
    start, _ = pb.reset(seed=seed)
    be = swarm.BatchedSwarmEnv(cfg, worlds=1, motor_noise=False)
    be.world_rngs[0] = seeding.np_random(seed)[0]
    be.env_rngs = [be.world_rngs[0]] * be.num_envs
    be.reset()
    rows = np.arange(be.num_envs)
    be.sensors.rngs = [pb.world._suite_rng(a) for a in range(be.agents)]
    be.sensors.reset(rows, be.pos, be.vel, be.quaternion)
    return pb, be, start, be._observe()


def _true_position(vehicle) -> np.ndarray:
    return np.array(p.getBasePositionAndOrientation(vehicle.body_id, physicsClientId=vehicle._client)[0])


def _fly(pb, be, rng, steps: int):
    """Random actions around hover for every live agent: the worst differences of the
    observations, rewards, true positions and readings, and how far the observations are
    from what the true state would show (the sensors' noise)."""
    hover = be.model.hover_thrust_fraction
    names = pb.possible_agents
    worst = dict.fromkeys(("observation", "reward", "position", "readings"), 0.0)
    noise = 0.0
    for step in range(1, steps + 1):
        live = list(pb.agents)
        if not live:
            break
        actions = np.zeros((len(names), 4))
        for name in live:
            actions[pb.agent_index[name]] = np.r_[rng.uniform(-0.5, 0.5, 3), hover * rng.uniform(0.95, 1.1)]
        o1, r1, t1, tr1, _ = pb.step({name: actions[pb.agent_index[name]] for name in live})
        o2, r2, t2, tr2, info = be.step(actions)
        final = info.get("final_obs", o2)
        for name in live:
            i = pb.agent_index[name]
            assert (t1[name], tr1[name]) == (bool(t2[i]), bool(tr2[i])), (step, name)
            got = final[i] if t2[i] or tr2[i] else o2[i]
            vehicle = pb.vehicles[i]
            worst["observation"] = max(worst["observation"], np.abs(o1[name] - got).max())
            worst["reward"] = max(worst["reward"], abs(r1[name] - r2[i]))
            worst["position"] = max(worst["position"], np.abs(_true_position(vehicle) - be.pos[i]).max())
            theirs, ours = vehicle.sensor_readings(), be.sensor_readings(i)
            assert theirs.keys() == ours.keys()
            for key in theirs:
                worst["readings"] = max(worst["readings"], np.abs(theirs[key] - ours[key]).max())
            noise = max(noise, np.abs(got[:3] - be.ang_vel_body[i]).max(), np.abs(got[10:13] - be.pos[i]).max())
    return worst, noise, step


@pytest.mark.parametrize("flight", list(FLIGHTS))
def test_sensed_worlds_agree_with_the_pybullet_engine(quiet_sensors_cf2x, flight):
    """2 s of random actions around hover: the same initial readings and observation at the
    reset, then every live agent's observation, reward, true position and readings within
    1e-6 (the measured differences printed); the observation is the sensors' when observed,
    the true state's when not; no agent lost."""
    env_name, overrides = FLIGHTS[flight]
    cfg = load_env_config(env_name).with_overrides(uav=quiet_sensors_cf2x, **overrides)
    pb, be, start, first = _paired(cfg, 6)
    names = pb.possible_agents
    assert be.single_observation_space == pb.observation_space(names[0])
    for i, name in enumerate(names):
        theirs, ours = pb.vehicles[i].sensor_readings(), be.sensor_readings(i)
        assert theirs.keys() == ours.keys()
        for key in theirs:  # the initial biases drawn alike (the spawns agree to PyBullet's storage)
            assert np.abs(theirs[key] - ours[key]).max() < 1e-12, (name, key)
        assert np.abs(start[name] - first[i]).max() < 1e-12, name
    worst, noise, flown = _fly(pb, be, np.random.default_rng(8), 60)
    print(f"{flight}: {worst}, the sensors' departure from the true state {noise:.2e}")
    pb.close()
    assert max(worst.values()) < BOUND, worst
    assert flown == 60 and be.alive.all()
    if be.sensors.source == swarm.OBSERVE_TRUE:
        assert noise == 0.0  # not observed: the observation is the true state's
    else:
        assert noise > 1e3 * BOUND


def test_the_streams_keep_in_step_through_a_crash_and_the_next_episode(quiet_sensors_cf2x):
    """One agent cut to zero thrust falls and crashes (within an agent step of each other in
    the two backends: PyBullet's contact threshold) while the others fly on; its sensors go on
    drawing while it lies there, in both, so when the world restarts every vehicle's new
    initial biases and readings are again the PyBullet world's, and the next episode's
    observations and readings agree within 1e-6."""
    cfg = load_env_config("ma_quadx_hover").with_overrides(
        uav=quiet_sensors_cf2x, agents=STACKED, sensors=SENSED, max_duration_seconds=1.0
    )
    pb, be, _, _ = _paired(cfg, 9)
    names = pb.possible_agents
    hover = be.model.hover_thrust_fraction
    rng = np.random.default_rng(2)
    crashed: dict[str, int] = {}
    worst = 0.0
    step = 0
    while pb.agents:
        step += 1
        live = list(pb.agents)
        actions = np.zeros((len(names), 4))
        for name in live:
            actions[pb.agent_index[name]] = np.r_[rng.uniform(-0.3, 0.3, 3), hover * rng.uniform(0.97, 1.05)]
        actions[0] = 0.0  # agent 0: no thrust
        o1, _, t1, _, _ = pb.step({name: actions[pb.agent_index[name]] for name in live})
        o2, _, t2, _, info = be.step(actions)
        if t1.get(names[0]):
            crashed["pybullet"] = step
        if t2[0] and be.steps[0] == step:  # (not its padding end with the world)
            crashed.setdefault("batched", step)
        for name in live[1:] if live[0] == names[0] else live:  # the others, live in both
            i = pb.agent_index[name]
            got = info["final_obs"][i] if "final_obs" in info and info["_final_obs"][i] else o2[i]
            worst = max(worst, np.abs(o1[name] - got).max())
    assert worst < BOUND, worst
    assert set(crashed) == {"pybullet", "batched"} and abs(crashed["pybullet"] - crashed["batched"]) <= 1, crashed
    assert step == 30 and be.steps.max() == 0  # the world restarted with the time limit
    start, _ = pb.reset()  # the next episode: no seed, every stream goes on
    for i, name in enumerate(names):
        theirs, ours = pb.vehicles[i].sensor_readings(), be.sensor_readings(i)
        for key in theirs:
            assert np.abs(theirs[key] - ours[key]).max() < 1e-12, (name, key)
        assert np.abs(start[name] - o2[i]).max() < 1e-12, name
    again, noise, flown = _fly(pb, be, rng, 20)
    pb.close()
    assert max(again.values()) < BOUND and flown == 20, again
    assert noise > 1e3 * BOUND


def _run(cfg, worlds: int, seed: int, steps: int = 20) -> tuple[np.ndarray, swarm.BatchedSwarmEnv]:
    env = swarm.BatchedSwarmEnv(cfg, worlds=worlds)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(1)
    out = [obs]
    hover = env.model.hover_thrust_fraction
    for _ in range(steps):
        a = np.c_[rng.uniform(-0.5, 0.5, (env.num_envs, 3)), hover * rng.uniform(0.95, 1.1, (env.num_envs, 1))]
        out.append(env.step(a)[0])
    return np.array(out), env


def test_streams_are_per_vehicle_and_seeded():
    """The same seed gives the same observations bit for bit; each vehicle's sensor stream
    depends on the seed, its world and its index alone: world 0 of a one-world batch reads
    what world 0 of a two-world batch reads, every vehicle draws its own biases, another seed
    draws others."""
    cfg = load_env_config("ma_quadx_hover").with_overrides(sensors=SENSED)
    a, env_a = _run(cfg, 2, 3)
    b, _ = _run(cfg, 2, 3)
    assert np.array_equal(a, b)
    _, one = _run(cfg, 1, 3, steps=0)
    _, fresh = _run(cfg, 2, 3, steps=0)
    agents = one.agents
    assert np.array_equal(one.sensor_state, fresh.sensor_state[:agents])
    biases = fresh.sensor_state[:, 0:3]  # the gyros' initial biases
    assert len({tuple(row) for row in biases.tolist()}) == fresh.num_envs
    _, other = _run(cfg, 1, 4, steps=0)
    assert not np.array_equal(other.sensor_state, one.sensor_state)
    assert env_a.sensor_counts[:, 0].min() > 0  # the gyros sampled


def test_a_checkpoint_carries_the_sensors():
    """``episode_state`` / ``restore_episode`` of every slot mid-episode: the biases, held
    readings, sample counts, estimate and each vehicle's stream come back, and the steps after
    it (worlds restarting and drawing new biases among them) repeat bit for bit."""
    from pyflyt_cli.training.envs import make_vec_env

    cfg = load_env_config("ma_quadx_hover").with_overrides(
        backend="batched", sensors=ESTIMATED, max_duration_seconds=0.5
    )
    vec = make_vec_env(cfg, 2)
    vec.seed(4)
    vec.reset()
    rng = np.random.default_rng(3)
    n = vec.num_envs
    for _ in range(5):
        vec.step(rng.uniform(-0.3, 0.3, (n, 4)).astype(np.float32))
    saved = vec.env_method("episode_state")
    env = vec.env
    assert "sensor_state" in saved[0]["batched"] and "sensors" in saved[0]["rng"]
    actions = rng.uniform(-0.3, 0.3, (20, n, 4)).astype(np.float32)
    first = [vec.step(a)[0] for a in actions]
    env.sensor_state[:] = 1.0  # state the restore must put back
    env.sensor_counts[:] = 0
    for stream in env.sensors.rngs:
        stream.random(3)
    for i in range(n):
        vec.env_method("restore_episode", saved[i], indices=i)
    again = [vec.step(a)[0] for a in actions]
    assert all(np.array_equal(x, y) for x, y in zip(first, again))


def test_sensors_are_simulated_and_what_stays_refused_is_named():
    """A sensors section in a multi-agent world, the airframe's or the env's, flies batched
    (the auto backend picks it); the range sensors stay refused by name, and a bad section
    fails as in the PyBullet engine."""
    from pyflyt_engine.errors import ConfigError

    for overrides in ({"uav": str(SENSORS_AIRFRAME)}, {"sensors": SENSED}, {"sensors": ESTIMATED}):
        cfg = load_env_config("ma_quadx_hover").with_overrides(**overrides)
        check_supported(cfg)
        assert resolve_backend(cfg.with_overrides(backend="auto")) == "batched"
    lidar = load_env_config("quadx_obstacles").range_sensors
    with pytest.raises(UnsupportedByBatched, match="env.range_sensors"):
        check_supported(load_env_config("ma_quadx_hover").with_overrides(range_sensors=lidar))
    bad = load_env_config("ma_quadx_hover").with_overrides(
        sensors={"observe": True, "imu": SUITES["fast_imu_fix_baro"]["imu"], "estimator": "complementary"}
    )
    with pytest.raises(ConfigError, match="sensors.position") as batched:
        swarm.BatchedSwarmEnv(bad)
    from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv

    with pytest.raises(ConfigError) as pybullet:
        MAQuadXHoverEnv(bad)
    assert str(batched.value) == str(pybullet.value)
    fast = load_env_config("ma_quadx_hover").with_overrides(sensors={"observe": True, "barometer": {"rate_hz": 1000.0}})
    with pytest.raises(ConfigError, match="sensors.barometer.rate_hz"):
        swarm.BatchedSwarmEnv(fast)

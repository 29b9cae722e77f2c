"""The batched multi-agent hover (pyflyt_engine.batched.swarm) against the PyBullet engine's.

Laws: the compiled downwash (``downwash_velocity``, the sum ``downwash_at`` with its reach
skip, CPython's ``hypot``) equals the engine's scalar forms bit for bit on random inputs.

Cross-check: MAQuadX-Hover with downwash, agents stacked closely enough that the wakes of
the upper ones blow on the lower ones, the same start states and actions, motor noise
off.  The bound, derived as for the single vehicle (tests/batched/test_crosscheck.py): the
laws -- the downwash among them -- are bit for bit the engine's, so the backends differ by
the rigid body's last bits (~eps |x| ~ 2.2e-16 x 2 m per physics step: PyBullet works in
the body frame and reports the attitude through its rotation matrix) and by the attitude
the drag and the downwash are read through; such a difference grows with the flight's
sensitivity, and the downwash couples the agents (a lower agent's wind depends on the
upper one's position and throttles).  480 physics steps x 4.4e-16 x a growth of even 1e3
is ~2e-10 (the growth an assumed margin, not measured for this flight), so 1e-6 holds with a wide margin; the test asserts 1e-6 on positions,
observations and rewards of every live agent and prints what it measured.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from pyflyt_engine.atmosphere import rotors as R
from pyflyt_engine.batched import check_supported, swarm
from pyflyt_engine.batched.model import UnsupportedByBatched
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.paths import uav_dir

BOUND = 1e-6


@pytest.fixture(scope="module")
def quiet_cf2x(tmp_path_factory):
    data = yaml.safe_load((uav_dir() / "quadx_cf2x.yaml").read_text())
    data["motors"]["noise_ratio"] = 0.0
    path = tmp_path_factory.mktemp("quiet") / "quadx_cf2x.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


# ---------------------------------------------------------------------------- laws


def test_hypot_is_cpythons_bit_for_bit():
    rng = np.random.default_rng(0)
    xs = rng.normal(0.0, 1.0, (50_000, 2)) * 10.0 ** rng.uniform(-6, 2, (50_000, 2))
    xs[:100, 1] = 0.0
    xs[100:200] *= 1e-310  # subnormal inputs take CPython's rescaled path
    for x, y in xs:
        assert swarm.py_hypot(x, y) == math.hypot(x, y), (x, y)


def test_downwash_velocity_is_the_engines_bit_for_bit():
    rng = np.random.default_rng(1)
    for _ in range(50_000):
        dz = rng.uniform(-0.5, 3.0)
        r = rng.uniform(0.0, 2.0) * rng.choice([1.0, 0.05])
        thrust = rng.uniform(-0.1, 2.5)
        area = rng.choice([0.0, rng.uniform(1e-4, 0.2)])
        expected = R.downwash_velocity(dz, r, thrust, area)
        assert swarm.downwash_velocity(dz, r, thrust, area, R.AIR_DENSITY, 2.0) == expected


@pytest.mark.parametrize("uav", ["quadx_cf2x", "quadx_f450"])
def test_the_downwash_sum_is_the_engines_bit_for_bit(uav):
    """Random swarms (positions within a few wake reaches, throttles in [-1, 1]):
    ``downwash_at`` of every vehicle equals ``RotorInteractions.downwash_at`` -- all pairs,
    in index order -- and ``downwash_near`` over the engine's own ``sources``."""
    from pyflyt_engine.spec import load_uav_spec

    spec = load_uav_spec(uav)
    rot = swarm._rotor_geometry(spec)
    hubs = np.zeros((len(rot["max_thrust"]), 3)).tolist()
    radii = [float(x) for x in spec.motors.to_array("prop_radius")]
    rng = np.random.default_rng(2)
    compared = nonzero = 0
    for trial in range(60):
        a = int(rng.integers(2, 24))
        engine = R.RotorInteractions(False, True)
        # each vehicle's own full thrusts (a drawn motor_kf scales a vehicle's)
        full = rot["max_thrust"] * rng.uniform(0.8, 1.2, (a, 1))
        for j in range(a):
            engine.add_vehicle(hubs, radii, full[j].tolist())
        spread = rng.choice([0.05, 0.3, 2.0])
        positions = np.c_[rng.uniform(-spread, spread, (a, 2)), rng.uniform(0.0, 2.0, a)]
        throttles = rng.uniform(-1.0, 1.0, (a, len(radii)))
        for i, position in enumerate(positions.tolist()):
            got = swarm.downwash_at(
                i,
                *position,
                positions,
                throttles,
                full,
                rot["is_rotor"],
                rot["disc_area"],
                rot["jet_diameter"],
                R.AIR_DENSITY,
                2.0,
            )
            expected = engine.downwash_at(i, position, positions.tolist(), throttles.tolist())
            assert got == expected, (trial, i)
            for j, q in enumerate(positions.tolist()):
                engine.place(j, q)
            sources = engine.sources(i, position)
            near = engine.downwash_near(
                i, position, sources, [positions[j].tolist() for j in sources], [throttles[j].tolist() for j in sources]
            )
            assert got == near
            compared += 1
            nonzero += got != 0.0
    assert nonzero > compared // 10  # the wakes reached many of them


def test_boxes_overlap_as_the_geometry_says():
    """Two level boxes touch when their centres are closer than their size along an axis;
    a box turned 45 degrees reaches farther along its diagonal."""
    centre, half = np.zeros(3), np.array([0.045, 0.045, 0.01])
    level = swarm.rotation_tuple(0.0, 0.0, 0.0, 1.0)
    a = np.zeros(3)
    assert swarm.boxes_overlap(a, level, np.array([0.089, 0.0, 0.0]), level, centre, half)
    assert not swarm.boxes_overlap(a, level, np.array([0.091, 0.0, 0.0]), level, centre, half)
    assert swarm.boxes_overlap(a, level, np.array([0.0, 0.0, 0.019]), level, centre, half)
    assert not swarm.boxes_overlap(a, level, np.array([0.0, 0.0, 0.021]), level, centre, half)
    s = math.sin(math.pi / 8)
    turned = swarm.rotation_tuple(0.0, 0.0, s, math.cos(math.pi / 8))  # 45 degrees about z
    reach = 0.045 + 0.045 * math.sqrt(2.0)
    assert swarm.boxes_overlap(a, level, np.array([reach - 1e-3, 0.0, 0.0]), turned, centre, half)
    assert not swarm.boxes_overlap(a, level, np.array([reach + 1e-3, 0.0, 0.0]), turned, centre, half)


# ---------------------------------------------------------------------------- cross-check

#: two stacks of two: each upper agent 0.3-0.4 m above and 2-4 cm beside a lower one (inside its wake)
STACKED = [
    {"spawn": {"position": [0.0, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.05}},
    {"spawn": {"position": [0.02, 0.01, 1.35], "position_noise": 0.0, "orientation_noise": 0.05}},
    {"spawn": {"position": [1.0, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.05}},
    {"spawn": {"position": [1.03, -0.02, 1.4], "position_noise": 0.0, "orientation_noise": 0.05}},
]


def _pair(uav: str, seed: int, agents=STACKED, env: str = "ma_quadx_hover", **overrides):
    """The PyBullet env of ``env`` and one batched world of the same config, from the same start states."""
    from pyflyt_engine.envs.multi_agent.formation import MAQuadXFormationEnv
    from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv

    cfg = load_env_config(env).with_overrides(uav=uav, agents=agents, **overrides)
    pb = {"ma_quadx_hover": MAQuadXHoverEnv, "ma_quadx_formation": MAQuadXFormationEnv}[env](cfg)
    obs, _ = pb.reset(seed=seed)
    be = swarm.BatchedSwarmEnv(cfg, worlds=1, motor_noise=False)
    be.reset(seed=seed)
    for i, vehicle in enumerate(pb.vehicles):
        pos, quat = p.getBasePositionAndOrientation(vehicle.body_id, physicsClientId=vehicle._client)
        lin, ang = p.getBaseVelocity(vehicle.body_id, physicsClientId=vehicle._client)
        be.pos[i], be.quat[i], be.vel[i], be.angvel[i] = pos, quat, lin, ang
    be._read()
    be._reset_world_task(0)  # the task's start from the copied states (the hover's distances)
    first = be._observe()
    for i, name in enumerate(pb.possible_agents):
        assert np.abs(obs[name] - first[i]).max() < 1e-12
    return pb, be


def _fly(pb, be, rng, steps, hover, motors=False):
    """Random actions around hover for every live agent (``motors``: in mode motors); the worst differences."""
    worst = {"position": 0.0, "observation": 0.0, "reward": 0.0}
    names = pb.possible_agents
    ends = []
    for step in range(1, steps + 1):
        live = list(pb.agents)
        if not live:
            break
        actions = np.zeros((len(names), 4))
        for name in live:
            if motors:
                actions[pb.agent_index[name]] = np.sqrt(hover) * rng.uniform(0.97, 1.05, 4)
            else:
                actions[pb.agent_index[name]] = np.r_[rng.uniform(-0.5, 0.5, 3), hover * rng.uniform(0.95, 1.1)]
        o1, r1, t1, tr1, _ = pb.step({name: actions[pb.agent_index[name]] for name in live})
        o2, r2, t2, tr2, info = be.step(actions)
        final = info.get("final_obs", o2)
        for name in live:
            i = pb.agent_index[name]
            assert (t1[name], tr1[name]) == (bool(t2[i]), bool(tr2[i])), (step, name)
            ended = t2[i] or tr2[i]
            got = final[i] if ended else o2[i]
            worst["position"] = max(worst["position"], np.abs(o1[name][10:13] - got[10:13]).max())
            worst["observation"] = max(worst["observation"], np.abs(o1[name] - got).max())
            worst["reward"] = max(worst["reward"], abs(r1[name] - r2[i]))
            if ended:
                ends.append((step, name))
    return worst, ends, step


MOTORS_ACTION = {
    "mode": "motors",
    "names": ["m0", "m1", "m2", "m3"],
    "units": ["1"] * 4,
    "low": [0.0] * 4,
    "high": [1.0] * 4,
}


@pytest.mark.parametrize("mode", ["rates_thrust", "motors"])
@pytest.mark.parametrize("seed", [0, 1])
def test_stacked_agents_with_downwash_agree_with_the_pybullet_engine(quiet_cf2x, seed, mode):
    """2 s (60 agent steps) of random actions around hover, the upper agents' wakes on the
    lower ones: every live agent's position, observation and reward within 1e-6.  In mode
    motors (open loop) the stacks tumble to the ground after ~1.2 s, where the backends
    differ by design (PyBullet's contact response moves the crashing body in its last step,
    and its contact threshold may end it a step earlier): that mode flies 1 s."""
    motors = mode == "motors"
    pb, be = _pair(quiet_cf2x, seed, downwash=True, **({"action": MOTORS_ACTION} if motors else {}))
    hover = be.model.hover_thrust_fraction
    # the wakes do blow: the lower agents feel a down-wind of at least 0.1 m/s at the start
    rot = be._wake_sources
    still = np.full(4, np.sqrt(hover)) if motors else np.r_[0.0, 0.0, 0.0, hover]
    pb.step({name: still for name in pb.agents})
    be.step(np.tile(still, (be.num_envs, 1)))
    lower = [
        swarm.downwash_at(
            k,
            *be.pos[k],
            be.pos,
            be.throttle,
            be._wake_thrust,
            rot["is_rotor"],
            rot["disc_area"],
            rot["jet_diameter"],
            R.AIR_DENSITY,
            2.0,
        )
        for k in (0, 2)
    ]
    assert max(lower) < -0.1, lower
    length = 29 if motors else 59
    worst, ends, steps = _fly(pb, be, np.random.default_rng(10 + seed), length, hover, motors)
    print(f"seed {seed}, {mode}: {worst}")
    assert max(worst.values()) < BOUND, worst
    assert steps == length and not ends, ends
    pb.close()


def test_downwash_changes_the_lower_agents_flight_only(quiet_cf2x):
    """The same start and actions with and without downwash: the upper agents fly the very
    same trajectory (no wake reaches them), the lower ones are pushed down (centimetres in 1 s)."""
    runs = {}
    for downwash in (False, True):
        env = swarm.BatchedSwarmEnv(
            load_env_config("ma_quadx_hover").with_overrides(uav=quiet_cf2x, agents=STACKED, downwash=downwash),
            worlds=1,
            seed=0,
            motor_noise=False,
        )
        env.reset(seed=0)
        hover = env.model.hover_thrust_fraction
        for _ in range(30):
            env.step(np.tile(np.r_[0.0, 0.0, 0.0, hover], (env.num_envs, 1)))
        runs[downwash] = env.pos.copy()
    upper, lower = [1, 3], [0, 2]
    assert np.array_equal(runs[True][upper], runs[False][upper])
    drop = runs[False][lower, 2] - runs[True][lower, 2]
    print(f"the lower agents' drop after 1 s: {drop} m")
    assert (drop > 0.01).all(), drop


def test_a_collision_between_agents_retires_both_in_both_backends(quiet_cf2x):
    """Two agents 0.3 m apart fly into each other (rolled towards each other, full thrust):
    both backends retire both on their contact, within one agent step of each other; the
    agents far away fly on."""
    agents = [
        {"spawn": {"position": [-0.15, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
        {"spawn": {"position": [0.15, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
        {"spawn": {"position": [3.0, 0.0, 1.0], "position_noise": 0.0, "orientation_noise": 0.0}},
    ]
    pb, be = _pair(quiet_cf2x, 0, agents=agents)
    hover = be.model.hover_thrust_fraction
    act = np.array([[0.0, 2.0, 0.0, hover * 1.1], [0.0, -2.0, 0.0, hover * 1.1], [0.0, 0.0, 0.0, hover]])
    ended = {"pybullet": {}, "batched": {}}
    for step in range(1, 40):
        if pb.agents:
            _, _, t1, _, i1 = pb.step({name: act[pb.agent_index[name]] for name in pb.agents})
            for name, done in t1.items():
                if done:
                    ended["pybullet"][pb.agent_index[name]] = (step, i1[name]["collision"])
        live = be.alive.copy()
        _, _, t2, _, i2 = be.step(act)
        for i in np.flatnonzero(t2 & live):
            ended["batched"][int(i)] = (step, bool(i2["collision"][i]))
    print(ended)
    for backend in ("pybullet", "batched"):
        assert set(ended[backend]) == {0, 1}, ended
        assert all(collided for _, collided in ended[backend].values())
    for i in (0, 1):
        assert abs(ended["pybullet"][i][0] - ended["batched"][i][0]) <= 1, ended
    pb.close()


def test_a_fall_to_the_ground_crashes_in_both_within_one_agent_step(quiet_cf2x):
    """One agent's motors off: it falls from 1 m and crashes on the ground in both backends
    within one agent step of each other (PyBullet reports contact from its contact threshold
    on); the others hover on."""
    pb, be = _pair(quiet_cf2x, 0, agents=STACKED[::2])  # the two lower agents, 1 m apart
    hover = be.model.hover_thrust_fraction
    act = np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, hover]])
    ends = {}
    for step in range(1, 30):
        _, _, t1, _, i1 = pb.step({name: act[pb.agent_index[name]] for name in pb.agents})
        if t1.get("uav_0"):
            ends["pybullet"] = (step, i1["uav_0"]["collision"])
        live = be.alive.copy()
        _, _, t2, _, i2 = be.step(act)
        if live[0] and t2[0]:
            ends["batched"] = (step, bool(i2["collision"][0]))
    print(ends)
    assert set(ends) == {"pybullet", "batched"} and all(c for _, c in ends.values()), ends
    assert abs(ends["pybullet"][0] - ends["batched"][0]) <= 1, ends
    assert pb.agents == ["uav_1"] and be.alive.tolist() == [False, True]
    pb.close()


# ---------------------------------------------------------------------------- the env


def test_retired_agents_pad_their_slots_until_the_world_restarts(quiet_cf2x):
    """An agent whose motors are cut falls, crashes and is done (its return and length in
    ``episode``); its slot is then zeros until the world's last agent ends, when every slot
    of the world is done and the world restarts."""
    cfg = load_env_config("ma_quadx_hover").with_overrides(
        uav=quiet_cf2x, agents=3, max_duration_seconds=2.0, orientation_noise=0.0, position_noise=0.0
    )
    env = swarm.BatchedSwarmEnv(cfg, worlds=2, seed=0, motor_noise=False)
    env.reset(seed=0)
    hover = env.model.hover_thrust_fraction
    act = np.tile(np.r_[0.0, 0.0, 0.0, hover], (6, 1))
    act[0, 3] = 0.0  # agent 0 of world 0 falls
    crashed_at = None
    for step in range(1, 61):
        obs, reward, term, trunc, info = env.step(act)
        if crashed_at is None and term[0]:
            crashed_at = step
            assert info["_episode"][0] and info["episode"]["r"][0] < -50 and info["episode"]["l"][0] == step
            assert info["final_obs"][0].any()
        elif crashed_at is not None and step < 60:
            assert not obs[0].any() and reward[0] == 0.0 and not (term[0] or trunc[0])
    assert crashed_at is not None and crashed_at < 40
    # the 2 s limit: the others truncated (a success), the padding slot ends with its world, which restarts
    assert trunc[1:].all() and not trunc[0] and term[0] and not info["_episode"][0] and info["_final_obs"][0]
    assert info["success"][1:].all() and not info["success"][0]
    assert obs[0].any() and (env.steps == 0).all() and env.alive.all()


def test_same_seed_same_numbers():
    def run():
        env = swarm.make_batched_swarm("ma_quadx_hover", worlds=3, seed=5, downwash=True)
        obs, _ = env.reset(seed=5)
        rng = np.random.default_rng(0)
        out = [obs]
        for _ in range(40):
            obs, reward, *_ = env.step(rng.uniform(env._low, env._high, (env.num_envs, 4)))
            out += [obs, reward]
        return np.concatenate([np.ravel(x) for x in out])

    a, b = run(), run()
    assert np.array_equal(a, b)


@pytest.mark.parametrize(
    ("overrides", "named"),
    [
        ({}, None),
        ({"downwash": True}, None),
        ({"wind": "gust"}, None),
        ({"wind": "dryden_severe", "ground_effect": True}, None),
        ({"latency": {"action_delay": 0.01}}, None),  # tests/batched/test_swarm_latency.py
        ({"randomize": "moderate"}, None),  # domain randomisation (tests/batched/test_swarm_randomization.py)
        ({"randomize": "sim2real"}, None),  # with its drawn delays
        (
            {"agents": [{"uav": "quadx_f450", "spawn": {"position": [0, 0, 1]}}, {"spawn": {"position": [2, 0, 1]}}]},
            "agents of different airframes",
        ),
        # the cascade modes, as the single-agent backend flies them (tests/batched/test_swarm_cascade.py)
        (
            {
                "action": {
                    "mode": "velocity_yawrate",
                    "names": ["vx", "vy", "yaw_rate", "vz"],
                    "units": ["m/s"] * 4,
                    "low": [-1.0] * 4,
                    "high": [1.0] * 4,
                }
            },
            None,
        ),
    ],
)
def test_what_it_simulates_and_what_it_refuses(overrides, named):
    cfg = load_env_config("ma_quadx_hover").with_overrides(**overrides)
    if named is None:
        check_supported(cfg)
        return
    with pytest.raises(UnsupportedByBatched, match=named):
        check_supported(cfg)


@pytest.mark.parametrize(("env", "task"), [("ma_fixedwing_dogfight", "dogfight")])
def test_other_multi_agent_tasks_are_refused_by_name(env, task):
    with pytest.raises(UnsupportedByBatched, match=f"the multi-agent task '{task}'"):
        check_supported(load_env_config(env))


def test_a_layout_whose_agents_would_touch_is_refused():
    from pyflyt_engine.errors import ConfigError

    with pytest.raises(ConfigError, match="64 agents on the ring layout spawn 0.098 m apart"):
        swarm.make_batched_swarm("ma_quadx_hover", agents=64)
    assert swarm.make_batched_swarm("ma_quadx_hover", agents=64, layout="grid").num_envs == 64


def test_a_formation_whose_agents_would_touch_is_refused_as_the_pybullet_env_refuses_it():
    # the formation has no layout option (always its grid): its refusal names the spacing alone
    from pyflyt_engine.envs.multi_agent.formation import MAQuadXFormationEnv
    from pyflyt_engine.errors import ConfigError

    cfg = load_env_config("ma_quadx_formation").with_overrides(agents=4, layout_spacing=0.05)
    with pytest.raises(ConfigError, match="4 agents on the grid layout spawn 0.050 m apart") as pybullet:
        MAQuadXFormationEnv(cfg)
    with pytest.raises(ConfigError, match="4 agents on the grid layout spawn 0.050 m apart") as batched:
        swarm.BatchedSwarmEnv(cfg)
    assert "raise task.layout_spacing" in str(pybullet.value) and "raise task.layout_spacing" in str(batched.value)
    assert "layout_radius" not in str(batched.value) and "task.layout:" not in str(batched.value)

"""PyFlyt/Rocket-Landing-v0: the paper's reward evaluated by hand, and deliberate landings.

The oracle never calls the env's reward or landing code: it reads the position, speed,
attitude and the pad contact flag from the observations, re-derives the landing outcome
from the documented rules (touchdown speed, tip-over, upright halt), applies the
paper's formula

    r = r_d + r_v + I_pad r_pad - 100 I_ground,   r_d = -0.2 d_pad,   r_v = -v / d_pad^2,
    r_pad = -20 if fatal, +100 if safe

(plus the documented -100 for leaving the dome), and compares.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from pyflyt_engine.frames import quaternion_to_matrix

ROCKET = "PyFlyt/Rocket-Landing-v0"
PAD_TOP = 0.1  # m, the pad's top face (centre at the origin)
STAND = PAD_TOP + 1.72  # m, centre-of-mass height of the rocket standing on the pad (feet 1.72 m below it)
HALT_STEPS = 15  # 0.5 s at 30 Hz
DRY_MASS = 138.0  # kg, conf/uav/rocket.yaml
FULL_TANK = 410.9  # kg


def _place(env, position, rpy=(0.0, 0.0, 0.0), lin_vel=(0.0, 0.0, 0.0), ang_vel=(0.0, 0.0, 0.0)):
    """Set the rocket's pose and ground-frame velocities directly in PyBullet."""
    cid, body = env.world.client, env.vehicle.body_id
    p.resetBasePositionAndOrientation(body, list(position), p.getQuaternionFromEuler(list(rpy)), physicsClientId=cid)
    p.resetBaseVelocity(body, list(lin_vel), list(ang_vel), physicsClientId=cid)


def _drop_in_from_above(env):
    """One free-fall step at rest high up, so the next step starts slow (as after a real descent)."""
    _place(env, (0.0, 0.0, 30.0))
    return env.step(np.zeros(7))


def _tilt(quaternion):
    x, y = quaternion[0], quaternion[1]
    return math.acos(min(1.0, max(-1.0, 1.0 - 2.0 * (x * x + y * y))))


class LandingOracle:
    """The documented outcome rules and the paper's reward, from observations (and, for a dome exit,
    the steps the episode had left: ``steps_left``)."""

    def __init__(self, obs, sparse):
        self.sparse = sparse
        self.speed = np.linalg.norm(obs[7:10])
        self.on_pad = False
        self.halted = 0
        self.seen = set()

    def __call__(self, obs, info, steps_left=0):
        ang_vel, quaternion, lin_vel, position = obs[0:3], obs[3:7], obs[7:10], obs[10:13]
        on_pad = obs[-1] == 1.0
        speed = float(np.linalg.norm(lin_vel))
        tilt = _tilt(quaternion)
        ground = info["ground_contact"]
        fatal = safe = False
        if on_pad:
            if not self.on_pad:
                fatal = max(self.speed, speed) >= 1.0
                self.halted = 0
            fatal = fatal or tilt > math.radians(30.0)
            still = speed < 0.1 and np.linalg.norm(ang_vel) < 0.1 and tilt < math.radians(10.0)
            self.halted = self.halted + 1 if still and not fatal else 0
            safe = self.halted >= HALT_STEPS and not ground
        else:
            self.halted = 0
        self.on_pad, self.speed = on_pad, speed
        out_of_bounds = np.linalg.norm(position) > 500.0
        assert out_of_bounds == info["out_of_bounds"]
        assert (safe, fatal, on_pad) == (info["safe_landing"], info["fatal_landing"], info["pad_contact"])
        d_pad = float(np.linalg.norm(position - [0.0, 0.0, PAD_TOP]))
        reward = 0.0 if self.sparse else -0.2 * d_pad - speed / d_pad**2
        reward += 100.0 * safe - 20.0 * fatal - 100.0 * ground - 100.0 * out_of_bounds
        if out_of_bounds and not self.sparse:  # r_d for the rest of the episode, at the exit distance
            reward += -0.2 * d_pad * steps_left
        self.seen |= {
            name
            for name, flag in (
                ("safe", safe),
                ("fatal", fatal),
                ("ground", ground),
                ("oob", out_of_bounds),
                ("pad", on_pad),
            )
            if flag
        }
        return reward, safe or fatal or ground or out_of_bounds


@pytest.mark.parametrize("sparse", [False, True])
def test_reward_matches_the_paper_on_flights_and_set_states(make, sparse):
    env = make(ROCKET, sparse_reward=sparse, angle_representation="quaternion")
    rng = np.random.default_rng(0)
    seen, checked = set(), 0
    for episode in range(16):
        obs, _ = env.reset(seed=episode)
        kind = episode % 4
        if kind == 0:  # the real drop, random actions for a while
            steps = 40
        else:
            obs = _drop_in_from_above(env)[0]
            steps = 120
            if kind == 1:  # near the pad, moving, tilted
                _place(
                    env,
                    (*rng.uniform(-3, 3, 2), rng.uniform(2.2, 6.0)),
                    rng.uniform(-0.4, 0.4, 3),
                    rng.uniform(-3, 3, 3),
                    rng.uniform(-0.5, 0.5, 3),
                )
            elif kind == 2:  # gently onto the pad, upright
                _place(env, (*rng.uniform(-0.5, 0.5, 2), STAND + 0.02), (0.0, 0.0, rng.uniform(-3, 3)), (0, 0, -0.1))
            else:  # beside the pad or far out
                position = (rng.uniform(4, 8), 0.0, 3.0) if episode % 8 == 3 else (0.0, 0.0, 499.9)
                _place(env, position, lin_vel=(0, 0, -2.0 if position[2] < 10 else 3.0))
        oracle = LandingOracle(obs, sparse)
        for _ in range(steps):
            action = (
                np.zeros(7)
                if kind == 2
                else np.array([*rng.uniform(-1, 1, 3), rng.uniform(0, 0.6), rng.uniform(0, 1), *rng.uniform(-1, 1, 2)])
            )
            obs, reward, terminated, truncated, info = env.step(action)
            # 30 s at 30 Hz: 900 steps per episode
            expected, ended = oracle(obs, info, steps_left=900 - env.unwrapped.elapsed_steps)
            assert reward == pytest.approx(expected, rel=1e-12, abs=1e-9)
            assert reward == pytest.approx(sum(info["reward_terms"].values()), abs=1e-12)
            assert terminated == ended and not truncated
            checked += 1
            if terminated:
                break
        seen |= oracle.seen
    assert checked > 300
    assert {"safe", "fatal", "ground", "oob", "pad"} <= seen


def test_safe_landing_succeeds_after_an_upright_halt(make):
    env = make(ROCKET)
    env.reset(seed=0)
    _drop_in_from_above(env)
    _place(env, (0.4, -0.3, STAND + 0.03), (0.0, 0.0, 0.5), (0.0, 0.0, -0.2))  # 3 cm up, 0.2 m/s down
    for step in range(1, 120):
        obs, reward, terminated, truncated, info = env.step(np.zeros(7))  # booster out
        assert not info["ground_contact"] and not info["fatal_landing"]
        if terminated:
            break
    assert terminated and not truncated and step >= HALT_STEPS
    assert info["success"] and info["env_complete"] and info["safe_landing"] and not info["fatal_landing"]
    assert 0.0 <= info["touchdown_speed"] < 1.0
    terms = info["reward_terms"]
    assert terms["safe_landing"] == 100.0 and terms["fatal_landing"] == 0.0 and terms["ground_contact"] == 0.0
    d_pad = np.linalg.norm(np.array(env.state.lin_pos) - [0, 0, PAD_TOP])
    assert 1.6 < d_pad < 1.9  # standing on its legs
    assert reward == pytest.approx(100.0 - 0.2 * d_pad - np.linalg.norm(env.state.lin_vel) / d_pad**2)
    assert obs[-1] == 1.0  # the pad contact flag


@pytest.mark.parametrize("sparse", [False, True])
def test_hitting_the_pad_at_5_m_s_is_fatal(make, sparse):
    env = make(ROCKET, sparse_reward=sparse)
    env.reset(seed=1)
    _drop_in_from_above(env)
    _place(env, (0.0, 0.0, STAND + 0.3), lin_vel=(0.0, 0.0, -4.6))
    for _ in range(10):
        _obs, reward, terminated, _truncated, info = env.step(np.zeros(7))
        if terminated:
            break
    assert terminated and info["fatal_landing"] and not info["success"] and not info["safe_landing"]
    assert info["pad_contact"] and not info["ground_contact"] and info["collision"]
    assert 4.6 < info["touchdown_speed"] < 5.5
    assert info["reward_terms"]["fatal_landing"] == -20.0 and info["reward_terms"]["safe_landing"] == 0.0
    if sparse:
        assert reward == -20.0


@pytest.mark.parametrize("v0, height, fatal", [(0.57, 0.04, False), (0.78, 0.05, True)])
def test_the_1_m_s_touchdown_limit(make, v0, height, fatal):
    """Falling from ``height`` above the pad at ``v0``: one step in the air (+ g/30 = 0.33 m/s),
    contact in the second, whose start speed (~0.9 or ~1.1 m/s) is the touchdown speed."""
    env = make(ROCKET)
    env.reset(seed=2)
    _drop_in_from_above(env)
    _place(env, (0.0, 0.0, STAND + height), lin_vel=(0.0, 0.0, -v0))
    obs, reward, terminated, truncated, info = env.step(np.zeros(7))
    assert not info["pad_contact"]
    start_speed = np.linalg.norm(env.state.lin_vel)
    _obs, _reward, terminated, _truncated, info = env.step(np.zeros(7))
    assert info["pad_contact"] and info["touchdown_speed"] == pytest.approx(start_speed)
    assert (info["touchdown_speed"] >= 1.0) == fatal and abs(info["touchdown_speed"] - 1.0) < 0.15
    assert info["fatal_landing"] == fatal and terminated == fatal
    assert info["reward_terms"]["fatal_landing"] == (-20.0 if fatal else 0.0)


def test_tipping_over_on_the_pad_is_fatal(make):
    env = make(ROCKET)
    env.reset(seed=3)
    _drop_in_from_above(env)
    _place(env, (0.0, 0.0, STAND + 0.002), lin_vel=(0.0, 0.0, -0.1))
    obs, reward, terminated, truncated, info = env.step(np.zeros(7))
    assert info["pad_contact"] and not terminated and info["touchdown_speed"] < 1.0
    # shove it over: a roll rate about one pair of legs
    state = env.state
    _place(env, state.lin_pos, state.ang_pos, (0.0, 0.0, 0.0), (2.5, 0.0, 0.0))
    for _ in range(60):
        _obs, _reward, terminated, _truncated, info = env.step(np.zeros(7))
        if terminated:
            break
    assert terminated and info["fatal_landing"] and not info["success"]
    assert _tilt(env.state.quaternion) > math.radians(30.0)
    assert info["pad_contact"] and info["touchdown_speed"] < 1.0  # tipped over, not a hard touchdown
    assert info["reward_terms"]["fatal_landing"] == -20.0


@pytest.mark.parametrize("sparse", [False, True])
def test_ground_contact_off_the_pad_costs_100(make, sparse):
    env = make(ROCKET, sparse_reward=sparse)
    env.reset(seed=4)
    _place(env, (8.0, 3.0, 3.0), lin_vel=(0.0, 0.0, -2.0))
    for _ in range(30):
        _obs, reward, terminated, _truncated, info = env.step(np.zeros(7))
        if terminated:
            break
    assert terminated and info["ground_contact"] and info["collision"] and not info["pad_contact"]
    assert not info["success"] and not info["fatal_landing"]
    contacts = p.getContactPoints(bodyA=env.vehicle.body_id, physicsClientId=env.world.client)
    assert any(c[2] == env.world.ground_id for c in contacts)  # really on the ground
    assert info["reward_terms"]["ground_contact"] == -100.0
    if sparse:
        assert reward == -100.0
    else:
        d_pad = np.linalg.norm(np.array(env.state.lin_pos) - [0, 0, PAD_TOP])
        assert reward == pytest.approx(-100.0 - 0.2 * d_pad - np.linalg.norm(env.state.lin_vel) / d_pad**2)


def test_the_drop_starts_450_m_up_with_1_percent_fuel_and_a_seeded_perturbation(make):
    env = make(ROCKET, angle_representation="euler")
    starts = []
    for seed in range(6):
        obs, info = env.reset(seed=seed)
        s = env.state
        assert s.lin_pos[2] == pytest.approx(450.0)
        assert max(abs(s.lin_pos[0]), abs(s.lin_pos[1])) <= 20.0
        assert max(abs(a) for a in s.ang_pos) <= 0.3 + 1e-9
        assert max(abs(v) for v in s.lin_vel_ground) <= 5.0 + 1e-9  # ground frame, per axis
        assert max(abs(w) for w in s.ang_vel) <= 0.5 + 1e-9  # body frame, per axis
        starts.append(np.array([*s.lin_vel_ground, *s.ang_vel]))
        fuel, duty, ignited = env.vehicle.aux_state[4:7]
        assert fuel == pytest.approx(0.01) and duty == 0.0 and ignited == 0.0
        assert obs[12 + 7 + 4] == pytest.approx(0.01)  # Euler: 12 + previous action 7 + fins 4, then fuel
        assert env.vehicle.mass == pytest.approx(DRY_MASS + 0.01 * FULL_TANK)
        assert info["touchdown_speed"] == -1.0 and not info["pad_contact"]
    starts = np.array(starts)
    # the initial velocity really is applied, and differs between seeds (the reference's bug)
    assert np.all(np.linalg.norm(starts[:, :3], axis=1) > 0.1) and np.all(np.linalg.norm(starts[:, 3:], axis=1) > 0.01)
    assert len({tuple(np.round(row, 9)) for row in starts}) == len(starts)
    # and it is in the physics, not just reported: over one step the body drifts with it
    env.reset(seed=0)
    p0, v0 = np.array(env.state.lin_pos), np.array(env.state.lin_vel_ground)
    env.step(np.zeros(7))
    np.testing.assert_allclose((np.array(env.state.lin_pos) - p0)[:2] * 30.0, v0[:2], atol=0.05)
    np.testing.assert_allclose(np.array(env.state.lin_vel_ground)[:2], v0[:2], atol=0.05)


def test_one_percent_fuel_lasts_about_2_8_s_at_full_throttle(make):
    env = make(ROCKET, sparse_reward=True, flight_dome_size=5000.0)  # it climbs out of the 500 m dome
    env.reset(seed=5)
    burn = np.array([0, 0, 0, 1.0, 1.0, 0, 0])
    fuel = []
    for _ in range(120):
        _obs, _reward, terminated, _truncated, _info = env.step(burn)
        fuel.append(env.vehicle.aux_state[4] * FULL_TANK)
        if terminated:
            break
    fuel = np.array(fuel)
    empty = int(np.argmax(fuel <= 0.0))
    assert fuel[0] < 0.01 * FULL_TANK and fuel[-1] == 0.0
    assert 0.01 * FULL_TANK / 1.451 * 30 - 3 <= empty + 1 <= 0.01 * FULL_TANK / 1.451 * 30 + 3  # ~85 steps
    assert env.vehicle.aux_state[5] == 0.0  # no fuel: no thrust


def test_time_limit_truncates_without_success(make):
    env = make(ROCKET, max_duration_seconds=0.5)
    env.reset(seed=0)
    results = [env.step(np.zeros(7)) for _ in range(15)]
    assert [r[3] for r in results] == [False] * 14 + [True]
    assert not any(r[2] for r in results) and not results[-1][4]["success"]


def _hoverslam(obs, landed, a_brake=35.0, v_land=0.6, h_slow=2.0):
    """A vertical landing controller: free fall, then burn to hold v_z on the braking curve
    v_ref(h) = -sqrt(2 a_brake (h - h_slow)) (and -v_land below h_slow), booster out from the first pad contact."""
    v_z = float(quaternion_to_matrix(obs[3:7])[2] @ obs[7:10])  # ground-frame vertical speed
    h = float(obs[12]) - STAND
    action = np.zeros(7)
    if landed or obs[-1] == 1.0:
        return action, True
    v_ref = -max(v_land, math.sqrt(2.0 * a_brake * max(h - h_slow, 0.0)))
    error = v_ref - v_z  # > 0: falling faster than the curve
    if error > 0.05:
        mass = DRY_MASS + 0.01 * FULL_TANK
        action[3] = 1.0
        action[4] = np.clip((mass * (9.81 + 8.0 * error) - 2966.7) / (7607.0 - 2966.7), 0.0, 1.0)
    return action, False


def _fly(env, policy):
    obs, _ = env.reset(seed=0)
    landed, total = False, 0.0
    while True:
        if policy == "fall":
            action = np.zeros(7)
        else:
            action, landed = _hoverslam(obs, landed)
        obs, reward, terminated, truncated, info = env.step(action)
        total += reward
        if terminated or truncated:
            return total, info


def test_a_scripted_hoverslam_lands_from_the_450_m_drop_and_the_envelope_reward_prefers_it(make):
    """Feasibility: the Rocket as configured (1 % fuel, minimum thrust above the weight) can land
    safely from 450 m: a burn along a 35 m/s^2 braking curve, then pulses near the pad, lands at
    < 1 m/s and halts upright.  The braking-envelope preset pays this landing far more than
    falling straight onto the pad; under the paper's dense reward the two are within 1 %."""
    noise = ("start_position_noise", "start_orientation_noise", "start_velocity_noise", "start_ang_vel_noise")
    still = dict.fromkeys(noise, 0.0)
    returns = {}
    for reward in ("rocket_landing_envelope", "rocket_landing_dense"):
        env = make(ROCKET, reward=reward, **still)
        landing, info = _fly(env, "hoverslam")
        assert info["safe_landing"] and info["success"] and 0.0 <= info["touchdown_speed"] < 1.0
        assert env.vehicle.aux_state[4] * FULL_TANK > 0.0  # fuel left
        crash, info = _fly(env, "fall")
        assert info["fatal_landing"] and info["touchdown_speed"] > 50.0  # straight onto the pad
        returns[reward] = (landing, crash)
    landing, crash = returns["rocket_landing_envelope"]
    assert landing - crash > 300.0
    landing, crash = returns["rocket_landing_dense"]
    assert abs(landing - crash) < 0.01 * abs(crash)


def test_a_mode_without_a_matching_action_layout_is_refused_with_the_layout():
    """``env.action.mode=velocity`` on the raw-channel config: the message names the mode's layout."""
    from pyflyt_engine.envs import make_env
    from pyflyt_engine.envs.config import load_env_config
    from pyflyt_engine.errors import ConfigError

    data = load_env_config("rocket_landing").model_dump(exclude={"source"})
    data["action"]["mode"] = "velocity"
    with pytest.raises(ConfigError, match=r"takes 4 \(vx, vy, vz, ignition\): give action.names, low and high"):
        make_env(data)

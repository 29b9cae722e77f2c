"""Rewards against the paper's formulas, evaluated here by hand from the observed state.

The oracles below never call the env's reward code: they read the position, attitude
and flags from observations (and the sampled waypoints from the task), apply the
paper's equations, and compare.  States come from random flights and from setting the
body's pose and velocity directly in PyBullet.  Every reward must also equal the sum of
its ``info["reward_terms"]`` breakdown.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest

from pyflyt_engine.envs import rewards
from pyflyt_engine.envs.config import load_reward_preset
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.state import KinematicState
from tests.envs.conftest import PROFILES

HOVER = "PyFlyt/QuadX-Hover-v0"
WAYPOINTS = "PyFlyt/QuadX-Waypoints-v0"
AGENT_HZ = 30.0


def _set_state(env, position, rpy, lin_vel, ang_vel):
    cid, body = env.world.client, env.vehicle.body_id
    p.resetBasePositionAndOrientation(body, list(position), p.getQuaternionFromEuler(list(rpy)), physicsClientId=cid)
    p.resetBaseVelocity(body, list(lin_vel), list(ang_vel), physicsClientId=cid)


def _check_breakdown(reward, info):
    assert reward == pytest.approx(sum(info["reward_terms"].values()), abs=1e-12)


def _policy(rng):
    """Random actions that keep the quad airborne for a while (rates small, thrust ~ hover)."""
    return np.array([*rng.uniform(-1.5, 1.5, 3), rng.uniform(0.05, 0.3)])


# ------------------------------------------------------------------------ hover


def hover_oracle(obs, info, sparse, dome=3.0):
    """Paper: -100 if crash, else -||[theta, phi]|| - ||[x, y, z - 1]||; sparse -0.1 per step."""
    roll, pitch = obs[3], obs[4]  # Euler observation: ang_vel 0:3, ang_pos 3:6
    x, y, z = obs[9:12]
    out_of_bounds = math.sqrt(x * x + y * y + z * z) > dome
    assert out_of_bounds == info["out_of_bounds"]
    if info["collision"] or out_of_bounds:
        return -100.0
    if sparse:
        return -0.1
    return -math.sqrt(pitch * pitch + roll * roll) - math.sqrt(x * x + y * y + (z - 1.0) ** 2)


@pytest.mark.parametrize("sparse", [False, True])
def test_hover_reward_matches_the_paper_on_random_flights(make, sparse):
    env = make(HOVER, sparse_reward=sparse, angle_representation="euler")
    rng = np.random.default_rng(0)
    crashes = steps = 0
    for episode in range(6):
        env.reset(seed=episode)
        for _ in range(80):
            obs, reward, terminated, truncated, info = env.step(_policy(rng))
            assert reward == pytest.approx(hover_oracle(obs, info, sparse), abs=1e-9)
            _check_breakdown(reward, info)
            steps += 1
            if terminated or truncated:
                crashes += terminated
                break
    assert steps > 100 and crashes > 0


@pytest.mark.parametrize("sparse", [False, True])
def test_hover_reward_matches_the_paper_on_set_states(make, sparse):
    env = make(HOVER, sparse_reward=sparse, angle_representation="euler")
    rng = np.random.default_rng(1)
    kinds = set()
    for i in range(40):
        env.reset(seed=100 + i)
        kind = i % 4
        if kind == 0:  # anywhere inside the dome, tilted, moving
            position = [*rng.uniform(-1.5, 1.5, 2), rng.uniform(0.3, 2.0)]
        elif kind == 1:  # outside the dome
            position = [*rng.uniform(2.5, 3.0, 2), rng.uniform(1.0, 2.0)]
        elif kind == 2:  # just above the ground, falling
            position = [*rng.uniform(-1, 1, 2), 0.02]
        else:  # near the hover point
            position = [*rng.uniform(-0.05, 0.05, 2), 1.0 + rng.uniform(-0.05, 0.05)]
        velocity = [0, 0, -1.0] if kind == 2 else rng.uniform(-1, 1, 3)
        _set_state(env, position, rng.uniform(-0.6, 0.6, 3), velocity, rng.uniform(-2, 2, 3))
        obs, reward, terminated, truncated, info = env.step(_policy(rng))
        expected = hover_oracle(obs, info, sparse)
        assert reward == pytest.approx(expected, abs=1e-9)
        _check_breakdown(reward, info)
        kinds.add(("crash" if expected == -100 else "alive", kind))
        if kind in (1, 2):
            assert terminated and expected == -100.0
    assert ("alive", 0) in kinds and ("alive", 3) in kinds


# -------------------------------------------------------------------- waypoints


def _segment_distance(a, b, c):
    ab, ac = b - a, c - a
    t = 0.0 if ab @ ab == 0 else float(np.clip((ac @ ab) / (ab @ ab), 0.0, 1.0))
    return float(np.linalg.norm(ac - t * ab))


class WaypointOracle:
    """The paper's waypoint reward, written out independently of the env.

    Defaults are QuadX-Waypoints' c_a = 0.1, c_b = 3, d = 0.2 m, dome 5 m (see the env
    docstring); Fixedwing-Waypoints uses the same formula with its own constants.
    delta_dot is the change of delta over the agent step [m] (the shipped dense presets),
    or with ``per_second`` its rate [m/s] (the ``*_dense_rate`` presets).
    """

    def __init__(
        self, targets, position, sparse, dome=5.0, c_a=0.1, c_b=3.0, reach=0.2, per_second=False, agent_hz=AGENT_HZ
    ):
        self.targets, self.position, self.sparse, self.dome = targets, np.array(position), sparse, dome
        self.c_a, self.c_b, self.reach = c_a, c_b, reach
        self.rate_scale = agent_hz if per_second else 1.0
        self.index = 0
        self.branches = set()

    def __call__(self, obs, info):
        position = obs["attitude"][10:13]  # quaternion observation: lin_pos 10:13
        out_of_bounds = np.linalg.norm(position) > self.dome
        assert out_of_bounds == info["out_of_bounds"]
        target = self.targets[self.index]
        delta = np.linalg.norm(position - target)
        delta_dot = (delta - np.linalg.norm(self.position - target)) * self.rate_scale
        reached = _segment_distance(self.position, position, target) < self.reach
        self.position = position.copy()
        if reached:
            self.index += 1
        if info["collision"] or out_of_bounds:
            branch, reward = "crash", -100.0
        elif reached:
            branch, reward = "reached", 100.0
        elif self.sparse:
            branch, reward = "nothing", 0.0
        elif delta_dot < 0:
            branch, reward = "approaching", self.c_a / delta - self.c_b * delta_dot
        else:
            branch, reward = "receding", self.c_a / delta
        self.branches.add(branch)
        assert info["num_targets_reached"] == self.index
        return reward


@pytest.mark.parametrize(
    ("reward", "agent_hz"), [("dense", 30), ("dense", 60), ("quadx_waypoints_dense_rate", 30), ("sparse", 30)]
)
def test_waypoint_reward_matches_the_paper_on_random_flights_and_set_states(make, reward, agent_hz):
    env = make(WAYPOINTS, reward=reward, agent_hz=agent_hz)
    rng = np.random.default_rng(2)
    checked = 0
    sparse, per_second = reward == "sparse", reward.endswith("_rate")
    for episode in range(12):
        obs, _ = env.reset(seed=episode)
        oracle = WaypointOracle(
            env.task.targets, obs["attitude"][10:13], sparse, per_second=per_second, agent_hz=agent_hz
        )
        for step in range(60):
            if episode % 2 and step % 3 == 0:
                # put the vehicle somewhere around its next waypoint, some of the time within d
                target = oracle.targets[oracle.index]
                offset = rng.normal(size=3)
                offset *= rng.choice([0.1, 0.3, 1.0]) / np.linalg.norm(offset)
                _set_state(env, target + offset, rng.uniform(-0.3, 0.3, 3), rng.uniform(-2, 2, 3), [0, 0, 0])
            obs, reward, terminated, truncated, info = env.step(_policy(rng))
            assert reward == pytest.approx(oracle(obs, info), rel=1e-9, abs=1e-9)
            _check_breakdown(reward, info)
            checked += 1
            if terminated or truncated:
                break
    assert checked > 200


@pytest.mark.parametrize("sparse", [False, True])
def test_every_waypoint_branch_is_exercised(make, sparse):
    """Set states around the waypoints so that every case of the piecewise reward occurs."""
    env = make(WAYPOINTS, sparse_reward=sparse)
    rng = np.random.default_rng(3)
    seen = set()
    for episode in range(10):
        obs, _ = env.reset(seed=50 + episode)
        oracle = WaypointOracle(env.task.targets, obs["attitude"][10:13], sparse)
        for step in range(40):
            if step % 4 == 0:
                target = oracle.targets[oracle.index]
                offset = rng.normal(size=3)
                offset *= rng.choice([0.1, 0.5]) / np.linalg.norm(offset)
                _set_state(env, target + offset, [0, 0, 0], rng.uniform(-1, 1, 3), [0, 0, 0])
            obs, reward, terminated, truncated, info = env.step(_policy(rng))
            assert reward == pytest.approx(oracle(obs, info), rel=1e-9, abs=1e-9)
            if terminated or truncated:
                break
        seen |= oracle.branches
    expected = {"crash", "reached", "nothing"} if sparse else {"crash", "reached", "approaching", "receding"}
    assert expected <= seen


# ------------------------------------------------------------- pure terms


def _ctx(**kw):
    state = KinematicState(
        ang_vel=(0.1, -0.2, 0.3),
        ang_pos=(0.3, -0.4, 1.0),
        lin_vel=(1.0, 2.0, 2.0),
        lin_pos=(1.0, 2.0, 3.0),
        quaternion=(0.0, 0.0, 0.0, 1.0),
        lin_vel_ground=(0.0, 0.0, 0.0),
        ang_vel_ground=(0.0, 0.0, 0.0),
    )
    base = dict(state=state, action=np.array([3.0, 4.0]), collision=False, ground_collision=False, out_of_bounds=False)
    base = {**base, **kw}
    base.setdefault("crashed", base["collision"] or base["out_of_bounds"])
    return rewards.StepContext(**base)


def test_terms_are_pure_functions_with_the_documented_values():
    ctx = _ctx(target_distance=0.5, target_distance_rate=-2.0)
    assert rewards.tilt(ctx) == pytest.approx(0.5)
    assert rewards.distance_to_point(ctx, point=(1.0, 2.0, 1.0)) == pytest.approx(2.0)
    assert rewards.inverse_target_distance(ctx) == pytest.approx(2.0)
    assert rewards.target_distance_rate(ctx) == -2.0
    assert rewards.speed(ctx) == pytest.approx(3.0)
    assert rewards.action_magnitude(ctx) == pytest.approx(5.0)
    assert rewards.altitude(ctx) == 3.0
    assert rewards.approaching(ctx) and not rewards.approaching(_ctx(target_distance_rate=0.0))
    assert rewards.crash(_ctx(out_of_bounds=True)) and rewards.crash(_ctx(collision=True)) and not rewards.crash(ctx)
    assert rewards.target_distance_over_remaining_steps(_ctx(target_distance=0.5, steps_remaining=12)) == 6.0
    assert rewards.target_distance_decrease(_ctx(target_distance_rate=-2.0, agent_dt=0.25)) == 0.5


def test_speed_above_braking_envelope_by_hand():
    term = rewards.speed_above_braking_envelope  # ||v|| = 3 m/s in _ctx
    # 10 m from the target, envelope from 1 m at 0.5 m/s braking at 0.125 m/s^2: 0.5 + sqrt(2 * 0.125 * 9) = 2
    assert term(_ctx(target_distance=10.0), deceleration=0.125, floor_speed=0.5, floor_distance=1.0) == pytest.approx(
        1.0
    )
    # inside the envelope (0.5 + sqrt(2 * 30 * 9) = 23.7 m/s): nothing
    assert term(_ctx(target_distance=10.0), deceleration=30.0, floor_speed=0.5, floor_distance=1.0) == 0.0
    # at or below floor_distance only floor_speed is allowed
    assert term(_ctx(target_distance=0.5), deceleration=30.0, floor_speed=0.5, floor_distance=1.0) == pytest.approx(2.5)


@pytest.mark.parametrize("bad", [-1.0, "fast", True])
def test_a_braking_envelope_parameter_must_be_a_nonnegative_number(bad):
    terms = {"e": {"term": "speed_above_braking_envelope", "params": {"deceleration": bad}}}
    with pytest.raises(ConfigError, match="'deceleration' must be a number >= 0"):
        rewards.compile_reward("x", terms)


@pytest.mark.parametrize(
    ("preset", "per_metre"),
    [("quadx_waypoints_dense", 3.0), ("quadx_waypoints_dense_rate", 3.0 * 30)],  # c_b; c_b x agent_hz
)
def test_waypoint_dense_presets_are_continuous_at_zero_rate_and_pay_their_rate_per_metre(preset, per_metre):
    reward = load_reward_preset(preset).compile()
    dt = 1.0 / 30  # the env's 30 Hz agent step
    at = lambda rate: reward(_ctx(target_distance=0.7, target_distance_rate=rate, agent_dt=dt))[0]  # noqa: E731
    assert at(-1e-9) == pytest.approx(at(0.0), abs=1e-6) == pytest.approx(at(1e-9), abs=1e-6)
    assert at(0.0) == pytest.approx(0.1 / 0.7)
    # closing 1 m in one step (delta_dot = -30 m/s at 30 Hz) pays c_b or c_b x 30 on top of c_a / delta
    assert at(-30.0) == pytest.approx(0.1 / 0.7 + per_metre)
    assert at(2.0) == pytest.approx(0.1 / 0.7)  # receding costs nothing
    total, terms = reward(_ctx(target_distance=0.1, target_distance_rate=-5.0, waypoint_reached=True, agent_dt=dt))
    assert total == 100.0 and terms["waypoint_bonus"] == 100.0 and terms["proximity"] == 0.0
    total, terms = reward(
        _ctx(target_distance=0.1, target_distance_rate=-5.0, waypoint_reached=True, collision=True, agent_dt=dt)
    )
    assert total == -100.0  # a crash takes precedence


# ------------------------------------------------------------ user presets


def test_a_user_preset_yaml_changes_the_reward_as_declared(make, tmp_path):
    preset = tmp_path / "my_reward.yaml"
    preset.write_text(
        "description: stay alive, higher is better\n"
        "terms:\n"
        "  alive: {term: constant, weight: 2.0, when: not_crash}\n"
        "  height: {term: altitude, weight: 0.5, when: [not_crash, not_out_of_bounds]}\n"
        "  near: {term: distance_to_point, weight: -1.0, params: {point: [1.0, 0.0, 2.0]}}\n"
        "  boom: {term: constant, weight: -7.0, when: crash}\n"
    )
    env = make(HOVER, reward=str(preset), angle_representation="euler")
    assert env.reward_preset.name == "my_reward"
    env.reset(seed=0)
    rng = np.random.default_rng(4)
    crashed = False
    for _ in range(200):
        obs, reward, terminated, truncated, info = env.step(_policy(rng))
        x, y, z = obs[9:12]
        crash = info["collision"] or info["out_of_bounds"]
        near = -math.sqrt((x - 1.0) ** 2 + y * y + (z - 2.0) ** 2)
        expected = near + (-7.0 if crash else 2.0 + 0.5 * z)
        assert reward == pytest.approx(expected, abs=1e-9)
        assert list(info["reward_terms"]) == ["alive", "height", "near", "boom"]
        _check_breakdown(reward, info)
        if terminated or truncated:
            crashed = crash
            break
    assert crashed
    # the same preset, given inline from Python
    inline = make(HOVER, reward={"terms": {"alive": {"term": "constant", "weight": 3.0}}})
    inline.reset(seed=0)
    assert inline.step(np.array([0, 0, 0, 0.125]))[1] == 3.0


def test_sparse_reward_selects_the_sparse_preset(make):
    assert make(HOVER).reward_preset.name == "quadx_hover_dense"
    assert make(HOVER, sparse_reward=True).reward_preset.name == "quadx_hover_sparse"
    assert make(WAYPOINTS, reward="sparse").reward_preset.name == "quadx_waypoints_sparse"
    assert make(HOVER, reward="quadx_hover_sparse").reward_preset.name == "quadx_hover_sparse"
    with pytest.raises(ConfigError, match="either sparse_reward or reward"):
        make(HOVER, sparse_reward=True, reward="dense")


@pytest.mark.parametrize("env_id", list(PROFILES))
def test_reward_terms_can_be_left_out_of_info(make, env_id):
    """The breakdown is in ``info`` by default; ``info_reward_terms=False`` (lighter steps
    in vector envs) leaves it out, ``last_reward_terms`` still has it, nothing else differs."""
    lean, full = make(env_id, info_reward_terms=False), make(env_id)
    assert not lean.info_reward_terms and full.info_reward_terms
    rng = np.random.default_rng(1)
    policy = PROFILES[env_id].policy
    for env in (lean, full):
        env.reset(seed=3)
        assert env.last_reward_terms == {}
    for _ in range(20):
        action = policy(rng)
        obs_l, reward_l, term_l, trunc_l, info_l = lean.step(action)
        obs_f, reward_f, term_f, trunc_f, info_f = full.step(action)
        assert "reward_terms" not in info_l
        assert info_f["reward_terms"] == full.last_reward_terms == lean.last_reward_terms
        assert list(lean.last_reward_terms) == list(lean.reward_preset.terms)
        _check_breakdown(reward_l, {"reward_terms": lean.last_reward_terms})
        assert reward_l == reward_f and (term_l, trunc_l) == (term_f, trunc_f)
        assert {k: v for k, v in info_f.items() if k != "reward_terms"} == info_l
        for key in obs_l if isinstance(obs_l, dict) else [None]:
            np.testing.assert_array_equal(obs_l if key is None else obs_l[key], obs_f if key is None else obs_f[key])
        if term_l or trunc_l:
            break
    # a copy: changing it changes nothing in the env
    lean.last_reward_terms.clear()
    assert lean.last_reward_terms

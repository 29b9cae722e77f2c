"""Payloads declared in env configs (pyflyt_engine.payloads) and the pole tasks.

Physics against oracles (pendulum period, tether length and slack free fall, a welded
payload keeping its pose), validation messages, deliberate terminations, rewards against
their formulas on constructed states, recordings carrying the payloads.
"""

from __future__ import annotations

import copy
import math
import warnings

import gymnasium
import numpy as np
import pybullet as p
import pytest
from typer.testing import CliRunner

import pyflyt_engine  # noqa: F401
from pyflyt_cli.main import app
from pyflyt_engine.constants import GRAVITY
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config, load_reward_preset
from pyflyt_engine.envs.rewards import StepContext
from pyflyt_engine.envs.tasks.pole import pole_lean
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.state import KinematicState

POLE = {
    "name": "pole",
    "body": {"shapes": [{"type": "cylinder", "radius": 0.005, "length": 1.0, "position": [0, 0, 0.5], "mass": 0.2}]},
    "attach": {"to": "vehicle", "joint": "ball", "anchor": [0, 0, 0.05]},
    "position": [0, 0, 0.05],
}


def hover_config(payloads, **changes):
    """quadx_hover's config (an unregistered copy) carrying ``payloads``."""
    cfg = load_env_config("quadx_hover").model_dump(exclude={"source"})
    cfg.update(id=None, payloads=payloads, **changes)
    return cfg


def build(payloads, **changes):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return make_env(hover_config(payloads, **changes))


# ------------------------------------------------------------------ validation


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda pl: pl["body"]["shapes"][0].pop("mass"), "payloads.0.body: body.mass and inertia missing"),
        (
            lambda pl: pl["body"].update(mass=0.0, inertia=[1e-3, 1e-3, 1e-3]),
            "payloads.0.body.mass: mass must be a positive",
        ),
        (
            lambda pl: pl.update(attach={"to": "vehicle", "joint": "tether", "length": 0.0}),
            "payloads.0.attach: tether length must be > 0 m, got 0.0",
        ),
        (
            lambda pl: pl.update(attach={"to": "vehicle", "joint": "tether"}),
            "a tether needs 'length'",
        ),
        (
            lambda pl: pl.update(attach={"to": "vehicle", "joint": "tether", "length": 0.3}, position=[0, 0, -0.5]),
            "farther than the tether length 0.3 m",
        ),
        (
            lambda pl: pl.update(
                attach={"to": "vehicle", "joint": "tether", "length": 2.0, "payload_anchor": [0.1, 0, 0]},
                position=[0, 0, -1.5],  # tied 0.1 m beside the pole's lower end: its middle is off the string
            ),
            "centre of mass must lie on its string's line",
        ),
        (lambda pl: pl.update(mass=1.0), "payloads.0.mass: unknown key 'mass'"),
        (
            lambda pl: pl.update(attach={"to": "world", "joint": "fixed"}, position=[0, 0, 9.0]),
            "outside the flight dome",
        ),
        (lambda pl: pl.update(name="bad name"), "payloads.0.name"),
    ],
)
def test_bad_payloads_are_refused_with_one_message_naming_the_key(change, message):
    payload = copy.deepcopy(POLE)
    change(payload)
    with pytest.raises(ConfigError) as info:
        load_env_config(hover_config([payload]))
    assert message in str(info.value)


def test_duplicate_payload_names_are_refused():
    with pytest.raises(ConfigError, match="payload name 'pole' is used twice"):
        load_env_config(hover_config([POLE, POLE]))


def test_bad_payload_from_the_command_line_exits_2():
    result = CliRunner().invoke(
        app, ["train", "env=quadx_pole_balance", "env.payloads.0.body.shapes.0.mass=0", "--cfg"]
    )
    assert result.exit_code == 2, result.output
    assert "payloads.0.body: body.mass and inertia missing" in result.output
    assert "Traceback" not in result.output


def test_pole_task_without_its_payload_is_refused():
    cfg = load_env_config("quadx_pole_balance").model_dump(exclude={"source"})
    cfg["payloads"] = []
    with pytest.raises(ConfigError, match="needs a payload named 'pole'"):
        make_env(cfg)


# --------------------------------------------------------------------- physics


def _world_pendulum_period(env, payload, steps):
    """Period [s] of a payload swinging in the world, from zero crossings of its x coordinate."""
    cid = env.world.client
    xs = []
    for _ in range(steps):
        p.stepSimulation(physicsClientId=cid)
        xs.append(env.payloads.state(payload).position[0])
    xs = np.array(xs)
    up = np.flatnonzero((xs[:-1] < 0) & (xs[1:] >= 0))
    return float(np.mean(np.diff(up))) * env.world.physics_dt


def test_ball_joint_pendulum_has_the_compound_pendulum_period():
    # a uniform rod of length L pivoted at one end: T = 2 pi sqrt(2 L / (3 g)) for small swings
    rod = {
        "name": "rod",
        "body": {
            "shapes": [{"type": "cylinder", "radius": 0.005, "length": 1.0, "position": [0, 0, -0.5], "mass": 0.2}]
        },
        "attach": {"to": "world", "joint": "ball", "anchor": [0.0, 0.0, 2.0]},
        "position": [0.0, 0.0, 2.0],
        "orientation": [0.0, 0.05, 0.0],  # 0.05 rad swing
    }
    env = build([rod], drag=False)
    env.reset(seed=0)
    period = _world_pendulum_period(env, "rod", 240 * 8)
    expected = 2 * math.pi * math.sqrt(2 * 1.0 / (3 * GRAVITY))
    assert period == pytest.approx(expected, rel=0.01)
    # the pivot holds: the rod's upper end stays at the anchor
    top = env.payloads.state("rod").point(env.payloads.by_name["rod"].local([0, 0, 0]))
    np.testing.assert_allclose(top, [0, 0, 2.0], atol=2e-3)
    env.close()


def test_tether_hangs_at_its_length_and_is_slack_when_shorter():
    ball = {
        "name": "ball",
        "body": {"shapes": [{"type": "sphere", "radius": 0.02, "mass": 0.1}]},
        "attach": {"to": "world", "joint": "tether", "anchor": [0.0, 0.0, 3.0], "length": 0.5},
        "position": [0.0, 0.0, 2.9],  # 0.1 m below the anchor: 0.4 m of slack
    }
    env = build([ball], drag=False)
    env.reset(seed=0)
    cid, dt = env.world.client, env.world.physics_dt
    # slack: free fall until the string is taut (0.4 m: t = 0.286 s); PyBullet integrates
    # semi-implicitly (v += g dt, then z += v dt): z_n = z0 - g dt^2 n (n + 1) / 2, v_n = -g n dt
    n = 48  # 0.2 s
    for _ in range(n):
        p.stepSimulation(physicsClientId=cid)
    s = env.payloads.state("ball")
    assert s.position[2] == pytest.approx(2.9 - GRAVITY * dt * dt * n * (n + 1) / 2, abs=1e-6)
    assert s.lin_vel[2] == pytest.approx(-GRAVITY * n * dt, abs=1e-6)
    np.testing.assert_allclose(s.position[:2], 0.0, atol=1e-9)
    # then it hangs at the string's length below the anchor (the catch is inelastic), within
    # 1 % of the length: the compliance of PyBullet's constraint and joint-limit solver
    for _ in range(240 * 4):
        p.stepSimulation(physicsClientId=cid)
    s = env.payloads.state("ball")
    np.testing.assert_allclose(s.position, [0.0, 0.0, 2.5], atol=0.005)
    assert np.linalg.norm(s.lin_vel) < 0.05
    env.close()


def test_tethered_payload_starts_at_its_declared_pose():
    bob = {
        "name": "bob",
        "body": {"shapes": [{"type": "box", "size": [0.1, 0.05, 0.02], "mass": 0.1, "position": [0, 0, -0.05]}]},
        "attach": {"to": "world", "joint": "tether", "anchor": [0.0, 0.0, 3.0], "length": 0.6},
        "position": [0.0, 0.0, 2.6],  # tied 0.4 m below the anchor, its centre 5 cm lower
        "orientation": [0.0, 0.0, 0.7],
    }
    env = build([bob], drag=False)
    env.reset(seed=0)
    s = env.payloads.state("bob")
    np.testing.assert_allclose(s.position, [0.0, 0.0, 2.55], atol=1e-9)
    np.testing.assert_allclose(np.abs(np.dot(s.quaternion, p.getQuaternionFromEuler([0, 0, 0.7]))), 1.0, atol=1e-9)
    # it falls straight down, slack, keeping its orientation, and stops at the string's length
    for _ in range(240 * 3):
        p.stepSimulation(physicsClientId=env.world.client)
    s = env.payloads.state("bob")
    np.testing.assert_allclose(s.position, [0.0, 0.0, 3.0 - 0.6 - 0.05], atol=0.006)
    np.testing.assert_allclose(np.abs(np.dot(s.quaternion, p.getQuaternionFromEuler([0, 0, 0.7]))), 1.0, atol=1e-6)
    env.close()


def test_fixed_payload_keeps_its_pose_on_the_vehicle():
    cup = {
        "name": "cup",
        "body": {"shapes": [{"type": "box", "size": [0.1, 0.1, 0.01], "mass": 0.01, "position": [0, 0, 0.0]}]},
        "attach": {"to": "vehicle", "joint": "fixed"},
        "position": [0.05, 0.0, 0.03],
    }
    env = build([cup])
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(20):
        env.step([*rng.uniform(-1, 1, 3), 0.13])
        s = env.vehicle.state
        from pyflyt_engine.frames import quaternion_to_matrix

        rot = quaternion_to_matrix(tuple(s.quaternion))
        expected = np.asarray(s.lin_pos) + rot @ np.array([0.05, 0.0, 0.03])
        np.testing.assert_allclose(env.payloads.state("cup").position, expected, atol=2e-3)
    env.close()


def test_payload_touching_the_ground_ends_the_episode_as_a_crash():
    ball = {
        "name": "ball",
        "body": {"shapes": [{"type": "sphere", "radius": 0.05, "mass": 0.05}]},
        "attach": {"to": "world", "joint": "free"},
        "position": [1.0, 0.0, 0.3],
    }
    env = build([ball])
    env.reset(seed=0)
    for step in range(30):  # 0.25 m of free fall: 0.23 s = 7 agent steps
        _, reward, terminated, _, info = env.step([0.0, 0.0, 0.0, 0.125])
        if terminated:
            break
    assert terminated and info["payload_ground_contact"] and not info["collision"] and step >= 5
    assert reward == -100.0
    env.close()


# ------------------------------------------------------------------ pole tasks


@pytest.mark.parametrize("env_id", ["PyFlyt/QuadX-Pole-Balance-v0", "PyFlyt/QuadX-Pole-Waypoints-v0"])
def test_a_pole_tipped_past_horizontal_ends_the_episode(env_id):
    env = gymnasium.make(env_id).unwrapped
    env.reset(seed=0)
    _, _, terminated, *_, info = env.step(np.full(4, 0.54))
    assert not terminated and 0.0 <= info["pole_lean"] < 0.2
    # tip the pole to 100 deg from vertical about its pivot
    payload = env.payloads.by_name["pole"]
    s = env.vehicle.state
    pivot = np.asarray(s.lin_pos) + np.array([0, 0, 0.05])
    angle = math.radians(100)
    com = pivot + 0.5 * np.array([math.sin(angle), 0.0, math.cos(angle)])
    quat = p.getQuaternionFromEuler([0.0, angle, 0.0])
    p.resetBasePositionAndOrientation(payload.body_id, com.tolist(), quat, physicsClientId=env.world.client)
    _obs, reward, terminated, truncated, info = env.step(np.full(4, 0.54))
    assert terminated and not truncated and info["pole_fallen"] and info["pole_lean"] == 1.0
    assert reward == -100.0 and not info["success"]
    env.close()


def test_pole_observation_is_the_pole_ends_in_the_body_frame():
    env = gymnasium.make("PyFlyt/QuadX-Pole-Balance-v0").unwrapped
    obs, _ = env.reset(seed=4)
    s = env.vehicle.state
    pole = obs[-12:]
    from pyflyt_engine.frames import quaternion_to_matrix

    rot = quaternion_to_matrix(tuple(s.quaternion))
    # at reset the pole stands along the body z axis on the pivot 5 cm above the centre of mass
    np.testing.assert_allclose(pole[3:6], [0, 0, 0.05], atol=1e-6)
    np.testing.assert_allclose(pole[0:3], [0, 0, 1.05], atol=1e-6)
    np.testing.assert_allclose(pole[6:12], 0.0, atol=1e-9)
    # and the lean is the sine of the spawn tilt (the pole is along the body z axis)
    tilt = math.acos(rot[2, 2])
    assert env.task.pole.lean == pytest.approx(math.sin(tilt), abs=1e-9)
    env.close()


def test_pole_lean_formula():
    assert pole_lean(np.array([0.0, 0.0, 1.0]), np.zeros(3), 1.0) == 0.0
    assert pole_lean(np.array([0.3, 0.4, 0.1]), np.zeros(3), 1.0) == pytest.approx(0.5)
    assert pole_lean(np.array([0.6, 0.8, 0.1]), np.zeros(3), 2.0) == pytest.approx(0.5)  # divided by the length
    assert pole_lean(np.array([0.1, 0.0, -0.1]), np.zeros(3), 1.0) == 1.0  # tip below base: fallen


def _ctx(lin_pos, ang_pos, ang_vel, lean, crashed=False, **kw):
    from pyflyt_engine.frames import euler_to_quaternion

    zero = (0.0, 0.0, 0.0)
    state = KinematicState(
        tuple(ang_vel), tuple(ang_pos), zero, tuple(lin_pos), tuple(euler_to_quaternion(*ang_pos)), zero, zero
    )
    return StepContext(
        state, np.zeros(4), crashed, False, False, crashed, extras={"pole_lean": lean, "pole_fallen": 0.0}, **kw
    )


def test_pole_balance_dense_reward_matches_the_reference_formula():
    reward = load_reward_preset("quadx_pole_balance_dense").compile(
        frozenset({"target_distance", "target_distance_rate", "pole"})
    )
    pos, ang, rates, lean = (0.3, -0.4, 1.5), (0.1, -0.2, 0.7), (0.2, 0.1, 2.0), 0.35
    total, terms = reward(_ctx(pos, ang, rates, lean))
    by_hand = -0.1 + 1.0 - math.sqrt(0.3**2 + 0.4**2 + 0.5**2) - math.sqrt(0.1**2 + 0.2**2) - lean - 0.01 * 2.0**2
    assert total == pytest.approx(by_hand, abs=1e-12) and sum(terms.values()) == pytest.approx(total, abs=1e-12)
    assert terms["pole_lean"] == -lean and terms["yaw_rate"] == pytest.approx(-0.04)
    crash_total, _ = reward(_ctx(pos, ang, rates, lean, crashed=True))
    assert crash_total == -100.0
    sparse = load_reward_preset("quadx_pole_balance_sparse").compile()
    assert sparse(_ctx(pos, ang, rates, lean))[0] == pytest.approx(-0.1)
    assert sparse(_ctx(pos, ang, rates, lean, crashed=True))[0] == -100.0


def test_pole_waypoints_dense_reward_matches_the_formula():
    provides = frozenset({"target_distance", "target_distance_rate", "waypoints", "pole"})
    reward = load_reward_preset("quadx_pole_waypoints_dense").compile(provides)
    pos, ang, rates, lean = (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.2
    total, _ = reward(_ctx(pos, ang, rates, lean, target_distance=2.0, target_distance_rate=-4.0))
    assert total == pytest.approx(-0.1 + 0.375 * 4.0 + 0.5 / 2.0 + 0.5 - lean - 0.01, abs=1e-12)
    receding, _ = reward(_ctx(pos, ang, rates, lean, target_distance=2.0, target_distance_rate=4.0))
    assert receding == pytest.approx(-0.1 + 0.5 / 2.0 + 0.5 - lean - 0.01, abs=1e-12)
    reached, _ = reward(
        _ctx(pos, ang, rates, lean, target_distance=0.1, target_distance_rate=-4.0, waypoint_reached=True)
    )
    assert reached == 300.0
    sparse = load_reward_preset("quadx_pole_waypoints_sparse").compile(provides)
    assert sparse(_ctx(pos, ang, rates, lean, target_distance=2.0, target_distance_rate=-4.0))[0] == pytest.approx(-0.1)
    assert sparse(_ctx(pos, ang, rates, lean, target_distance=0.1, waypoint_reached=True))[0] == 300.0


def test_pole_balance_reward_in_the_env_is_the_sum_of_its_terms_and_its_formula():
    env = gymnasium.make("PyFlyt/QuadX-Pole-Balance-v0").unwrapped
    env.reset(seed=1)
    for _ in range(5):
        _, reward, terminated, _, info = env.step(np.full(4, 0.54))
        s = env.vehicle.state
        x, y, z = s.lin_pos
        roll, pitch, _ = s.ang_pos
        by_hand = (
            0.9
            - math.sqrt(x * x + y * y + (z - 1) ** 2)
            - math.hypot(roll, pitch)
            - info["pole_lean"]
            - 0.01 * s.ang_vel[2] ** 2
        )
        assert not terminated and reward == pytest.approx(by_hand, abs=1e-9)
        assert sum(info["reward_terms"].values()) == pytest.approx(reward, abs=1e-12)
    env.close()


# ------------------------------------------------------------------ recordings


def test_recording_carries_the_payload_frames_scene_and_urdf(tmp_path):
    from pyflyt_engine.telemetry import RecordEpisode, load_episode, read_mcap
    from pyflyt_engine.telemetry.replay import verify

    env = RecordEpisode(gymnasium.make("PyFlyt/QuadX-Pole-Balance-v0"), tmp_path)
    env.reset(seed=2)
    for _ in range(15):
        env.step(np.full(4, 0.55))
    env.close()
    path = env.paths[0]
    contents = read_mcap(path)
    frames = [m for m in contents.on("/tf") if m.data["child_frame_id"] == "payload/pole"]
    assert len(frames) == 16  # reset + 15 steps
    scene_entities = [e for m in contents.on("/scene") for e in m.data["entities"]]
    pole = [e for e in scene_entities if e["id"] == "payload/pole"]
    assert pole and pole[0]["frame_locked"] and pole[0]["cylinders"]
    assert "payload_pole.urdf" in [a.name for a in contents.attachments]
    result = verify(load_episode(path), tolerance=0.0)
    assert result.ok and result.max_deviation == 0.0 and result.max_reward_deviation == 0.0


# ---------------------------------------------------------------- ball in cup


def _put_ball(env, height, up_speed=0.0):
    """Put the tethered ball ``height`` m straight above the string's anchor (slack), rising at ``up_speed``."""
    payload = env.payloads.by_name["ball"]
    s = env.vehicle.state
    cid = env.world.client
    anchor = np.asarray(s.lin_pos) + np.array([0.0, 0.0, -0.03])
    flipped = p.getQuaternionFromEuler([math.pi, 0.0, 0.0])  # the string's axis (down at reset) now points up
    p.resetBasePositionAndOrientation(payload.body_id, anchor.tolist(), flipped, physicsClientId=cid)
    p.resetBaseVelocity(payload.body_id, [0, 0, 0], [0, 0, 0], physicsClientId=cid)
    p.resetJointState(payload.body_id, 0, height, up_speed, physicsClientId=cid)


def test_ball_dropped_into_the_cup_at_the_hover_point_is_a_catch():
    env = gymnasium.make("PyFlyt/QuadX-Ball-In-Cup-v0").unwrapped
    env.reset(seed=0)
    _, reward, terminated, *_ = env.step([0.0, 0.0, 0.0, 0.28])
    assert not terminated
    _put_ball(env, 0.13)  # centre 0.10 m above the centre of mass: 1 cm above the cup floor
    for _ in range(3):  # a 1 cm drop takes 45 ms: 2 agent steps
        obs, reward, terminated, _truncated, info = env.step([0.0, 0.0, 0.0, 0.28])
        if terminated:
            break
    assert terminated and info["env_complete"] and info["success"] and info["ball_in_cup"]
    assert not info["collision"] and not info["ball_hit_vehicle"]
    assert info["reward_terms"]["catch"] == 1000.0 and reward > 900.0
    np.testing.assert_allclose(obs[-6:-3], [0.0, 0.0, 0.09], atol=0.02)  # resting on the floor plate
    env.close()


def test_ball_in_the_cup_away_from_the_hover_point_is_not_yet_a_catch():
    env = gymnasium.make("PyFlyt/QuadX-Ball-In-Cup-v0", hover_point=(0.0, 0.0, 3.5)).unwrapped
    env.reset(seed=0)
    _put_ball(env, 0.13)
    for _ in range(3):
        _, _reward, terminated, _, info = env.step([0.0, 0.0, 0.0, 0.28])
        if info["ball_in_cup"]:
            break
    terms = info["reward_terms"]
    assert not terminated and info["ball_in_cup"] and not info["success"]
    # e = squared distance from (0, 0, 3.5), about 1.5^2: the cup shaping pays 10 / (e + 0.1)
    z = env.vehicle.state.lin_pos[2]
    e = sum(v * v for v in np.subtract(env.vehicle.state.lin_pos, (0.0, 0.0, 3.5)))
    assert terms["cup_hold"] == pytest.approx(10.0 / (e + 0.1), rel=1e-9) and 1.3 < 3.5 - z < 1.7
    assert terms["catch"] == 0.0
    env.close()


def test_ball_striking_the_vehicle_from_below_ends_the_episode():
    env = gymnasium.make("PyFlyt/QuadX-Ball-In-Cup-v0").unwrapped
    env.reset(seed=0)
    payload = env.payloads.by_name["ball"]
    p.resetJointState(payload.body_id, 0, 0.12, -6.0, physicsClientId=env.world.client)  # flung up at 6 m/s
    _, reward, terminated, _truncated, info = env.step([0.0, 0.0, 0.0, 0.28])
    assert terminated and info["ball_hit_vehicle"] and info["collision"] and not info["success"]
    assert reward == -500.0 and info["reward_terms"]["self_collision"] == -500.0
    env.close()


def test_ball_in_cup_dense_reward_matches_the_reference_formula():
    from pyflyt_engine.frames import euler_to_quaternion

    reward = load_reward_preset("quadx_ball_in_cup_dense").compile(frozenset({"ball_in_cup"}))
    ang_vel, ang_pos, lin_vel, lin_pos = (0.2, -0.1, 1.5), (0.1, 0.05, -0.3), (0.4, 0.0, -0.2), (0.3, 0.2, 1.6)
    state = KinematicState(ang_vel, ang_pos, lin_vel, lin_pos, tuple(euler_to_quaternion(*ang_pos)), lin_vel, ang_vel)
    E = sum(v * v for v in (*ang_vel, *ang_pos, *lin_vel)) + 0.3**2 + 0.2**2 + 0.4**2
    base = -0.1 + 0.4 - 0.01 * 1.5**2 - 0.01 * E

    def extras(**kw):
        e = {
            "ball_height": -0.5,
            "ball_distance": 0.53,
            "ball_above": 0.0,
            "ball_cup_contact": 0.0,
            "ball_hit_vehicle": 0.0,
            "hover_error": 0.29,
            "hover_error_decrease": 0.01,
            "caught": 0.0,
        }
        e.update(kw)
        return e

    def r(crashed=False, complete=False, **kw):
        ctx = StepContext(
            state, np.zeros(4), crashed, False, False, crashed, task_complete=complete, extras=extras(**kw)
        )
        total, terms = reward(ctx)
        assert sum(terms.values()) == pytest.approx(total, abs=1e-12)
        return total

    assert r() == pytest.approx(base - 0.5, abs=1e-12)  # ball below: + h
    above = r(ball_height=0.3, ball_distance=0.35, ball_above=1.0)
    assert above == pytest.approx(base - 4.0 * math.log(0.45 * 0.35 + 0.01), abs=1e-12)
    in_cup = r(ball_height=0.1, ball_distance=0.1, ball_above=1.0, ball_cup_contact=1.0)
    shaping = 50.0 * 0.01 + 10.0 / (0.29 + 0.1)
    assert in_cup == pytest.approx(base - 4.0 * math.log(0.45 * 0.1 + 0.01) + shaping, abs=1e-12)
    caught = r(complete=True, ball_height=0.1, ball_distance=0.1, ball_above=1.0, ball_cup_contact=1.0, caught=1.0)
    assert caught == pytest.approx(base - 4.0 * math.log(0.45 * 0.1 + 0.01) + 1000.0, abs=1e-12)
    assert r(crashed=True) == -100.0
    assert r(crashed=True, ball_hit_vehicle=1.0) == -500.0
    sparse = load_reward_preset("quadx_ball_in_cup_sparse").compile(frozenset({"ball_in_cup"}))
    ctx = StepContext(state, np.zeros(4), False, False, False, False, task_complete=True, extras=extras(caught=1.0))
    assert sparse(ctx)[0] == pytest.approx(999.9)


# ------------------------------------------------------------------ rendering


def _colour_pixels(image: np.ndarray, rgb) -> int:
    """Pixels within 40 of ``rgb`` (0-255) in every channel."""
    return int(np.all(np.abs(image.astype(int) - np.asarray(rgb)) < 40, axis=-1).sum())


def test_rgb_array_render_shows_the_payload_bodies():
    """The env's chase camera draws payloads: a magenta pole shows magenta pixels, recoloured green, green ones."""
    view = {"resolution": [96, 96], "camera_distance": 2.0, "camera_height": 0.8, "fov": 60.0}
    counts = {}
    for name, colour in (("magenta", [1.0, 0.0, 1.0, 1.0]), ("green", [0.0, 1.0, 0.0, 1.0])):
        pole = copy.deepcopy(POLE)
        pole["body"]["shapes"][0]["radius"] = 0.02  # a few pixels wide at this resolution
        pole["body"]["shapes"][0]["color"] = colour
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = make_env(hover_config([pole], render=view), render_mode="rgb_array")
        env.reset(seed=0)
        image = env.render()
        env.close()
        assert image.shape == (96, 96, 3) and image.dtype == np.uint8
        counts[name] = (_colour_pixels(image, (255, 0, 255)), _colour_pixels(image, (0, 255, 0)))
    # the pixels follow the payload's colour: they are the payload's
    assert counts["magenta"][0] >= 20 and counts["magenta"][1] <= 5
    assert counts["green"][1] >= 20 and counts["green"][0] <= 5

"""QuadX-Gates-v0 and camera observations declared in env configs.

Gate passing against hand-built crossings, the random course (seeded, inside the dome),
deliberate passes, strikes and completion, the image's layout and channel order, and a
tiny MultiInputPolicy training run through the training library.
"""

from __future__ import annotations

import math
import warnings

import gymnasium
import numpy as np
import pybullet as p
import pytest

import pyflyt_engine  # noqa: F401
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config, load_reward_preset
from pyflyt_engine.envs.rewards import StepContext
from pyflyt_engine.envs.tasks.gates import GatesOptions, gate_crossing, random_course
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import euler_to_quaternion, quaternion_to_matrix
from pyflyt_engine.state import KinematicState

CAMERA = {"camera": {"name": "cam", "width": 32, "height": 24, "fov": 60.0, "near": 0.05}}


def gates_env(**kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gymnasium.make("PyFlyt/QuadX-Gates-v0", **kwargs).unwrapped


# ------------------------------------------------------------------ pure parts


def test_gate_crossing_counts_only_forward_passes_through_the_opening():
    rot = quaternion_to_matrix(euler_to_quaternion(0.0, 0.0, math.pi / 2))  # gate faces +y
    centre = np.array([1.0, 2.0, 1.5])
    half = 0.2
    through = gate_crossing(np.array([1.05, 1.7, 1.45]), np.array([1.1, 2.3, 1.55]), centre, rot, half)
    backwards = gate_crossing(np.array([1.1, 2.3, 1.55]), np.array([1.05, 1.7, 1.45]), centre, rot, half)
    beside = gate_crossing(np.array([1.3, 1.7, 1.5]), np.array([1.3, 2.3, 1.5]), centre, rot, half)  # 0.3 m off
    short = gate_crossing(np.array([1.0, 1.5, 1.5]), np.array([1.0, 1.9, 1.5]), centre, rot, half)  # stops before
    assert through and not backwards and not beside and not short
    # the crossing point is interpolated on the segment: a diagonal that enters inside counts
    assert gate_crossing(np.array([0.5, 1.0, 1.5]), np.array([1.3, 2.6, 1.5]), centre, rot, half)  # at x = 1.0


def test_random_course_is_seeded_and_follows_its_bounds():
    o = GatesOptions(gates=[f"g{i}" for i in range(6)])
    a = random_course(np.random.default_rng(3), np.array([0.0, 0.0, 1.0]), 6, o)
    b = random_course(np.random.default_rng(3), np.array([0.0, 0.0, 1.0]), 6, o)
    c = random_course(np.random.default_rng(4), np.array([0.0, 0.0, 1.0]), 6, o)
    np.testing.assert_array_equal(a[0], b[0]) and np.testing.assert_array_equal(a[1], b[1])
    assert not np.allclose(a[0], c[0])
    centres, headings = a
    steps = np.linalg.norm(np.diff(np.vstack([[0.0, 0.0, 1.0], centres]), axis=0), axis=1)
    assert np.all(steps <= o.max_gate_distance + 1e-9)  # height clamping only shortens a step
    assert np.all(np.abs(np.diff(np.concatenate([[0.0], headings]))) <= o.max_turn + 1e-12)
    assert np.all((centres[:, 2] >= o.min_gate_height) & (centres[:, 2] <= o.max_gate_height))


def test_gates_presets_match_their_formulas():
    provides = frozenset({"target_distance", "target_distance_rate", "waypoints"})
    zero = (0.0, 0.0, 0.0)
    state = KinematicState(zero, zero, zero, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0), zero, zero)

    def ctx(**kw):
        crashed = kw.pop("crashed", False)
        return StepContext(state, np.zeros(4), crashed, False, False, crashed, agent_dt=1 / 40, **kw)

    dense = load_reward_preset("quadx_gates_dense").compile(provides)
    sparse = load_reward_preset("quadx_gates_sparse").compile(provides)
    # progress: approaching at 1.5 m/s for one 40 Hz step is 0.0375 m, paid 3 per metre;
    # receding as fast is charged as much (a loop away and back nets nothing)
    assert dense(ctx(target_distance=2.0, target_distance_rate=-1.5))[0] == pytest.approx(-0.1 + 3 * 1.5 / 40)
    assert dense(ctx(target_distance=2.0, target_distance_rate=1.5))[0] == pytest.approx(-0.1 - 3 * 1.5 / 40)
    assert dense(ctx(target_distance=0.05, target_distance_rate=0.0))[0] == pytest.approx(-0.1)  # hovering pays nothing
    assert dense(ctx(target_distance=0.3, target_distance_rate=-1.0, waypoint_reached=True))[0] == pytest.approx(99.9)
    assert dense(ctx(crashed=True, target_distance=1.0, target_distance_rate=-1.0))[0] == -100.0
    assert sparse(ctx(target_distance=2.0, target_distance_rate=-1.5))[0] == pytest.approx(-0.1)
    assert sparse(ctx(target_distance=0.3, target_distance_rate=-1.0, waypoint_reached=True))[0] == pytest.approx(99.9)


# ------------------------------------------------------------------ the env


def test_course_is_inside_the_dome_and_reproducible_from_the_seed():
    env = gates_env()
    env.reset(seed=5)
    first = env.task.centres.copy()
    env.reset(seed=6)
    assert not np.allclose(first, env.task.centres)
    env.reset(seed=5)
    np.testing.assert_array_equal(first, env.task.centres)
    assert np.all(np.linalg.norm(first, axis=1) < env.config.flight_dome_size)
    # the gate bodies are where the task says
    for name, centre in zip(env.task.options.gates, first):
        np.testing.assert_allclose(env.payloads.state(name).position, centre, atol=1e-9)
    env.close()


def _fly_through(env, gate_index, speed=3.0, offset=(0.0, 0.0)):
    """Place the vehicle 5 cm before gate ``gate_index``, moving through it along its normal."""
    rot = env.task.rotations[gate_index]
    start = env.task.centres[gate_index] + rot @ np.array([-0.05, offset[0], offset[1]])
    yaw = math.atan2(rot[1, 0], rot[0, 0])
    cid, body = env.world.client, env.vehicle.body_id
    p.resetBasePositionAndOrientation(body, start.tolist(), euler_to_quaternion(0.0, 0.0, yaw), physicsClientId=cid)
    p.resetBaseVelocity(body, (speed * rot[:, 0]).tolist(), [0, 0, 0], physicsClientId=cid)
    env.vehicle.state_changed()
    env.task._position = start.copy()  # the step's segment starts here
    env.task._distance = float(np.linalg.norm(env.task.remaining[0] - start)) if len(env.task.remaining) else 0.0


def test_flying_through_every_gate_in_order_completes_the_task():
    env = gates_env(course="fixed")  # the declared straight course: gates 2 m apart along x
    env.reset(seed=0)
    np.testing.assert_allclose(env.task.centres[:, 0], [2.0, 4.0, 6.0, 8.0, 10.0])
    for i in range(5):
        _fly_through(env, i)
        obs, _reward, terminated, _truncated, info = env.step([0.0, 0.0, 0.0, 0.125])
        assert info["num_targets_reached"] == i + 1 and not info["collision"]
        assert info["reward_terms"]["gate_bonus"] == 100.0
        assert len(obs["target_deltas"]) == 4 - i
        assert terminated == (i == 4)
    assert info["env_complete"] and info["success"]
    env.close()


def test_passing_gates_out_of_order_counts_nothing_and_the_frame_is_a_crash():
    env = gates_env(course="fixed")
    env.reset(seed=0)
    _fly_through(env, 1)  # the second gate first
    _, reward, terminated, _, info = env.step([0.0, 0.0, 0.0, 0.125])
    assert info["num_targets_reached"] == 0 and info["reward_terms"]["gate_bonus"] == 0.0 and not terminated
    _fly_through(env, 0, offset=(0.225, 0.0))  # into the side bar of the first gate
    for _ in range(3):
        _, reward, terminated, _, info = env.step([0.0, 0.0, 0.0, 0.125])
        if terminated:
            break
    assert terminated and info["collision"] and reward == -100.0 and info["num_targets_reached"] == 0
    env.close()


def test_negative_clearance_counts_crossings_beside_the_gate_for_one_episode():
    """A curriculum's easing: clearance -0.8 counts a crossing 0.6 m beside the opening (outside
    the frame), for the episode it is set for; the configured task does not."""
    env = gates_env(course="fixed")
    for clearance, counted in ((-0.8, 1), (None, 0)):
        env.reset(seed=0, options={"task": {"clearance": clearance}} if clearance is not None else None)
        assert env.task.options.clearance == (clearance if clearance is not None else 0.0)
        _fly_through(env, 0, offset=(0.6, 0.0))  # 0.35 m clear of the side bar's outer face
        _, reward, _, _, info = env.step([0.0, 0.0, 0.0, 0.125])
        assert info["num_targets_reached"] == counted and not info["collision"]
        assert info["reward_terms"]["gate_bonus"] == 100.0 * counted
    with pytest.raises(ValueError, match="clearance"):
        env.reset(seed=0, options={"task": {"clearance": 0.2}})  # leaves no opening
    env.close()


def test_random_course_too_big_for_the_dome_is_refused():
    with pytest.raises(ConfigError, match="outside the flight dome"):
        gates_env(flight_dome_size=8.0, course="random")


def test_gate_declared_outside_the_dome_is_refused():
    cfg = load_env_config("quadx_gates").model_dump(exclude={"source"})
    cfg["payloads"][4]["position"] = [30.0, 0.0, 1.0]
    with pytest.raises(ConfigError, match=r"payloads.4 \('gate_4'\) reaches .* outside the flight dome"):
        load_env_config(cfg)


# ----------------------------------------------------------- camera observation


def test_gates_image_is_rgb_height_width_channels_and_sees_the_gate():
    env = gates_env(course="fixed")
    obs, _ = env.reset(seed=0)
    assert env.observation_space["image"] == gymnasium.spaces.Box(0, 255, (64, 64, 3), np.uint8)
    image = obs["image"]
    assert image.shape == (64, 64, 3) and image.dtype == np.uint8 and image.flags["C_CONTIGUOUS"]
    # the first gate (orange: 0.9, 0.5, 0.0) is 2 m straight ahead: orange pixels near the centre
    orange = (image[:, :, 0] > 150) & (image[:, :, 1] > 60) & (image[:, :, 1] < 160) & (image[:, :, 2] < 60)
    rows, cols = np.nonzero(orange)
    assert len(rows) > 10 and abs(cols.mean() - 32) < 8
    # the ground (below the horizon) fills the bottom rows, the sky the top: row 0 is the top
    assert image[-1].astype(int).sum() != image[0].astype(int).sum()
    env.close()


def test_any_env_adds_a_camera_image_by_config_in_either_channel_order():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hwc = make_env("quadx_hover", camera_observation=CAMERA)
        chw = make_env("quadx_hover", camera_observation={**CAMERA, "channel_first": True, "channels": "rgba"})
    a, _ = hwc.reset(seed=1)
    b, _ = chw.reset(seed=1)
    assert set(a) == {"attitude", "image"} and a["attitude"].shape == (21,)
    assert a["image"].shape == (24, 32, 3) and b["image"].shape == (4, 24, 32)
    np.testing.assert_array_equal(a["image"], b["image"][:3].transpose(1, 2, 0))
    assert np.all(b["image"][3] == 255)  # alpha
    assert hwc.observation_space.contains(a) and chw.observation_space.contains(b)
    # the airframe itself is unchanged: the camera is the env's
    assert not hwc.airframe.cameras and hwc.vehicle.spec.cameras[-1].name == "cam"
    hwc.close()
    chw.close()


def test_bad_camera_observation_configs_are_refused():
    with pytest.raises(ConfigError, match="camera_observation.camera.width"):
        make_env("quadx_hover", camera_observation={"camera": {"name": "c", "width": 0}})
    with pytest.raises(ConfigError, match="camera_observation.key"):
        make_env("quadx_hover", camera_observation={**CAMERA, "key": "attitude"})


def test_image_observation_is_deterministic_and_not_shared():
    env = gates_env()
    a, _ = env.reset(seed=2)
    b, _ = env.step([0.0, 0.0, 0.0, 0.13])[:2]
    assert not np.shares_memory(a["image"], b["image"])
    c, _ = env.reset(seed=2)
    np.testing.assert_array_equal(a["image"], c["image"])
    env.close()


# ------------------------------------------------------------------ training


def test_multi_input_policy_trains_on_the_gates_image(tmp_path):
    from pyflyt_cli.training.compose import compose_config
    from pyflyt_cli.training import train

    overrides = [
        "env=quadx_gates",
        "algo=ppo",
        "train.total_timesteps=64",
        "train.n_envs=1",
        "algo.n_steps=64",
        "algo.batch_size=32",
        "algo.n_epochs=1",
        "train.eval_freq=64",
        "train.eval_episodes=1",
        "train.checkpoint_freq=64",
        "train.progress_bar=false",
        "algo.normalize.observation=true",
        f"train.output_dir={tmp_path}",
    ]
    result = train(compose_config(overrides=overrides), command=["pyflyt", "train"], overrides=overrides)
    assert result.num_timesteps == 64 and not result.interrupted
    from pyflyt_cli.training.models import read_policy

    policy = read_policy(result.run_dir / "model.pt")
    assert any("cnn" in k for k in policy.policy)  # SB3's NatureCNN on the image
    assert set(policy.normalizer["obs_rms"]) == {"attitude"}  # the image is not normalised

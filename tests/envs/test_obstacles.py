"""Obstacles in env configs: validation, seeded layouts, keep-out, contact as a crash, meshes,
QuadX-Obstacles-v0's goal and success, and the gates task's fixed-size observations."""

from __future__ import annotations

import math
from typing import ClassVar, Literal

import numpy as np
import pybullet as p
import pytest

from pyflyt_engine.envs.quadx import QuadXHoverEnv
from pyflyt_engine.envs.quadx_obstacles import QuadXObstaclesEnv
from pyflyt_engine.envs.tasks import register_task
from pyflyt_engine.envs.tasks.hover import HoverOptions, HoverTask
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.obstacles import CylinderObstacle, ForestGenerator, draw_layout, prism_mesh

FOREST = {"kind": "forest", "x_range": [-3.0, 3.0], "y_range": [-3.0, 3.0], "density": 0.5, "keep_out": 1.0}
CUBE_OBJ = """# unit cube
v -0.5 -0.5 -0.5
v 0.5 -0.5 -0.5
v 0.5 0.5 -0.5
v -0.5 0.5 -0.5
v -0.5 -0.5 0.5
v 0.5 -0.5 0.5
v 0.5 0.5 0.5
v -0.5 0.5 0.5
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
"""


def _layout(env) -> list[tuple]:
    return [(o.position, o.radius, o.height) for o in env.obstacles.generated]


def test_a_seed_fixes_the_layout_and_each_reset_draws_a_new_one(make):
    env = make("PyFlyt/QuadX-Obstacles-v0")
    env.reset(seed=4)
    first = _layout(env)
    bodies = p.getNumBodies(physicsClientId=env.world.client)
    env.reset()
    assert _layout(env) != first  # regenerated per episode
    env.reset(seed=4)
    assert _layout(env) == first
    other = make("PyFlyt/QuadX-Obstacles-v0")
    other.reset(seed=4)
    assert _layout(other) == first
    assert p.getNumBodies(physicsClientId=env.world.client) == bodies  # rebuilt in place, same count


def test_the_layout_keeps_clear_of_spawn_and_goal_and_has_the_configured_count(make):
    env = make("PyFlyt/QuadX-Obstacles-v0")
    g = env.config.obstacles.generators[0]
    assert g.count == round(0.25 * 6 * 8) == 12
    for seed in range(20):
        env.reset(seed=seed)
        trunks = [o for o in env.obstacles.generated if o is not None]
        assert len(trunks) == 12 and env.obstacles.parked == 0
        for point in (env.state.lin_pos, env.task.goal):
            for o in trunks:
                gap = math.hypot(o.position[0] - point[0], o.position[1] - point[1]) - o.radius
                assert gap >= g.keep_out
        for o in trunks:
            assert g.x_range[0] <= o.position[0] <= g.x_range[1] and g.y_range[0] <= o.position[1] <= g.y_range[1]
            assert g.radius_range[0] - 0.005 <= o.radius <= g.radius_range[1] + 0.005
            assert o.position[2] == 0.5 * o.height  # standing on the ground
        for i, a in enumerate(trunks):
            for b in trunks[i + 1 :]:
                d = math.hypot(a.position[0] - b.position[0], a.position[1] - b.position[1])
                assert d - a.radius - b.radius >= g.min_spacing


def test_an_impossible_keep_out_parks_obstacles_and_says_so():
    gen = ForestGenerator(**{**FOREST, "keep_out": 10.0, "max_attempts": 5})
    drawn, parked = draw_layout(gen, np.random.default_rng(0), [(0.0, 0.0, 1.0)])
    assert parked == gen.count == len(drawn) and all(o is None for o in drawn)


def test_touching_an_obstacle_is_a_crash():
    slab = {"items": [{"type": "box", "size": [2.0, 2.0, 0.5], "position": [0.0, 0.0, 1.6]}]}
    env = QuadXHoverEnv(obstacles=slab)
    try:
        env.reset(seed=0)
        for _ in range(60):
            _, reward, terminated, _, info = env.step(np.array([0.0, 0.0, 0.0, 0.4]))  # climb into it
            if terminated:
                break
        assert terminated and info["obstacle_contact"] and info["collision"] and reward == -100.0
        assert env.state.lin_pos[2] < 1.35
    finally:
        env.close()


class _TouchOptions(HoverOptions):
    name: Literal["hover_touching"] = "hover_touching"  # type: ignore[assignment]


class _TouchTask(HoverTask):
    """Hover where contacts are no crash (the task's rules), to show the obstacles' own rule."""

    name: ClassVar[str] = "hover_touching"
    Options: ClassVar[type] = _TouchOptions
    crash_on_contact: ClassVar[bool] = False


@pytest.mark.parametrize("crash", [True, False])
def test_crash_on_contact_decides_for_obstacles_whatever_the_task(crash):
    register_task(_TouchTask)
    slab = {"items": [{"type": "box", "size": [2.0, 2.0, 0.5], "position": [0.0, 0.0, 1.6]}], "crash_on_contact": crash}
    env = QuadXHoverEnv(obstacles=slab, task={"name": "hover_touching"})
    try:
        env.reset(seed=0)
        touched = ended = False
        for _ in range(60):
            _, _, terminated, _, info = env.step(np.array([0.0, 0.0, 0.0, 0.4]))
            touched |= info["obstacle_contact"]
            ended |= terminated
            if terminated:
                break
        assert touched and ended == crash
    finally:
        env.close()


def test_a_mesh_obstacle_is_loaded_validated_and_seen(tmp_path):
    obj = tmp_path / "cube.obj"
    obj.write_text(CUBE_OBJ)
    mesh = {"type": "mesh", "file": str(obj), "scale": [1.0, 2.0, 2.0], "position": [2.5, 0.0, 1.0]}
    lidar = [{"name": "lidar", "type": "lidar", "horizontal_beams": 64, "max_range": 5.0, "min_range": 0.1}]
    env = QuadXHoverEnv(
        obstacles={"items": [mesh]}, range_sensors=lidar, start_position_noise=0.0, start_orientation_noise=0.0
    )
    try:
        obs, _ = env.reset(seed=0)
        # the scaled cube's face is the plane x = 2 (|y| <= 1): the two beams nearest ahead
        # (+-2.8 deg) read 2 / cos(2.8 deg)
        a = math.radians(180.0 / 64)
        np.testing.assert_allclose(obs["lidar"][31:33], 2.0 / math.cos(a), atol=2e-6)
        assert obs["lidar"][0] == 5.0  # behind: nothing
    finally:
        env.close()
    (tmp_path / "notes.txt").write_text("v 0 0 0")
    for bad, message in (
        (str(tmp_path / "missing.obj"), "no such mesh file"),
        (str(tmp_path / "notes.txt"), "Wavefront .obj"),
    ):
        with pytest.raises(ConfigError, match=message):
            QuadXHoverEnv(obstacles={"items": [{**mesh, "file": bad}]})
    empty = tmp_path / "empty.obj"
    empty.write_text("# nothing\n")
    with pytest.raises(ConfigError, match="no vertices and faces"):
        QuadXHoverEnv(obstacles={"items": [{**mesh, "file": str(empty)}]})


@pytest.mark.parametrize(
    "obstacles, message",
    [
        ({}, "at least one entry"),
        ({"items": [{"type": "box", "size": [1.0, -1.0, 1.0], "position": [0, 0, 0]}]}, "size"),
        ({"items": [{"type": "cone", "position": [0, 0, 0]}]}, "type"),
        ({"generators": [{**FOREST, "density": 0.001}]}, "gives no obstacle"),
        ({"generators": [{**FOREST, "radius_range": [0.3, 0.1]}]}, "radius_range"),
        ({"generators": [{**FOREST, "x_range": [1.0, -1.0]}]}, "x_range"),
        ({"generators": [{**FOREST, "trees": 3}]}, "trees"),
        ({"items": [], "generators": [FOREST], "crash": True}, "crash"),
    ],
)
def test_bad_obstacle_configs_are_refused_by_name(obstacles, message):
    with pytest.raises(ConfigError, match=message):
        QuadXHoverEnv(obstacles=obstacles)


def test_a_multi_agent_env_draws_layouts_clear_of_every_agent():
    from pyflyt_engine.envs.multi_agent import ma_quadx_hover_v0

    env = ma_quadx_hover_v0.parallel_env(agents=4, obstacles={"generators": [FOREST]})
    try:
        for seed in range(3):
            env.reset(seed=seed)
            spawns = [v.state.lin_pos for v in env.vehicles]
            for body in env.obstacles.body_ids:
                (x, y, _), _ = p.getBasePositionAndOrientation(body, physicsClientId=env.world.client)
                assert all(math.hypot(x - sx, y - sy) > 1.0 for sx, sy, _ in spawns)  # FOREST keep_out
    finally:
        env.close()


def test_cylinders_collide_as_the_inscribed_prism():
    vertices, indices = prism_mesh(0.2, 3.0, 32)
    radii = [math.hypot(x, y) for x, y, _ in vertices[:64]]
    np.testing.assert_allclose(radii, 0.2, rtol=1e-12)
    assert len(indices) == 3 * 4 * 32
    # a LiDAR beam straight at a facet's middle reads the apothem r cos(pi / 32), at a vertex r
    env = QuadXHoverEnv(
        obstacles={"items": [CylinderObstacle(radius=0.2, height=3.0, position=(2.0, 0.0, 1.5)).model_dump()]},
        range_sensors=[
            {"name": "lidar", "type": "lidar", "horizontal_beams": 1, "horizontal_fov_deg": 1.0, "max_range": 5.0}
        ],
        start_position_noise=0.0,
        start_orientation_noise=0.0,
    )
    try:
        obs, _ = env.reset(seed=0)
        com_x = env.state.lin_pos[0]
        assert abs(obs["lidar"][0] - (2.0 - 0.2 - com_x)) < 2e-6  # the vertex at angle 180 deg
    finally:
        env.close()


def test_quadx_obstacles_success_is_the_goal_reached_without_contact(make):
    env = make("PyFlyt/QuadX-Obstacles-v0")
    obs, info = env.reset(seed=2)
    goal = env.task.goal
    np.testing.assert_allclose(obs["goal_delta"], goal - env.state.lin_pos, atol=0.2 * 8.5)  # level-ish spawn
    assert 4.0 == goal[0] and -2.0 <= goal[1] <= 2.0 and 1.0 <= goal[2] <= 2.0
    # put the vehicle just short of the goal: the next step's segment passes within reach
    env.vehicle.reset(tuple(goal - np.array([0.05, 0.0, 0.0])), (0.0, 0.0, 0.0))
    _, reward, terminated, truncated, info = env.step(np.array([0.0, 0.0, 0.0, 0.125]))
    assert terminated and not truncated and info["success"] and info["goal_reached"]
    assert env.last_reward_terms["goal_bonus"] == 100.0 and not info["obstacle_contact"]


def test_quadx_obstacles_crash_into_a_trunk_is_no_success(make):
    env = make("PyFlyt/QuadX-Obstacles-v0")
    env.reset(seed=2)
    trunk = env.obstacles.generated[0]
    # start just beside a trunk, moving into it
    x, y, _ = trunk.position
    env.vehicle.reset((x - trunk.radius - 0.1, y, 1.0), (0.0, 0.0, 0.0), lin_vel=(2.0, 0.0, 0.0))
    for _ in range(30):
        _, reward, terminated, _, info = env.step(np.array([0.0, 0.0, 0.0, 0.125]))
        if terminated:
            break
    assert terminated and info["obstacle_contact"] and not info["success"] and reward == -100.0


def test_the_shipped_forest_is_in_the_recorded_scene(tmp_path):
    from pyflyt_engine.telemetry import RecordEpisode, read_mcap

    env = RecordEpisode(QuadXObstaclesEnv(), tmp_path)
    env.reset(seed=1)
    env.step(env.action_space.sample())
    env.close()
    contents = read_mcap(env.paths[0])
    scenes = [m for m in contents.messages if m.topic == "/scene"]
    scenery = [e for m in scenes for e in m.data["entities"] if e["id"].startswith("scenery/")]
    cylinders = [c for e in scenery for c in e["cylinders"]]
    trunks = [o for o in env.unwrapped.obstacles.generated if o is not None]
    assert len(cylinders) == len(trunks) == 12
    got = sorted((round(c["pose"]["position"]["x"], 9), round(c["size"]["x"] / 2, 9)) for c in cylinders)
    assert got == sorted((round(o.position[0], 9), round(o.radius, 9)) for o in trunks)
    clouds = [m for m in contents.messages if m.topic == "/uav/0/range/lidar"]
    assert len(clouds) == 2  # the reset and the step


# ------------------------------------------------------------------ gates


@pytest.mark.parametrize("kind", ["corners", "relative_pose"])
def test_gate_observations_match_the_gate_geometry(make, kind):
    env = make("PyFlyt/QuadX-Gates-v0", observation=kind)
    deltas = make("PyFlyt/QuadX-Gates-v0")
    obs, _ = env.reset(seed=5)
    ref, _ = deltas.reset(seed=5)
    centre = ref["target_deltas"][0]  # body-frame vector to the next gate's centre
    if kind == "corners":
        corners = obs["gate"].reshape(4, 3)
        np.testing.assert_allclose(corners.mean(axis=0), centre, atol=1e-12)
        sides = [np.linalg.norm(corners[i] - corners[(i + 1) % 4]) for i in range(4)]
        np.testing.assert_allclose(sides, env.task.options.opening, atol=1e-12)
        # seen along the gate's +x: corner 0 (top left) is left of corner 1 and above corner 3
        gate_y = env.task.rotations[0][:, 1]
        body = np.array(env.state.quaternion)
        from pyflyt_engine.frames import quaternion_to_matrix

        r = quaternion_to_matrix(tuple(body))
        assert (r @ (corners[0] - corners[1])) @ gate_y > 0
    else:
        np.testing.assert_allclose(obs["gate"][:3], centre, atol=1e-12)
        from pyflyt_engine.frames import quaternion_to_matrix

        r_body = quaternion_to_matrix(tuple(env.state.quaternion))
        r_rel = quaternion_to_matrix(tuple(obs["gate"][3:]))
        np.testing.assert_allclose(r_body @ r_rel, env.task.rotations[0], atol=1e-12)


@pytest.mark.parametrize("kind", ["corners", "relative_pose"])
def test_gate_observation_options_pass_the_env_checkers(make, kind):
    import warnings

    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = make("PyFlyt/QuadX-Gates-v0", observation=kind)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # as tests/envs/test_contract.py: only the action box and infinities
        warnings.filterwarnings("ignore", message=".*(symmetric|float32|float64|infinity).*")
        check_env(env, skip_render_check=True)
        sb3_check_env(env, warn=True)  # the Dict of Boxes and the image as it is


def test_cylinder_facets_set_the_collision_prism():
    # 33 facets: the facet facing the vehicle (at 180 deg) has its middle on the beam, so
    # the beam reads the apothem r cos(pi / 33); 32: a vertex faces it and it reads r
    def reading(facets: int) -> float:
        env = QuadXHoverEnv(
            obstacles={
                "items": [{"type": "cylinder", "radius": 0.2, "height": 3.0, "position": [2.0, 0.0, 1.5]}],
                "cylinder_facets": facets,
            },
            range_sensors=[
                {"name": "lidar", "type": "lidar", "horizontal_beams": 1, "horizontal_fov_deg": 1.0, "max_range": 5.0}
            ],
            start_position_noise=0.0,
            start_orientation_noise=0.0,
        )
        try:
            obs, _ = env.reset(seed=0)
            return float(obs["lidar"][0]) + env.state.lin_pos[0]
        finally:
            env.close()

    assert abs(reading(33) - (2.0 - 0.2 * math.cos(math.pi / 33))) < 2e-6
    assert abs(reading(32) - (2.0 - 0.2)) < 2e-6


# a wedge on a 2 x 1 rectangle, 0.5 high over its edge x = 0, sloping down to x = 2; three
# faces are quads (fanned into 2 triangles each): 6 vertices, 8 triangles
WEDGE_OBJ = """# wedge
o wedge
v 0 0 0
v 2 0 0
v 2 1 0
v 0 1 0
v 0 0 0.5
vn 0 0 1
v 0 1 0.5
f 1 4 3 2
f 1/1/1 2/1/1 5/1/1
f 4//1 6//1 3//1
f 1 5 6 4
f -5 -4 -1 -2
"""


def test_a_recorded_mesh_obstacle_is_drawn_from_its_file(tmp_path):
    import json

    import jsonschema
    from typer.testing import CliRunner

    from pyflyt_cli.main import app
    from pyflyt_engine.frames import euler_to_quaternion
    from pyflyt_engine.telemetry import RecordEpisode, read_mcap

    obj = tmp_path / "wedge.obj"
    obj.write_text(WEDGE_OBJ)
    position, yaw, scale = (3.0, 1.0, 0.2), 0.3, (1.5, 2.0, 4.0)
    mesh = {
        "type": "mesh",
        "file": str(obj),
        "scale": list(scale),
        "position": list(position),
        "orientation": [0.0, 0.0, yaw],
        "color": [0.2, 0.4, 0.6, 1.0],
    }
    env = RecordEpisode(QuadXHoverEnv(obstacles={"items": [mesh]}), tmp_path / "runs")
    env.reset(seed=0)
    env.step(np.array([0.0, 0.0, 0.0, 0.125]))
    # what collides is what the file says at the scale: a ray straight down at local (x, 0.5)
    # meets the slope 2 (1 - x / 3) above the base (scaled: 3 long, 2 high)
    c, s = math.cos(yaw), math.sin(yaw)
    for x in (0.5, 1.5, 2.5):
        wx, wy = position[0] + c * x - s * 1.0, position[1] + s * x + c * 1.0
        hit = p.rayTest([wx, wy, 5.0], [wx, wy, -1.0], physicsClientId=env.unwrapped.world.client)[0]
        assert hit[0] == env.unwrapped.obstacles.fixed_ids[0]
        assert abs(hit[3][2] - (position[2] + 2.0 * (1.0 - x / 3.0))) < 1e-5
    env.reset(seed=1)
    env.close()

    scenes = []
    with open(env.paths[0], "rb") as f:
        from mcap.reader import make_reader

        for schema, channel, message in make_reader(f, validate_crcs=True).iter_messages():
            if channel.topic == "/scene":
                data = json.loads(message.data)
                errors = list(jsonschema.Draft202012Validator(json.loads(schema.data)).iter_errors(data))
                assert not errors, errors[0].message
                scenes.append(data)
    drawn = [e for m in scenes for e in m["entities"] if e["id"].startswith("scenery/")]
    assert len(drawn) == 1  # the reset of this episode (the next reset starts a new file)
    wedge = drawn[0]
    assert wedge["metadata"] == [{"key": "mesh", "value": "wedge.obj"}]
    assert not wedge["cubes"] and not wedge["models"] and len(wedge["triangles"]) == 1
    tri = wedge["triangles"][0]
    points = np.array([[q["x"], q["y"], q["z"]] for q in tri["points"]])
    assert points.shape == (6, 3)  # one point per vertex of the file
    np.testing.assert_array_equal(points.min(axis=0), [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(points.max(axis=0), [2.0 * 1.5, 1.0 * 2.0, 0.5 * 4.0])
    assert len(tri["indices"]) == 3 * 8 and set(tri["indices"]) == set(range(6))
    np.testing.assert_allclose(
        [tri["color"][k] for k in "rgba"], [0.2, 0.4, 0.6, 1.0], atol=1e-7
    )  # float32 in PyBullet
    np.testing.assert_allclose([tri["pose"]["position"][k] for k in "xyz"], position, atol=1e-12)
    q = [tri["pose"]["orientation"][k] for k in "xyzw"]
    np.testing.assert_allclose(np.abs(np.dot(q, euler_to_quaternion(0.0, 0.0, yaw))), 1.0, atol=1e-9)
    # the recording stays readable by the project's own tools, and holds the file it drew
    contents = read_mcap(env.paths[0])
    assert contents.messages
    assert [a.data for a in contents.attachments if a.name == "obstacle_mesh_0.obj"] == [WEDGE_OBJ.encode()]
    result = CliRunner().invoke(app, ["replay", str(env.paths[0])])
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize(
    "text, message",
    [
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2", "line 5: a face needs at least three corners"),
        ("v 0 0 0\nv 1 0 0\nv 0 1", "line 3: a vertex needs three finite numbers"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "line 4: a face names vertex 4, the file holds 3"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "line 4: face corner '-4' names no vertex"),
        ("v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3\n", "line 2: a vertex needs three finite numbers"),
        ("v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n", "line 2: a vertex needs three finite numbers"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\0\n", "binary"),
    ],
)
def test_a_malformed_or_cut_mesh_file_is_refused_at_load_by_name(tmp_path, text, message):
    obj = tmp_path / "bad_mesh.obj"
    obj.write_text(text)
    with pytest.raises(ConfigError, match=message) as caught:
        QuadXHoverEnv(obstacles={"items": [{"type": "mesh", "file": str(obj), "position": [2.0, 0.0, 1.0]}]})
    assert str(obj) in str(caught.value)


def _record_into_the_cube(directory, obj):
    """One episode flown into the unit-cube mesh 0.6 m ahead until it touches it (a crash)."""
    from pyflyt_engine.telemetry import RecordEpisode

    mesh = {"type": "mesh", "file": str(obj), "scale": [1.0, 1.0, 1.5], "position": [0.6, 0.0, 1.0]}
    env = RecordEpisode(QuadXHoverEnv(obstacles={"items": [mesh]}), directory)
    env.reset(seed=0)
    info = {}
    for _ in range(100):
        _, _, terminated, truncated, info = env.step(np.array([0.3, 0.0, 0.0, 0.13]))
        if terminated or truncated:
            break
    env.close()
    assert info.get("collision"), info  # the episode's end depends on the mesh
    return env.paths[0]


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    """Recorded files are cached in a folder of tmp_path."""
    cache = tmp_path / "cache"
    monkeypatch.setenv("PYFLYT_CACHE_DIR", str(cache))
    return cache


def test_a_recording_with_a_mesh_obstacle_replays_exactly_without_its_file(tmp_path, private_cache):
    """The recording holds the OBJ file (attachment and digest); --verify flies that copy,
    written to the private cache, once the original is gone."""
    import hashlib
    import json

    from typer.testing import CliRunner

    from pyflyt_cli.main import app
    from pyflyt_engine.telemetry import load_episode
    from pyflyt_engine.telemetry.replay import verify

    obj = tmp_path / "meshes" / "cube.obj"
    obj.parent.mkdir()
    text = "mtllib cube.mtl\n" + CUBE_OBJ  # a material library by plain name (none in the cache): flown
    obj.write_text(text)
    path = _record_into_the_cube(tmp_path / "runs", obj)
    episode = load_episode(path)
    assert json.loads(episode.env_info["obstacle_meshes"]) == [
        {"file": str(obj), "attachment": "obstacle_mesh_0.obj", "sha256": hashlib.sha256(text.encode()).hexdigest()}
    ]
    obj.rename(tmp_path / "elsewhere.obj")  # the original file is gone
    result = verify(episode, tolerance=0.0)
    assert result.ok and result.max_deviation == 0.0 and result.max_reward_deviation == 0.0, result
    assert not obj.exists()
    cached = [f for f in private_cache.iterdir() if f.suffix == ".obj"]
    assert [f.read_text() for f in cached] == [text]
    result = CliRunner().invoke(app, ["replay", str(path), "--verify", "--tolerance", "0"])
    assert result.exit_code == 0, result.output
    assert "verify    OK" in result.output and "largest state deviation 0," in result.output
    assert not obj.exists()


def test_a_missing_altered_or_malformed_mesh_copy_is_refused_by_name(tmp_path, private_cache):
    import hashlib
    import json

    from typer.testing import CliRunner

    from pyflyt_cli.main import app
    from pyflyt_engine.errors import TelemetryError
    from pyflyt_engine.telemetry import load_episode
    from pyflyt_engine.telemetry.replay import verify
    from tests.telemetry.conftest import rewrite_mcap

    obj = tmp_path / "cube.obj"
    obj.write_text(CUBE_OBJ)
    path = _record_into_the_cube(tmp_path / "runs", obj)
    obj.unlink()

    def keep(topic, data):  # messages copied as they are
        return None

    def table(change):
        def metadata(name, record):
            if name == "env":
                entries = json.loads(record["obstacle_meshes"])
                change(entries[0])
                record["obstacle_meshes"] = json.dumps(entries)
            return record

        return metadata

    def refused(recording, *phrases):
        with pytest.raises(TelemetryError) as caught:
            verify(load_episode(recording))
        for phrase in (str(recording), *phrases):
            assert phrase in str(caught.value)
        result = CliRunner().invoke(app, ["replay", str(recording), "--verify"])
        assert result.exit_code == 2 and "Traceback" not in result.output, result.output
        for phrase in (str(recording), *phrases):
            assert phrase in " ".join(result.output.split()), result.output

    # one byte of the copy changed (a vertex moved): its digest no longer matches
    altered = tmp_path / "altered.mcap"
    rewrite_mcap(path, altered, keep, attachments=lambda n, d: d.replace(b"v 0.5 0.5 0.5", b"v 0.5 0.5 0.6"))
    refused(altered, str(obj), "obstacle_mesh_0.obj", "does not match its recorded sha256")
    # the metadata points at an attachment the file does not hold
    missing = tmp_path / "missing.mcap"
    rewrite_mcap(path, missing, keep, table(lambda e: e.update(attachment="obstacle_mesh_7.obj")))
    refused(missing, str(obj), "obstacle_mesh_7.obj", "is missing")
    # a recording from before meshes were embedded
    older = tmp_path / "older.mcap"

    def drop(name, record):
        record.pop("obstacle_meshes", None)
        return record

    rewrite_mcap(path, older, keep, drop)
    refused(older, str(obj), "holds no copy")
    # a copy that is not an OBJ mesh, its digest made to match: refused by the load's checks
    cut = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"
    malformed = tmp_path / "malformed.mcap"
    rewrite_mcap(
        path,
        malformed,
        keep,
        table(lambda e: e.update(sha256=hashlib.sha256(cut).hexdigest())),
        attachments=lambda n, d: cut if n == "obstacle_mesh_0.obj" else d,
    )
    refused(malformed, "obstacle_mesh_0.obj", "a face names vertex 4, the file holds 3")
    # a copy naming a material library by a path (PyBullet would open it from the cache's folder)
    for library in ("../../../etc/some.mtl", "sub\\some.mtl"):
        reaching = f"mtllib {library}\n{CUBE_OBJ}".encode()
        named = tmp_path / f"mtllib_{len(library)}.mcap"
        rewrite_mcap(
            path,
            named,
            keep,
            table(lambda e, d=reaching: e.update(sha256=hashlib.sha256(d).hexdigest())),
            attachments=lambda n, d, r=reaching: r if n == "obstacle_mesh_0.obj" else d,
        )
        refused(named, "obstacle_mesh_0.obj", "'mtllib ", "some.mtl", "names a file by a path")
    assert not [f for f in private_cache.iterdir() if f.suffix == ".obj"]  # nothing refused was written


def test_the_recorded_copy_is_what_verify_flies(tmp_path, private_cache):
    """Another mesh in the attachment (its digest made to match) re-simulates another episode:
    the copy, not the file the config names, is flown."""
    import hashlib
    import json

    from pyflyt_engine.telemetry import load_episode
    from pyflyt_engine.telemetry.replay import verify
    from tests.telemetry.conftest import rewrite_mcap

    obj = tmp_path / "cube.obj"
    obj.write_text(CUBE_OBJ)
    path = _record_into_the_cube(tmp_path / "runs", obj)
    far = CUBE_OBJ.replace("v -0.5", "v 5.5").replace("v 0.5", "v 6.5").encode()  # the cube moved 6 m along x

    def metadata(name, record):
        if name == "env":
            entries = json.loads(record["obstacle_meshes"])
            entries[0]["sha256"] = hashlib.sha256(far).hexdigest()
            record["obstacle_meshes"] = json.dumps(entries)
        return record

    swapped = tmp_path / "swapped.mcap"
    rewrite_mcap(
        path, swapped, lambda topic, data: None, metadata, attachments=lambda n, d: far if n.endswith(".obj") else d
    )
    result = verify(load_episode(swapped), tolerance=0.0)  # the original file is still there, and not read
    assert not result.ok and "did not" in result.diverged_termination, result


def test_a_mesh_file_changed_after_the_env_was_built_is_not_recorded(tmp_path):
    from pyflyt_engine.errors import TelemetryError
    from pyflyt_engine.telemetry import RecordEpisode

    obj = tmp_path / "cube.obj"
    obj.write_text(CUBE_OBJ)
    env = RecordEpisode(
        QuadXHoverEnv(obstacles={"items": [{"type": "mesh", "file": str(obj), "position": [2.0, 0.0, 1.0]}]}),
        tmp_path / "runs",
    )
    obj.write_text(CUBE_OBJ.replace("v 0.5 0.5 0.5", "v 0.5 0.5 0.7"))
    with pytest.raises(TelemetryError, match="changed since the environment was built"):
        env.reset(seed=0)
    env.close()
    assert not list((tmp_path / "runs").glob("*.mcap"))  # refused before any file was made


def test_a_recorded_forest_episode_replays_exactly(tmp_path):
    from pyflyt_engine.telemetry import RecordEpisode, load_episode
    from pyflyt_engine.telemetry.replay import verify

    env = RecordEpisode(QuadXObstaclesEnv(), tmp_path)
    rng = np.random.default_rng(0)
    for seed in (3, None):  # a seeded episode and the one after it
        env.reset(seed=seed)
        for _ in range(40):
            if any(env.step(np.array([*rng.uniform(-0.5, 0.5, 3), rng.uniform(0.1, 0.16)]))[2:4]):
                break
    env.close()
    for path in env.paths:
        result = verify(load_episode(path), tolerance=0.0)
        assert result.ok and result.max_deviation == 0.0 and result.max_reward_deviation == 0.0, result


def test_a_forest_keeps_clear_of_the_gates(make):
    forest = {
        "generators": [{**FOREST, "x_range": [-8.0, 8.0], "y_range": [-8.0, 8.0], "density": 0.3, "keep_out": 0.8}]
    }
    env = make("PyFlyt/QuadX-Gates-v0", obstacles=forest)
    env.reset(seed=1)
    trunks = [o for o in env.obstacles.generated if o is not None]
    assert len(trunks) > 50
    for centre in env.task.centres:
        for o in trunks:
            assert math.hypot(o.position[0] - centre[0], o.position[1] - centre[1]) - o.radius >= 0.8


def test_scenery_of_another_mesh_format_is_drawn_as_its_embedded_file(tmp_path):
    # a body a task adds with an STL visual: not an OBJ, so the file itself goes in as a model
    import base64

    from pyflyt_engine.telemetry.scene import body_entity

    stl = tmp_path / "plate.stl"
    stl.write_text(
        "solid plate\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n"
        "  endloop\n endfacet\nendsolid plate\n"
    )
    client = p.connect(p.DIRECT)
    try:
        visual = p.createVisualShape(p.GEOM_MESH, fileName=str(stl), meshScale=[2.0, 3.0, 4.0], physicsClientId=client)
        body = p.createMultiBody(0.0, -1, visual, [1.0, 2.0, 3.0], physicsClientId=client)
        e = body_entity(0, client, body)
    finally:
        p.disconnect(client)
    assert e is not None and not e["triangles"] and len(e["models"]) == 1
    model = e["models"][0]
    assert model["media_type"] == "model/stl" and base64.b64decode(model["data"]) == stl.read_bytes()
    assert [model["scale"][k] for k in "xyz"] == [2.0, 3.0, 4.0]
    assert [model["pose"]["position"][k] for k in "xyz"] == [1.0, 2.0, 3.0]
    assert e["metadata"] == [{"key": "mesh", "value": "plate.stl"}]

"""What ported PyFlyt code imports, subclasses and reads runs here (the reproductions of the
issue that asked for the reference's module tree, names and unwrapped attributes).

Facts about the reference come from PyFlyt 0.29.0 (its module tree and signatures) or from
``tests/compat/data/reference_episodes.json`` (recorded by
``experiments/record_reference_episodes.py`` in the reference's interpreter)."""

from __future__ import annotations

import importlib
import json
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium import spaces

import pyflyt_engine.compat.gym_envs  # noqa: F401 - registers the reference ids
from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_base_env import QuadXBaseEnv

RECORD = json.loads((Path(__file__).parent / "data" / "reference_episodes.json").read_text())
FACTS = RECORD["facts"]

#: PyFlyt 0.29.0's public modules and the names user code takes from them
REFERENCE_TREE = {
    "core": ["Aviary", "loadOBJ", "obj_visual", "obj_collision"],
    "core.aviary": ["Aviary", "AviaryInitException"],
    "core.utils.load_objs": ["loadOBJ", "obj_visual", "obj_collision"],
    "core.utils.compile_helpers": ["jitter", "check_numpy"],
    "core.abstractions": ["ControlClass", "DroneClass", "WindFieldClass", "Camera", "Motors", "PID"],
    "core.abstractions.base_controller": ["ControlClass"],
    "core.abstractions.base_drone": ["DroneClass"],
    "core.abstractions.base_wind_field": ["WindFieldClass"],
    "core.abstractions.boosters": ["Boosters"],
    "core.abstractions.boring_bodies": ["BoringBodies"],
    "core.abstractions.camera": ["Camera"],
    "core.abstractions.gimbals": ["Gimbals"],
    "core.abstractions.lifting_surfaces": ["LiftingSurface", "LiftingSurfaces"],
    "core.abstractions.motors": ["Motors"],
    "core.abstractions.pid": ["PID"],
    "core.drones": ["QuadX", "Fixedwing", "Rocket"],
    "core.wind": [],
    "gym_envs": ["FlattenWaypointEnv"],
    "gym_envs.quadx_envs.quadx_base_env": ["QuadXBaseEnv"],
    "gym_envs.quadx_envs.quadx_hover_env": ["QuadXHoverEnv"],
    "gym_envs.quadx_envs.quadx_waypoints_env": ["QuadXWaypointsEnv"],
    "gym_envs.quadx_envs.quadx_gates_env": ["QuadXGatesEnv"],
    "gym_envs.quadx_envs.quadx_pole_balance_env": ["QuadXPoleBalanceEnv"],
    "gym_envs.quadx_envs.quadx_pole_waypoints_env": ["QuadXPoleWaypointsEnv"],
    "gym_envs.quadx_envs.quadx_ball_in_cup_env": ["QuadXBallInCupEnv"],
    "gym_envs.fixedwing_envs.fixedwing_base_env": ["FixedwingBaseEnv"],
    "gym_envs.fixedwing_envs.fixedwing_waypoints_env": ["FixedwingWaypointsEnv"],
    "gym_envs.rocket_envs.rocket_base_env": ["RocketBaseEnv"],
    "gym_envs.rocket_envs.rocket_landing_env": ["RocketLandingEnv"],
    "gym_envs.utils.waypoint_handler": ["WaypointHandler"],
    "gym_envs.utils.pole_handler": ["PoleHandler"],
    "gym_envs.utils.flatten_waypoint_env": ["FlattenWaypointEnv"],
    "pz_envs": ["MAQuadXHoverEnvV2", "MAFixedwingDogfightEnvV2"],
    "pz_envs.quadx_envs.ma_quadx_base_env": ["MAQuadXBaseEnv"],
    "pz_envs.quadx_envs.ma_quadx_hover_env": ["MAQuadXHoverEnv"],
    "pz_envs.fixedwing_envs.ma_fixedwing_base_env": ["MAFixedwingBaseEnv"],
    "pz_envs.fixedwing_envs.ma_fixedwing_dogfight_env": ["MAFixedwingDogfightEnv"],
}


@pytest.mark.parametrize("module", sorted(REFERENCE_TREE))
def test_the_references_module_paths_import_with_their_names(module):
    loaded = importlib.import_module(f"pyflyt_engine.compat.{module}")
    for name in REFERENCE_TREE[module]:
        assert hasattr(loaded, name), f"pyflyt_engine.compat.{module} lacks {name}"


def test_the_stock_classes_are_the_registered_ones():
    from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_hover_env import QuadXHoverEnv
    from pyflyt_engine.compat.pz_envs import MAQuadXHoverEnvV2
    from pyflyt_engine.compat.pz_envs.quadx_envs.ma_quadx_hover_env import MAQuadXHoverEnv

    env = gymnasium.make("PyFlyt/QuadX-Hover-v4")
    try:
        assert type(env.unwrapped) is QuadXHoverEnv
    finally:
        env.close()
    assert MAQuadXHoverEnv is MAQuadXHoverEnvV2


def test_python_drone_classes_stay_refused_with_the_documented_message():
    from pyflyt_engine.compat.core.abstractions import UnsupportedFeature
    from pyflyt_engine.compat.core.abstractions.camera import Camera
    from pyflyt_engine.compat.core.drones import QuadX

    for cls in (QuadX, Camera):
        with pytest.raises(UnsupportedFeature, match="YAML"):
            cls()


@pytest.mark.parametrize(
    "option", [{"model_dir": "models/", "drone_model": "modded_drone"}, {"drone_model": "primitive_drone"}]
)
def test_the_references_drone_model_files_are_refused_as_files_not_as_python_classes(option, tmp_path):
    """A project that flies its own QuadX model (a URDF and its YAML of motor, drag and control
    parameters, as the reference's model_dir / drone_model select) is told that those files are
    not read and what to pass instead -- not that it wrote a Python class, which it did not."""
    from pyflyt_engine.compat.core import Aviary
    from pyflyt_engine.compat.core.abstractions import UnsupportedFeature

    with pytest.raises(UnsupportedFeature) as refused:
        Aviary(
            start_pos=np.zeros((1, 3)) + [0, 0, 1], start_orn=np.zeros((1, 3)), drone_type="quadx", drone_options=option
        )
    message = str(refused.value)
    assert "drone model files" in message and "drone_type" in message and "Python" not in message


# ------------------------------------------------------------------ the unwrapped env


def test_unwrapped_env_is_the_aviary_and_its_state_reads_as_the_references():
    env = gymnasium.make("PyFlyt/QuadX-Hover-v4", angle_representation="euler")
    try:
        obs, _ = env.reset(seed=0)
        base = env.unwrapped
        state = base.env.state(0)  # the line of many public projects
        assert list(state.shape) == FACTS["hover_unwrapped_env_state_shape"]
        np.testing.assert_allclose(state[-1], obs[9:12])
        assert base.max_steps == FACTS["hover_max_steps"] and base.env_step_ratio == FACTS["hover_env_step_ratio"]
        assert base.step_count == 0 and np.array_equal(base.action, np.zeros(4))
        obs, reward, *_ = env.step(np.array([0.0, 0.0, 0.0, 0.3]))
        assert base.step_count == 1 and base.reward == reward
        np.testing.assert_array_equal(base.state, obs)
        np.testing.assert_array_equal(base.action, [0.0, 0.0, 0.0, 0.3])
        assert set(FACTS["hover_reset_info"]) <= set(base.info)
        assert np.any(base.env.contact_array) in (True, False) and base.env.planeId == base.world.ground_id
    finally:
        env.close()


@pytest.mark.parametrize(
    "env_id", ["PyFlyt/QuadX-Hover-v4", "PyFlyt/QuadX-Waypoints-v4", "PyFlyt/QuadX-Pole-Balance-v4"]
)
def test_assigning_start_pos_moves_the_spawn_as_in_the_reference(env_id):
    # reference: start_pos (1, -2, 3) -> first observed position (1, -2, 2.965) (settled)
    env = gymnasium.make(env_id)
    try:
        env.unwrapped.start_pos = np.array([[1.0, -2.0, 3.0]])
        env.reset(seed=0)
        position = env.unwrapped.env.state(0)[-1]
        # the reference's first position after its 10 settling steps
        np.testing.assert_allclose(position, FACTS["hover_moved_spawn_first_position"], atol=0.01)
        np.testing.assert_allclose(env.unwrapped.start_pos, [[1.0, -2.0, 3.0]])
    finally:
        env.close()
    with pytest.raises(ValueError, match="start_pos"):
        gymnasium.make("PyFlyt/QuadX-Hover-v4").unwrapped.start_pos = [1.0, 2.0]


def test_render_fps_is_the_references():
    for env_id, fps in FACTS["render_fps"].items():
        env = gymnasium.make(env_id, agent_hz=40) if "Fixedwing" not in env_id else gymnasium.make(env_id)
        try:
            assert env.unwrapped.metadata["render_fps"] == fps
        finally:
            env.close()


def test_waypoints_expose_the_handler_and_yaw_targets_work():
    env = gymnasium.make("PyFlyt/QuadX-Waypoints-v4", use_yaw_targets=True, num_targets=3)
    try:
        obs, _ = env.reset(seed=2)
        w = env.unwrapped.waypoints
        assert len(w.targets) == 3 and len(w.yaw_targets) == 3 and w.num_targets_reached == 0
        assert obs["target_deltas"].shape == (3, 4) and env.observation_space.contains(obs)
        assert np.all(np.asarray(w.targets)[:, 2] >= 0.1)  # PyFlyt 0.29.0: min_height 0.1
        assert np.all(np.linalg.norm(w.targets, axis=1) <= 0.9 * 5.0 + 1e-9)
    finally:
        env.close()


def test_subclassing_a_stock_env_overrides_its_reward_as_in_the_reference():
    from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_hover_env import QuadXHoverEnv

    class AltitudeOnly(QuadXHoverEnv):
        def compute_term_trunc_reward(self):
            super().compute_base_term_trunc_reward()
            self.reward = -abs(self.env.state(0)[-1][2] - 1.0)

    env = AltitudeOnly()
    try:
        env.reset(seed=0)
        _, reward, *_ = env.step(np.array([0.0, 0.0, 0.0, 0.3]))
        assert reward == pytest.approx(-abs(env.env.state(0)[-1][2] - 1.0))
    finally:
        env.close()


# ------------------------------------------------------------------ the base envs


class _PointHover(QuadXBaseEnv):
    """A task written as for the reference: hold (0, 0, 1)."""

    def __init__(self, **kwargs):
        super().__init__(flight_dome_size=3.0, **kwargs)
        self.observation_space = self.combined_space

    def reset(self, *, seed=None, options=None):
        super().begin_reset(seed, options)
        super().end_reset(seed, options)
        return self.state, self.info

    def compute_state(self):
        ang_vel, ang_pos, lin_vel, lin_pos, quaternion = super().compute_attitude()
        self.state = np.concatenate([ang_vel, quaternion, lin_vel, lin_pos, self.action, super().compute_auxiliary()])

    def compute_term_trunc_reward(self):
        super().compute_base_term_trunc_reward()
        self.reward -= float(np.linalg.norm(self.env.state(0)[-1] - [0.0, 0.0, 1.0]))


def test_a_task_on_quadx_base_env_runs_as_in_the_reference():
    env = _PointHover()
    try:
        obs, info = env.reset(seed=0)
        assert env.observation_space.contains(obs) and info == {
            "out_of_bounds": False,
            "collision": False,
            "env_complete": False,
        }
        # 10 settling steps of 1/120 s, as the reference: 3.4 cm below the spawn
        assert obs[12] == pytest.approx(1.0 - 0.5 * 9.81 / 144, abs=3e-3)
        total, steps = 0.0, 0
        while True:
            obs, reward, terminated, truncated, info = env.step(np.array([0.0, 0.0, 0.0, 0.3]))
            total, steps = total + reward, steps + 1
            if terminated or truncated:
                break
        # the crash sets -100, then the task's own term is subtracted, as in the reference
        assert terminated and info["collision"] and -101.5 < reward <= -100.0 and env.step_count == steps
        env.start_pos = np.array([[0.5, 0.0, 1.5]])
        env.reset(seed=0)
        np.testing.assert_allclose(env.env.state(0)[-1][:2], [0.5, 0.0], atol=1e-6)
    finally:
        env.close()


def test_base_env_episodes_repeat_under_a_seed():
    returns = []
    for _ in range(2):
        env = _PointHover()
        env.reset(seed=4)
        returns.append(sum(env.step(np.array([0.1, 0.0, 0.0, 0.31]))[1] for _ in range(20)))
        env.close()
    assert returns[0] == returns[1]


def test_a_fixedwing_task_with_the_waypoint_handler():
    from pyflyt_engine.compat.gym_envs.fixedwing_envs.fixedwing_base_env import FixedwingBaseEnv
    from pyflyt_engine.compat.gym_envs.utils.waypoint_handler import WaypointHandler

    class Course(FixedwingBaseEnv):
        def __init__(self):
            super().__init__(flight_dome_size=100.0)
            self.waypoints = WaypointHandler(False, 2, False, 2.0, np.inf, 100.0, 0.5, self.np_random)

        def reset(self, *, seed=None, options=None):
            super().begin_reset(seed, options)
            self.waypoints.reset(self.env, self.np_random)
            super().end_reset()
            return self.state, self.info

        def compute_state(self):
            ang_vel, ang_pos, lin_vel, lin_pos, q = self.compute_attitude()
            self.state = self.waypoints.distance_to_targets(ang_pos, lin_pos, q)

        def compute_term_trunc_reward(self):
            super().compute_base_term_trunc_reward()
            self.reward += max(3.0 * self.waypoints.progress_to_next_target, 0.0)

    env = Course()
    try:
        deltas, _ = env.reset(seed=1)
        assert deltas.shape == (2, 3)
        # the reference's first target delta, body frame: the target minus the position, rotated
        position = env.env.state(0)[-1]
        np.testing.assert_allclose(np.linalg.norm(deltas[0]), np.linalg.norm(env.waypoints.targets[0] - position))
        env.step(np.array([0.0, 0.0, 0.0, 0.0]))  # thrust -1 .. 1 reaches the aircraft as 0 .. 1
        assert env.env.drones[0].setpoint[-1] == pytest.approx(0.5)
    finally:
        env.close()


def test_a_rocket_task_draws_and_accelerates_its_drop():
    from pyflyt_engine.compat.gym_envs.rocket_envs.rocket_base_env import RocketBaseEnv

    class Drop(RocketBaseEnv):
        def __init__(self):
            super().__init__(ceiling=500.0, max_displacement=200.0)
            self.observation_space = self.combined_space

        def reset(self, *, seed=None, options=None):
            super().begin_reset(seed, {"randomize_drop": True, "accelerate_drop": True})
            super().end_reset()
            return self.state, self.info

        def compute_state(self):
            self.state = self.env.state(0)

        def compute_term_trunc_reward(self):
            super().compute_base_term_trunc_reward()

    env = Drop()
    try:
        env.reset(seed=3)
        _, _, lin_vel, lin_pos = env.env.state(0)
        assert 0.8 * 500 - 10 <= lin_pos[2] <= 0.9 * 500 and np.all(np.abs(lin_pos[:2]) <= 20.0)
        assert np.linalg.norm(lin_vel) > 90.0  # falling at ~100 m/s
        np.testing.assert_allclose(env.env.aux_state(0), FACTS["rocket_env_aux_at_reset"], atol=1e-9)
    finally:
        env.close()


# ------------------------------------------------------------------ core


def test_aviary_names_the_reference_has():
    from pyflyt_engine.compat.core import Aviary

    aviary = Aviary(start_pos=np.array([[0.0, 0.0, 10.0]]), start_orn=np.zeros((1, 3)), drone_type="rocket")
    try:
        assert len(aviary.armed_drones) == FACTS["armed_drones_count"]
        aviary.set_armed(False)
        assert aviary.armed_drones == []
        aviary.reset()
        assert aviary.armed_drones == aviary.drones
        np.testing.assert_allclose(aviary.aux_state(0), FACTS["aviary_rocket_aux_at_start"], atol=1e-9)
        aviary.set_mode(0)
        aviary.set_setpoint(0, np.array([0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0]))
        for _ in range(30):
            aviary.step()
        burning, ref = aviary.aux_state(0), FACTS["aviary_rocket_aux_burning"]
        # [fins x 4, ignition, fuel, throttle, gimbals x 2]: lit, burning fuel, throttled up
        assert burning[4] == ref[4] == 1.0 and burning[5] < 0.05 and burning[6] > 0.5
        last = aviary.state(0)
    finally:
        aviary.disconnect()
    assert FACTS["state_after_disconnect_is_last"] is True
    np.testing.assert_array_equal(aviary.drones[0].state, last)


def test_camera_depth_is_the_z_buffer():
    from pyflyt_engine.compat.core import Aviary

    aviary = Aviary(
        start_pos=np.array([[0.0, 0.0, 1.0]]),
        start_orn=np.zeros((1, 3)),
        drone_type="quadx",
        drone_options={"use_camera": True},
    )
    try:
        aviary.set_mode(0)
        for _ in range(5):
            aviary.step()
        depth = aviary.drones[0].depthImg
        low, high = FACTS["camera_depth_range"]  # the reference's: [0.87, 1.0]
        assert 0.0 <= depth.min() and depth.max() <= 1.0 + 1e-6
        assert depth.min() == pytest.approx(low, abs=0.1) and depth.max() == pytest.approx(high, abs=1e-3)
    finally:
        aviary.disconnect()


def test_load_obj_puts_a_mesh_body_in_the_world(tmp_path):
    from pyflyt_engine.compat.core import Aviary, loadOBJ, obj_collision, obj_visual

    mesh = tmp_path / "cube.obj"
    corners = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
    faces = [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]
    lines = [f"v {x} {y} {z}" for x, y, z in corners] + [f"f {a} {b} {c} {d}" for a, b, c, d in faces]
    mesh.write_text("\n".join(lines) + "\n")
    aviary = Aviary(start_pos=np.array([[0.0, 0.0, 1.0]]), start_orn=np.zeros((1, 3)), drone_type="quadx")
    try:
        before = aviary.getNumBodies()
        body = loadOBJ(
            aviary,
            fileName=str(mesh),
            visualId=obj_visual(aviary, str(mesh)),
            collisionId=obj_collision(aviary, str(mesh)),
            basePosition=[3.0, 0.0, 0.5],
        )
        assert aviary.getNumBodies() == before + 1
        position, _ = aviary.getBasePositionAndOrientation(body)
        np.testing.assert_allclose(position, [3.0, 0.0, 0.5])
        assert body < aviary.contact_array.shape[0]  # registered for collisions
    finally:
        aviary.disconnect()


# ------------------------------------------------------------------ PettingZoo


def test_pettingzoo_envs_pass_the_api_test_with_warnings_as_errors():
    from pettingzoo.test import parallel_api_test

    from pyflyt_engine.compat.pz_envs import MAFixedwingDogfightEnvV2, MAQuadXHoverEnvV2

    for env in (MAQuadXHoverEnvV2(), MAFixedwingDogfightEnvV2(team_size=1)):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                parallel_api_test(env, num_cycles=20)
                env.reset(seed=0, options={"anything": 1})  # the reference ignores options, silently
            assert env.num_possible_agents == len(env.possible_agents)
            assert env.agent_name_mapping == {f"uav_{i}": i for i in range(env.num_possible_agents)}
            assert env.step_count == 0 and env.max_steps > 0
            np.testing.assert_allclose(env.aviary.state(0)[-1], env.world.vehicles[0].state.lin_pos)
        finally:
            env.close()


def test_a_multi_agent_task_on_the_base_env():
    from pyflyt_engine.compat.pz_envs.quadx_envs.ma_quadx_base_env import MAQuadXBaseEnv

    class Hold(MAQuadXBaseEnv):
        def observation_space(self, agent=None):
            return spaces.Box(-np.inf, np.inf, shape=(3,), dtype=np.float64)

        def reset(self, seed=None, options=None):
            super().begin_reset(seed, options)
            super().end_reset(seed, options)
            return {a: self.compute_observation_by_id(self.agent_name_mapping[a]) for a in self.agents}, {
                a: {} for a in self.agents
            }

        def compute_observation_by_id(self, agent_id):
            return self.aviary.state(agent_id)[-1]

        def compute_term_trunc_reward_info_by_id(self, agent_id):
            crashed = bool(np.any(self.aviary.contact_array[self.aviary.drones[agent_id].Id]))
            return crashed, self.step_count > self.max_steps, -1.0, {"crashed": crashed}

    env = Hold(max_duration_seconds=1.0)
    try:
        obs, _ = env.reset(seed=0)
        assert set(obs) == {"uav_0", "uav_1", "uav_2", "uav_3"}
        _, rewards, *_ = env.step({a: np.array([0.0, 0.0, 0.0, 0.3]) for a in env.agents})
        assert rewards == {a: -3.0 for a in env.possible_agents}  # summed over 120 / 40 Aviary steps
        while env.agents:
            env.step({a: np.zeros(4) for a in env.agents})  # motors idle: every one falls and lands
        assert env.step_count <= env.max_steps + 2
    finally:
        env.close()


@pytest.mark.parametrize("env_id", sorted(pyflyt_engine.compat.gym_envs.REFERENCE_IDS))
def test_making_resetting_and_stepping_a_reference_id_warns_nothing(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gymnasium.make(env_id)
        try:
            env.reset(seed=0, options={"unknown": 1})  # the reference ignores reset options
            env.step(env.action_space.sample())
        finally:
            env.close()


def test_the_pole_handler_builds_a_free_pole_that_rests_on_the_vehicle():
    from pyflyt_engine.compat.core import Aviary
    from pyflyt_engine.compat.gym_envs.utils.pole_handler import PoleHandler

    aviary = Aviary(start_pos=np.array([[0.0, 0.0, 1.0]]), start_orn=np.zeros((1, 3)), drone_type="quadx")
    try:
        pole = PoleHandler()
        pole.reset(aviary, np.array([0.0, 0.0, 1.55]))  # the reference's pole envs' start
        aviary.register_all_new_bodies()
        aviary.set_mode(0)
        for _ in range(60):
            aviary.step()
        _, _, lin_vel, lin_pos = aviary.state(0)
        top, _, bottom, _ = pole.compute_state(np.eye(3), lin_pos, lin_vel)
        # upright, 1 m long, its foot on the airframe: PyFlyt 0.29.0 pole.urdf's geometry
        assert np.linalg.norm(top - bottom) == pytest.approx(1.0, abs=1e-6)
        assert 0.0 < bottom[2] < 0.1 and pole.leaningness < 0.05
        assert pole.observation_space.shape == (12,)
    finally:
        aviary.disconnect()


def test_a_malformed_aviary_raises_the_references_exception():
    from pyflyt_engine.compat.core.aviary import Aviary, AviaryInitException

    with pytest.raises(AviaryInitException, match=r"start_pos must be an array of shape \(n, 3\)"):
        Aviary(start_pos=np.zeros(3), start_orn=np.zeros(3), drone_type="quadx")
    assert issubclass(AviaryInitException, ValueError)


@pytest.mark.parametrize("module", sorted(RECORD["public_names"]))
def test_every_module_and_public_name_of_the_reference_exists(module):
    # recorded from the reference's package itself (experiments/record_reference_episodes.py)
    loaded = importlib.import_module(f"pyflyt_engine.compat.{module}")
    missing = [name for name in RECORD["public_names"][module] if not hasattr(loaded, name)]
    assert not missing, f"pyflyt_engine.compat.{module} lacks {missing}"


@pytest.mark.parametrize("module", sorted(RECORD["public_imports"]))
def test_names_the_references_modules_hold_through_imports_import_here(module):
    # `from PyFlyt.core.aviary import DroneIndex` or `... quadx_hover_env import QuadXBaseEnv`
    # works on the reference (recorded from its package): so it does here
    loaded = importlib.import_module(f"pyflyt_engine.compat.{module}")
    missing = [name for name in RECORD["public_imports"][module] if not hasattr(loaded, name)]
    assert not missing, f"pyflyt_engine.compat.{module} lacks {missing}"


def test_a_fixedwings_starting_velocity_is_a_ground_frame_vector():
    # PyFlyt 0.29.0 Fixedwing.reset: resetBaseVelocity(Id, starting_velocity): ground frame
    from pyflyt_engine.compat.core import Aviary

    aviary = Aviary(
        start_pos=np.array([[0.0, 0.0, 50.0], [0.0, 30.0, 50.0]]),
        start_orn=np.array([[0.0, 0.0, np.pi / 2], [0.0, 0.0, np.pi / 2]]),
        drone_type="fixedwing",
        drone_options=[{"starting_velocity": np.array([0.0, 20.0, 0.0])}, {}],
    )
    try:
        # nose along +y, flying +y: all forward in the body frame
        np.testing.assert_allclose(aviary.state(0)[2], [20.0, 0.0, 0.0], atol=1e-6)
        np.testing.assert_allclose(aviary.world.vehicles[0].state.lin_vel_ground, [0.0, 20.0, 0.0], atol=1e-6)
        # the default (20, 0, 0) is ground +x, so a nose along +y slips sideways at spawn, as there
        np.testing.assert_allclose(aviary.world.vehicles[1].state.lin_vel_ground, [20.0, 0.0, 0.0], atol=1e-6)
        np.testing.assert_allclose(aviary.state(1)[2], [0.0, -20.0, 0.0], atol=1e-6)
    finally:
        aviary.disconnect()


def test_a_stock_env_subclass_overriding_reset_calls_its_two_halves_as_in_the_reference():
    from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_waypoints_env import QuadXWaypointsEnv

    class FixedCourse(QuadXWaypointsEnv):
        """The reference's pattern: begin_reset, the task's own set-up, end_reset."""

        def reset(self, *, seed=None, options=None):
            super().begin_reset(seed, options)
            self.waypoints.reset(self.env, self.np_random)
            self.waypoints.targets = np.array([[1.0, 0.0, 1.0], [1.0, 1.0, 1.0]])
            self.info["num_targets_reached"] = 0
            super().end_reset(seed, options)
            return self.state, self.info

    env = FixedCourse(num_targets=2, angle_representation="euler")
    try:
        obs, info = env.reset(seed=0)
        assert env.step_count == 0 and info["num_targets_reached"] == 0
        position = env.env.state(0)[-1]
        # settled 1/12 s below the spawn, as the stock reset; the deltas to the assigned course
        assert position[2] == pytest.approx(1.0 - 0.5 * 9.81 / 144, abs=3e-3)
        np.testing.assert_allclose(
            np.linalg.norm(obs["target_deltas"], axis=1),
            np.linalg.norm(env.waypoints.targets - position, axis=1),
            rtol=1e-9,
        )
        env.step(np.array([0.0, 0.0, 0.0, 0.3]))
        assert env.step_count == 1
    finally:
        env.close()


@pytest.mark.parametrize("key", sorted(FACTS["waypoint_targets"]))
def test_a_seeded_reset_draws_the_references_course(key):
    # PyFlyt 0.29.0: the course is the first draw of the env's seeded np_random
    env_id, *flags = key.split()
    for seed, course in FACTS["waypoint_targets"][key].items():
        env = gymnasium.make(env_id, **{flag: True for flag in flags})
        try:
            env.reset(seed=int(seed))
            w = env.unwrapped.waypoints
            np.testing.assert_allclose(w.targets, course["targets"], rtol=0, atol=1e-12)
            if "yaw_targets" in course:
                np.testing.assert_allclose(w.yaw_targets, course["yaw_targets"], rtol=0, atol=1e-12)
        finally:
            env.close()


def test_a_task_on_the_base_env_draws_the_references_course_from_np_random():
    # the reference's pattern (its QuadXWaypointsEnv): a handler reset with the env's np_random
    # right after begin_reset draws the course of the reference's seeded reset
    from pyflyt_engine.compat.gym_envs.utils.waypoint_handler import WaypointHandler

    class Course(_PointHover):
        def __init__(self):
            super().__init__()
            self.flight_dome_size = 5.0
            self.waypoints = WaypointHandler(False, 4, False, 0.2, 0.1, 5.0, 0.1, self.np_random)

        def reset(self, *, seed=None, options=None):
            super().begin_reset(seed, options)
            self.waypoints.reset(self.env, self.np_random)
            super().end_reset(seed, options)
            return self.state, self.info

    env = Course()
    try:
        for seed, course in FACTS["waypoint_targets"]["PyFlyt/QuadX-Waypoints-v4"].items():
            env.reset(seed=int(seed))
            np.testing.assert_allclose(env.waypoints.targets, course["targets"], rtol=0, atol=1e-12)
    finally:
        env.close()


def test_a_seeded_rocket_reset_drops_where_the_references_does():
    # PyFlyt 0.29.0 RocketBaseEnv, default randomize_drop: the first draws of the seeded np_random
    for seed, drop in FACTS["rocket_drop"].items():
        env = gymnasium.make("PyFlyt/Rocket-Landing-v4", angle_representation="euler")
        try:
            env.reset(seed=int(seed))
            np.testing.assert_allclose(env.unwrapped.start_pos, drop["start_pos"], rtol=0, atol=1e-9)
            np.testing.assert_allclose(env.unwrapped.start_orn, drop["start_orn"], rtol=0, atol=1e-12)
            # then 10 settling steps of 1/120 s at ~100 m/s downwards: ~8.3 m lower
            position = env.unwrapped.env.state(0)[-1]
            assert drop["start_pos"][0][2] - position[2] == pytest.approx(100.0 / 12, abs=0.5)
            np.testing.assert_allclose(position[:2], drop["start_pos"][0][:2], atol=0.5)
        finally:
            env.close()

"""The compat Aviary keeps the reference's semantics where the native World differs."""

from __future__ import annotations

import numpy as np
import pytest

from pyflyt_engine.compat.core import Aviary
from pyflyt_engine.compat.core.abstractions import ControlClass, DroneClass, UnsupportedFeature, WindFieldClass

ONE = np.array([[0.0, 0.0, 1.0]])
LEVEL = np.zeros((1, 3))


def test_state_rows_are_the_references_and_last_is_position():
    env = Aviary(start_pos=np.array([[0.5, -0.5, 1.0]]), start_orn=LEVEL, drone_type="quadx")
    try:
        state = env.state(0)
        assert state.shape == (4, 3)
        np.testing.assert_allclose(state[-1], [0.5, -0.5, 1.0], atol=1e-9)  # position last
        np.testing.assert_allclose(env.all_states[0], state)
        assert env.aux_state(0).shape == (4,)
    finally:
        env.disconnect()


def test_one_step_is_one_120th_of_a_second_and_the_slowest_controller_sets_it():
    env = Aviary(start_pos=ONE, start_orn=LEVEL, drone_type="quadx")
    try:
        for _ in range(120):
            env.step()
        assert env.elapsed_time == pytest.approx(1.0)
    finally:
        env.disconnect()
    env = Aviary(
        start_pos=np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]]),
        start_orn=np.zeros((2, 3)),
        drone_type="quadx",
        drone_options=[dict(control_hz=60), dict(control_hz=240)],
    )
    try:
        env.step()
        assert env.elapsed_time == pytest.approx(1 / 60)
        assert env.drones[0].control_period == pytest.approx(1 / 60)
    finally:
        env.disconnect()


def test_position_mode_holds_then_flies_to_the_setpoint():
    env = Aviary(start_pos=ONE, start_orn=LEVEL, drone_type="quadx")
    try:
        env.set_mode(7)  # the reference presets the setpoint to the current position
        for _ in range(240):
            env.step()
        np.testing.assert_allclose(env.state(0)[-1], [0.0, 0.0, 1.0], atol=0.05)
        env.set_setpoint(0, np.array([1.0, 0.0, 0.0, 1.0]))
        for _ in range(600):
            env.step()
        np.testing.assert_allclose(env.state(0)[-1], [1.0, 0.0, 1.0], atol=0.1)
    finally:
        env.disconnect()


def test_the_references_custom_controller_example_reaches_one_one_one():
    class Towards111(ControlClass):
        def __init__(self):
            pass

        def reset(self):
            pass

        def step(self, state, setpoint):
            velocity = np.array([1.0, 1.0, 1.0]) - state[-1]  # state[-1]: the position
            return np.array([*velocity[:2], 0.5, velocity[-1]])

    env = Aviary(start_pos=ONE, start_orn=LEVEL, drone_type="quadx")
    try:
        env.drones[0].register_controller(controller_constructor=Towards111, controller_id=8, base_mode=6)
        env.set_mode(8)
        for _ in range(1000):
            env.step()
        np.testing.assert_allclose(env.state(0)[-1], [1.0, 1.0, 1.0], atol=0.1)
    finally:
        env.disconnect()


def test_wind_function_and_class_push_the_vehicle():
    def updraft(time, position):
        wind = np.zeros_like(position)
        wind[:, -1] = 20.0
        return wind

    class Updraft(WindFieldClass):
        def __call__(self, time, position):
            return updraft(time, position)

    heights = []
    for mode in ("none", "function", "class"):
        env = Aviary(
            start_pos=np.array([[0.0, 0.0, 10.0]]),
            start_orn=LEVEL,
            drone_type="rocket",
            wind_type=Updraft if mode == "class" else None,
        )
        try:
            if mode == "function":
                env.register_wind_field_function(updraft)
            for _ in range(120):
                env.step()
            heights.append(env.state(0)[-1][2])
        finally:
            env.disconnect()
    assert heights[1] > heights[0] + 0.05 and heights[2] == pytest.approx(heights[1])


def test_contacts_by_body_id_and_bullet_methods():
    env = Aviary(start_pos=np.array([[0.0, 0.0, 0.0]]), start_orn=LEVEL, drone_type="quadx")
    try:
        env.step()
        assert env.contact_array[env.planeId, env.drones[0].Id]
        assert env.getNumBodies() == 2  # a PyBullet function, bound to this client
        env.register_all_new_bodies()
    finally:
        env.disconnect()


def test_cameras_come_from_drone_options():
    env = Aviary(
        start_pos=ONE,
        start_orn=LEVEL,
        drone_type="quadx",
        drone_options=dict(use_camera=True, camera_resolution=(32, 48)),
    )
    try:
        env.step()
        drone = env.drones[0]
        assert drone.rgbaImg.shape == (32, 48, 4) and drone.depthImg.shape == (32, 48, 1)
        assert drone.segImg.shape == (32, 48, 1)
    finally:
        env.disconnect()


def test_python_drone_classes_are_refused_with_the_yaml_route():
    class Brick(DroneClass):
        pass

    with pytest.raises(UnsupportedFeature, match="YAML"):
        Aviary(start_pos=ONE, start_orn=LEVEL, drone_type="brick", drone_type_mappings={"brick": Brick})
    with pytest.raises(UnsupportedFeature, match="YAML"):
        Brick()

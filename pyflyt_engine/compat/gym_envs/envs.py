"""The reference's single-agent envs, each one native env config with the reference's defaults.

Constructor arguments, their defaults, the spaces and the info keys are those of PyFlyt
0.29.0 (cited per class); the loop, tasks and rewards are the native ones
(:class:`~pyflyt_engine.envs.env.UAVEnv`).  ``docs/migrating_from_pyflyt.md`` lists
what still differs (rewards, spawn noise of some tasks, waypoint placement).
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np

from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.compat.gym_envs._base import (
    ReferenceEnv,
    common_overrides,
    headless_render_mode,
    native_config,
    quadx_action,
    still_spawn,
)
from pyflyt_engine.envs.fixedwing import FixedwingWaypointsEnv as _NativeFixedwingWaypoints
from pyflyt_engine.envs.quadx import QuadXHoverEnv as _NativeHover
from pyflyt_engine.envs.quadx import QuadXWaypointsEnv as _NativeWaypoints
from pyflyt_engine.envs.quadx_payloads import QuadXBallInCupEnv as _NativeBallInCup
from pyflyt_engine.envs.quadx_payloads import QuadXGatesEnv as _NativeGates
from pyflyt_engine.envs.quadx_payloads import QuadXPoleBalanceEnv as _NativePoleBalance
from pyflyt_engine.envs.quadx_payloads import QuadXPoleWaypointsEnv as _NativePoleWaypoints
from pyflyt_engine.envs.rocket import RocketLandingEnv as _NativeRocketLanding

Angles = Literal["euler", "quaternion"]
RenderMode = Literal["human", "rgb_array"] | None


def _no_yaw_targets(use_yaw_targets: bool) -> None:
    if use_yaw_targets:
        raise ValueError(
            "use_yaw_targets=True is not supported by pyflyt_engine.compat: waypoints here are positions only "
            "(docs/migrating_from_pyflyt.md)"
        )


class QuadXHoverEnv(ReferenceEnv, _NativeHover):
    """``PyFlyt/QuadX-Hover-v4``: the native hover task with the reference's arguments.

    PyFlyt 0.29.0 QuadXHoverEnv: sparse_reward False, flight_mode 0, flight_dome_size 3.0,
    max_duration_seconds 10.0, angle_representation "quaternion", agent_hz 40,
    render_resolution (480, 480); spawn exactly at (0, 0, 1), level, at rest; action
    [p, q, r, T] in [-pi, pi]^3 x [0, 0.8]; observation Box(21,) / Box(20,).
    """

    reference_id = "PyFlyt/QuadX-Hover-v4"

    def __init__(
        self,
        sparse_reward: bool = False,
        flight_mode: int = 0,
        flight_dome_size: float = 3.0,
        max_duration_seconds: float = 10.0,
        angle_representation: Angles = "quaternion",
        agent_hz: int = 40,
        render_mode: RenderMode = None,
        render_resolution: tuple[int, int] = (480, 480),
    ) -> None:
        cfg = common_overrides(
            native_config("quadx_hover"),
            reference_id=self.reference_id,
            sparse_reward=sparse_reward,
            flight_dome_size=flight_dome_size,
            max_duration_seconds=max_duration_seconds,
            angle_representation=angle_representation,
            agent_hz=agent_hz,
            render_mode=render_mode,
            render_resolution=render_resolution,
        )
        cfg["action"] = quadx_action(flight_mode)
        still_spawn(cfg["task"], (0.0, 0.0, 1.0))
        self.flight_mode = flight_mode
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)


class QuadXWaypointsEnv(ReferenceEnv, _NativeWaypoints):
    """``PyFlyt/QuadX-Waypoints-v4``.

    PyFlyt 0.29.0 QuadXWaypointsEnv: num_targets 4, use_yaw_targets False,
    goal_reach_distance 0.2, goal_reach_angle 0.1 (only with yaw targets), flight_mode 0,
    flight_dome_size 5.0, max_duration_seconds 10.0, agent_hz 30; spawn at (0, 0, 1);
    waypoints at least 0.1 m high; target deltas bounded by +-2 x flight_dome_size;
    info ``num_targets_reached``; the last target reached truncates the episode.
    """

    reference_id = "PyFlyt/QuadX-Waypoints-v4"
    completion_truncates = True

    def __init__(
        self,
        sparse_reward: bool = False,
        num_targets: int = 4,
        use_yaw_targets: bool = False,
        goal_reach_distance: float = 0.2,
        goal_reach_angle: float = 0.1,
        flight_mode: int = 0,
        flight_dome_size: float = 5.0,
        max_duration_seconds: float = 10.0,
        angle_representation: Angles = "quaternion",
        agent_hz: int = 30,
        render_mode: RenderMode = None,
        render_resolution: tuple[int, int] = (480, 480),
    ) -> None:
        _no_yaw_targets(use_yaw_targets)
        cfg = common_overrides(
            native_config("quadx_waypoints"),
            reference_id=self.reference_id,
            sparse_reward=sparse_reward,
            flight_dome_size=flight_dome_size,
            max_duration_seconds=max_duration_seconds,
            angle_representation=angle_representation,
            agent_hz=agent_hz,
            render_mode=render_mode,
            render_resolution=render_resolution,
        )
        cfg["action"] = quadx_action(flight_mode)
        cfg["task"].update(
            num_targets=int(num_targets), goal_reach_distance=float(goal_reach_distance), min_target_height=0.1
        )
        still_spawn(cfg["task"], (0.0, 0.0, 1.0))
        self.flight_mode, self.use_yaw_targets, self.goal_reach_angle = flight_mode, use_yaw_targets, goal_reach_angle
        self._delta_bound = 2.0 * float(flight_dome_size)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)


class QuadXPoleBalanceEnv(ReferenceEnv, _NativePoleBalance):
    """``PyFlyt/QuadX-Pole-Balance-v4``.

    PyFlyt 0.29.0 QuadXPoleBalanceEnv: flight_mode -1 (four motor commands in [0, 0.8]),
    flight_dome_size 3.0, max_duration_seconds 20.0, agent_hz 40; observation Box(33,) /
    Box(32,).
    """

    reference_id = "PyFlyt/QuadX-Pole-Balance-v4"

    def __init__(
        self,
        sparse_reward: bool = False,
        flight_mode: int = -1,
        flight_dome_size: float = 3.0,
        max_duration_seconds: float = 20.0,
        angle_representation: Angles = "quaternion",
        agent_hz: int = 40,
        render_mode: RenderMode = None,
        render_resolution: tuple[int, int] = (480, 480),
    ) -> None:
        cfg = common_overrides(
            native_config("quadx_pole_balance"),
            reference_id=self.reference_id,
            sparse_reward=sparse_reward,
            flight_dome_size=flight_dome_size,
            max_duration_seconds=max_duration_seconds,
            angle_representation=angle_representation,
            agent_hz=agent_hz,
            render_mode=render_mode,
            render_resolution=render_resolution,
        )
        cfg["action"] = quadx_action(flight_mode)
        self.flight_mode = flight_mode
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)


class QuadXPoleWaypointsEnv(ReferenceEnv, _NativePoleWaypoints):
    """``PyFlyt/QuadX-Pole-Waypoints-v4``.

    PyFlyt 0.29.0 QuadXPoleWaypointsEnv: num_targets 4, goal_reach_distance 0.2,
    flight_mode -1, flight_dome_size 10.0, max_duration_seconds 20.0, agent_hz 40;
    waypoints at least 1.3 m high; target deltas bounded by +-2 x flight_dome_size.
    """

    reference_id = "PyFlyt/QuadX-Pole-Waypoints-v4"
    completion_truncates = True

    def __init__(
        self,
        sparse_reward: bool = False,
        num_targets: int = 4,
        goal_reach_distance: float = 0.2,
        flight_mode: int = -1,
        flight_dome_size: float = 10.0,
        max_duration_seconds: float = 20.0,
        angle_representation: Angles = "quaternion",
        agent_hz: int = 40,
        render_mode: RenderMode = None,
        render_resolution: tuple[int, int] = (480, 480),
    ) -> None:
        cfg = common_overrides(
            native_config("quadx_pole_waypoints"),
            reference_id=self.reference_id,
            sparse_reward=sparse_reward,
            flight_dome_size=flight_dome_size,
            max_duration_seconds=max_duration_seconds,
            angle_representation=angle_representation,
            agent_hz=agent_hz,
            render_mode=render_mode,
            render_resolution=render_resolution,
        )
        cfg["action"] = quadx_action(flight_mode)
        cfg["task"].update(
            num_targets=int(num_targets), goal_reach_distance=float(goal_reach_distance), min_target_height=1.3
        )
        self.flight_mode = flight_mode
        self._delta_bound = 2.0 * float(flight_dome_size)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)


class QuadXBallInCupEnv(ReferenceEnv, _NativeBallInCup):
    """``PyFlyt/QuadX-Ball-In-Cup-v4``.

    PyFlyt 0.29.0 QuadXBallInCupEnv: goal_reach_distance 1.0, goal_reach_velocity 1.0,
    flight_mode 0, flight_dome_size 30.0, max_duration_seconds 10.0, agent_hz 30;
    observation Box(27,) / Box(26,).
    """

    reference_id = "PyFlyt/QuadX-Ball-In-Cup-v4"

    def __init__(
        self,
        sparse_reward: bool = False,
        goal_reach_distance: float = 1.0,
        goal_reach_velocity: float = 1.0,
        flight_mode: int = 0,
        flight_dome_size: float = 30.0,
        max_duration_seconds: float = 10.0,
        angle_representation: Angles = "quaternion",
        agent_hz: int = 30,
        render_mode: RenderMode = None,
        render_resolution: tuple[int, int] = (480, 480),
    ) -> None:
        cfg = common_overrides(
            native_config("quadx_ball_in_cup"),
            reference_id=self.reference_id,
            sparse_reward=sparse_reward,
            flight_dome_size=flight_dome_size,
            max_duration_seconds=max_duration_seconds,
            angle_representation=angle_representation,
            agent_hz=agent_hz,
            render_mode=render_mode,
            render_resolution=render_resolution,
        )
        cfg["action"] = quadx_action(flight_mode)
        cfg["task"].update(
            goal_reach_distance=float(goal_reach_distance), goal_reach_velocity=float(goal_reach_velocity)
        )
        self.flight_mode = flight_mode
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)


class QuadXGatesEnv(ReferenceEnv, _NativeGates):
    """``PyFlyt/QuadX-Gates-v3``.

    PyFlyt 0.29.0 QuadXGatesEnv: num_targets 5, flight_mode 0, goal_reach_distance 0.21,
    min_gate_height 1.0, max_gate_angles [0.0, 0.3, 1.0] (roll, pitch, yaw),
    min_gate_distance 1.0, max_gate_distance 4.0, camera_resolution (128, 128),
    max_duration_seconds 10.0, agent_hz 40; observation Dict(attitude, rgba_cam
    Box(0, 255, (4, H, W), uint8), target_deltas Sequence(Box(3,))).

    Here a gate is passed by flying through its opening (``goal_reach_distance`` is
    accepted and not used), the course climbs at most ``max_gate_angles[1]`` and turns at
    most ``max_gate_angles[2]`` per gate; gate roll is always 0.
    """

    reference_id = "PyFlyt/QuadX-Gates-v3"
    completion_truncates = False

    def __init__(
        self,
        num_targets: int = 5,
        flight_mode: int = 0,
        goal_reach_distance: float = 0.21,
        min_gate_height: float = 1.0,
        max_gate_angles: list[float] = [0.0, 0.3, 1.0],  # noqa: B006 - the reference's signature
        min_gate_distance: float = 1.0,
        max_gate_distance: float = 4.0,
        camera_resolution: tuple[int, int] = (128, 128),
        max_duration_seconds: float = 10.0,
        angle_representation: Angles = "quaternion",
        agent_hz: int = 40,
        render_mode: RenderMode = None,
        render_resolution: tuple[int, int] = (480, 480),
    ) -> None:
        base = native_config("quadx_gates")
        cfg = common_overrides(
            base,
            reference_id=self.reference_id,
            sparse_reward=False,
            flight_dome_size=base["flight_dome_size"],
            max_duration_seconds=max_duration_seconds,
            angle_representation=angle_representation,
            agent_hz=agent_hz,
            render_mode=render_mode,
            render_resolution=render_resolution,
        )
        cfg["action"] = quadx_action(flight_mode)
        n = int(num_targets)
        if n < 1:
            raise ValueError(f"num_targets must be at least 1, got {n}")
        template = cfg["payloads"][0]
        cfg["payloads"] = [
            {**template, "name": f"gate_{i}", "position": (2.0 * (i + 1), 0.0, 1.0)} for i in range(n)
        ]
        pitch, yaw = float(max_gate_angles[1]), float(max_gate_angles[2])
        cfg["task"].update(
            gates=[f"gate_{i}" for i in range(n)],
            min_gate_height=float(min_gate_height),
            min_gate_distance=float(min_gate_distance),
            max_gate_distance=float(max_gate_distance),
            max_turn=min(abs(yaw), math.pi),
            max_climb=min(abs(pitch), 1.5),
            max_gate_height=max(cfg["task"]["max_gate_height"], float(min_gate_height)),
        )
        cfg["flight_dome_size"] = max(cfg["flight_dome_size"], 1.5 * n * float(max_gate_distance) + 5.0)
        cam = dict(cfg["camera_observation"])
        cam["camera"] = {**cam["camera"], "height": int(camera_resolution[0]), "width": int(camera_resolution[1])}
        cam.update(key="rgba_cam", channels="rgba", channel_first=True)
        cfg["camera_observation"] = cam
        self.flight_mode, self.goal_reach_distance = flight_mode, goal_reach_distance
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)


class FixedwingWaypointsEnv(ReferenceEnv, _NativeFixedwingWaypoints):
    """``PyFlyt/Fixedwing-Waypoints-v3`` (and ``-v4``).

    PyFlyt 0.29.0 FixedwingWaypointsEnv: num_targets 4, goal_reach_distance 2.0,
    flight_mode 0, flight_dome_size 100.0, max_duration_seconds 120.0, agent_hz 30; spawn
    at (0, 0, 10) flying at 20 m/s (PyFlyt 0.29.0 Fixedwing: starting_velocity
    (20, 0, 0)); waypoints at least 0.5 m high; action [aileron, elevator, rudder,
    thrust] in [-1, 1]^4; target deltas bounded by +-2 x flight_dome_size.
    """

    reference_id = "PyFlyt/Fixedwing-Waypoints-v3"
    completion_truncates = True

    def __init__(
        self,
        sparse_reward: bool = False,
        num_targets: int = 4,
        goal_reach_distance: float = 2.0,
        flight_mode: int = 0,
        flight_dome_size: float = 100.0,
        max_duration_seconds: float = 120.0,
        angle_representation: Angles = "quaternion",
        agent_hz: int = 30,
        render_mode: RenderMode = None,
        render_resolution: tuple[int, int] = (480, 480),
    ) -> None:
        if int(flight_mode) not in (-1, 0):
            raise ValueError(f"`flight_mode` of the fixed-wing must be -1 or 0, got {flight_mode}")
        cfg = common_overrides(
            native_config("fixedwing_waypoints"),
            reference_id=self.reference_id,
            sparse_reward=sparse_reward,
            flight_dome_size=flight_dome_size,
            max_duration_seconds=max_duration_seconds,
            angle_representation=angle_representation,
            agent_hz=agent_hz,
            render_mode=render_mode,
            render_resolution=render_resolution,
        )
        cfg["action"] = {**cfg["action"], "low": [-1.0, -1.0, -1.0, -1.0], "high": [1.0, 1.0, 1.0, 1.0]}
        task = cfg["task"]
        task.update(
            num_targets=int(num_targets),
            goal_reach_distance=float(goal_reach_distance),
            min_target_height=0.5,
            min_target_distance=min(task["min_target_distance"], 0.2 * float(flight_dome_size)),
        )
        still_spawn(task, (0.0, 0.0, 10.0))
        task["start_lin_vel"] = (20.0, 0.0, 0.0)
        self.flight_mode = flight_mode
        self._delta_bound = 2.0 * float(flight_dome_size)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)


class RocketLandingEnv(ReferenceEnv, _NativeRocketLanding):
    """``PyFlyt/Rocket-Landing-v4``.

    PyFlyt 0.29.0 RocketLandingEnv: ceiling 500.0, max_displacement 200.0,
    max_duration_seconds 30.0, agent_hz 40; spawn x, y ~ U(+-0.1 max_displacement),
    z ~ U(0.8, 0.9) x ceiling, attitude U(+-0.3) rad per angle, falling at 100 m/s (its
    default reset options ``randomize_drop`` and ``accelerate_drop``; the velocity noise it
    means to add is never applied), 5 % fuel (``starting_fuel_ratio``); out of bounds
    beyond max_displacement sideways or above the ceiling; info ``out_of_bounds``,
    ``fatal_collision``, ``env_complete``; observation Box(30,) / Box(29,) whose last entry (pad contact) is in [0, 1].
    """

    reference_id = "PyFlyt/Rocket-Landing-v4"

    def __init__(
        self,
        sparse_reward: bool = False,
        ceiling: float = 500.0,
        max_displacement: float = 200.0,
        max_duration_seconds: float = 30.0,
        angle_representation: Angles = "quaternion",
        agent_hz: int = 40,
        render_mode: RenderMode = None,
        render_resolution: tuple[int, int] = (480, 480),
    ) -> None:
        self.ceiling, self.max_displacement = float(ceiling), float(max_displacement)
        cfg = common_overrides(
            native_config("rocket_landing"),
            reference_id=self.reference_id,
            sparse_reward=sparse_reward,
            flight_dome_size=math.hypot(self.ceiling, self.max_displacement) + 1.0,
            max_duration_seconds=max_duration_seconds,
            angle_representation=angle_representation,
            agent_hz=agent_hz,
            render_mode=render_mode,
            render_resolution=render_resolution,
        )
        cfg["task"].update(
            start_position=(0.0, 0.0, 0.85 * self.ceiling),
            start_height_noise=0.05 * self.ceiling,
            start_position_noise=0.1 * self.max_displacement,
            start_orientation=(0.0, 0.0, 0.0),
            start_orientation_noise=0.3,
            start_lin_vel=(0.0, 0.0, 0.0),
            start_velocity_noise=0.0,
            start_ang_vel_noise=0.0,
            initial_fuel=0.05,
        )
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)

    #: PyFlyt 0.29.0 RocketBaseEnv ``accelerate_drop``: the drop starts at this ground velocity [m/s]
    drop_velocity = (0.0, 0.0, -100.0)

    def _after_spawn(self) -> None:
        state = self.vehicle.state
        cid = self.world.client
        rotation = np.array(p.getMatrixFromQuaternion(state.quaternion, physicsClientId=cid)).reshape(3, 3)
        body_velocity = rotation.T @ np.array(self.drop_velocity)  # ground -> body
        self.vehicle.reset(tuple(state.lin_pos), tuple(state.ang_pos), lin_vel=tuple(body_velocity))

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        observation, reward, terminated, truncated, info = super().step(action)
        x, y, z = self.vehicle.state.lin_pos
        if math.hypot(x, y) > self.max_displacement or z > self.ceiling:
            info["out_of_bounds"] = True
            terminated, truncated = True, False
        return observation, reward, terminated, truncated, info

    def _reference_info(self, info: dict[str, Any]) -> dict[str, Any]:
        info = dict(info)
        info["fatal_collision"] = bool(info.get("fatal_landing", False))
        return info

"""The reference's single-agent envs: a native env config's world, the reference's episode.

Constructor arguments, their defaults, the spaces, the info keys, the observations, the
rewards and the endings are those of PyFlyt 0.29.0 (cited per class): each env's
``compute_state`` and ``compute_term_trunc_reward`` are the reference's hooks, run by
:class:`~pyflyt_engine.compat.gym_envs._base.ReferenceEnv` every 1/120 s; the world
(airframe, payloads, pad, gates) is built by the native env class from its shipped
config.  ``docs/migrating_from_pyflyt.md`` lists what still differs (the vehicles'
models, random streams).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

import numpy as np

from gymnasium import spaces

from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.compat.gym_envs._base import (
    REFERENCE_PRIMITIVE_HOVER_COMMAND,
    ReferenceEnv,
    common_overrides,
    headless_render_mode,
    native_config,
    quadx_action,
    still_spawn,
)
from pyflyt_engine.compat.gym_envs.utils.waypoint_handler import WaypointHandler
from pyflyt_engine.envs.fixedwing import FixedwingWaypointsEnv as _NativeFixedwingWaypoints
from pyflyt_engine.envs.quadx import QuadXHoverEnv as _NativeHover
from pyflyt_engine.envs.quadx import QuadXWaypointsEnv as _NativeWaypoints
from pyflyt_engine.envs.quadx_payloads import QuadXBallInCupEnv as _NativeBallInCup
from pyflyt_engine.envs.quadx_gates import QuadXGatesEnv as _NativeGates
from pyflyt_engine.envs.quadx_payloads import QuadXPoleBalanceEnv as _NativePoleBalance
from pyflyt_engine.envs.quadx_payloads import QuadXPoleWaypointsEnv as _NativePoleWaypoints
from pyflyt_engine.envs.rocket import RocketLandingEnv as _NativeRocketLanding

Angles = Literal["euler", "quaternion"]
RenderMode = Literal["human", "rgb_array"] | None


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
        self.flight_mode, self.sparse_reward = flight_mode, bool(sparse_reward)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)

    def compute_state(self) -> None:
        """[ang_vel, Euler | quaternion, lin_vel, lin_pos, previous action, aux (4)]."""
        self.state = self._attitude(self.action, self.angle_representation)

    def compute_term_trunc_reward(self) -> None:
        """PyFlyt 0.29.0 QuadXHoverEnv, per 1/120 s: the base endings; dense: + 1 - |p - (0, 0, 1)|
        - |(roll, pitch)| - 0.01 r^2 (r the yaw rate)."""
        self.compute_base_term_trunc_reward()
        if not self.sparse_reward:
            ang_vel, ang_pos, _, lin_pos = self.env.state(0)
            self.reward -= 0.01 * float(ang_vel[2]) ** 2
            self.reward -= float(np.linalg.norm(lin_pos - np.array([0.0, 0.0, 1.0])) + np.linalg.norm(ang_pos[:2]))
            self.reward += 1.0


class _WaypointCourse(ReferenceEnv):
    """The reference's waypoint episode over a :class:`WaypointHandler` (PyFlyt 0.29.0 QuadX and
    Fixedwing waypoint envs): targets drawn at each reset, deltas observed in the body
    frame, reward 100 at a target reached, the last one truncating (``env_complete``)."""

    waypoints: WaypointHandler
    #: the dense reward's progress weight (PyFlyt 0.29.0: 3; Pole-Waypoints 15)
    _progress_weight: ClassVar[float] = 3.0
    #: the dense reward's inverse-distance weight (QuadX 0.1, Fixedwing 1.0, Pole-Waypoints 0.5)
    _closeness_weight: ClassVar[float] = 0.1
    #: the dense reward's yaw-rate penalty weight (QuadX 0.01, Fixedwing none)
    _yaw_rate_weight: ClassVar[float] = 0.01
    #: the reward of the step a target is reached (100; Pole-Waypoints 300)
    _reach_reward: ClassVar[float] = 100.0

    def _attitude_extras(self) -> np.ndarray:
        """Entries after the attitude vector (the pole's 12 values)."""
        return np.zeros(0)

    def _extra_shaping(self) -> float:
        """Further dense terms (Pole-Waypoints: 0.5 - the pole's lean)."""
        return 0.0

    def _reference_reset(self) -> None:
        self.waypoints.reset(self.env, self._reference_rng)
        self.info["num_targets_reached"] = 0

    def _marker_points(self) -> Any:
        return np.asarray(self.waypoints.targets, dtype=np.float64).reshape(-1, 3)

    def compute_state(self) -> None:
        """``attitude`` as Hover's; ``target_deltas`` (n, 3) to every remaining target, body frame
        ((n, 4) with yaw targets: the yaw error last)."""
        read = self.compute_attitude()
        _, ang_pos, _, lin_pos, quaternion = read
        attitude = self._attitude(self.action, self.angle_representation, read)
        self.state = {
            "attitude": np.concatenate([attitude, self._attitude_extras()]),
            "target_deltas": self.waypoints.distance_to_targets(ang_pos, lin_pos, quaternion),
        }

    def compute_term_trunc_reward(self) -> None:
        """Per 1/120 s: the base endings; dense: + max(k x progress, 0) + w / distance (- 0.01 r^2
        on the QuadX; + 0.5 - lean with the pole); a target reached: reward 100 (300 with the
        pole), the next target, the last truncates."""
        self.compute_base_term_trunc_reward()
        w = self.waypoints
        if not self.sparse_reward:
            self.reward += max(self._progress_weight * w.progress_to_next_target, 0.0)
            self.reward += self._closeness_weight / w.distance_to_next_target
            self.reward += self._extra_shaping()
            if self._yaw_rate_weight:
                self.reward -= self._yaw_rate_weight * float(self.env.state(0)[0][2]) ** 2
        if w.target_reached:
            self.reward = self._reach_reward
            w.advance_targets()
            self.truncation |= w.all_targets_reached
            self.info["env_complete"] = w.all_targets_reached
            self.info["num_targets_reached"] = w.num_targets_reached


class QuadXWaypointsEnv(_WaypointCourse, ReferenceEnv, _NativeWaypoints):
    """``PyFlyt/QuadX-Waypoints-v4``.

    PyFlyt 0.29.0 QuadXWaypointsEnv: num_targets 4, use_yaw_targets False,
    goal_reach_distance 0.2, goal_reach_angle 0.1 (only with yaw targets), flight_mode 0,
    flight_dome_size 5.0, max_duration_seconds 10.0, agent_hz 30; spawn at (0, 0, 1);
    waypoints at least 0.1 m high; target deltas bounded by +-2 x flight_dome_size;
    info ``num_targets_reached``; the last target reached truncates the episode.
    """

    reference_id = "PyFlyt/QuadX-Waypoints-v4"

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
        self.sparse_reward = bool(sparse_reward)
        self._delta_bound = 2.0 * float(flight_dome_size)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)
        self.waypoints = WaypointHandler(
            enable_render=False,  # the env's markers show the course
            num_targets=int(num_targets),
            use_yaw_targets=bool(use_yaw_targets),
            goal_reach_distance=float(goal_reach_distance),
            goal_reach_angle=float(goal_reach_angle),
            flight_dome_size=float(flight_dome_size),
            min_height=0.1,
            np_random=self.np_random,
        )
        if use_yaw_targets:  # PyFlyt 0.29.0: each delta gains the yaw error, same bounds
            b = self._delta_bound
            deltas = spaces.Sequence(spaces.Box(-b, b, shape=(4,), dtype=np.float64), stack=True)
            self.observation_space = spaces.Dict({**self.observation_space.spaces, "target_deltas": deltas})


class _PoleReadings(ReferenceEnv):
    """The native pole payload read as the reference's ``PoleHandler`` (PyFlyt 0.29.0): its
    12 values [tip position, base position, tip velocity, base velocity], relative to the
    vehicle in its body frame, and its ``leaningness`` (horizontal tip-to-base distance,
    1 once the tip is not above the base)."""

    def _attitude_extras(self) -> np.ndarray:
        return self.task.pole.observe(self.vehicle.state)

    @property
    def leaningness(self) -> float:
        return float(self.task.pole.lean)


class QuadXPoleBalanceEnv(_PoleReadings, ReferenceEnv, _NativePoleBalance):
    """``PyFlyt/QuadX-Pole-Balance-v4``.

    PyFlyt 0.29.0 QuadXPoleBalanceEnv: flight_mode -1 (four motor commands in [0, 0.8]),
    flight_dome_size 3.0, max_duration_seconds 20.0, agent_hz 40; observation Box(33,) /
    Box(32,).
    """

    reference_id = "PyFlyt/QuadX-Pole-Balance-v4"
    reference_hover_command = REFERENCE_PRIMITIVE_HOVER_COMMAND  # its primitive_drone

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
        still_spawn(cfg["task"], (0.0, 0.0, 1.0))
        self.flight_mode, self.sparse_reward = flight_mode, bool(sparse_reward)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)

    def compute_state(self) -> None:
        """Hover's attitude vector, then the pole's 12 values."""
        self.state = np.concatenate([self._attitude(self.action, self.angle_representation), self._attitude_extras()])

    def compute_term_trunc_reward(self) -> None:
        """PyFlyt 0.29.0 QuadXPoleBalanceEnv, per 1/120 s: the base endings (the pole touching the
        ground is a crash); dense: + 1 - |p - (0, 0, 1)| - |(roll, pitch)| - lean - 0.01 r^2."""
        self.compute_base_term_trunc_reward()
        if not self.sparse_reward:
            ang_vel, ang_pos, _, lin_pos = self.env.state(0)
            self.reward -= float(np.linalg.norm(lin_pos - np.array([0.0, 0.0, 1.0])) + np.linalg.norm(ang_pos[:2]))
            self.reward -= self.leaningness
            self.reward += 1.0
            self.reward -= 0.01 * float(ang_vel[2]) ** 2


class QuadXPoleWaypointsEnv(_PoleReadings, _WaypointCourse, ReferenceEnv, _NativePoleWaypoints):
    """``PyFlyt/QuadX-Pole-Waypoints-v4``.

    PyFlyt 0.29.0 QuadXPoleWaypointsEnv: num_targets 4, goal_reach_distance 0.2,
    flight_mode -1, flight_dome_size 10.0, max_duration_seconds 20.0, agent_hz 40;
    waypoints at least 1.3 m high; target deltas bounded by +-2 x flight_dome_size.
    """

    reference_id = "PyFlyt/QuadX-Pole-Waypoints-v4"
    reference_hover_command = REFERENCE_PRIMITIVE_HOVER_COMMAND  # its primitive_drone
    # PyFlyt 0.29.0 QuadXPoleWaypointsEnv: + max(15 progress, 0) + 0.5 / distance + 0.5 - lean, 300 a target
    _progress_weight = 15.0
    _closeness_weight = 0.5
    _reach_reward = 300.0

    def _extra_shaping(self) -> float:
        return 0.5 - self.leaningness

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
        still_spawn(cfg["task"], (0.0, 0.0, 1.0))
        self.flight_mode, self.sparse_reward = flight_mode, bool(sparse_reward)
        self._delta_bound = 2.0 * float(flight_dome_size)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)
        self.waypoints = WaypointHandler(
            enable_render=False,  # the env's markers show the course
            num_targets=int(num_targets),
            use_yaw_targets=False,
            goal_reach_distance=float(goal_reach_distance),
            goal_reach_angle=math.inf,
            flight_dome_size=float(flight_dome_size),
            min_height=1.3,
            np_random=self.np_random,
        )


class QuadXBallInCupEnv(ReferenceEnv, _NativeBallInCup):
    """``PyFlyt/QuadX-Ball-In-Cup-v4``.

    PyFlyt 0.29.0 QuadXBallInCupEnv: goal_reach_distance 1.0, goal_reach_velocity 1.0,
    flight_mode 0, flight_dome_size 30.0, max_duration_seconds 10.0, agent_hz 30; spawn
    exactly at (0, 0, 4); observation Box(27,) / Box(26,): the attitude vector, the ball's
    position relative to the vehicle and its velocity, both in the body frame.  The ball
    and cup are the native payloads (a 0.1 kg ball on a 0.5 m tether, a cup with a floor);
    the ball touching the cup counts as touching the vehicle, where the reference's ball
    rests on its airframe between the cup's walls.
    """

    reference_id = "PyFlyt/QuadX-Ball-In-Cup-v4"
    reference_hover_command = REFERENCE_PRIMITIVE_HOVER_COMMAND  # its primitive_drone

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
        still_spawn(cfg["task"], (0.0, 0.0, 4.0))
        self.flight_mode, self.sparse_reward = flight_mode, bool(sparse_reward)
        self.goal_reach_distance, self.goal_reach_velocity = float(goal_reach_distance), float(goal_reach_velocity)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)

    @property
    def pendulum_id(self) -> int:
        """The ball's PyBullet body (the reference's name)."""
        return int(self._payload_set.by_name[self.task.options.ball].body_id)

    @property
    def cup_id(self) -> int:
        return int(self._payload_set.by_name[self.task.options.cup].body_id)

    @property
    def _payload_set(self) -> Any:
        """The ball and cup (this env always builds them)."""
        assert self.payloads is not None
        return self.payloads

    def _reference_reset(self) -> None:
        self.drone_state_error = np.zeros(4)
        self.drone_state_prev_error = np.zeros(4)

    def compute_state(self) -> None:
        """The attitude vector, then the ball's body-frame offset and body-frame velocity; updates
        the four squared errors [|omega|^2, |angles|^2, |v|^2, |p - (0, 0, 1)|^2] the reward reads."""
        read = self.compute_attitude()
        _, _, _, lin_pos, quaternion = read
        rotation = np.array(p.getMatrixFromQuaternion(quaternion)).reshape(3, 3)  # body -> ground
        ball = self._payload_set.state(self.task.options.ball)
        self.ball_lin_pos, self.ball_lin_vel = np.asarray(ball.position), np.asarray(ball.lin_vel)
        self.ball_rel_lin_pos = rotation.T @ (self.ball_lin_pos - lin_pos)
        self.ball_rel_lin_vel = rotation.T @ self.ball_lin_vel  # the ball's own velocity, as the reference's
        self.drone_state_prev_error = self.drone_state_error.copy()
        error = self.env.state(0).copy()
        error[-1] -= np.array([0.0, 0.0, 1.0])
        self.drone_state_error = np.linalg.norm(error, axis=-1) ** 2
        attitude = self._attitude(self.action, self.angle_representation, read)
        self.state = np.concatenate([attitude, self.ball_rel_lin_pos, self.ball_rel_lin_vel])

    def _ball_touches_vehicle(self) -> bool:
        contacts = self.env.contact_array
        ball = self.pendulum_id
        return bool(contacts[ball, self.env.drones[0].Id] or contacts[ball, self.cup_id])

    def compute_term_trunc_reward(self) -> None:
        """PyFlyt 0.29.0 QuadXBallInCupEnv, per 1/120 s: the base endings (the ball on the ground
        is a crash); dense: + 0.4 - 0.01 r^2 - 0.01 x (sum of the squared errors), and with the
        ball above the vehicle - 4 ln(0.45 d + 0.01) (d its distance), else + its height
        below.  The ball touching the vehicle from below: -500, terminated
        (``self_collision``); from above with the position error^2 < goal_reach_distance and
        the velocity^2 < goal_reach_velocity: +1000, truncated (``env_complete``); else dense:
        + 50 x (the position error^2 shed) + 10 / (position error^2 + 0.1)."""
        self.compute_base_term_trunc_reward()
        offset = self.ball_lin_pos - self.env.state(0)[-1]
        height, distance = float(offset[2]), float(np.linalg.norm(offset))
        if not self.sparse_reward:
            self.reward -= 0.01 * float(self.env.state(0)[0][2]) ** 2
            self.reward += 0.4
            self.reward -= 0.01 * float(np.sum(self.drone_state_error))
            self.reward += -4.0 * float(np.log(0.45 * distance + 1e-2)) if height > 0.0 else height
        if not self._ball_touches_vehicle():
            return
        if height < 0.0:
            self.reward = -500.0
            self.termination = True
            self.info["self_collision"] = True
            return
        error = self.drone_state_error
        if error[-1] < self.goal_reach_distance and error[-2] < self.goal_reach_velocity:
            self.reward += 1000.0
            self.truncation = True
            self.info["env_complete"] = True
            return
        if not self.sparse_reward:
            self.reward += 50.0 * float(self.drone_state_prev_error[-1] - self.drone_state_error[-1])
            self.reward += 10.0 / (float(self.drone_state_error[-1]) + 0.1)


class QuadXGatesEnv(ReferenceEnv, _NativeGates):
    """``PyFlyt/QuadX-Gates-v3``.

    PyFlyt 0.29.0 QuadXGatesEnv: num_targets 5, flight_mode 0, goal_reach_distance 0.21,
    min_gate_height 1.0, max_gate_angles [0.0, 0.3, 1.0] (roll, pitch, yaw),
    min_gate_distance 1.0, max_gate_distance 4.0, camera_resolution (128, 128),
    max_duration_seconds 10.0, agent_hz 40; observation Dict(attitude, rgba_cam
    Box(0, 255, (4, H, W), uint8), target_deltas Sequence(Box(3,))).

    The episode is the reference's: a gate counts when the vehicle is within
    ``goal_reach_distance`` of its centre (+100; the last one terminates with
    ``env_complete``), more than 2 x ``max_gate_distance`` from the next gate is
    ``out_of_bounds`` (-100), no flight dome (the reference's is infinite), the camera
    frame is taken once per agent step.  The course is the native one: it climbs at most
    ``max_gate_angles[1]`` and turns at most ``max_gate_angles[2]`` per gate; gate roll is
    always 0; the gates are the native gate bodies.
    """

    reference_id = "PyFlyt/QuadX-Gates-v3"

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
        cfg["payloads"] = [{**template, "name": f"gate_{i}", "position": (2.0 * (i + 1), 0.0, 1.0)} for i in range(n)]
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
        self.flight_mode, self.goal_reach_distance = flight_mode, float(goal_reach_distance)
        self.num_targets, self.max_gate_distance = n, float(max_gate_distance)
        self.camera_resolution = tuple(camera_resolution)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)
        self.flight_dome_size = math.inf  # PyFlyt 0.29.0 QuadXGatesEnv: the base env's default

    def _reference_reset(self) -> None:
        """The course the native reset drew: gate centres, ground frame."""
        self.targets = [c.copy() for c in np.asarray(self.task.centres, dtype=np.float64)]
        key = self.config.camera_observation.key
        self._rgba_cam = np.zeros(self.observation_space[key].shape, dtype=np.uint8)  # until the settled frame

    def _camera_frame(self) -> None:
        """The onboard camera's (4, H, W) RGBA frame, taken now (once per agent step)."""
        key = self.config.camera_observation.key
        self._rgba_cam = self._observe(0, [self.vehicle.state])[key]

    def _after_agent_step(self) -> None:
        self._camera_frame()
        self.state["rgba_cam"] = self._rgba_cam

    def compute_state(self) -> None:
        """``attitude``, the last camera frame ``rgba_cam``, body-frame ``target_deltas`` to the gates left."""
        read = self.compute_attitude()
        _, _, _, lin_pos, quaternion = read
        rotation = np.array(p.getMatrixFromQuaternion(quaternion)).reshape(3, 3)  # body -> ground
        deltas = (np.asarray(self.targets) - lin_pos) @ rotation
        self.dis_error_scalar = float(np.linalg.norm(deltas[0]))
        self.state = {
            "attitude": self._attitude(self.action, self.angle_representation, read),
            "rgba_cam": self._rgba_cam,
            "target_deltas": deltas,
        }

    @property
    def target_reached(self) -> bool:
        return self.dis_error_scalar < self.goal_reach_distance

    def _marker_points(self) -> Any:
        return np.asarray(self.targets, dtype=np.float64).reshape(-1, 3)

    def compute_term_trunc_reward(self) -> None:
        """PyFlyt 0.29.0 QuadXGatesEnv, per 1/120 s: the base endings; more than 2 x
        max_gate_distance from the next gate: -100, ``out_of_bounds``; a gate reached: +100,
        the next one (the last terminates with ``env_complete``)."""
        self.compute_base_term_trunc_reward()
        if self.dis_error_scalar > 2.0 * self.max_gate_distance:
            self.reward += -100.0
            self.info["out_of_bounds"] = True
            self.termination = True
        if self.target_reached:
            self.reward += 100.0
            if len(self.targets) > 1:
                self.targets = self.targets[1:]
            else:
                self.info["env_complete"] = True
                self.termination = True


class FixedwingWaypointsEnv(_WaypointCourse, ReferenceEnv, _NativeFixedwingWaypoints):
    """``PyFlyt/Fixedwing-Waypoints-v3`` (and ``-v4``).

    PyFlyt 0.29.0 FixedwingWaypointsEnv: num_targets 4, goal_reach_distance 2.0,
    flight_mode 0, flight_dome_size 100.0, max_duration_seconds 120.0, agent_hz 30; spawn
    at (0, 0, 10) flying at 20 m/s (PyFlyt 0.29.0 Fixedwing: starting_velocity
    (20, 0, 0)); waypoints at least 0.5 m high; action [aileron, elevator, rudder,
    thrust] in [-1, 1]^4, the thrust reaching the aircraft as ``T / 2 + 0.5``
    (FixedwingBaseEnv.step); target deltas bounded by +-2 x flight_dome_size; dense reward
    + max(3 x progress, 0) + 1 / distance per 1/120 s; a crash is any contact.
    """

    reference_id = "PyFlyt/Fixedwing-Waypoints-v3"
    drone_kind = "fixedwing"
    _closeness_weight = 1.0
    _yaw_rate_weight = 0.0

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
        self.flight_mode, self.sparse_reward = flight_mode, bool(sparse_reward)
        self._delta_bound = 2.0 * float(flight_dome_size)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)
        self.waypoints = WaypointHandler(
            enable_render=False,  # the env's markers show the course
            num_targets=int(num_targets),
            use_yaw_targets=False,
            goal_reach_distance=float(goal_reach_distance),
            goal_reach_angle=math.inf,
            flight_dome_size=float(flight_dome_size),
            min_height=0.5,
            np_random=self.np_random,
        )

    def _crashed(self) -> bool:
        return bool(np.any(self.env.contact_array))

    def _to_setpoint(self, action: np.ndarray) -> np.ndarray:
        action[-1] = action[-1] / 2.0 + 0.5  # PyFlyt 0.29.0 FixedwingBaseEnv.step
        return action


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
    drone_kind = "rocket"
    step_reward = 0.0

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
        self.sparse_reward = bool(sparse_reward)
        super().__init__(cfg, render_mode=headless_render_mode(render_mode), info_reward_terms=False)
        self._finish_init(render_resolution, render_mode)

    #: PyFlyt 0.29.0 RocketBaseEnv ``accelerate_drop``: the drop starts at this ground velocity [m/s]
    drop_velocity = (0.0, 0.0, -100.0)

    def _after_spawn(self) -> None:
        """PyFlyt 0.29.0 ``RocketBaseEnv.begin_reset`` with its default ``randomize_drop``: the drop
        point x, y ~ U(+-0.1 ``max_displacement``), z ~ U(0.8, 0.9) x ``ceiling`` and the attitude
        ~ U(+-0.3) rad, in that order the first draws of the seeded stream (so a seed drops where
        the reference's does), then ``accelerate_drop``'s 100 m/s downwards."""
        rng = self._reference_rng
        spread = 0.1 * self.max_displacement
        xy = rng.uniform(-spread, spread, size=(2,))
        z = rng.uniform(0.8 * self.ceiling, 0.9 * self.ceiling)
        orn = rng.uniform(-0.3, 0.3, size=(3,))
        self._drop = (np.array([[xy[0], xy[1], z]]), orn[None, :])
        cid = self.world.client
        quaternion = p.getQuaternionFromEuler(orn.tolist(), physicsClientId=cid)
        rotation = np.array(p.getMatrixFromQuaternion(quaternion, physicsClientId=cid)).reshape(3, 3)
        body_velocity = rotation.T @ np.array(self.drop_velocity)  # ground -> body
        self.vehicle.reset((xy[0], xy[1], z), tuple(orn), lin_vel=tuple(body_velocity))

    @property
    def start_pos(self) -> np.ndarray:
        """(1, 3): the last drop point (PyFlyt 0.29.0: ``randomize_drop`` overwrites ``start_pos``
        at every reset, so assigning it has no lasting effect there either)."""
        drop = getattr(self, "_drop", None)
        return drop[0].copy() if drop is not None else self._task_option("start_position")

    @start_pos.setter
    def start_pos(self, value: Any) -> None:
        self._set_task_option("start_position", value)

    @property
    def start_orn(self) -> np.ndarray:
        """(1, 3): the last drop attitude (Euler angles, rad)."""
        drop = getattr(self, "_drop", None)
        return drop[1].copy() if drop is not None else self._task_option("start_orientation")

    @start_orn.setter
    def start_orn(self, value: Any) -> None:
        self._set_task_option("start_orientation", value)

    def _new_info(self) -> dict[str, Any]:
        return {"out_of_bounds": False, "fatal_collision": False, "env_complete": False}

    def _reference_reset(self) -> None:
        """PyFlyt 0.29.0 RocketLandingEnv.reset: no pad contact, the previous read-outs zero."""
        self.landing_pad_contact = 0.0
        self.ang_vel, self.lin_vel, self.lin_pos, self.ground_lin_vel = (np.zeros(3) for _ in range(4))
        self.previous_ang_vel, self.previous_lin_vel = np.zeros(3), np.zeros(3)
        self.previous_lin_pos, self.previous_ground_lin_vel = np.zeros(3), np.zeros(3)

    @property
    def landing_pad_id(self) -> int:
        """The pad's PyBullet body (the native landing task's)."""
        return int(self.task.pad_id)

    def compute_state(self) -> None:
        """[ang_vel, Euler | quaternion, lin_vel, lin_pos, previous action, aux (9), pad contact]."""
        self.previous_ang_vel, self.previous_lin_vel = self.ang_vel.copy(), self.lin_vel.copy()
        self.previous_lin_pos, self.previous_ground_lin_vel = self.lin_pos.copy(), self.ground_lin_vel.copy()
        self.ang_vel, self.ang_pos, self.lin_vel, self.lin_pos, quaternion = self.compute_attitude()
        rotation = np.array(p.getMatrixFromQuaternion(quaternion)).reshape(3, 3)
        self.ground_lin_vel = rotation @ self.lin_vel  # body -> ground
        angles = self.ang_pos if self.angle_representation == 0 else quaternion
        aux = self.compute_auxiliary()
        self.state = np.concatenate(
            [self.ang_vel, angles, self.lin_vel, self.lin_pos, self.action, aux, [self.landing_pad_contact]]
        )

    def compute_base_term_trunc_reward(self) -> None:
        """PyFlyt 0.29.0 RocketBaseEnv with the pad's contact ignored: the time limit; any other
        contact or z < 0 is ``fatal_collision``; beyond ``max_displacement`` sideways or above
        ``ceiling`` is ``out_of_bounds``."""
        if self.step_count > self.max_steps:
            self.truncation |= True
        contacts = self.env.contact_array.copy()
        rocket, pad = self.env.drones[0].Id, self.landing_pad_id
        contacts[rocket, pad] = contacts[pad, rocket] = False
        position = self.env.state(0)[-1]
        if np.any(contacts) or position[2] < 0.0:
            self.info["fatal_collision"] = True
            self.termination |= True
        if np.linalg.norm(position[:2]) > self.max_displacement or position[2] > self.ceiling:
            self.info["out_of_bounds"] = True
            self.termination |= True

    def compute_term_trunc_reward(self) -> None:
        """PyFlyt 0.29.0 RocketLandingEnv, per 1/120 s.  Dense: -0.3 + 0.3 / (lateral distance
        + 0.1) + 10 x (lateral distance gained) + 0.2 x (height lost) + 4 x (deceleration
        progress: the change of the ground vertical velocity + 1, over e^height, signed by
        whether it descends) - |yaw rate| - |(roll, pitch)|.  On the pad: + 5 - 0.3 |vz|; landing with |omega| > 0.35 or
        |v| > 1 (the previous step's) is fatal; at rest (|omega|, |v| < 0.02) and level
        (|roll, pitch| < 0.1) it truncates with + 3 (``env_complete``)."""
        self.compute_base_term_trunc_reward()
        if not self.sparse_reward:
            lateral_progress = float(np.linalg.norm(self.previous_lin_pos[:2]) - np.linalg.norm(self.lin_pos[:2]))
            vertical_progress = float(self.previous_lin_pos[-1] - self.lin_pos[-1])
            lateral_distance = float(np.linalg.norm(self.lin_pos[:2])) + 0.1
            descending = 1.0 if self.ground_lin_vel[-1] < 0.0 else -1.0
            deceleration = (self.ground_lin_vel[-1] - self.previous_ground_lin_vel[-1] + 1.0) / np.exp(self.lin_pos[-1])
            self.reward += (
                -0.3
                + 0.3 / lateral_distance
                + 10.0 * lateral_progress
                + 0.2 * vertical_progress
                + 4.0 * deceleration * descending
                - abs(float(self.ang_vel[-1]))
                - float(np.linalg.norm(self.ang_pos[:2]))
            )
        if not self.env.contact_array[self.env.drones[0].Id, self.landing_pad_id]:
            self.landing_pad_contact = 0.0
            return
        self.landing_pad_contact = 1.0
        self.reward += 5.0 - 0.3 * abs(self.ground_lin_vel[-1])
        if np.linalg.norm(self.previous_ang_vel) > 0.35 or np.linalg.norm(self.previous_lin_vel) > 1.0:
            self.termination |= True
            self.info["fatal_collision"] = True
            return
        if (
            np.linalg.norm(self.previous_ang_vel) < 0.02
            and np.linalg.norm(self.previous_lin_vel) < 0.02
            and np.linalg.norm(self.ang_pos[:2]) < 0.1
        ):
            self.truncation |= True
            self.info["env_complete"] = True
            self.reward += 3.0

"""Ball in cup: swing a ball hanging on a string from the vehicle up into a cup on its top.

Two payloads of the env config (``payloads:``, :mod:`pyflyt_engine.payloads`): the ball,
tethered below the vehicle (task option ``ball``), and the cup, welded on top (``cup``).
The ball's contacts with the vehicle are simulated (``collide_with_parent: true``), so a
ball striking the vehicle is a vehicle contact: a crash.

Per agent step the task reports, as extras:

* ``ball_height``: height of the ball's centre above the vehicle's centre of mass [m]
  (ground z difference);
* ``ball_distance``: distance from the vehicle's centre of mass to the ball's centre [m];
* ``ball_above``: 1 when ``ball_height > 0``;
* ``ball_cup_contact``: 1 when the ball touched the cup during the step with its centre
  above the vehicle's (the ball is in the cup);
* ``ball_hit_vehicle``: 1 when the ball touched the vehicle itself;
* ``hover_error``: squared distance of the vehicle from ``hover_point`` [m^2], and
  ``hover_error_decrease``: its decrease over the step [m^2];
* ``caught``: 1 when the ball is in the cup while the vehicle is within
  ``goal_reach_distance`` of ``hover_point`` and slower than ``goal_reach_velocity``
  (the reference's success test): the task is complete.

Observation: the attitude Box followed by 6 values in the vehicle's body frame: the ball's
position relative to the vehicle's centre of mass [m], then the ball's (ground) velocity
in body axes [m/s] (``R^T v_ball``, as the reference).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

import numpy as np
from gymnasium import spaces
from pydantic import Field

from pyflyt_engine import exact
from pyflyt_engine.envs.rewards import Condition, RewardTerm, StepContext, register_condition, register_term
from pyflyt_engine.envs.observe import FLAT, ObservationLayout, ObservationPart
from pyflyt_engine.envs.task_registry import register_task
from pyflyt_engine.envs.tasks.base import Task, TaskOptions, TaskSignals, Vec3
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import quaternion_to_rows
from pyflyt_engine.state import KinematicState

BALL_OBS_SIZE = 6


class BallInCupOptions(TaskOptions):
    """Options of the ball-in-cup task (``task:`` in the env YAML)."""

    name: Literal["ball_in_cup"] = "ball_in_cup"
    ball: str = Field("ball", description="name of the tethered ball payload")
    cup: str = Field("cup", description="name of the cup payload")
    hover_point: Vec3 = Field((0.0, 0.0, 2.0), description="point the vehicle should hold (x, y, z) [m], ground frame")
    goal_reach_distance: float = Field(
        1.0, gt=0, description="a catch counts within this distance of hover_point [m] (reference: 1)"
    )
    goal_reach_velocity: float = Field(
        1.0, gt=0, description="a catch counts below this vehicle speed [m/s] (reference: 1)"
    )


class BallInCupTask(Task):
    """Catch the tethered ball in the cup near ``hover_point`` (module docstring)."""

    name: ClassVar[str] = "ball_in_cup"
    Options: ClassVar[type[TaskOptions]] = BallInCupOptions
    provides: ClassVar[frozenset[str]] = frozenset({"ball_in_cup"})

    options: BallInCupOptions

    def __init__(self, options: TaskOptions, *, flight_dome_size: float, agent_hz: float) -> None:
        super().__init__(options, flight_dome_size=flight_dome_size, agent_hz=agent_hz)
        self._extras: dict[str, float] = {}
        self._hover_error = 0.0

    def setup(self, world: Any) -> None:
        payloads = self.payloads
        for role in ("ball", "cup"):
            name = getattr(self.options, role)
            if payloads is None or name not in payloads.by_name:
                have = ", ".join(payloads.by_name) if payloads is not None else "none"
                raise ConfigError(
                    f"task 'ball_in_cup' needs a payload named '{name}' (task.{role}); the env config declares: {have}"
                )
        if payloads.by_name[self.options.ball].spec.attach.joint != "tether":  # type: ignore[union-attr]
            raise ConfigError(f"task 'ball_in_cup': payload '{self.options.ball}' must hang on a tether (attach.joint)")

    def _hover_error_of(self, state: KinematicState) -> float:
        x, y, z = state.lin_pos
        hx, hy, hz = self.options.hover_point
        return (x - hx) ** 2 + (y - hy) ** 2 + (z - hz) ** 2

    def reset(self, state: KinematicState, rng: np.random.Generator) -> None:
        self._hover_error = self._hover_error_of(state)
        self._extras = {}

    def observation_space(self, attitude: spaces.Box) -> spaces.Space:
        return spaces.Box(-np.inf, np.inf, shape=(attitude.shape[0] + BALL_OBS_SIZE,), dtype=np.float64)

    def observation_parts(self, attitude: tuple[ObservationPart, ...]) -> ObservationLayout:
        return {
            FLAT: (
                *attitude,
                ObservationPart("ball_position", 3, "ball position relative to the centre of mass", "body, m"),
                ObservationPart("ball_velocity", 3, "ball velocity (ground) in body axes, R^T v_ball", "body, m/s"),
            )
        }

    def observe(self, attitude: np.ndarray, state: KinematicState) -> np.ndarray:
        ball = self.payloads.state(self.options.ball)  # type: ignore[union-attr]
        rotation = quaternion_to_rows(state.quaternion)
        relative = exact.rotate_t(rotation, ball.position - np.asarray(state.lin_pos))
        velocity = exact.rotate_t(rotation, ball.lin_vel)
        return np.concatenate((attitude, relative, velocity))

    def update(self, state: KinematicState) -> TaskSignals:
        o = self.options
        payloads = self.payloads
        ball = payloads.state(o.ball)  # type: ignore[union-attr]
        offset = ball.position - np.asarray(state.lin_pos)
        height = float(offset[2])
        in_cup = payloads.touched(o.ball, o.cup) and height > 0.0  # type: ignore[union-attr]
        hit_vehicle = payloads.touched(o.ball)  # type: ignore[union-attr]
        error = self._hover_error_of(state)
        u, v, w = state.lin_vel
        speed = math.sqrt(u * u + v * v + w * w)
        caught = in_cup and error < o.goal_reach_distance**2 and speed < o.goal_reach_velocity
        self._extras = {
            "ball_height": height,
            "ball_distance": exact.norm(offset),
            "ball_above": float(height > 0.0),
            "ball_cup_contact": float(in_cup),
            "ball_hit_vehicle": float(hit_vehicle),
            "hover_error": error,
            "hover_error_decrease": self._hover_error - error,
            "caught": float(caught),
        }
        self._hover_error = error
        return TaskSignals(complete=caught, extras=self._extras)

    def info(self) -> dict[str, Any]:
        e = self._extras
        return {
            "ball_in_cup": bool(e.get("ball_cup_contact", 0.0)),
            "ball_hit_vehicle": bool(e.get("ball_hit_vehicle", 0.0)),
            "ball_height": float(e.get("ball_height", 0.0)),
        }

    def markers(self) -> np.ndarray:
        return np.array([self.options.hover_point], dtype=np.float64)


# ------------------------------------------------ reward terms and conditions of this task


def ball_distance_log(ctx: StepContext, scale: float = 0.45, offset: float = 0.01) -> float:
    """ln(scale * d + offset), d the vehicle-to-ball distance [m] (ball-in-cup; the reference's 0.45, 0.01)."""
    return math.log(scale * ctx.extras["ball_distance"] + offset)


def ball_height(ctx: StepContext) -> float:
    """Height of the ball's centre above the vehicle's centre of mass [m] (ball-in-cup)."""
    return ctx.extras["ball_height"]


def inverse_hover_error(ctx: StepContext, offset: float = 0.1) -> float:
    """1 / (e + offset), e the squared distance of the vehicle from the task's hover point [1/m^2] (ball-in-cup)."""
    return 1.0 / (ctx.extras["hover_error"] + offset)


def hover_error_decrease(ctx: StepContext) -> float:
    """Decrease over the step of the squared distance from the task's hover point [m^2] (ball-in-cup)."""
    return ctx.extras["hover_error_decrease"]


def ball_above(ctx: StepContext) -> bool:
    """The ball's centre is above the vehicle's centre of mass (ball-in-cup)."""
    return ctx.extras.get("ball_above", 0.0) > 0.5


def ball_in_cup(ctx: StepContext) -> bool:
    """The ball touched the cup during the step with its centre above the vehicle's (ball-in-cup)."""
    return ctx.extras.get("ball_cup_contact", 0.0) > 0.5


def ball_hit_vehicle(ctx: StepContext) -> bool:
    """The ball struck the vehicle itself during the step (ball-in-cup)."""
    return ctx.extras.get("ball_hit_vehicle", 0.0) > 0.5


register_term("ball_distance_log", RewardTerm(ball_distance_log, "1", ("ball_in_cup",)))
register_term("ball_height", RewardTerm(ball_height, "m", ("ball_in_cup",)))
register_term("inverse_hover_error", RewardTerm(inverse_hover_error, "1/m^2", ("ball_in_cup",)))
register_term("hover_error_decrease", RewardTerm(hover_error_decrease, "m^2", ("ball_in_cup",)))
register_condition("ball_above", Condition(ball_above, ("ball_in_cup",)))
register_condition("ball_in_cup", Condition(ball_in_cup, ("ball_in_cup",)))
register_condition("ball_hit_vehicle", Condition(ball_hit_vehicle, ("ball_in_cup",)))


register_task(BallInCupTask)

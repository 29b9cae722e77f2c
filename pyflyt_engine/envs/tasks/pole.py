"""Pole tasks: keep a pole, pinned on top of the vehicle by a passive joint, upright.

The pole is a payload of the env config (``payloads:``, see :mod:`pyflyt_engine.payloads`)
named by the task option ``pole``; ``pole_base`` and ``pole_tip`` are its two ends in the
payload's own frame.

Lean (a number in [0, 1]): the horizontal distance between tip and base divided by the
pole's length, i.e. the sine of the pole's tilt from vertical, while the tip is above the
base; 1 once the tip is at or below the base.  The reference PyFlyt's "leaningness" is the
same horizontal distance in metres for its 1 m pole (not divided by the length).

The pole has **fallen** when its tip is at or below its base (tilt >= 90 deg): the episode
ends as a crash.  The reference's pole rests unattached on the vehicle and ends the episode
only when it (or anything) hits the ground; ours is pinned, so it can swing below the
vehicle instead of dropping off, and falling past horizontal is the failure.

Observation: the attitude Box followed by 12 values, all in the vehicle's body frame: the
pole tip and base positions relative to the vehicle's centre of mass [m], then their
velocities relative to the vehicle's centre of mass [m/s] (``R^T (v_point - v_vehicle)``).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

import numpy as np
from gymnasium import spaces
from pydantic import Field

from pyflyt_engine import exact
from pyflyt_engine.envs.rewards import RewardTerm, StepContext, register_term
from pyflyt_engine.envs.observe import FLAT, ObservationLayout, ObservationPart
from pyflyt_engine.envs.task_registry import register_task
from pyflyt_engine.envs.tasks.base import Task, TaskOptions, TaskSignals, Vec3
from pyflyt_engine.envs.tasks.hover import HoverOptions, HoverTask
from pyflyt_engine.envs.tasks.waypoints import WaypointsOptions, WaypointsTask
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import quaternion_to_rows
from pyflyt_engine.state import KinematicState

#: number of pole values appended to the attitude vector
POLE_OBS_SIZE = 12


def pole_lean(tip: np.ndarray, base: np.ndarray, length: float) -> float:
    """Lean in [0, 1]: horizontal tip-to-base distance / length while the tip is above the base, else 1."""
    dz = float(tip[2] - base[2])
    if dz <= 0.0:
        return 1.0
    dx, dy = float(tip[0] - base[0]), float(tip[1] - base[1])
    return min(1.0, math.sqrt(dx * dx + dy * dy) / length)


class _PoleFields(TaskOptions):
    pole: str = Field("pole", description="name of the pole payload (env config 'payloads')")
    pole_base: Vec3 = Field((0.0, 0.0, 0.0), description="lower end of the pole in the payload's frame [m]")
    pole_tip: Vec3 = Field((0.0, 0.0, 1.0), description="upper end of the pole in the payload's frame [m]")


class PoleReadout:
    """Reads the pole payload: lean, fallen flag and the 12 observation values."""

    def __init__(self, task: Task, options: _PoleFields) -> None:
        self.task = task
        self.options = options
        length = exact.norm(np.subtract(options.pole_tip, options.pole_base))
        if length <= 0:
            raise ConfigError("task.pole_tip and task.pole_base are the same point: give the two ends of the pole")
        self.length = length
        self.lean = 0.0
        self.fallen = False

    def check(self) -> None:
        """Called from the task's setup: the payload must exist."""
        payloads = self.task.payloads
        if payloads is None or self.options.pole not in payloads.by_name:
            have = ", ".join(payloads.by_name) if payloads is not None else "none"
            raise ConfigError(
                f"task '{self.task.name}' needs a payload named '{self.options.pole}' (task.pole); "
                f"the env config declares: {have}"
            )
        self._payload = payloads.by_name[self.options.pole]
        self._base = self._payload.local(self.options.pole_base)
        self._tip = self._payload.local(self.options.pole_tip)

    def observe(self, state: KinematicState) -> np.ndarray:
        """The 12 pole values (module docstring) and update :attr:`lean` / :attr:`fallen`."""
        s = self.task.payloads.state(self.options.pole)  # type: ignore[union-attr]
        tip, base = s.point(self._tip), s.point(self._base)
        self.lean = pole_lean(tip, base, self.length)
        self.fallen = bool(tip[2] <= base[2])
        rotation = quaternion_to_rows(state.quaternion)  # body -> ground
        position = np.asarray(state.lin_pos)
        velocity = np.asarray(state.lin_vel_ground)
        out = np.empty(POLE_OBS_SIZE)
        out[0:3] = exact.rotate_t(rotation, tip - position)
        out[3:6] = exact.rotate_t(rotation, base - position)
        out[6:9] = exact.rotate_t(rotation, s.point_velocity(self._tip) - velocity)
        out[9:12] = exact.rotate_t(rotation, s.point_velocity(self._base) - velocity)
        self._values = out
        return out

    @property
    def values(self) -> np.ndarray:
        return self._values


#: the pole's values after the attitude vector (module docstring), POLE_OBS_SIZE in all
POLE_PARTS = (
    ObservationPart("pole_tip", 3, "pole tip position relative to the centre of mass", "body, m"),
    ObservationPart("pole_base", 3, "pole base position relative to the centre of mass", "body, m"),
    ObservationPart("pole_tip_velocity", 3, "pole tip velocity relative to the centre of mass", "body, m/s"),
    ObservationPart("pole_base_velocity", 3, "pole base velocity relative to the centre of mass", "body, m/s"),
)


def _extend(attitude: spaces.Box) -> spaces.Box:
    size = attitude.shape[0] + POLE_OBS_SIZE
    return spaces.Box(-np.inf, np.inf, shape=(size,), dtype=np.float64)


class PoleBalanceOptions(HoverOptions, _PoleFields):
    """Options of the pole-balance task (``task:`` in the env YAML)."""

    name: Literal["pole_balance"] = "pole_balance"  # type: ignore[assignment]


class PoleBalanceTask(HoverTask):
    """Hover at ``hover_point`` with the pole upright (module docstring).

    Signals: as :class:`HoverTask` plus extras ``pole_lean`` (in [0, 1]) and
    ``pole_fallen`` (0/1); failed when the pole has fallen.
    """

    name: ClassVar[str] = "pole_balance"
    Options: ClassVar[type[TaskOptions]] = PoleBalanceOptions
    provides: ClassVar[frozenset[str]] = frozenset({"target_distance", "target_distance_rate", "pole"})

    def __init__(self, options: TaskOptions, *, flight_dome_size: float, agent_hz: float) -> None:
        super().__init__(options, flight_dome_size=flight_dome_size, agent_hz=agent_hz)
        self.pole = PoleReadout(self, self.options)  # type: ignore[arg-type]

    def setup(self, world: Any) -> None:
        self.pole.check()

    def observation_space(self, attitude: spaces.Box) -> spaces.Space:
        return _extend(attitude)

    def observation_parts(self, attitude: tuple[ObservationPart, ...]) -> ObservationLayout:
        return {FLAT: (*attitude, *POLE_PARTS)}

    def observe(self, attitude: np.ndarray, state: KinematicState) -> np.ndarray:
        return np.concatenate((attitude, self.pole.observe(state)))

    def update(self, state: KinematicState) -> TaskSignals:
        signals = super().update(state)
        self.pole.observe(state)
        return TaskSignals(
            target_distance=signals.target_distance,
            target_distance_rate=signals.target_distance_rate,
            failed=self.pole.fallen,
            extras={"pole_lean": self.pole.lean, "pole_fallen": float(self.pole.fallen)},
        )

    def info(self) -> dict[str, Any]:
        return {"pole_lean": self.pole.lean, "pole_fallen": self.pole.fallen}


class PoleWaypointsOptions(WaypointsOptions, _PoleFields):
    """Options of the pole-waypoints task (``task:`` in the env YAML)."""

    name: Literal["pole_waypoints"] = "pole_waypoints"  # type: ignore[assignment]


class PoleWaypointsTask(WaypointsTask):
    """Reach waypoints in order with the pole upright (module docstring; waypoints as :class:`WaypointsTask`).

    Observation: ``Dict(attitude=Box(attitude + 12 pole values), target_deltas=...)``.
    Signals: as :class:`WaypointsTask` plus extras ``pole_lean`` and ``pole_fallen``.
    """

    name: ClassVar[str] = "pole_waypoints"
    Options: ClassVar[type[TaskOptions]] = PoleWaypointsOptions
    provides: ClassVar[frozenset[str]] = WaypointsTask.provides | {"pole"}

    def __init__(self, options: TaskOptions, *, flight_dome_size: float, agent_hz: float) -> None:
        super().__init__(options, flight_dome_size=flight_dome_size, agent_hz=agent_hz)
        self.pole = PoleReadout(self, self.options)  # type: ignore[arg-type]

    def setup(self, world: Any) -> None:
        self.pole.check()

    def observation_space(self, attitude: spaces.Box) -> spaces.Space:
        return super().observation_space(_extend(attitude))

    def observation_parts(self, attitude: tuple[ObservationPart, ...]) -> ObservationLayout:
        return super().observation_parts((*attitude, *POLE_PARTS))

    def observe(self, attitude: np.ndarray, state: KinematicState) -> dict[str, np.ndarray]:
        return super().observe(np.concatenate((attitude, self.pole.observe(state))), state)

    def update(self, state: KinematicState) -> TaskSignals:
        signals = super().update(state)
        self.pole.observe(state)
        return TaskSignals(
            target_distance=signals.target_distance,
            target_distance_rate=signals.target_distance_rate,
            waypoint_reached=signals.waypoint_reached,
            complete=signals.complete,
            failed=self.pole.fallen,
            extras={"pole_lean": self.pole.lean, "pole_fallen": float(self.pole.fallen)},
        )

    def info(self) -> dict[str, Any]:
        return {**super().info(), "pole_lean": self.pole.lean, "pole_fallen": self.pole.fallen}


# ------------------------------------------------ reward terms and conditions of this task


def pole_lean_term(ctx: StepContext) -> float:
    """Lean of the pole in [0, 1]: sine of its tilt while upright, 1 once fallen (pole tasks)."""
    return ctx.extras["pole_lean"]


register_term("pole_lean", RewardTerm(pole_lean_term, "1", ("pole",)))


register_task(PoleBalanceTask)
register_task(PoleWaypointsTask)

"""Waypoints: reach a sequence of random points in order (any vehicle type)."""

from __future__ import annotations

from typing import Any, ClassVar, Literal

import numpy as np
from gymnasium import spaces
from pydantic import Field, model_validator

from pyflyt_engine.envs.observe import ObservationLayout, ObservationPart
from pyflyt_engine.envs.task_registry import register_task
from pyflyt_engine.envs.tasks.base import Task, TaskOptions, TaskSignals
from pyflyt_engine.envs.tasks.measures import Measure
from pyflyt_engine.envs.waypoints import WaypointTracker, body_frame_deltas, sample_waypoints
from pyflyt_engine.state import KinematicState


#: a row of ``target_deltas``, one per waypoint not yet reached, next first
TARGET_DELTA = ObservationPart(
    "target_delta", 3, "vector to a waypoint not yet reached, one row each, next first", "body, m"
)


class WaypointsOptions(TaskOptions):
    """Options of the waypoints task (``task:`` in the env YAML)."""

    name: Literal["waypoints"] = "waypoints"
    num_targets: int = Field(5, ge=1, description="waypoints per episode (paper: 5)")
    goal_reach_distance: float = Field(0.2, gt=0, description="reach distance d [m] (paper: 0.2 for QuadX)")
    min_target_distance: float = Field(1.0, ge=0, description="closest a waypoint is to the origin [m]")
    max_target_distance: float = Field(
        0.9, gt=0, description="farthest a waypoint is from the origin, as a fraction of the flight dome radius"
    )
    min_target_height: float = Field(0.1, ge=0, description="lowest waypoint height [m]")

    @model_validator(mode="after")
    def _ordered(self) -> WaypointsOptions:
        if self.max_target_distance > 1.0:
            raise ValueError(
                f"max_target_distance is a fraction of the flight dome radius and must be <= 1 "
                f"(waypoints outside the dome cannot be reached), got {self.max_target_distance}"
            )
        return self


class WaypointsTask(Task):
    """Reach ``num_targets`` random waypoints in order.

    Observation: ``Dict(attitude=Box, target_deltas=Sequence(Box(3,), stack=True))``, the
    deltas being body-frame vectors [m] from the vehicle to every waypoint not yet
    reached, next one first (shape ``(remaining, 3)``; ``(0, 3)`` once all are reached).

    Signals: ``target_distance`` delta [m] and ``target_distance_rate`` [m/s] to the next
    waypoint, ``waypoint_reached`` (see :mod:`pyflyt_engine.envs.waypoints` for the reach
    test); complete when the last waypoint is reached.

    Measures: ``waypoints_reached`` (of ``num_targets``) and ``all_reached`` (1 when every
    waypoint was reached: the episode's success unless it crashed on the last one).
    """

    name: ClassVar[str] = "waypoints"
    Options: ClassVar[type[TaskOptions]] = WaypointsOptions
    provides: ClassVar[frozenset[str]] = frozenset({"target_distance", "target_distance_rate", "waypoints"})
    # read at every reset (sampling, spawn) or step (the reach test); num_targets is not:
    # the renderer sizes its markers by it once
    episode_options: ClassVar[frozenset[str]] = frozenset(
        {
            "goal_reach_distance",
            "min_target_distance",
            "max_target_distance",
            "min_target_height",
            "start_position_noise",
            "start_orientation_noise",
        }
    )

    measures: ClassVar[tuple[Measure, ...]] = (
        Measure("waypoints_reached", "waypoints reached", digits=2),
        Measure("all_reached", "every waypoint reached", percent=True),
    )

    options: WaypointsOptions

    def __init__(self, options: TaskOptions, *, flight_dome_size: float, agent_hz: float) -> None:
        super().__init__(options, flight_dome_size=flight_dome_size, agent_hz=agent_hz)
        self.check_options(self.options)
        self.tracker = WaypointTracker(self.options.goal_reach_distance)

    def check_options(self, options: TaskOptions) -> None:
        o: WaypointsOptions = options  # type: ignore[assignment]
        if o.min_target_distance > o.max_target_distance * self.flight_dome_size:
            from pyflyt_engine.errors import ConfigError

            raise ConfigError(
                f"task.min_target_distance ({o.min_target_distance} m) exceeds max_target_distance x flight_dome_size "
                f"({o.max_target_distance} x {self.flight_dome_size} m): widen the dome or lower min_target_distance"
            )

    def options_changed(self) -> None:
        self.tracker.reach_distance = float(self.options.goal_reach_distance)

    def reset(self, state: KinematicState, rng: np.random.Generator) -> None:
        o = self.options
        targets = sample_waypoints(
            rng,
            o.num_targets,
            o.min_target_distance,
            o.max_target_distance * self.flight_dome_size,
            o.min_target_height,
        )
        self.tracker.reset(targets, state.lin_pos)

    def observation_space(self, attitude: spaces.Box) -> spaces.Space:
        deltas = spaces.Box(-np.inf, np.inf, shape=(3,), dtype=np.float64)
        return spaces.Dict({"attitude": attitude, "target_deltas": spaces.Sequence(deltas, stack=True)})

    def observation_parts(self, attitude: tuple[ObservationPart, ...]) -> ObservationLayout:
        return {"attitude": attitude, "target_deltas": (TARGET_DELTA,)}

    def observe(self, attitude: np.ndarray, state: KinematicState) -> dict[str, np.ndarray]:
        deltas = body_frame_deltas(self.tracker.remaining, state.lin_pos, state.quaternion)
        return {"attitude": attitude, "target_deltas": deltas}

    def update(self, state: KinematicState) -> TaskSignals:
        distance, rate, reached = self.tracker.step(state.lin_pos, self.agent_dt)
        return TaskSignals(
            target_distance=distance,
            target_distance_rate=rate,
            waypoint_reached=reached,
            complete=reached and self.tracker.all_reached,
        )

    def info(self) -> dict[str, Any]:
        return {"num_targets_reached": self.tracker.num_reached}

    def episode_measures(self) -> dict[str, float]:
        return {"waypoints_reached": float(self.tracker.num_reached), "all_reached": float(self.tracker.all_reached)}

    def markers(self) -> np.ndarray:
        return self.tracker.remaining.copy()

    def marker_style(self) -> tuple[int, float]:
        return self.options.num_targets, self.options.goal_reach_distance

    @property
    def targets(self) -> np.ndarray:
        """Every waypoint of the episode, ``(num_targets, 3)`` ground frame [m] (a copy)."""
        return self.tracker.targets.copy()


register_task(WaypointsTask)

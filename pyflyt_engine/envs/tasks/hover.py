"""Hover: stay at a fixed point, level, for as long as the episode lasts."""

from __future__ import annotations

import math
from typing import ClassVar, Literal

import numpy as np
from pydantic import Field

from pyflyt_engine.envs.task_registry import register_task
from pyflyt_engine.envs.tasks.base import Task, TaskOptions, TaskSignals, Vec3
from pyflyt_engine.envs.tasks.measures import DISTANCE_HELD, DistanceHeld, Measure
from pyflyt_engine.state import KinematicState


class HoverOptions(TaskOptions):
    """Options of the hover task (``task:`` in the env YAML)."""

    name: Literal["hover"] = "hover"
    hover_point: Vec3 = Field(
        (0.0, 0.0, 1.0), description="point to hold (x, y, z) [m], ground frame; the paper uses (0, 0, 1)"
    )


class HoverTask(Task):
    """Hold ``hover_point``.

    Signals: ``target_distance`` = distance to the hover point [m] (the paper's
    ||[x, y, z - 1]|| for the default point) and ``target_distance_rate`` [m/s].
    Never completes by itself: reaching the time limit without a crash is a success.

    Measures: ``distance_mean`` and ``distance_max``, the distance to the hover point over
    the episode's agent steps [m].
    """

    name: ClassVar[str] = "hover"
    Options: ClassVar[type[TaskOptions]] = HoverOptions
    provides: ClassVar[frozenset[str]] = frozenset({"target_distance", "target_distance_rate"})
    succeeds_at_time_limit: ClassVar[bool] = True
    measures: ClassVar[tuple[Measure, ...]] = DISTANCE_HELD

    options: HoverOptions

    def reset(self, state: KinematicState, rng: np.random.Generator) -> None:
        self._distance = self._distance_to_point(state)
        self._held = DistanceHeld()

    def _distance_to_point(self, state: KinematicState) -> float:
        x, y, z = state.lin_pos
        hx, hy, hz = self.options.hover_point
        return math.sqrt((x - hx) ** 2 + (y - hy) ** 2 + (z - hz) ** 2)

    def update(self, state: KinematicState) -> TaskSignals:
        distance = self._distance_to_point(state)
        rate = (distance - self._distance) / self.agent_dt
        self._distance = distance
        self._held.add(distance)
        return TaskSignals(target_distance=distance, target_distance_rate=rate)

    def episode_measures(self) -> dict[str, float]:
        return self._held.values()

    def markers(self) -> np.ndarray:
        return np.array([self.options.hover_point], dtype=np.float64)


register_task(HoverTask)

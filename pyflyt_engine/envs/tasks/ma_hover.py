"""The multi-agent hover task (``ma_hover``): every agent holds its own point.

Its options (:class:`MAHoverOptions`, ``task:`` of ``conf/env/ma_quadx_hover.yaml``), its
task (:class:`MAHoverTask`) and its registration, run by
:class:`~pyflyt_engine.envs.multi_agent.hover.MAQuadXHoverEnv`.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from pyflyt_engine.envs.observe import ObservationPart
from pyflyt_engine.envs.task_registry import register_task
from pyflyt_engine.envs.tasks.measures import DISTANCE_HELD, DistanceHeld, Measure
from pyflyt_engine.envs.tasks.multi import AgentSignals, MATaskOptions, MultiAgentTask, SpawnConfig, grid_layout
from pyflyt_engine.state import KinematicState


class MAHoverOptions(MATaskOptions):
    """``task:`` of MAQuadX-Hover: every agent holds its own point."""

    name: Literal["ma_hover"] = "ma_hover"
    layout: Literal["ring", "grid"] = Field(
        "ring", description="how agents given by count are placed: on a ring about the z axis, or on a square grid"
    )
    layout_radius: float = Field(
        1.0, ge=0, description="ring layout: agents given by count spawn on a ring of this radius about the z axis [m]"
    )
    layout_spacing: float = Field(
        1.0, gt=0, description="grid layout: distance between neighbouring agents on the square grid [m]"
    )
    layout_height: float = Field(1.0, gt=0, description="height of the ring or grid [m]")
    position_noise: float = Field(0.1, ge=0, description="layout spawn: U(-noise, noise) per coordinate [m]")
    orientation_noise: float = Field(0.1, ge=0, description="layout spawn: U(-noise, noise) per Euler angle [rad]")

    def layout_gap(self, count: int) -> float | None:
        """The distance between the closest two layout spawn centres (None for one agent)."""
        if count < 2:
            return None
        if self.layout == "grid":
            return self.layout_spacing
        return 2.0 * self.layout_radius * math.sin(math.pi / count)  # the chord between ring neighbours

    def layout_spawn(self, index: int, count: int) -> SpawnConfig:
        """Agent ``index`` of ``count`` on the ring or grid (the centre for a single agent), level, at rest."""
        if count == 1:
            position = (0.0, 0.0, self.layout_height)
        elif self.layout == "grid":
            position = grid_layout(index, count, self.layout_spacing, self.layout_height)
        else:
            angle = 2.0 * math.pi * index / count
            r = self.layout_radius
            position = (r * math.cos(angle), r * math.sin(angle), self.layout_height)
        return SpawnConfig(
            position=position, position_noise=self.position_noise, orientation_noise=self.orientation_noise
        )


class MAHoverTask(MultiAgentTask):
    """``ma_hover``: agent i holds ``hover_point`` of its resolved entry (its spawn centre
    by default); colliders are out; alive at the time limit is a success.

    Signals: ``target_distance`` (to the agent's point) [m] and ``target_distance_rate``
    [m/s].  Observation: the hover point minus the position (3, ground frame).
    Measures: each agent's ``distance_mean`` and ``distance_max`` to its point [m].
    """

    name: ClassVar[str] = "ma_hover"
    Options: ClassVar[type[MATaskOptions]] = MAHoverOptions
    provides: ClassVar[frozenset[str]] = frozenset({"target_distance", "target_distance_rate"})
    succeeds_at_time_limit: ClassVar[bool] = True
    measures: ClassVar[tuple[Measure, ...]] = DISTANCE_HELD

    def extra_size(self) -> int:
        return 3

    def observation_parts(self) -> tuple[ObservationPart, ...]:
        return (ObservationPart("hover_delta", 3, "the agent's hover point minus its position", "ground, m"),)

    def reset(self, states: list[KinematicState]) -> None:
        self._points = np.array([a.hover_point for a in self.agents], dtype=np.float64)
        self._distances = [self._distance(i, s) for i, s in enumerate(states)]
        self._held = [DistanceHeld() for _ in states]

    def _distance(self, i: int, state: KinematicState) -> float:
        x, y, z = state.lin_pos
        hx, hy, hz = self.agents[i].hover_point
        return math.sqrt((x - hx) ** 2 + (y - hy) ** 2 + (z - hz) ** 2)

    def update(
        self, states: list[KinematicState], live: list[int], collisions: dict[int, bool], step: int
    ) -> dict[int, AgentSignals]:
        out = {}
        dt = self.agent_dt
        for i in live:
            distance = self._distance(i, states[i])
            rate = (distance - self._distances[i]) / dt
            self._distances[i] = distance
            self._held[i].add(distance)
            out[i] = AgentSignals(
                target_distance=distance, target_distance_rate=rate, info={"target_distance": distance}
            )
        return out

    def observe(self, i: int, states: list[KinematicState]) -> np.ndarray:
        return self._points[i] - states[i].lin_pos

    def episode_measures(self, i: int) -> dict[str, float]:
        return self._held[i].values()

    def reset_info(self, i: int) -> dict[str, Any]:
        return {"target_distance": self._distances[i]}

    def markers(self) -> np.ndarray:
        return np.array([a.hover_point for a in self.agents], dtype=np.float64)


register_task(MAHoverTask, env="pyflyt_engine.envs.multi_agent.hover:MAQuadXHoverEnv")

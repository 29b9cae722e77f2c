"""The multi-agent hover task: every agent holds its own point."""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from pyflyt_engine.envs.multi_agent.task import AgentSignals, MultiAgentTask
from pyflyt_engine.envs.tasks.measures import DISTANCE_HELD, DistanceHeld, Measure
from pyflyt_engine.state import KinematicState


class MAHoverTask(MultiAgentTask):
    """``ma_hover``: agent i holds ``hover_point`` of its resolved entry (its spawn centre
    by default); colliders are out; alive at the time limit is a success.

    Signals: ``target_distance`` (to the agent's point) [m] and ``target_distance_rate``
    [m/s].  Observation: the hover point minus the position (3, ground frame).
    Measures: each agent's ``distance_mean`` and ``distance_max`` to its point [m].
    """

    name: ClassVar[str] = "ma_hover"
    provides: ClassVar[frozenset[str]] = frozenset({"target_distance", "target_distance_rate"})
    succeeds_at_time_limit: ClassVar[bool] = True
    measures: ClassVar[tuple[Measure, ...]] = DISTANCE_HELD

    def extra_size(self) -> int:
        return 3

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

"""The formation task (``ma_formation``): a swarm keeps a grid formation that moves at a set velocity.

Its options (:class:`MAFormationOptions`, ``task:`` of ``conf/env/ma_quadx_formation.yaml``),
its reward terms and condition (registered for every reward preset: they read the
``formation`` signal the task puts in ``ctx.extras``), its task (:class:`MAFormationTask`)
and its registration, run by :class:`~pyflyt_engine.envs.multi_agent.formation.MAQuadXFormationEnv`.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from pyflyt_engine.envs.rewards import Condition, RewardTerm, StepContext, register_condition, register_term
from pyflyt_engine.envs.observe import ObservationPart
from pyflyt_engine.envs.task_registry import register_task
from pyflyt_engine.envs.tasks.multi import AgentSignals, MATaskOptions, MultiAgentTask, SpawnConfig, Vec3, grid_layout
from pyflyt_engine.spatial import PlanarGrid
from pyflyt_engine.state import KinematicState


class MAFormationOptions(MATaskOptions):
    """``task:`` of MAQuadX-Formation: a swarm keeps a grid formation that moves at a set velocity."""

    name: Literal["ma_formation"] = "ma_formation"
    layout_spacing: float = Field(
        1.0, gt=0, description="distance between neighbouring slots of the square grid formation [m]"
    )
    layout_height: float = Field(1.5, gt=0, description="height of the formation at the start [m]")
    velocity: Vec3 = Field(
        (0.2, 0.0, 0.0), description="the formation's velocity (x, y, z) [m/s], ground frame: every slot moves with it"
    )
    neighbours: int = Field(3, ge=0, le=16, description="nearest other live agents each agent observes")
    neighbour_radius: float = Field(
        3.0, gt=0, description="an agent observes the neighbours within this distance only [m]"
    )
    separation: float = Field(
        0.5, gt=0, description="closer to another live agent than this is crowding (the crowding term) [m]"
    )
    tolerance: float = Field(
        0.25, gt=0, description="in formation: within this distance of both the slot and the shape (sparse reward) [m]"
    )
    position_noise: float = Field(0.05, ge=0, description="layout spawn: U(-noise, noise) per coordinate [m]")
    orientation_noise: float = Field(0.05, ge=0, description="layout spawn: U(-noise, noise) per Euler angle [rad]")

    def layout_gap(self, count: int) -> float | None:
        """The distance between the closest two layout spawn centres (None for one agent)."""
        return self.layout_spacing if count > 1 else None

    def layout_spawn(self, index: int, count: int) -> SpawnConfig:
        """Agent ``index`` of ``count`` on the grid formation, level, at rest."""
        return SpawnConfig(
            position=grid_layout(index, count, self.layout_spacing, self.layout_height),
            position_noise=self.position_noise,
            orientation_noise=self.orientation_noise,
        )


# ------------------------------------------------ reward terms and conditions of this task


def formation_error(ctx: StepContext) -> float:
    """Distance between the agent's offset from the swarm's centroid and its slot's offset
    from the centroid of the slots (live agents only) [m]: the error of the shape, wherever
    the swarm is (formation)."""
    return ctx.extras["formation_error"]


def crowding(ctx: StepContext) -> float:
    """``max(0, 1 - d / separation)`` for the nearest other live agent at distance ``d``:
    0 at the separation and beyond, 1 when touching (formation)."""
    return ctx.extras["crowding"]


def in_formation(ctx: StepContext) -> bool:
    """Alive, and within the task's tolerance of both its moving slot and the shape (formation)."""
    return not ctx.crashed and ctx.extras["in_formation"] > 0.5


register_term("formation_error", RewardTerm(formation_error, "m", ("formation",)))
register_term("crowding", RewardTerm(crowding, "1", ("formation",)))
register_condition("in_formation", Condition(in_formation, ("formation",)))


# ------------------------------------------------------------------- the task


class MAFormationTask(MultiAgentTask):
    """``ma_formation``: agent i keeps its slot ``slot_i(t) = slot_i(0) + v t`` and the
    swarm's shape (the manual is :class:`~pyflyt_engine.envs.multi_agent.formation.MAQuadXFormationEnv`).

    Signals: ``target_distance`` (to the slot), ``target_distance_rate`` and ``formation``
    (``formation_error``, ``crowding``, ``in_formation`` in the extras; the terms are
    registered above).  Observation: slot minus position (3), the
    formation's velocity (3), per neighbour nearest first its offset (3) and 1, zeros past
    the live neighbours within ``neighbour_radius``.
    """

    name: ClassVar[str] = "ma_formation"
    Options: ClassVar[type[MATaskOptions]] = MAFormationOptions
    provides: ClassVar[frozenset[str]] = frozenset({"target_distance", "target_distance_rate", "formation"})
    succeeds_at_time_limit: ClassVar[bool] = True
    #: read at every reset and step: a curriculum may loosen the formation early
    episode_options: ClassVar[frozenset[str]] = frozenset({"tolerance", "separation"})

    def extra_size(self) -> int:
        return 6 + 4 * self.options.neighbours  # type: ignore[attr-defined]

    def observation_parts(self) -> tuple[ObservationPart, ...]:
        n = self.options.neighbours  # type: ignore[attr-defined]
        parts = [
            ObservationPart("slot_delta", 3, "the agent's moving slot minus its position", "ground, m"),
            ObservationPart("formation_velocity", 3, "the formation's velocity", "ground, m/s"),
        ]
        for k in range(n):
            parts.append(
                ObservationPart(
                    f"neighbour_{k}",
                    4,
                    f"neighbour {k + 1} (nearest first): its offset (x, y, z) and 1; zeros past the live "
                    "neighbours within neighbour_radius",
                    "ground, m; 0/1",
                )
            )
        return tuple(parts)

    def reset(self, states: list[KinematicState]) -> None:
        opts: Any = self.options
        self._slots0 = [tuple(a.hover_point) for a in self.agents]
        self._velocity = tuple(float(v) for v in opts.velocity)
        self._reach = max(opts.neighbour_radius, opts.separation)
        # cells a little narrower than the formation's spacing: the nearest few agents are
        # found within two or three rings of cells
        self._grid = PlanarGrid(min(self._reach, 0.75 * opts.layout_spacing))
        everyone = list(range(len(self.agents)))
        self._slots = self._slots_at(0.0)
        self._distances = [self._distance(i, states[i]) for i in everyone]
        self._survey(states, everyone)

    def _slots_at(self, t: float) -> list[tuple[float, float, float]]:
        vx, vy, vz = self._velocity
        return [(x + vx * t, y + vy * t, z + vz * t) for x, y, z in self._slots0]

    def _distance(self, i: int, state: KinematicState) -> float:
        x, y, z = state.lin_pos
        sx, sy, sz = self._slots[i]
        return math.sqrt((x - sx) ** 2 + (y - sy) ** 2 + (z - sz) ** 2)

    def _survey(self, states: list[KinematicState], live: list[int]) -> None:
        """Per live agent: its neighbours (nearest first), nearest distance and shape error."""
        opts: Any = self.options
        grid, reach, k = self._grid, self._reach, opts.neighbours
        radius2 = opts.neighbour_radius**2
        grid.clear()
        positions = {i: tuple(states[i].lin_pos) for i in live}
        for i in live:
            grid.place(i, positions[i])
        n = len(live)
        cx = math.fsum(positions[i][0] for i in live) / n
        cy = math.fsum(positions[i][1] for i in live) / n
        cz = math.fsum(positions[i][2] for i in live) / n
        sx = math.fsum(self._slots0[i][0] for i in live) / n
        sy = math.fsum(self._slots0[i][1] for i in live) / n
        sz = math.fsum(self._slots0[i][2] for i in live) / n
        self._neighbours: dict[int, list[tuple[float, int]]] = {}
        self._nearest: dict[int, float] = {}
        self._shape: dict[int, float] = {}
        for i in live:
            x, y, z = positions[i]
            close = grid.nearest(x, y, z, positions, max(k, 1), reach, i)
            self._nearest[i] = math.sqrt(close[0][0]) if close else math.inf
            self._neighbours[i] = [(d2, j) for d2, j in close if d2 <= radius2][:k]
            ox, oy, oz = self._slots0[i]
            self._shape[i] = math.sqrt(
                ((x - cx) - (ox - sx)) ** 2 + ((y - cy) - (oy - sy)) ** 2 + ((z - cz) - (oz - sz)) ** 2
            )

    def update(
        self, states: list[KinematicState], live: list[int], collisions: dict[int, bool], step: int
    ) -> dict[int, AgentSignals]:
        opts: Any = self.options
        self._slots = self._slots_at(step * self.agent_dt)
        self._survey(states, live)
        out = {}
        for i in live:
            distance = self._distance(i, states[i])
            rate = (distance - self._distances[i]) / self.agent_dt
            self._distances[i] = distance
            shape, nearest = self._shape[i], self._nearest[i]
            crowding = max(0.0, 1.0 - nearest / opts.separation)
            formed = distance <= opts.tolerance and shape <= opts.tolerance
            out[i] = AgentSignals(
                target_distance=distance,
                target_distance_rate=rate,
                extras={"formation_error": shape, "crowding": crowding, "in_formation": 1.0 if formed else 0.0},
                info={"target_distance": distance, "formation_error": shape, "nearest_neighbour": nearest},
            )
        return out

    def observe(self, i: int, states: list[KinematicState]) -> np.ndarray:
        x, y, z = states[i].lin_pos
        sx, sy, sz = self._slots[i]
        values = [sx - x, sy - y, sz - z, *self._velocity]
        for _, j in self._neighbours.get(i, ()):
            px, py, pz = states[j].lin_pos
            values += [px - x, py - y, pz - z, 1.0]
        values += [0.0] * (self.extra_size() - len(values))
        return np.array(values, dtype=np.float64)

    def reset_info(self, i: int) -> dict[str, Any]:
        return {
            "target_distance": self._distances[i],
            "formation_error": self._shape[i],
            "nearest_neighbour": self._nearest[i],
        }

    def markers(self) -> np.ndarray:
        """The slots now, ``(N, 3)`` (the starting slots before the first reset)."""
        slots = getattr(self, "_slots", None)
        if slots is None:
            return np.array([a.hover_point for a in self.agents], dtype=np.float64)
        return np.array(slots, dtype=np.float64)


register_task(MAFormationTask, env="pyflyt_engine.envs.multi_agent.formation:MAQuadXFormationEnv")

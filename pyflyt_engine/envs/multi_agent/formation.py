"""MAQuadX-Formation: a swarm of quadrotors keeping a grid formation that moves."""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from pyflyt_engine.envs.config import MAFormationOptions
from pyflyt_engine.envs.multi_agent.base import AgentSignals, MultiAgentUAVEnv
from pyflyt_engine.spatial import PlanarGrid
from pyflyt_engine.state import KinematicState


class MAQuadXFormationEnv(MultiAgentUAVEnv):
    """``ma_quadx_formation_v0``: N quadrotors (2 to 128) keep a grid formation moving at a set velocity.

    Config: ``conf/env/ma_quadx_formation.yaml`` (16 Crazyflie-class QuadX on a square grid
    1 m apart at 1.5 m, the formation moving at 0.2 m/s along +x).  Each agent's *slot* is
    its place in the formation: its layout grid point (or the listed agent's
    ``hover_point``, default its spawn position) at the start, moving with the formation's
    ``velocity``: ``slot_i(t) = slot_i(0) + v t``.  Agents are named ``uav_0 ... uav_{N-1}``.

    **Action space** (per agent) ``Box(4,)`` float64, clipped: body rates p, q, r
    [rad/s] in [-pi, pi] and collective thrust in [0, 1], flown by ``rates_thrust`` (as
    MAQuadX-Hover).

    **Observation space** (per agent) ``Box(30 + 4 K,)`` float64 with quaternion
    (``Box(29 + 4 K,)`` Euler), ``K = neighbours`` (3: ``Box(42,)``):

    ==========  ====  ============================================  =============
    slice       size  meaning                                       frame / unit
    ==========  ====  ============================================  =============
    0:3         3     angular velocity (p, q, r)                    body, rad/s
    3:7 | 3:6   4|3   attitude quaternion (x, y, z, w) | Euler       ground, rad
    next        3     linear velocity (u, v, w)                     body, m/s
    next        3     position (x, y, z)                            ground ENU, m
    next        4     previous action                               as the action
    next        4     motor throttles (aux)                         [0, 1]
    next        3     own slot minus position                       ground, m
    next        3     the formation's velocity                      ground, m/s
    next        4 K   per neighbour, nearest first: its position    ground, m
                      minus own (3) and 1; zeros past the live
                      neighbours within ``neighbour_radius``
    ==========  ====  ============================================  =============

    **Reward** per agent (dense, preset ``ma_quadx_formation_dense``)::

        r = -100                                               if crash
            1 - ||p - slot|| - formation_error - crowding - 0.1 ||[roll, pitch]||   otherwise

    ``formation_error``: the distance between the agent's offset from the centroid of the
    live agents and its slot's offset from the centroid of their slots -- the error of the
    shape, whatever the swarm's position; ``crowding``: ``max(0, 1 - d / separation)`` for
    the nearest other live agent at ``d``.  Terms: ``crash``, ``alive_bonus``,
    ``slot_error``, ``formation_error``, ``crowding``, ``attitude_error``; each agent's
    breakdown is in its ``info["reward_terms"]``.  Sparse (``ma_quadx_formation_sparse``):
    -100 on a crash, +0.1 per step *in formation* (within ``tolerance`` of both its slot
    and the shape).

    **Episode end** (per agent): *terminated* on a crash -- any contact, with the ground or
    another agent, or leaving the ``flight_dome_size`` = 20 m sphere; *truncated* for
    every live agent after ``max_duration_seconds`` = 30 s (900 steps), which counts as
    ``info["success"]``.  A retired agent is disarmed and falls; it stays in the world and
    leaves the centroids and the neighbour lists.  The episode ends when no agent is left.

    **Info** per agent: ``collision``, ``out_of_bounds``, ``success``, ``env_complete``
    (always False), ``target_distance`` (to its slot) [m], ``formation_error`` [m],
    ``nearest_neighbour`` [m] (inf without a live neighbour within reach),
    ``reward_terms``.

    **Arguments**: ``agents`` (a count, 1 to 128, or a list of agents with ``uav``,
    ``spawn``, ``hover_point``), ``reward``/``sparse_reward``, ``angle_representation``,
    ``agent_hz`` (30), ``max_duration_seconds`` (30), ``flight_dome_size`` (20),
    ``layout_spacing`` (1 m), ``layout_height`` (1.5 m), ``velocity`` ((0.2, 0, 0) m/s),
    ``neighbours`` (3), ``neighbour_radius`` (3 m), ``separation`` (0.5 m), ``tolerance``
    (0.25 m), ``position_noise`` (0.05 m), ``orientation_noise`` (0.05 rad), ``downwash``
    (on: the wakes of the agents above), ``uav`` ("quadx_cf2x"), ``render_mode``.  Agents
    given by count must spawn clear of each other: ``layout_spacing`` at least two
    bounding radii of the airframe plus ``2 sqrt(3) position_noise`` (checked at build).

    **Cost**: neighbours are found on a :class:`~pyflyt_engine.spatial.PlanarGrid` of
    cells ``neighbour_radius`` wide and the downwash sums only the wakes that can reach an
    agent, so a step costs O(N) (docs/multi_agent.md has the measured curve).

    **Version history**: v0 -- new in this package (the reference PyFlyt has no swarm task).
    """

    metadata: ClassVar[dict] = {**MultiAgentUAVEnv.metadata, "name": "ma_quadx_formation_v0"}
    config_name: ClassVar[str | None] = "ma_quadx_formation"
    task_name: ClassVar[str] = "ma_formation"

    @property
    def options(self) -> MAFormationOptions:
        return self.config.task  # type: ignore[return-value]

    def _extra_size(self) -> int:
        return 6 + 4 * self.options.neighbours

    # ------------------------------------------------------------- the task

    def _task_reset(self, states: list[KinematicState]) -> None:
        opts = self.options
        self._slots0 = [tuple(a.hover_point) for a in self.agent_list]
        self._velocity = tuple(float(v) for v in opts.velocity)
        self._reach = max(opts.neighbour_radius, opts.separation)
        # cells a little narrower than the formation's spacing: the nearest few agents are
        # found within two or three rings of cells
        self._grid = PlanarGrid(min(self._reach, 0.75 * opts.layout_spacing))
        everyone = list(range(len(self.agent_list)))
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
        grid, reach, k = self._grid, self._reach, self.options.neighbours
        radius2 = self.options.neighbour_radius ** 2
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

    def _task_update(
        self, states: list[KinematicState], live: list[int], collisions: dict[int, bool]
    ) -> dict[int, AgentSignals]:
        opts = self.options
        self._slots = self._slots_at(self._steps * self._agent_dt)
        self._survey(states, live)
        out = {}
        for i in live:
            distance = self._distance(i, states[i])
            rate = (distance - self._distances[i]) / self._agent_dt
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

    def _task_observe(self, i: int, states: list[KinematicState]) -> np.ndarray:
        x, y, z = states[i].lin_pos
        sx, sy, sz = self._slots[i]
        values = [sx - x, sy - y, sz - z, *self._velocity]
        for _, j in self._neighbours.get(i, ()):
            px, py, pz = states[j].lin_pos
            values += [px - x, py - y, pz - z, 1.0]
        values += [0.0] * (self._extra_size() - len(values))
        return np.array(values, dtype=np.float64)

    def _reset_info(self, i: int) -> dict:
        return {
            **super()._reset_info(i),
            "target_distance": self._distances[i],
            "formation_error": self._shape[i],
            "nearest_neighbour": self._nearest[i],
        }

    def _succeeds_at_time_limit(self) -> bool:
        return True

    def markers(self) -> np.ndarray:
        """The slots now, ``(N, 3)``."""
        slots = getattr(self, "_slots", None)
        if slots is None:
            return np.array([a.hover_point for a in self.agent_list], dtype=np.float64)
        return np.array(slots, dtype=np.float64)

"""MAQuadX-Formation: a swarm of quadrotors keeping a grid formation that moves (the task:
:class:`~pyflyt_engine.envs.tasks.ma_formation.MAFormationTask`)."""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.multi_agent.base import MultiAgentUAVEnv
from pyflyt_engine.envs.tasks.ma_formation import MAFormationTask
from pyflyt_engine.envs.tasks.multi import MultiAgentTask


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

    **Observation space** (per agent) ``Box(27 + 4 K,)`` float64 with quaternion
    (``Box(26 + 4 K,)`` Euler), ``K = neighbours`` (3: ``Box(39,)``):

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

    metadata = {**MultiAgentUAVEnv.metadata, "name": "ma_quadx_formation_v0"}
    config_name: ClassVar[str | None] = "ma_quadx_formation"
    task_class: ClassVar[type[MultiAgentTask] | None] = MAFormationTask

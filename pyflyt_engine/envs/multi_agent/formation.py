"""MAQuadX-Formation: a swarm of quadrotors keeping a grid formation that moves (the task:
:class:`~pyflyt_engine.envs.tasks.ma_formation.MAFormationTask`)."""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.multi_agent.base import MultiAgentUAVEnv
from pyflyt_engine.envs.tasks.ma_formation import MAFormationTask
from pyflyt_engine.envs.tasks.multi import MultiAgentTask


class MAQuadXFormationEnv(MultiAgentUAVEnv):
    """``ma_quadx_formation_v0``: N quadrotors (2 to 128) keep a grid formation moving at a set velocity.

    Each agent's *slot* is its place in the formation: its layout grid point (or the listed
    agent's ``hover_point``, default its spawn position) at the start, moving with the
    formation's ``velocity``: ``slot_i(t) = slot_i(0) + v t``.  Agents are named
    ``uav_0 ... uav_{N-1}``; vehicle and action per agent as MAQuadX-Hover.

    Its manual -- loop rates, agents and spawn regions, per-agent action table and
    observation layout, reward presets with their terms and weights, task options, episode
    end, arguments -- is generated from its config and spaces: ``pyflyt envs ma_quadx_formation_v0``
    (docs/environments.md, "Env manuals").

    **Design notes**: the dense reward is an alive bonus less the distance to the slot, the
    formation error, crowding and tilt (a crash penalty instead).  ``formation_error`` is
    the distance between the agent's offset from the centroid of the live agents and its
    slot's offset from the centroid of their slots -- the error of the shape, whatever the
    swarm's position; ``crowding`` is ``max(0, 1 - d / separation)`` for the nearest other
    live agent at ``d``.  The sparse preset pays per step *in formation* (within
    ``tolerance`` of both its slot and the shape).  A crash is any contact, with the ground
    or another agent, or leaving the dome; the time limit alive counts as
    ``info["success"]``.  A retired agent is disarmed and falls; it stays in the world and
    leaves the centroids and the neighbour lists.  Info per agent: ``collision``,
    ``out_of_bounds``, ``success``, ``env_complete`` (always False), ``target_distance``
    (to its slot) [m], ``formation_error`` [m], ``nearest_neighbour`` [m] (inf without a
    live neighbour within reach), ``reward_terms``.  Agents given by count must spawn
    clear of each other: ``layout_spacing`` at least two bounding radii of the airframe
    plus ``2 sqrt(3) position_noise`` (checked at build).

    **Cost**: neighbours are found on a :class:`~pyflyt_engine.spatial.PlanarGrid` of
    cells ``neighbour_radius`` wide and the downwash sums only the wakes that can reach an
    agent, so a step costs O(N) (docs/multi_agent.md has the measured curve).

    **Version history**: v0 -- new in this package (the reference PyFlyt has no swarm task).
    """

    metadata = {**MultiAgentUAVEnv.metadata, "name": "ma_quadx_formation_v0"}
    config_name: ClassVar[str | None] = "ma_quadx_formation"
    task_class: ClassVar[type[MultiAgentTask] | None] = MAFormationTask

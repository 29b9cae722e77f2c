"""MAQuadX-Hover: N quadrotors in one world, each holding its own point (the task:
:class:`~pyflyt_engine.envs.tasks.ma_hover.MAHoverTask`)."""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.multi_agent.base import MultiAgentUAVEnv
from pyflyt_engine.envs.tasks.ma_hover import MAHoverTask
from pyflyt_engine.envs.tasks.multi import MultiAgentTask


class MAQuadXHoverEnv(MultiAgentUAVEnv):
    """``ma_quadx_hover_v0``: N quadrotors, each holding its own hover point; colliders are out.

    The shipped config places its agents on a ring, as the reference PyFlyt's four agents
    at (+-1, +-1, 1) m.  Agents are named ``uav_0 ... uav_{N-1}`` unless the config names
    them; airframes may be mixed (an F450 and a cf2x) as long as they share the action
    layout and observation size.  Vehicle and action per agent as
    :class:`~pyflyt_engine.envs.quadx.QuadXHoverEnv`.

    Its manual -- loop rates, agents and spawn regions, per-agent action table and
    observation layout, reward presets with their terms and weights, task options, episode
    end, arguments -- is generated from its config and spaces: ``pyflyt envs ma_quadx_hover_v0``
    (docs/environments.md, "Env manuals").

    **Design notes**: the dense reward is the reference PyFlyt's MAQuadX-Hover reward (an
    alive bonus less the distance to the agent's own hover point and its tilt, a crash
    penalty instead); each agent's breakdown is in its ``info["reward_terms"]``.  A crash
    is any contact, with the ground or another agent (both colliders are out), or leaving
    the dome; reaching the time limit alive counts as ``info["success"]``.  A retired agent
    is disarmed (motors off) and falls; it stays in the world.  The episode ends when no
    agent is left.  Info per agent: ``collision``, ``out_of_bounds``, ``success``,
    ``env_complete`` (always False), ``target_distance`` [m], ``reward_terms``.

    **Version history**: v0 -- the reference PyFlyt 0.29.0 ``MAQuadXHoverEnv`` differs:
    agent rate 40 Hz, exact spawn at the hover point, the absolute hover point observed
    (here: its offset from the vehicle), collisions read every control step.
    """

    metadata = {**MultiAgentUAVEnv.metadata, "name": "ma_quadx_hover_v0"}
    config_name: ClassVar[str | None] = "ma_quadx_hover"
    task_class: ClassVar[type[MultiAgentTask] | None] = MAHoverTask

"""MAQuadX-Hover: N quadrotors in one world, each holding its own point (the task:
:class:`~pyflyt_engine.envs.tasks.ma_hover.MAHoverTask`)."""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.multi_agent.base import MultiAgentUAVEnv
from pyflyt_engine.envs.tasks.ma_hover import MAHoverTask
from pyflyt_engine.envs.tasks.multi import MultiAgentTask


class MAQuadXHoverEnv(MultiAgentUAVEnv):
    """``ma_quadx_hover_v0``: N quadrotors, each holding its own hover point; colliders are out.

    Config: ``conf/env/ma_quadx_hover.yaml`` (4 Crazyflie-class QuadX on a 1 m ring at 1 m
    height, as the reference PyFlyt's four agents at (+-1, +-1, 1) m).  Agents are named
    ``uav_0 ... uav_{N-1}`` unless the config names them; airframes may be mixed (an F450
    and a cf2x) as long as they share the action layout and observation size.

    **Action space** (per agent) ``Box(4,)`` float64, clipped: body rates p, q, r
    [rad/s] in [-pi, pi] and collective thrust in [0, 1], flown by ``rates_thrust`` --
    exactly as :class:`~pyflyt_engine.envs.quadx.QuadXHoverEnv`.

    **Observation space** (per agent) ``Box(24,)`` float64 (quaternion; ``Box(23,)`` Euler):

    ==========  ====  ============================================  =============
    slice       size  meaning                                       frame / unit
    ==========  ====  ============================================  =============
    0:3         3     angular velocity (p, q, r)                    body, rad/s
    3:7 | 3:6   4|3   attitude quaternion (x, y, z, w) | Euler       ground, rad
    next        3     linear velocity (u, v, w)                     body, m/s
    next        3     position (x, y, z)                            ground ENU, m
    next        4     previous action                               as the action
    next        4     motor throttles (aux)                         [0, 1]
    last        3     hover point minus position                    ground, m
    ==========  ====  ============================================  =============

    **Reward** per agent (dense, preset ``ma_quadx_hover_dense``, the reference PyFlyt's
    MAQuadX-Hover reward)::

        r = -100                                     if crash (any contact or out of the dome)
            1 - ||p - hover point|| - 0.1 ||[roll, pitch]||   otherwise

    Terms: ``crash``, ``alive_bonus``, ``position_error``, ``attitude_error``; each
    agent's breakdown is in its ``info["reward_terms"]``.  Sparse
    (``ma_quadx_hover_sparse``): -100 on a crash, +0.1 per step alive.

    **Episode end** (per agent): *terminated* on a crash -- any contact, with the ground or
    another agent (both colliders are out) or leaving the ``flight_dome_size`` = 10 m
    sphere; *truncated* for every live agent after ``max_duration_seconds`` = 30 s (900
    steps), which counts as ``info["success"]``.  A retired agent is disarmed (motors
    off) and falls; it stays in the world.  The episode ends when no agent is left.

    **Info** per agent: ``collision``, ``out_of_bounds``, ``success``, ``env_complete``
    (always False), ``target_distance`` [m], ``reward_terms``.

    **Arguments**: ``agents`` (a count or a list of agents with ``uav``, ``spawn``,
    ``hover_point``), ``reward``/``sparse_reward`` ("dense" | "sparse" | a preset),
    ``angle_representation``, ``agent_hz`` (30), ``physics_hz`` (240), ``control_hz``
    (120), ``max_duration_seconds`` (30), ``flight_dome_size`` (10), ``layout_radius``
    (1 m), ``layout_height`` (1 m), ``position_noise`` (0.1 m), ``orientation_noise``
    (0.1 rad), ``uav`` ("quadx_cf2x"), ``render_mode``.

    **Version history**: v0 -- the reference PyFlyt 0.29.0 ``MAQuadXHoverEnv`` differs:
    agent rate 40 Hz, exact spawn at the hover point, the absolute hover point observed
    (here: its offset from the vehicle), collisions read every control step.
    """

    metadata = {**MultiAgentUAVEnv.metadata, "name": "ma_quadx_hover_v0"}
    config_name: ClassVar[str | None] = "ma_quadx_hover"
    task_class: ClassVar[type[MultiAgentTask] | None] = MAHoverTask

"""The Fixedwing environment of the paper: ``PyFlyt/Fixedwing-Waypoints-v0``.

The class is the generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped
config (``conf/env/fixedwing_waypoints.yaml``); its docstring is the environment's manual.
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv


class FixedwingWaypointsEnv(UAVEnv):
    """``PyFlyt/Fixedwing-Waypoints-v0``: fly the paper's Fixedwing through random waypoints in order.

    The QuadX-Waypoints task (paper, "Provided Environments") with the Fixedwing: reach
    distance d = 2 m, c_a = 1, c_b = 3, and every length of the QuadX task 20 times
    larger.  Config: ``conf/env/fixedwing_waypoints.yaml``.

    **Vehicle**: ``fixedwing`` (``conf/uav/fixedwing.yaml``: 2.35 kg, 2.4 m span, one
    18 N puller motor, thrust-to-weight 0.78; trims at ~13.5 m/s), flown on its raw
    channels (flight mode ``channels``: no autopilot); physics 240 Hz, control 120 Hz,
    one agent step = 1/30 s (8 physics steps).

    **Action space** ``Box(4,)``, float64, clipped to its bounds (the paper's normalised
    aileron, horizontal and vertical stabiliser deflections and thrust):

    ====  ================================  ========  =======================================
    idx   meaning                           bounds    effect of a positive value
    ====  ================================  ========  =======================================
    0     aileron (channel ``roll``)        [-1, 1]   left aileron down, right up (x 30 deg):
                                                      rolls the right wing down
    1     elevator (channel ``pitch``)      [-1, 1]   trailing edge down (x 20 deg): nose down
    2     rudder (channel ``yaw``)          [-1, 1]   x 20 deg: yaws the nose left
    3     thrust (channel ``thrust``)       [0, 1]    motor speed fraction; thrust ~ square,
                                                      ~0.45 holds 14 m/s level
    ====  ================================  ========  =======================================

    Deflection commands are reached through a first-order lag (tau 0.05 s), the motor
    through one of 0.01 s.

    **Observation space** ``Dict``:

    * ``attitude``: ``Box(23,)`` (quaternion) or ``Box(22,)`` (Euler), float64:

      ==========  ====  ==========================================  ===============
      slice       size  meaning                                     frame / unit
      ==========  ====  ==========================================  ===============
      0:3         3     angular velocity (p, q, r)                  body, rad/s
      3:7 | 3:6   4|3   attitude: quaternion (x, y, z, w) or         ground
                        Euler (roll, pitch, yaw)                    rad
      next        3     linear velocity (u, v, w)                   body, m/s
      next        3     position (x, y, z)                          ground ENU, m
      next        4     previous action (as the action space)       -
      next        1     motor throttle (aux)                        [0, 1]
      last        5     surface deflections / their limits (aux):   [-1, 1]
                        main wing (no flap: always 0), left
                        aileron, right aileron, horizontal tail,
                        vertical tail
      ==========  ====  ==========================================  ===============

    * ``target_deltas``: ``Sequence(Box(3,), stack=True)``: an ``(n, 3)`` float64 array,
      one row per waypoint not yet reached, next one first: the vector from the centre
      of mass to the waypoint **in the body frame** [m] (x forward, y left, z up).  ``n``
      shrinks as waypoints are reached (``(0, 3)`` after the last).  Use
      :class:`~pyflyt_engine.envs.wrappers.FlattenWaypointEnv` for a fixed-size Box.

    **Waypoints** (20 x QuadX-Waypoints): ``num_targets`` = 5, at distances U(20 m,
    0.9 x flight_dome_size = 90 m) from the origin in directions uniform on the upper
    hemisphere, at least 2 m high, drawn at reset from the env's seeded RNG.  Reached
    when the centre of mass comes within ``goal_reach_distance`` d = 2 m of the next
    waypoint during an agent step (segment test between the step's start and end
    positions: a pass through the sphere at 14 m/s, 0.47 m per step, always counts).

    **Reward** (dense, preset ``fixedwing_waypoints_dense``), c_a = 1, c_b = 3::

        r = -100                                   if crash
            100                                    if a waypoint was reached
            c_a / delta - c_b * delta_dot          if delta_dot < 0 (approaching)
            c_a / delta                            otherwise

    delta: distance to the next waypoint [m] at the end of the step (>= d unless
    reached, so c_a / delta <= 0.5); delta_dot: its change over the step [m] (c_b = 3
    per metre closed, as for QuadX; preset ``fixedwing_waypoints_dense_rate``: the rate
    in m/s).  Cases tried in that order.  Terms (``info["reward_terms"]``): ``crash``,
    ``waypoint_bonus``, ``proximity`` (c_a / delta), ``approach`` (-c_b delta_dot when
    approaching).  The paper prints the last case as 1/delta; with c_a = 1 the two agree.

    Sparse (``sparse_reward=True``, preset ``fixedwing_waypoints_sparse``): -100 on a
    crash, +100 per waypoint reached, 0 otherwise.

    **Starting state**: in flight at (0, 0, 20) m + U(-2, 2) m per axis (20 x QuadX's
    spawn), attitude U(-0.1, 0.1) rad per Euler angle, moving at 14 m/s along the body x
    axis (the trim speed), not rotating; motor idle, surfaces neutral.  With neutral
    controls and no thrust it glides ~130 m (~9 s) before reaching the ground; with
    thrust ~0.45 it holds its height.

    **Episode end**: terminated on a crash (any contact, ground included:
    ``info["collision"]``; or farther than ``flight_dome_size`` = 100 m from the origin:
    ``info["out_of_bounds"]``) or when the last waypoint is reached
    (``info["env_complete"] = info["success"] = True``); truncated after
    ``max_duration_seconds`` = 120 s (3600 steps): five legs of up to 180 m at ~14 m/s
    plus turns (radius ~35 m at a 30 deg bank) take about a minute.
    ``info["num_targets_reached"]`` counts the waypoints reached.

    **Arguments** (``gymnasium.make(id, **kwargs)``): ``sparse_reward`` (bool),
    ``reward`` ("dense", "sparse", a preset name or YAML path), ``angle_representation``
    ("quaternion" | "euler"), ``agent_hz`` (30), ``physics_hz`` (240), ``control_hz``
    (120), ``max_duration_seconds`` (120.0), ``flight_dome_size`` (100.0),
    ``num_targets`` (5), ``goal_reach_distance`` (2.0 m), ``min_target_distance``
    (20.0 m), ``max_target_distance`` (0.9 of the dome radius), ``min_target_height``
    (2.0 m), ``start_position`` ((0, 0, 20) m), ``start_position_noise`` (2.0 m),
    ``start_orientation`` ((0, 0, 0) rad), ``start_orientation_noise`` (0.1 rad),
    ``start_lin_vel`` ((14, 0, 0) m/s, body frame), ``uav`` ("fixedwing"), ``drag``
    (True), ``wind`` ("calm": still air; a preset of conf/wind such as "dryden_light", a path or a mapping, docs/atmosphere.md), ``ground_effect`` and ``downwash`` (False), ``randomize`` ({}: none; per-episode draws declared in config, reported in ``info["randomization"]`` at reset), ``render_mode`` (None | "rgb_array" | "human").

    **Version history**: v0 — this implementation of the paper's environment (reference
    PyFlyt 0.29.0 differs: 4 waypoints from 1 m out and 0.5 m high, spawn at (0, 0, 10) m
    at 20 m/s, thrust action in [-1, 1], reward 1/delta + max(3 x per-step progress in m,
    0) - 0.1 per step, point reach test at 120 Hz, completion as truncation).
    """

    config_name: ClassVar[str | None] = "fixedwing_waypoints"

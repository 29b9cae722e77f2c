"""The QuadX environments of the paper: ``PyFlyt/QuadX-Hover-v0`` and ``PyFlyt/QuadX-Waypoints-v0``.

Each class is the generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped
config (``conf/env/<config_name>.yaml``); its docstring is the environment's manual.
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv


class QuadXHoverEnv(UAVEnv):
    """``PyFlyt/QuadX-Hover-v0``: hover a Crazyflie-class QuadX at (0, 0, 1) m.

    The task (paper, "Provided Environments") is to hold the quadrotor level at the hover
    point for the whole episode.  Config: ``conf/env/quadx_hover.yaml``.

    **Vehicle**: ``quadx_cf2x`` (27 g, 8:1 thrust-to-weight), flown in flight mode
    ``rates_thrust`` by the cascaded rate controller at 120 Hz; physics at 240 Hz;
    one agent step = 1/30 s (8 physics steps).

    **Action space** ``Box(4,)``, float64, clipped to its bounds:

    ====  ==========================  ==========  =======================
    idx   meaning                     unit        bounds
    ====  ==========================  ==========  =======================
    0     roll rate setpoint p        rad/s       [-pi, pi]
    1     pitch rate setpoint q       rad/s       [-pi, pi]
    2     yaw rate setpoint r         rad/s       [-pi, pi]
    3     collective thrust           fraction    [0, 1] of max thrust
    ====  ==========================  ==========  =======================

    Rates are body-frame (x forward, y left, z up); thrust 0.125 balances the weight when
    level (8:1 thrust-to-weight).  The rate limit pi rad/s is the reference PyFlyt's.

    **Observation space** ``Box(21,)`` (quaternion) or ``Box(20,)`` (Euler), float64:

    ==========  ====  =======================================  =============
    slice       size  meaning                                  frame / unit
    ==========  ====  =======================================  =============
    0:3         3     angular velocity (p, q, r)               body, rad/s
    3:7 | 3:6   4|3   attitude: quaternion (x, y, z, w) or     ground
                      Euler (roll, pitch, yaw)                 rad
    next        3     linear velocity (u, v, w)                body, m/s
    next        3     position (x, y, z)                       ground ENU, m
    next        4     previous action (p, q, r, thrust)        as the action
    last        4     motor throttles (aux state)              [0, 1]
    ==========  ====  =======================================  =============

    **Reward** (``reward="dense"``/``sparse_reward=False``, preset ``quadx_hover_dense``)::

        r = -100                                  if crash
            -||[theta, phi]|| - ||[x, y, z - 1]|| otherwise

    with theta, phi the pitch and roll [rad] and (x, y, z) the position [m].  Terms
    (``info["reward_terms"]``): ``crash`` (-100 x [crash]), ``attitude_error``
    (-tilt x [not crash]), ``position_error`` (-distance to (0, 0, 1) x [not crash]).

    Sparse (``sparse_reward=True``, preset ``quadx_hover_sparse``): -0.1 per step
    (``time_penalty``), -100 on the crash step (``crash``).

    A *crash* is any contact of the vehicle (ground included) or leaving the flight dome.
    Unlike the reference PyFlyt, the dense reward has no +1 per-step offset (the paper
    has none).

    **Starting state**: at rest at (0, 0, 1) + U(-0.1, 0.1) m per axis, attitude
    U(-0.1, 0.1) rad per Euler angle, motors idle; drawn from the env's seeded RNG.

    **Episode end**: terminated on a crash (``info["collision"]`` or
    ``info["out_of_bounds"]``: farther than ``flight_dome_size`` = 3 m from the origin);
    truncated after ``max_duration_seconds`` = 10 s (300 steps), which counts as
    ``info["success"] = True``.  ``info["env_complete"]`` is always False (hover never
    completes by itself).

    **Arguments** (``gymnasium.make(id, **kwargs)``): ``sparse_reward`` (bool),
    ``reward`` ("dense", "sparse", a preset name or a preset YAML path),
    ``angle_representation`` ("quaternion" | "euler"), ``agent_hz`` (30),
    ``physics_hz`` (240), ``control_hz`` (120), ``max_duration_seconds`` (10.0),
    ``flight_dome_size`` (3.0), ``hover_point`` ((0, 0, 1)), ``start_position_noise``
    (0.1 m), ``start_orientation_noise`` (0.1 rad), ``uav`` ("quadx_cf2x"), ``drag``
    (True), ``wind`` ("calm": still air; a preset of conf/wind such as "dryden_light", a path or a mapping, docs/atmosphere.md), ``ground_effect`` and ``downwash`` (False), ``randomize`` ({}: none; per-episode draws declared in config, reported in ``info["randomization"]`` at reset), ``render_mode`` (None | "rgb_array" | "human").

    **Version history**: v0 — this implementation of the paper's environment (reference
    PyFlyt 0.29.0 differs: +1 per-step offset in the dense reward, agent 40 Hz, exact
    spawn at (0, 0, 1)).
    """

    config_name: ClassVar[str | None] = "quadx_hover"


class QuadXWaypointsEnv(UAVEnv):
    """``PyFlyt/QuadX-Waypoints-v0``: fly a Crazyflie-class QuadX through random waypoints in order.

    Config: ``conf/env/quadx_waypoints.yaml``.  Vehicle, loop rates and action space as
    :class:`QuadXHoverEnv` (``rates_thrust``: p, q, r in [-pi, pi] rad/s, thrust in [0, 1]).

    **Observation space** ``Dict``:

    * ``attitude``: ``Box(21,)`` / ``Box(20,)`` float64, exactly as :class:`QuadXHoverEnv`.
    * ``target_deltas``: ``Sequence(Box(3,), stack=True)``: an ``(n, 3)`` float64 array,
      one row per waypoint not yet reached, next one first: the vector from the
      vehicle's centre of mass to the waypoint **in the body frame** [m]
      (x forward, y left, z up).  ``n`` shrinks as waypoints are reached; ``(0, 3)``
      after the last one.  Use :class:`~pyflyt_engine.envs.wrappers.FlattenWaypointEnv`
      for a fixed-size Box (Stable-Baselines3).

    **Waypoints**: ``num_targets`` = 5, at distances U(1, 0.9 x flight_dome_size) m from
    the origin in directions uniform on the upper hemisphere, at least 0.1 m high,
    drawn at reset from the env's seeded RNG.  A waypoint counts as reached when the
    centre of mass comes within ``goal_reach_distance`` d = 0.2 m of it during an agent
    step (tested on the straight segment between the step's start and end positions, so
    that passing through at speed counts whatever the agent rate); the next one then
    becomes the target.

    **Reward** (dense, preset ``quadx_waypoints_dense``), c_a = 0.1, c_b = 3::

        r = -100                                   if crash
            100                                    if a waypoint was reached
            c_a / delta - c_b * delta_dot          if delta_dot < 0 (approaching)
            c_a / delta                            otherwise

    delta is the distance to the next waypoint [m] at the end of the step, delta_dot its
    change over the step [m] (both to the waypoint that was the target during the step):
    approaching pays c_b = 3 per metre closed, at any agent rate, as in the reference
    PyFlyt.  The cases are tried in that order (crash first).  Note: the paper prints
    the last case as 1/delta (no c_a); c_a/delta is used because it is the only form
    continuous at delta_dot = 0 — with 1/delta, lingering just outside the reach radius
    while drifting away would pay 10x more than approaching.  Preset
    ``quadx_waypoints_dense_rate`` reads delta_dot as a rate [m/s] instead: c_b x 30 = 90
    per metre at 30 Hz, which makes a near miss pay almost as much as a waypoint.  Terms:
    ``crash``, ``waypoint_bonus``, ``proximity`` (c_a/delta), ``approach`` (-c_b
    delta_dot when approaching).

    Sparse (preset ``quadx_waypoints_sparse``): -100 on a crash, +100 per waypoint
    reached, 0 otherwise.

    **Starting state**: as :class:`QuadXHoverEnv` (at rest near (0, 0, 1) m).

    **Episode end**: terminated on a crash (any contact, or farther than
    ``flight_dome_size`` = 5 m from the origin) or when the last waypoint is reached
    (``info["env_complete"] = info["success"] = True``); truncated after
    ``max_duration_seconds`` = 20 s (600 steps).  ``info["num_targets_reached"]``
    counts the waypoints reached so far.

    **Arguments**: as :class:`QuadXHoverEnv` plus ``num_targets`` (5),
    ``goal_reach_distance`` (0.2 m), ``min_target_distance`` (1.0 m),
    ``max_target_distance`` (0.9 of the dome radius), ``min_target_height`` (0.1 m);
    defaults ``flight_dome_size`` 5.0, ``max_duration_seconds`` 20.0.  An episode may
    set ``goal_reach_distance`` and the waypoint and spawn ranges through
    ``reset(options={"task": {...}})``.

    **Training**: ``pyflyt train env=quadx_waypoints`` (PPO, 4.5 M steps, ~26 minutes on
    2 cores) starts its training episodes with a 1 m reach sphere and shrinks it to
    0.2 m over 2 M steps (``train.curriculum``); 3 of 5 seeds reach all 5 waypoints in
    >= 80 % of the episodes (experiments/results/learn_waypoints.md).

    **Version history**: v0 — this implementation of the paper's environment (reference
    PyFlyt 0.29.0 differs: 4 waypoints, 10 s, per-step progress in metres, point reach
    test at 120 Hz, waypoint completion as truncation).
    """

    config_name: ClassVar[str | None] = "quadx_waypoints"

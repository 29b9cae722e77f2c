"""QuadX tasks with payloads (reference PyFlyt 0.29.0 tasks beyond the paper).

``PyFlyt/QuadX-Pole-Balance-v0``, ``PyFlyt/QuadX-Pole-Waypoints-v0`` and
``PyFlyt/QuadX-Ball-In-Cup-v0``.  Each class is the
generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped config
(``conf/env/<config_name>.yaml``), whose ``payloads:`` declare the bodies it carries; its
docstring is the environment's manual.  (``PyFlyt/QuadX-Gates-v0``, which carries no
payload, is :mod:`pyflyt_engine.envs.quadx_gates`; its class is still importable from here.)
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv
from pyflyt_engine.envs.quadx_gates import QuadXGatesEnv


class QuadXPoleBalanceEnv(UAVEnv):
    """``PyFlyt/QuadX-Pole-Balance-v0``: hover a 1 kg QuadX at (0, 0, 1) m with a pole balanced on top.

    Config: ``conf/env/quadx_pole_balance.yaml``.  A 1 m, 0.2 kg pole (a uniform cylinder of
    5 mm radius, the reference's) stands on a frictionless ball joint 5 cm above the
    vehicle's centre of mass: an inverted pendulum the vehicle must keep upright by moving
    under it, while holding the hover point.

    **Vehicle**: ``quadx_f450`` (1 kg, 40 N static thrust; the reference flies its 1 kg
    "primitive_drone" of the same thrust), flown in flight mode ``motors`` (raw throttles,
    no controller: the reference's flight mode -1); physics 240 Hz; one agent step = 1/40 s
    (6 physics steps), the reference's agent rate.

    **Action space** ``Box(4,)``, float64, clipped to its bounds: the four motor throttles
    in [0, 1] (fraction of maximum RPM; thrust ~ throttle^2), motor order front-right,
    rear-left, front-left, rear-right (``conf/uav/quadx_f450.yaml``).  Hover with the pole
    is about throttle 0.54 ((1.2 kg x 9.81 / 40 N)^0.5).

    **Observation space** ``Box(33,)`` (quaternion) or ``Box(32,)`` (Euler), float64:

    ==========  ====  ===============================================  =============
    slice       size  meaning                                          frame / unit
    ==========  ====  ===============================================  =============
    0:3         3     angular velocity (p, q, r)                       body, rad/s
    3:7 | 3:6   4|3   attitude: quaternion (x, y, z, w) or Euler       ground, rad
    next        3     linear velocity (u, v, w)                        body, m/s
    next        3     position (x, y, z)                               ground ENU, m
    next        4     previous action (4 throttles)                    [0, 1]
    next        4     motor throttles (aux state)                      [0, 1]
    next        3     pole tip position relative to the vehicle         body, m
    next        3     pole base position relative to the vehicle        body, m
    next        3     pole tip velocity relative to the vehicle         body, m/s
    last        3     pole base velocity relative to the vehicle        body, m/s
    ==========  ====  ===============================================  =============

    Relative velocities are ``R^T (v_point - v_vehicle)`` (ground velocities rotated into
    the body frame), as the reference's.

    **Reward** (dense, preset ``quadx_pole_balance_dense``; the reference's formula)::

        r = -100                                                          if crash
            0.9 - ||[x, y, z - 1]|| - ||[roll, pitch]|| - lean - 0.01 r^2  otherwise

    lean in [0, 1] is the pole's horizontal tip-to-base distance over its length (the sine
    of its tilt) while the tip is above the base, 1 after; r the body yaw rate [rad/s].
    Terms (``info["reward_terms"]``): ``crash``, ``time_penalty`` (-0.1), ``alive`` (+1),
    ``position_error``, ``attitude_error``, ``pole_lean``, ``yaw_rate``.
    Sparse (preset ``quadx_pole_balance_sparse``): -0.1 per step, -100 on the crash step.

    A *crash* is any contact of the vehicle, leaving the flight dome (3 m), the pole touching
    the ground (``info["payload_ground_contact"]``), or the pole falling: its tip at or below
    its base (``info["pole_fallen"]``).

    **Starting state**: at rest at (0, 0, 1) + U(-0.1, 0.1) m per axis, attitude
    U(-0.05, 0.05) rad per Euler angle, the pole along the vehicle's z axis, at rest.

    **Episode end**: terminated on a crash; truncated after 20 s (800 steps), which counts as
    ``info["success"] = True``.  ``info`` also carries ``pole_lean``.

    **Arguments**: as :class:`~pyflyt_engine.envs.quadx.QuadXHoverEnv` plus ``pole``,
    ``pole_base``, ``pole_tip`` (the payload and its ends); the pole itself is the
    config's ``payloads`` entry (mass, geometry, joint).

    **Differences from the reference** (PyFlyt 0.29.0 ``QuadX-Pole-Balance-v0``): its pole
    rests unattached on the vehicle, held by friction, and the episode ends only when
    something hits the ground; ours is pinned by a ball joint and the episode also ends when
    it falls past horizontal.  Our crash step pays -100 only (the reference adds the dense
    terms to it).  Spawn noise is ours (the reference spawns exactly).

    **Version history**: v0 — first version.
    """

    config_name: ClassVar[str | None] = "quadx_pole_balance"


class QuadXPoleWaypointsEnv(UAVEnv):
    """``PyFlyt/QuadX-Pole-Waypoints-v0``: fly a 1 kg QuadX through waypoints with a pole balanced on top.

    Config: ``conf/env/quadx_pole_waypoints.yaml``.  Vehicle, pole, action space and loop
    rates as :class:`QuadXPoleBalanceEnv` (4 motor throttles in [0, 1], agent 40 Hz).

    **Observation space** ``Dict``:

    * ``attitude``: ``Box(33,)`` / ``Box(32,)`` float64, exactly the observation of
      :class:`QuadXPoleBalanceEnv` (vehicle attitude vector, then the 12 pole values).
    * ``target_deltas``: ``Sequence(Box(3,), stack=True)``: ``(n, 3)`` float64, one row per
      waypoint not yet reached, next first: vehicle-to-waypoint vectors in the body frame
      [m] (as :class:`~pyflyt_engine.envs.quadx.QuadXWaypointsEnv`).  Use
      :class:`~pyflyt_engine.envs.wrappers.FlattenWaypointEnv` for a fixed-size Box.

    **Waypoints**: ``num_targets`` = 4 at U(1, 9) m from the origin on the upper hemisphere,
    at least 1.3 m high (the reference's), reached within 0.2 m (segment test, see
    :mod:`pyflyt_engine.envs.waypoints`).

    **Reward** (dense, preset ``quadx_pole_waypoints_dense``)::

        r = -100                                                        if crash
            300                                                         if a waypoint was reached
            -0.1 + 0.375 max(-delta_dot, 0) + 0.5 / delta + 0.5 - lean - 0.01 r^2   otherwise

    delta [m] and delta_dot [m/s]: distance to the next waypoint and its rate.  The
    reference pays 15 x the per-step progress in metres at 40 Hz: 0.375 s x the approach
    speed is the same number at 40 Hz and does not change with the agent rate.  Terms:
    ``crash``, ``waypoint_bonus``, ``time_penalty``, ``approach``, ``proximity``,
    ``upright_bonus``, ``pole_lean``, ``yaw_rate``.  Sparse (``quadx_pole_waypoints_sparse``):
    -0.1 per step, +300 per waypoint, -100 on the crash step.

    **Episode end**: terminated on a crash (as :class:`QuadXPoleBalanceEnv`, flight dome
    10 m) or when the last waypoint is reached (``info["env_complete"] = info["success"] =
    True``; the reference truncates there); truncated after 20 s (800 steps).
    ``info["num_targets_reached"]`` counts waypoints reached.

    **Arguments**: as :class:`~pyflyt_engine.envs.quadx.QuadXWaypointsEnv` plus ``pole``,
    ``pole_base``, ``pole_tip``; defaults ``num_targets`` 4, ``min_target_height`` 1.3,
    ``flight_dome_size`` 10.0, ``agent_hz`` 40.

    **Differences from the reference**: the pole is pinned (see
    :class:`QuadXPoleBalanceEnv`); completing the last waypoint terminates with success
    instead of truncating; waypoints are reached on the segment test.

    **Version history**: v0 — first version.
    """

    config_name: ClassVar[str | None] = "quadx_pole_waypoints"


class QuadXBallInCupEnv(UAVEnv):
    """``PyFlyt/QuadX-Ball-In-Cup-v0``: swing a ball hanging below a 1 kg QuadX up into the cup on its top.

    Config: ``conf/env/quadx_ball_in_cup.yaml``.  Payloads: a 0.1 kg ball of 50 mm radius
    on a 0.5 m string (a tether: it can go slack) from the bottom of the airframe, and an
    open cup (0.2 x 0.2 m floor, four 0.1 m walls, 50 g) welded on top; both the
    reference's sizes and masses.

    **Vehicle**: ``quadx_f450`` (1 kg, 40 N) in flight mode ``rates_thrust`` (the
    reference's flight mode 0); physics 240 Hz, control 120 Hz, agent 30 Hz.

    **Action space** ``Box(4,)``, float64: body rate setpoints p, q, r [rad/s] in
    [-pi, pi] and collective thrust in [0, 1] of the maximum (about 0.28 hovers the
    1.16 kg total).

    **Observation space** ``Box(27,)`` (quaternion) or ``Box(26,)`` (Euler), float64: the
    21 (20) values of the attitude vector (angular velocity, attitude, body velocity,
    position, previous action, 4 motor throttles; see
    :class:`~pyflyt_engine.envs.quadx.QuadXHoverEnv`), then the ball's position relative
    to the vehicle's centre of mass in the body frame [m] (3), then the ball's ground
    velocity in body axes, ``R^T v_ball`` [m/s] (3).

    **Catch** (success): the ball touches the cup with its centre above the vehicle's
    centre of mass while the vehicle is within ``goal_reach_distance`` = 1 m of
    ``hover_point`` = (0, 0, 2) m and slower than ``goal_reach_velocity`` = 1 m/s.

    **Reward** (dense, preset ``quadx_ball_in_cup_dense``; the reference's formula)::

        r = -100                 crash (not by the ball)
            -500                 the ball struck the vehicle
            0.3 - 0.01 r_yaw^2 - 0.01 E
              - 4 ln(0.45 d + 0.01)   if the ball is above the vehicle, else + h
              + 50 (e_prev - e) + 10 / (e + 0.1)   while the ball is in the cup, not caught
              + 1000             on the catch

    E = |omega|^2 + |euler|^2 + |v|^2 + |p - p_hover|^2 (SI units squared), d the
    vehicle-to-ball distance [m], h the ball's height above the vehicle [m], e =
    |p - p_hover|^2 [m^2].  Terms: ``crash``, ``self_collision``, ``time_penalty``,
    ``alive``, ``yaw_rate``, ``state_error``, ``ball_proximity``, ``ball_below``,
    ``cup_approach``, ``cup_hold``, ``catch``.  Sparse (``quadx_ball_in_cup_sparse``):
    -0.1 per step, +1000 on the catch, -100 on a crash, -500 when the ball strikes the
    vehicle.

    **Episode end**: terminated on a crash — any vehicle contact (the ball striking the
    airframe included: ``info["ball_hit_vehicle"]``), leaving the 30 m flight dome, the
    ball or cup touching the ground (``info["payload_ground_contact"]``) — or on the catch
    (``info["env_complete"] = info["success"] = True``); truncated after 10 s (300
    steps).  ``info["ball_in_cup"]`` and ``info["ball_height"]`` every step.

    **Starting state**: at rest at (0, 0, 2) + U(-0.1, 0.1) m per axis, attitude
    U(-0.05, 0.05) rad per angle; the ball hanging still at full string length.

    **Arguments**: as :class:`~pyflyt_engine.envs.quadx.QuadXHoverEnv` plus ``ball``,
    ``cup`` (payload names), ``hover_point``, ``goal_reach_distance``,
    ``goal_reach_velocity``.

    **Differences from the reference** (PyFlyt 0.29.0): it spawns at 4 m and measures its
    state error and catch from (0, 0, 1); we spawn at and measure from one point, 2 m up.
    Its ball starts at a random angle; ours hangs still (the spawn attitude varies).  Its
    cup has no floor (a caught ball lands on the airframe); ours has a floor plate, and any
    ball contact with the airframe is a strike (the reference only penalises strikes from
    below).  The catch terminates with success (the reference truncates).  Our crash steps
    pay their penalty only.

    **Version history**: v0 — first version.
    """

    config_name: ClassVar[str | None] = "quadx_ball_in_cup"


__all__ = ["QuadXBallInCupEnv", "QuadXGatesEnv", "QuadXPoleBalanceEnv", "QuadXPoleWaypointsEnv"]

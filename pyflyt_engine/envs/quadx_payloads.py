"""QuadX tasks with payloads (reference PyFlyt 0.29.0 tasks beyond the paper).

``PyFlyt/QuadX-Pole-Balance-v0``, ``PyFlyt/QuadX-Pole-Waypoints-v0`` and
``PyFlyt/QuadX-Ball-In-Cup-v0``.  Each class is the
generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped config
(``conf/env/<config_name>.yaml``), whose ``payloads:`` declare the bodies it carries;
``pyflyt envs <id>`` prints its manual, generated from the config and spaces
(:mod:`pyflyt_engine.envs.manual`).  (``PyFlyt/QuadX-Gates-v0``, which carries no
payload, is :mod:`pyflyt_engine.envs.quadx_gates`; its class is still importable from here.)
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv
from pyflyt_engine.envs.quadx_gates import QuadXGatesEnv


class QuadXPoleBalanceEnv(UAVEnv):
    """``PyFlyt/QuadX-Pole-Balance-v0``: hover a 1 kg QuadX with a pole balanced on top.

    A pole stands on a frictionless ball joint just above the vehicle's centre of mass (the
    config's ``payloads`` entry: the reference's 1 m, 0.2 kg uniform cylinder): an inverted
    pendulum the vehicle must keep upright by moving under it, while holding the hover
    point.  The ``quadx_f450`` (the reference flies its 1 kg "primitive_drone" of the same
    thrust) is flown on raw motor throttles (flight mode ``motors``, no controller: the
    reference's flight mode -1) at the reference's agent rate.

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/QuadX-Pole-Balance-v0`` (docs/environments.md, "Env manuals").

    **Design notes**: throttles are fractions of maximum RPM (thrust ~ throttle^2), motor
    order front-right, rear-left, front-left, rear-right (``conf/uav/quadx_f450.yaml``);
    hover with the pole is about throttle 0.54 ((1.2 kg x 9.81 / 40 N)^0.5).  The pole's
    relative velocities in the observation are ``R^T (v_point - v_vehicle)``, as the
    reference's.  The dense reward is the reference's formula,
    ``alive - ||p - hover_point|| - ||[roll, pitch]|| - lean - c r^2`` with a crash
    penalty instead; lean in [0, 1] is the pole's horizontal tip-to-base distance over its
    length (the sine of its tilt) while the tip is above the base, 1 after.  A *crash* is
    any contact of the vehicle, leaving the flight dome, the pole touching the ground
    (``info["payload_ground_contact"]``) or the pole falling: its tip at or below its base
    (``info["pole_fallen"]``).  ``info`` also carries ``pole_lean``.

    **Differences from the reference** (PyFlyt 0.29.0 ``QuadX-Pole-Balance-v0``): its pole
    rests unattached on the vehicle, held by friction, and the episode ends only when
    something hits the ground; ours is pinned by a ball joint and the episode also ends when
    it falls past horizontal.  Our crash step pays the crash penalty only (the reference
    adds the dense terms to it).  Spawn noise is ours (the reference spawns exactly).

    **Version history**: v0 -- first version.
    """

    config_name: ClassVar[str | None] = "quadx_pole_balance"


class QuadXPoleWaypointsEnv(UAVEnv):
    """``PyFlyt/QuadX-Pole-Waypoints-v0``: fly a 1 kg QuadX through waypoints with a pole balanced on top.

    Vehicle, pole and action as :class:`QuadXPoleBalanceEnv`; the observation is its
    vector under ``attitude`` plus ``target_deltas`` as
    :class:`~pyflyt_engine.envs.quadx.QuadXWaypointsEnv` (waypoint ranges the reference's;
    reached on the segment test of :mod:`pyflyt_engine.envs.waypoints`).

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/QuadX-Pole-Waypoints-v0`` (docs/environments.md, "Env manuals").

    **Design notes**: the dense reward pays a waypoint bonus, and otherwise a time penalty,
    ``c s max(-delta_dot, 0)`` for approaching, ``c_a / delta`` proximity and an upright
    bonus, less the pole's lean and the squared yaw rate (delta [m] and delta_dot [m/s]:
    distance to the next waypoint and its rate).  The reference pays 15 x the per-step
    progress in metres at 40 Hz; 0.375 s x the approach speed is the same number at 40 Hz
    and does not change with the agent rate.

    **Differences from the reference**: the pole is pinned (see
    :class:`QuadXPoleBalanceEnv`); completing the last waypoint terminates with success
    instead of truncating; waypoints are reached on the segment test.

    **Version history**: v0 -- first version.
    """

    config_name: ClassVar[str | None] = "quadx_pole_waypoints"


class QuadXBallInCupEnv(UAVEnv):
    """``PyFlyt/QuadX-Ball-In-Cup-v0``: swing a ball hanging below a 1 kg QuadX up into the cup on its top.

    Payloads (the config's ``payloads``, the reference's sizes and masses): a ball on a
    string (a tether: it can go slack) from the bottom of the airframe, and an open cup
    welded on top.  The ``quadx_f450`` is flown by body rates and thrust (the reference's
    flight mode 0; about 0.28 thrust hovers the 1.16 kg total).  **Catch** (success): the
    ball touches the cup with its centre above the vehicle's centre of mass while the
    vehicle is within ``goal_reach_distance`` of ``hover_point`` and slower than
    ``goal_reach_velocity``.

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/QuadX-Ball-In-Cup-v0`` (docs/environments.md, "Env manuals").

    **Design notes**: the dense reward is the reference's formula: a crash penalty (not by
    the ball), a larger one when the ball strikes the vehicle, and otherwise an alive
    bonus less the squared yaw rate and the state error E = |omega|^2 + |euler|^2 + |v|^2 +
    |p - p_hover|^2, a log proximity to the ball while it is above the vehicle (its height
    otherwise), an approach and a hold term while the ball is in the cup, and the catch
    bonus.  Crashes: any vehicle contact (the ball striking the airframe included:
    ``info["ball_hit_vehicle"]``), leaving the dome, the ball or cup touching the ground
    (``info["payload_ground_contact"]``).  ``info["ball_in_cup"]`` and
    ``info["ball_height"]`` every step; the ball starts hanging still at full string
    length.

    **Differences from the reference** (PyFlyt 0.29.0): it spawns at 4 m and measures its
    state error and catch from (0, 0, 1); we spawn at and measure from one point, 2 m up.
    Its ball starts at a random angle; ours hangs still (the spawn attitude varies).  Its
    cup has no floor (a caught ball lands on the airframe); ours has a floor plate, and any
    ball contact with the airframe is a strike (the reference only penalises strikes from
    below).  The catch terminates with success (the reference truncates).  Our crash steps
    pay their penalty only.

    **Version history**: v0 -- first version.
    """

    config_name: ClassVar[str | None] = "quadx_ball_in_cup"


__all__ = ["QuadXBallInCupEnv", "QuadXGatesEnv", "QuadXPoleBalanceEnv", "QuadXPoleWaypointsEnv"]

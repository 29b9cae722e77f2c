"""The Fixedwing environment of the paper: ``PyFlyt/Fixedwing-Waypoints-v0``.

The class is the generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped
config (``conf/env/fixedwing_waypoints.yaml``); ``pyflyt envs PyFlyt/Fixedwing-Waypoints-v0``
prints its manual, generated from the config and spaces (:mod:`pyflyt_engine.envs.manual`).
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv


class FixedwingWaypointsEnv(UAVEnv):
    """``PyFlyt/Fixedwing-Waypoints-v0``: fly the paper's Fixedwing through random waypoints in order.

    The QuadX-Waypoints task (paper, "Provided Environments") with the Fixedwing: the same
    reward terms with the paper's Fixedwing constants and every length of the QuadX task
    20 times larger (waypoint distances and heights, reach distance, spawn noise, dome).
    The aircraft is flown on its raw channels (flight mode ``channels``: no autopilot)
    and starts in flight at its trim speed along the body x axis.

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/Fixedwing-Waypoints-v0`` (docs/environments.md, "Env manuals").

    **Vehicle** (``conf/uav/fixedwing.yaml``): 2.35 kg, 2.4 m span, one 18 N puller motor
    (thrust-to-weight 0.78); it trims at about 13.5 m/s, a throttle of about 0.45 holds
    14 m/s level, and with neutral controls and no thrust it glides about 130 m (9 s)
    from the spawn height.  A positive aileron puts the left aileron down and the right up
    (rolls the right wing down), a positive elevator puts the trailing edge down (nose
    down), a positive rudder yaws the nose left; deflection commands are reached through a
    first-order lag of 0.05 s, the motor through one of 0.01 s.  The aux state is the
    motor throttle, then the surfaces' deflections over their limits: main wing (no flap:
    always 0), left aileron, right aileron, horizontal tail, vertical tail.

    **Design notes**: a pass through the reach sphere at 14 m/s (0.47 m per agent step)
    always counts (the segment test of :mod:`pyflyt_engine.envs.waypoints`).  With c_a = 1
    the paper's printed last reward case (1/delta) and ours (c_a/delta) agree; delta >= d
    until a waypoint is reached, so c_a/delta stays bounded.  Five legs of up to 180 m at
    ~14 m/s plus turns (radius ~35 m at a 30 deg bank) take about a minute: the time limit
    leaves room for that.

    **Version history**: v0 -- this implementation of the paper's environment (reference
    PyFlyt 0.29.0 differs: 4 waypoints from 1 m out and 0.5 m high, spawn at (0, 0, 10) m
    at 20 m/s, thrust action in [-1, 1], reward 1/delta + max(3 x per-step progress in m,
    0) - 0.1 per step, point reach test at 120 Hz, completion as truncation).
    """

    config_name: ClassVar[str | None] = "fixedwing_waypoints"

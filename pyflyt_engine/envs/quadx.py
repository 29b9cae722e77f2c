"""The QuadX environments of the paper: ``PyFlyt/QuadX-Hover-v0`` and ``PyFlyt/QuadX-Waypoints-v0``.

Each class is the generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped
config (``conf/env/<config_name>.yaml``); its docstring says what the task is for and why
it is built so, and ``pyflyt envs <id>`` prints its manual, generated from the config and
spaces (:mod:`pyflyt_engine.envs.manual`).
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv


class QuadXHoverEnv(UAVEnv):
    """``PyFlyt/QuadX-Hover-v0``: hover a Crazyflie-class QuadX at a fixed point.

    The task (paper, "Provided Environments") is to hold the quadrotor level at the hover
    point for the whole episode: a survival task, so reaching the time limit uncrashed is
    the success (``info["success"]``) and ``info["env_complete"]`` stays False.

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/QuadX-Hover-v0`` (docs/environments.md, "Env manuals").

    **Design notes**: the dense reward is the paper's, ``-||[theta, phi]|| - ||[x, y, z] -
    hover_point||`` (tilt and distance) with a crash penalty instead; unlike the reference
    PyFlyt it has no +1 per-step offset (the paper has none).  With the 8:1 thrust-to-weight
    ``quadx_cf2x`` a collective thrust of about 0.125 balances the weight when level; the
    rate limit of the action is the reference PyFlyt's.  A *crash* is any contact of the
    vehicle (ground included) or leaving the flight dome.

    **Version history**: v0 -- this implementation of the paper's environment (reference
    PyFlyt 0.29.0 differs: +1 per-step offset in the dense reward, agent 40 Hz, exact
    spawn at (0, 0, 1)).
    """

    config_name: ClassVar[str | None] = "quadx_hover"


class QuadXWaypointsEnv(UAVEnv):
    """``PyFlyt/QuadX-Waypoints-v0``: fly a Crazyflie-class QuadX through random waypoints in order.

    Vehicle and action as :class:`QuadXHoverEnv`; the observation adds ``target_deltas``,
    one body-frame row per waypoint not yet reached, next first (``(0, 3)`` after the
    last; :class:`~pyflyt_engine.envs.wrappers.FlattenWaypointEnv` gives a fixed-size Box
    for Stable-Baselines3).  Waypoints are drawn at reset on the upper hemisphere (distances
    and minimum height: the task options); reaching the last one ends the episode with
    success, and ``info["num_targets_reached"]`` counts them.

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/QuadX-Waypoints-v0`` (docs/environments.md, "Env manuals").

    **Design notes**: a waypoint counts as reached when the centre of mass comes within
    ``goal_reach_distance`` of it *during* an agent step -- the straight segment between
    the step's start and end positions is tested -- so passing through at speed counts
    whatever the agent rate.  The dense reward (preset ``quadx_waypoints_dense``) reads, in
    this order: the crash penalty if crashed; the waypoint bonus if one was reached;
    ``c_a / delta - c_b delta_dot`` while approaching, else ``c_a / delta`` (delta the
    distance to the waypoint that was the target during the step, delta_dot its change
    over the step in metres: approaching pays c_b per metre closed at any agent rate, as
    in the reference PyFlyt).  The paper prints the last case as 1/delta (no c_a); c_a/delta
    is used because it is the only form continuous at delta_dot = 0 -- with 1/delta,
    lingering just outside the reach radius while drifting away would pay 10x more than
    approaching.  Preset ``quadx_waypoints_dense_rate`` reads delta_dot as a rate [m/s]
    instead (c_b x agent_hz per metre), which makes a near miss pay almost as much as a
    waypoint.  An episode may set ``goal_reach_distance`` and the waypoint and spawn
    ranges through ``reset(options={"task": {...}})``.

    **Training**: ``pyflyt train env=quadx_waypoints`` (PPO, 4.5 M steps, ~26 minutes on
    2 cores) starts its training episodes with a 1 m reach sphere and shrinks it to
    0.2 m over 2 M steps (``train.curriculum``); 3 of 5 seeds reach all 5 waypoints in
    >= 80 % of the episodes (experiments/results/learn_waypoints.md).

    **Version history**: v0 -- this implementation of the paper's environment (reference
    PyFlyt 0.29.0 differs: 4 waypoints, 10 s, per-step progress in metres, point reach
    test at 120 Hz, waypoint completion as truncation).
    """

    config_name: ClassVar[str | None] = "quadx_waypoints"

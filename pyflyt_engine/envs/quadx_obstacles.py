"""``PyFlyt/QuadX-Obstacles-v0``: the QuadX in a cluttered world (obstacles and a LiDAR).

The class is the generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped
config; ``pyflyt envs PyFlyt/QuadX-Obstacles-v0`` prints its manual, generated from the
config and spaces (:mod:`pyflyt_engine.envs.manual`).
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv


class QuadXObstaclesEnv(UAVEnv):
    """``PyFlyt/QuadX-Obstacles-v0``: fly a Crazyflie-class QuadX to a goal through a random forest.

    The goal is drawn at every reset across the forest from the spawn (the task options);
    between them a forest of upright cylinders (``obstacles:`` of the config,
    :mod:`pyflyt_engine.obstacles`) is drawn at every reset from the episode's seed, keeping
    clear of the spawn point and the goal.  The vehicle sees them through a planar LiDAR
    (``range_sensors:``: beam k at azimuth ``-fov/2 + (k + 1/2) fov / n`` about the body z
    axis, 0 = forward, counter-clockwise; the distance to the first surface, the maximum
    range where nothing is hit; ray cast at every agent step,
    :mod:`pyflyt_engine.components.range_sensor`).

    Its manual -- loop rates, action table, observation layout, reward presets with their
    terms and weights, task options, episode end, arguments -- is generated from its config
    and spaces: ``pyflyt envs PyFlyt/QuadX-Obstacles-v0`` (docs/environments.md, "Env manuals").

    **Design notes**: the dense reward is QuadX-Waypoints' dense reward for one goal; a
    crash is any contact (a trunk or the ground) or leaving the dome, and ``success`` is the
    goal reached without contact.  ``info`` also has ``goal_reached``, ``obstacle_contact``
    (the vehicle touched an obstacle this step) and ``obstacles_parked`` (trunks that found
    no place this episode and were left out; 0 with the shipped density).  The forest, the
    goal, the spawn and the LiDAR noise follow the reset's seed, bit for bit across
    processes; a recording of an episode re-simulates exactly (``pyflyt replay --verify``).

    **Learning**: ``pyflyt train env=quadx_obstacles`` imitates the
    ``quadx_forest_navigator`` oracle (DAgger) and then runs PPO; the imitated policy reaches
    the goal in 90-100 % of probe episodes after ~4 CPU-minutes
    (``experiments/results/learn_obstacles.md``, ``docs/environments.md``).

    **Version history**: v0 -- first version.
    """

    config_name: ClassVar[str | None] = "quadx_obstacles"

"""``PyFlyt/QuadX-Obstacles-v0``: the QuadX in a cluttered world (obstacles and a LiDAR).

The class is the generic :class:`~pyflyt_engine.envs.env.UAVEnv` bound to its shipped
config; its docstring is the environment's manual.
"""

from __future__ import annotations

from typing import ClassVar

from pyflyt_engine.envs.env import UAVEnv


class QuadXObstaclesEnv(UAVEnv):
    """``PyFlyt/QuadX-Obstacles-v0``: fly a Crazyflie-class QuadX to a goal through a random forest.

    Config: ``conf/env/quadx_obstacles.yaml``.  The vehicle spawns at (-4, 0, 1) m
    (+-0.1 m per axis, +-0.1 rad per Euler angle); the goal is drawn at every reset at
    x = 4 m, y in [-2, 2] m, z in [1, 2] m.  Between them a forest of 12 upright
    cylinders (radius 0.1-0.25 m, 3-5 m tall, at least 0.6 m apart) is drawn at every
    reset from the episode's seed in x in [-3, 3] m, y in [-4, 4] m, none within 1 m
    (horizontally) of the spawn point or the goal (``obstacles:`` of the config,
    :mod:`pyflyt_engine.obstacles`).

    **Vehicle and action**: as :class:`~pyflyt_engine.envs.quadx.QuadXHoverEnv`
    (``quadx_cf2x`` in ``rates_thrust``: ``Box(4,)`` = p, q, r [rad/s] in [-pi, pi],
    thrust in [0, 1]; agent 30 Hz).

    **Observation** ``Dict``:

    * ``attitude``: ``Box(21,)`` / ``Box(20,)`` float64, as
      :class:`~pyflyt_engine.envs.quadx.QuadXHoverEnv`;
    * ``goal_delta``: ``Box(3,)`` float64, the vector from the vehicle to the goal in
      the body frame [m] (zeros once reached);
    * ``lidar``: ``Box(0, 5, (64,))`` float32, a planar LiDAR at the body centre:
      64 beams over 360 deg, beam k at azimuth ``-180 + (k + 1/2) * 5.625`` deg about the
      body z axis (0 = forward, counter-clockwise), the distance [m] along the beam to the
      first surface between 0.1 and 5 m, 5 where nothing is hit; Gaussian noise of
      0.01 m on hits; ray cast (``pybullet.rayTestBatch``) at every agent step
      (:mod:`pyflyt_engine.components.range_sensor`).

    **Reward** (dense, preset ``quadx_obstacles_dense``: QuadX-Waypoints' dense reward
    for one goal)::

        r = -100                               if crash (obstacle contact included)
            +100                               if the goal is reached
            0.1 / delta + 3 * (-delta_dot)     if approaching (delta_dot < 0)
            0.1 / delta                        otherwise

    with delta the distance to the goal [m] and delta_dot its change over the agent step
    [m].  Sparse (``quadx_obstacles_sparse``): -100 on a crash, +100 at the goal.

    **Episode end**: terminated on a crash -- any contact (a trunk or the ground), or
    leaving the 7 m flight dome -- or when the goal is reached (``success``: reached
    without contact); truncated after 20 s (600 steps).

    **Info**: as every env, plus ``goal_reached``, ``obstacle_contact`` (the vehicle
    touched an obstacle this step) and ``obstacles_parked`` (trunks that found no place
    this episode and were left out; 0 with the shipped density).

    **Arguments**: as :class:`~pyflyt_engine.envs.quadx.QuadXHoverEnv` plus the task's
    options (``goal_x_range``, ``goal_y_range``, ``goal_z_range``,
    ``goal_reach_distance``) and any config key (``obstacles={...}``,
    ``range_sensors=[...]``).  Episode options (``reset(options={"task": ...})``): the
    goal ranges, ``goal_reach_distance`` and the spawn noise.

    Determinism: the forest, the goal, the spawn and the LiDAR noise follow the reset's
    seed, bit for bit across processes; a recording of an episode re-simulates exactly
    (``pyflyt replay --verify``).

    **Learning**: ``pyflyt train env=quadx_obstacles`` imitates the
    ``quadx_forest_navigator`` oracle (DAgger) and then runs PPO; the imitated policy reaches
    the goal in 90-100 % of probe episodes after ~4 CPU-minutes
    (``experiments/results/learn_obstacles.md``, ``docs/environments.md``).

    **Version history**: v0 — first version.
    """

    config_name: ClassVar[str | None] = "quadx_obstacles"

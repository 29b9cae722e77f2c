"""The reference's ``fixedwing_envs.fixedwing_waypoints_env`` (PyFlyt 0.29.0): the compat ``FixedwingWaypointsEnv``."""

from pyflyt_engine.compat.gym_envs.envs import FixedwingWaypointsEnv

__all__ = ["FixedwingWaypointsEnv"]

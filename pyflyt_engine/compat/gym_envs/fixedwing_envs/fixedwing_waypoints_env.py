"""The reference's ``fixedwing_envs.fixedwing_waypoints_env`` (PyFlyt 0.29.0): the compat ``FixedwingWaypointsEnv``."""

from pyflyt_engine.compat.gym_envs.envs import FixedwingWaypointsEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.gym_envs.fixedwing_envs.fixedwing_base_env import FixedwingBaseEnv
from pyflyt_engine.compat.gym_envs.utils.waypoint_handler import WaypointHandler

__all__ = ["FixedwingBaseEnv", "FixedwingWaypointsEnv", "WaypointHandler"]

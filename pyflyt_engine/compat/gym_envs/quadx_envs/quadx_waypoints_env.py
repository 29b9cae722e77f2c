"""The reference's ``quadx_envs.quadx_waypoints_env`` (PyFlyt 0.29.0): the compat ``QuadXWaypointsEnv``."""

from pyflyt_engine.compat.gym_envs.envs import QuadXWaypointsEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_base_env import QuadXBaseEnv
from pyflyt_engine.compat.gym_envs.utils.waypoint_handler import WaypointHandler

__all__ = ["QuadXBaseEnv", "QuadXWaypointsEnv", "WaypointHandler"]

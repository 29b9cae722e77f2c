"""The reference's ``quadx_envs.quadx_pole_waypoints_env`` (PyFlyt 0.29.0): the compat ``QuadXPoleWaypointsEnv``."""

from pyflyt_engine.compat.gym_envs.envs import QuadXPoleWaypointsEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_base_env import QuadXBaseEnv
from pyflyt_engine.compat.gym_envs.utils.pole_handler import PoleHandler
from pyflyt_engine.compat.gym_envs.utils.waypoint_handler import WaypointHandler

__all__ = ["PoleHandler", "QuadXBaseEnv", "QuadXPoleWaypointsEnv", "WaypointHandler"]

"""The reference's ``gym_envs.utils.flatten_waypoint_env`` module path, holding :class:`FlattenWaypointEnv`."""

from pyflyt_engine.compat.gym_envs.flatten import FlattenWaypointEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.gym_envs.utils.waypoint_handler import WaypointHandler

__all__ = ["FlattenWaypointEnv", "WaypointHandler"]

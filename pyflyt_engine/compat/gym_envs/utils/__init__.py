"""The reference's ``PyFlyt.gym_envs.utils``: ``FlattenWaypointEnv``, ``WaypointHandler``, ``PoleHandler``."""

from pyflyt_engine.compat.gym_envs.utils.flatten_waypoint_env import FlattenWaypointEnv
from pyflyt_engine.compat.gym_envs.utils.pole_handler import PoleHandler
from pyflyt_engine.compat.gym_envs.utils.waypoint_handler import WaypointHandler

__all__ = ["FlattenWaypointEnv", "PoleHandler", "WaypointHandler"]

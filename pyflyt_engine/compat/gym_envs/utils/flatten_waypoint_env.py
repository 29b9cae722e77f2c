"""The reference's ``gym_envs.utils.flatten_waypoint_env`` module path, holding :class:`FlattenWaypointEnv`."""

from pyflyt_engine.compat.gym_envs.flatten import FlattenWaypointEnv

__all__ = ["FlattenWaypointEnv"]

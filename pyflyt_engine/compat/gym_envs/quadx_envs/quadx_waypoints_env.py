"""The reference's ``quadx_envs.quadx_waypoints_env`` (PyFlyt 0.29.0): the compat ``QuadXWaypointsEnv``."""

from pyflyt_engine.compat.gym_envs.envs import QuadXWaypointsEnv

__all__ = ["QuadXWaypointsEnv"]

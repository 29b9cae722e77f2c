"""The reference's ``quadx_envs.quadx_pole_waypoints_env`` (PyFlyt 0.29.0): the compat ``QuadXPoleWaypointsEnv``."""

from pyflyt_engine.compat.gym_envs.envs import QuadXPoleWaypointsEnv

__all__ = ["QuadXPoleWaypointsEnv"]

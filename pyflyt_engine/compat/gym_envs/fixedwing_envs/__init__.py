"""The reference's ``PyFlyt.gym_envs.fixedwing_envs``: its fixed-wing base env and waypoints env."""

from pyflyt_engine.compat.gym_envs.fixedwing_envs.fixedwing_base_env import FixedwingBaseEnv
from pyflyt_engine.compat.gym_envs.fixedwing_envs.fixedwing_waypoints_env import FixedwingWaypointsEnv

__all__ = ["FixedwingBaseEnv", "FixedwingWaypointsEnv"]

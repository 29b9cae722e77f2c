"""The reference's ``rocket_envs.rocket_landing_env`` (PyFlyt 0.29.0): the compat ``RocketLandingEnv``."""

from pyflyt_engine.compat.gym_envs.envs import RocketLandingEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.gym_envs.rocket_envs.rocket_base_env import RocketBaseEnv

__all__ = ["RocketBaseEnv", "RocketLandingEnv"]

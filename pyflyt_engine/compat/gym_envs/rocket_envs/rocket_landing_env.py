"""The reference's ``rocket_envs.rocket_landing_env`` (PyFlyt 0.29.0): the compat ``RocketLandingEnv``."""

from pyflyt_engine.compat.gym_envs.envs import RocketLandingEnv

__all__ = ["RocketLandingEnv"]

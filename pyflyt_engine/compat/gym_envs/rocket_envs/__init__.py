"""The reference's ``PyFlyt.gym_envs.rocket_envs``: its rocket base env and landing env."""

from pyflyt_engine.compat.gym_envs.rocket_envs.rocket_base_env import RocketBaseEnv
from pyflyt_engine.compat.gym_envs.rocket_envs.rocket_landing_env import RocketLandingEnv

__all__ = ["RocketBaseEnv", "RocketLandingEnv"]

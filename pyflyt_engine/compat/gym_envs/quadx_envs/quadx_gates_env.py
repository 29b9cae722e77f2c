"""The reference's ``quadx_envs.quadx_gates_env`` (PyFlyt 0.29.0): the compat ``QuadXGatesEnv``."""

from pyflyt_engine.compat.gym_envs.envs import QuadXGatesEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_base_env import QuadXBaseEnv

__all__ = ["QuadXBaseEnv", "QuadXGatesEnv"]

"""The reference's ``quadx_envs.quadx_gates_env`` (PyFlyt 0.29.0): the compat ``QuadXGatesEnv``."""

from pyflyt_engine.compat.gym_envs.envs import QuadXGatesEnv

__all__ = ["QuadXGatesEnv"]

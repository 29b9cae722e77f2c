"""The reference's ``quadx_envs.quadx_pole_balance_env`` (PyFlyt 0.29.0): the compat ``QuadXPoleBalanceEnv``."""

from pyflyt_engine.compat.gym_envs.envs import QuadXPoleBalanceEnv

__all__ = ["QuadXPoleBalanceEnv"]

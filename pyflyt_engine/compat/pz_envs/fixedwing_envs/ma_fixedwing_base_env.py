"""The reference's ``pz_envs.fixedwing_envs.ma_fixedwing_base_env`` module path: ``MAFixedwingBaseEnv``."""

from pyflyt_engine.compat.pz_envs._aviary_base import MAFixedwingBaseEnv

__all__ = ["MAFixedwingBaseEnv"]

"""The reference's ``pz_envs.quadx_envs.ma_quadx_base_env`` module path: ``MAQuadXBaseEnv``."""

from pyflyt_engine.compat.pz_envs._aviary_base import MAQuadXBaseEnv

__all__ = ["MAQuadXBaseEnv"]

"""The reference's ``pz_envs.quadx_envs.ma_quadx_base_env`` module path: ``MAQuadXBaseEnv``."""

from pyflyt_engine.compat.pz_envs._aviary_base import MAQuadXBaseEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.aviary import Aviary

__all__ = ["Aviary", "MAQuadXBaseEnv"]

"""The reference's ``pz_envs.fixedwing_envs.ma_fixedwing_base_env`` module path: ``MAFixedwingBaseEnv``."""

from pyflyt_engine.compat.pz_envs._aviary_base import MAFixedwingBaseEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.aviary import Aviary
from pyflyt_engine.compat.core.utils.compile_helpers import jitter

__all__ = ["Aviary", "MAFixedwingBaseEnv", "jitter"]

"""The reference's ``pz_envs.fixedwing_envs.ma_fixedwing_dogfight_env`` module path:
``MAFixedwingDogfightEnv`` (exported by ``pz_envs`` as ``MAFixedwingDogfightEnvV2``)."""

from pyflyt_engine.compat.pz_envs._envs import MAFixedwingDogfightEnvV2 as MAFixedwingDogfightEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.pz_envs.fixedwing_envs.ma_fixedwing_base_env import MAFixedwingBaseEnv

__all__ = ["MAFixedwingBaseEnv", "MAFixedwingDogfightEnv"]

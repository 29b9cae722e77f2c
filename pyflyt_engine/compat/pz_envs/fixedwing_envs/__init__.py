"""The reference's ``PyFlyt.pz_envs.fixedwing_envs``."""

from pyflyt_engine.compat.pz_envs.fixedwing_envs.ma_fixedwing_base_env import MAFixedwingBaseEnv
from pyflyt_engine.compat.pz_envs.fixedwing_envs.ma_fixedwing_dogfight_env import MAFixedwingDogfightEnv

__all__ = ["MAFixedwingBaseEnv", "MAFixedwingDogfightEnv"]

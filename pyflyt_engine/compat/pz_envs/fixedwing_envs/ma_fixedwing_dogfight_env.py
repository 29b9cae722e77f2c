"""The reference's ``pz_envs.fixedwing_envs.ma_fixedwing_dogfight_env`` module path:
``MAFixedwingDogfightEnv`` (exported by ``pz_envs`` as ``MAFixedwingDogfightEnvV2``)."""

from pyflyt_engine.compat.pz_envs._envs import MAFixedwingDogfightEnvV2 as MAFixedwingDogfightEnv

__all__ = ["MAFixedwingDogfightEnv"]

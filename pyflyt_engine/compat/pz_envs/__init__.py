"""The reference's PettingZoo envs (``from PyFlyt.pz_envs import ...``'s counterpart).

``MAQuadXHoverEnvV2`` (:mod:`._envs`, the native multi-agent hover running the
reference's episode) and ``MAFixedwingDogfightEnvV2`` (:mod:`._dogfight`, the reference's
dogfight over the compat Aviary) have the reference's arguments, spaces, layouts, rewards
and endings; the reference's module tree is mirrored too (``pz_envs.quadx_envs.ma_quadx_hover_env.MAQuadXHoverEnv``,
``pz_envs.fixedwing_envs.ma_fixedwing_dogfight_env.MAFixedwingDogfightEnv``, and the base
envs ``MAQuadXBaseEnv`` / ``MAFixedwingBaseEnv`` for tasks users write, :mod:`._aviary_base`).
"""

from pyflyt_engine.compat.pz_envs._envs import MAFixedwingDogfightEnvV2, MAQuadXHoverEnvV2

__all__ = ["MAFixedwingDogfightEnvV2", "MAQuadXHoverEnvV2"]

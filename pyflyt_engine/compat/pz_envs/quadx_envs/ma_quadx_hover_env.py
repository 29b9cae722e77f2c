"""The reference's ``pz_envs.quadx_envs.ma_quadx_hover_env`` module path: ``MAQuadXHoverEnv``
(exported by ``pz_envs`` as ``MAQuadXHoverEnvV2``, as in the reference)."""

from pyflyt_engine.compat.pz_envs._envs import MAQuadXHoverEnvV2 as MAQuadXHoverEnv

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.pz_envs.quadx_envs.ma_quadx_base_env import MAQuadXBaseEnv

__all__ = ["MAQuadXBaseEnv", "MAQuadXHoverEnv"]

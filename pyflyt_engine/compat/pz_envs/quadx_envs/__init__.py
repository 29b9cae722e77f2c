"""The reference's ``PyFlyt.pz_envs.quadx_envs``."""

from pyflyt_engine.compat.pz_envs.quadx_envs.ma_quadx_base_env import MAQuadXBaseEnv
from pyflyt_engine.compat.pz_envs.quadx_envs.ma_quadx_hover_env import MAQuadXHoverEnv

__all__ = ["MAQuadXBaseEnv", "MAQuadXHoverEnv"]

"""The reference's ``quadx_envs.quadx_hover_env`` (PyFlyt 0.29.0): the compat ``QuadXHoverEnv``."""

from pyflyt_engine.compat.gym_envs.envs import QuadXHoverEnv

__all__ = ["QuadXHoverEnv"]

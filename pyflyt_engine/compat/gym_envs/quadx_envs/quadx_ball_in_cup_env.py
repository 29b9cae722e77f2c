"""The reference's ``quadx_envs.quadx_ball_in_cup_env`` (PyFlyt 0.29.0): the compat ``QuadXBallInCupEnv``."""

from pyflyt_engine.compat.gym_envs.envs import QuadXBallInCupEnv

__all__ = ["QuadXBallInCupEnv"]

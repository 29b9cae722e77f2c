"""The reference's ``PyFlyt.gym_envs.quadx_envs``: its QuadX base env and stock QuadX envs."""

from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_ball_in_cup_env import QuadXBallInCupEnv
from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_base_env import QuadXBaseEnv
from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_gates_env import QuadXGatesEnv
from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_hover_env import QuadXHoverEnv
from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_pole_balance_env import QuadXPoleBalanceEnv
from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_pole_waypoints_env import QuadXPoleWaypointsEnv
from pyflyt_engine.compat.gym_envs.quadx_envs.quadx_waypoints_env import QuadXWaypointsEnv

__all__ = [
    "QuadXBallInCupEnv",
    "QuadXBaseEnv",
    "QuadXGatesEnv",
    "QuadXHoverEnv",
    "QuadXPoleBalanceEnv",
    "QuadXPoleWaypointsEnv",
    "QuadXWaypointsEnv",
]

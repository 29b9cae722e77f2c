"""MAQuadX-Formation, version 0, in PettingZoo's module layout.

``parallel_env(**kwargs)`` builds the :class:`~pyflyt_engine.envs.multi_agent.formation.MAQuadXFormationEnv`
(a ``ParallelEnv``; its docstring is the manual), ``env(**kwargs)`` the same as an AEC
env (``pettingzoo.utils.conversions.parallel_to_aec``), ``raw_env`` is the class::

    from pyflyt_engine.envs.multi_agent import ma_quadx_formation_v0
    env = ma_quadx_formation_v0.parallel_env(agents=64, layout_spacing=0.8)
"""

from __future__ import annotations

from typing import Any

from pettingzoo.utils.conversions import parallel_to_aec

from pyflyt_engine.envs.multi_agent.formation import MAQuadXFormationEnv

raw_env = MAQuadXFormationEnv


def parallel_env(**kwargs: Any) -> MAQuadXFormationEnv:
    """The parallel (simultaneous-action) environment; ``kwargs`` as :class:`MAQuadXFormationEnv`."""
    return MAQuadXFormationEnv(**kwargs)


def env(**kwargs: Any) -> Any:
    """The AEC (turn-based) form of :func:`parallel_env`: agents act in turn, the world steps once per cycle."""
    return parallel_to_aec(parallel_env(**kwargs))

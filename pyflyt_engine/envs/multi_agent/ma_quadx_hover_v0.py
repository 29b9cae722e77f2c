"""MAQuadX-Hover, version 0, in PettingZoo's module layout.

``parallel_env(**kwargs)`` builds the :class:`~pyflyt_engine.envs.multi_agent.hover.MAQuadXHoverEnv`
(a ``ParallelEnv``; its docstring is the manual), ``env(**kwargs)`` the same as an AEC
env (``pettingzoo.utils.conversions.parallel_to_aec``), ``raw_env`` is the class::

    from pyflyt_engine.envs.multi_agent import ma_quadx_hover_v0
    env = ma_quadx_hover_v0.parallel_env(agents=8, uav="quadx_f450")
"""

from __future__ import annotations

from typing import Any

from pettingzoo.utils.conversions import parallel_to_aec

from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv

raw_env = MAQuadXHoverEnv


def parallel_env(**kwargs: Any) -> MAQuadXHoverEnv:
    """The parallel (simultaneous-action) environment; ``kwargs`` as :class:`MAQuadXHoverEnv`."""
    return MAQuadXHoverEnv(**kwargs)


def env(**kwargs: Any) -> Any:
    """The AEC (turn-based) form of :func:`parallel_env`: agents act in turn, the world steps once per cycle."""
    return parallel_to_aec(parallel_env(**kwargs))

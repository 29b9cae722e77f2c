"""MAFixedwing-Dogfight, version 0, in PettingZoo's module layout.

``parallel_env(**kwargs)`` builds the :class:`~pyflyt_engine.envs.multi_agent.dogfight.MAFixedwingDogfightEnv`
(a ``ParallelEnv``; its docstring is the manual), ``env(**kwargs)`` the same as an AEC
env (``pettingzoo.utils.conversions.parallel_to_aec``), ``raw_env`` is the class::

    from pyflyt_engine.envs.multi_agent import ma_fixedwing_dogfight_v0
    env = ma_fixedwing_dogfight_v0.parallel_env(agents=4)
"""

from __future__ import annotations

from typing import Any

from pettingzoo.utils.conversions import parallel_to_aec

from pyflyt_engine.envs.multi_agent.dogfight import MAFixedwingDogfightEnv

raw_env = MAFixedwingDogfightEnv


def parallel_env(**kwargs: Any) -> MAFixedwingDogfightEnv:
    """The parallel (simultaneous-action) environment; ``kwargs`` as :class:`MAFixedwingDogfightEnv`."""
    return MAFixedwingDogfightEnv(**kwargs)


def env(**kwargs: Any) -> Any:
    """The AEC (turn-based) form of :func:`parallel_env`: agents act in turn, the world steps once per cycle."""
    return parallel_to_aec(parallel_env(**kwargs))

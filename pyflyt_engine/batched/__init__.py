"""The batched backend: N multirotors or fixed-wings as arrays, advanced by one compiled call per agent step.

``env.backend: batched`` in an env config (with ``train.n_envs: N``) trains on it;
:func:`make_batched_env` builds it from Python as a Gymnasium vector env.  The laws are the
PyBullet engine's own (:mod:`pyflyt_engine.batched.kernels`, held to their scalar forms bit
for bit by the tests), the rigid body integrated as PyBullet integrates it, and what it
does not simulate is refused by name (docs/batched.md).
"""

from __future__ import annotations

from pyflyt_engine.batched.env import BATCHED_TASKS, BatchedUAVEnv, check_supported, make_batched_env, resolve_backend
from pyflyt_engine.batched.model import BatchedModel, UnsupportedByBatched, batched_model

__all__ = [
    "BATCHED_TASKS",
    "BatchedModel",
    "BatchedUAVEnv",
    "UnsupportedByBatched",
    "batched_model",
    "check_supported",
    "make_batched_env",
    "resolve_backend",
]

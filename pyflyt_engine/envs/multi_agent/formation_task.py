"""The formation task moved to :mod:`pyflyt_engine.envs.tasks.ma_formation`, with the rest of
the task; this module keeps the old import path working."""

from __future__ import annotations

from pyflyt_engine.envs.tasks.ma_formation import MAFormationTask

__all__ = ["MAFormationTask"]

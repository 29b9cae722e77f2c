"""The formation task's reward terms moved to :mod:`pyflyt_engine.envs.tasks.ma_formation`,
with the rest of the task; this module keeps the old import path working."""

from __future__ import annotations

from pyflyt_engine.envs.tasks.ma_formation import crowding, formation_error, in_formation

__all__ = ["crowding", "formation_error", "in_formation"]

"""The dogfight's reward terms moved to :mod:`pyflyt_engine.envs.tasks.dogfight`, with the rest
of the task; this module keeps the old import path working."""

from __future__ import annotations

from pyflyt_engine.envs.tasks.dogfight import (
    aim,
    aimed_at,
    health,
    hits_dealt,
    hits_taken,
    kills,
    pursuit,
    team_win,
)

__all__ = ["aim", "aimed_at", "health", "hits_dealt", "hits_taken", "kills", "pursuit", "team_win"]

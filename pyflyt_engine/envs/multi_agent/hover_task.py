"""The multi-agent hover task moved to :mod:`pyflyt_engine.envs.tasks.ma_hover`, with the rest
of the task; this module keeps the old import path working."""

from __future__ import annotations

from pyflyt_engine.envs.tasks.ma_hover import MAHoverTask

__all__ = ["MAHoverTask"]

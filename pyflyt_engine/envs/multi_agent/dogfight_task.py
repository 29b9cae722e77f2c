"""The dogfight task moved to :mod:`pyflyt_engine.envs.tasks.dogfight`, with the rest of the
task; this module keeps the old import path working."""

from __future__ import annotations

from pyflyt_engine.envs.tasks.dogfight import OTHER_SIZE, DogfightTask

__all__ = ["OTHER_SIZE", "DogfightTask"]

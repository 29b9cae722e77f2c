"""The reference's ``core.abstractions.base_drone`` module path (see :mod:`pyflyt_engine.compat.core.abstractions`)."""

from pyflyt_engine.compat.core.abstractions import DroneClass

__all__ = ["DroneClass"]

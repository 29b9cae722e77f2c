"""The reference's ``core.abstractions.lifting_surfaces`` module path."""

from pyflyt_engine.compat.core.abstractions import LiftingSurface, LiftingSurfaces

__all__ = ["LiftingSurface", "LiftingSurfaces"]

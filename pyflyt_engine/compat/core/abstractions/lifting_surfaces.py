"""The reference's ``core.abstractions.lifting_surfaces`` module path."""

from pyflyt_engine.compat.core.abstractions import LiftingSurface, LiftingSurfaces

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.utils.compile_helpers import jitter

__all__ = ["LiftingSurface", "LiftingSurfaces", "jitter"]

"""The reference's ``core.abstractions.boring_bodies`` module path."""

from pyflyt_engine.compat.core.abstractions import BoringBodies

__all__ = ["BoringBodies"]

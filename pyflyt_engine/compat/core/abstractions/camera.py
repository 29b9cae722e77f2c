"""The reference's ``core.abstractions.camera`` module path (see :mod:`pyflyt_engine.compat.core.abstractions`)."""

from pyflyt_engine.compat.core.abstractions import Camera

__all__ = ["Camera"]

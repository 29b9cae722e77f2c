"""The reference's ``core.abstractions.motors`` module path (see :mod:`pyflyt_engine.compat.core.abstractions`)."""

from pyflyt_engine.compat.core.abstractions import Motors

__all__ = ["Motors"]

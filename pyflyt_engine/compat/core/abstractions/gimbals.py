"""The reference's ``core.abstractions.gimbals`` module path (see :mod:`pyflyt_engine.compat.core.abstractions`)."""

from pyflyt_engine.compat.core.abstractions import Gimbals

__all__ = ["Gimbals"]

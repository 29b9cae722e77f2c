"""The reference's ``core.abstractions.boosters`` module path (see :mod:`pyflyt_engine.compat.core.abstractions`)."""

from pyflyt_engine.compat.core.abstractions import Boosters

__all__ = ["Boosters"]

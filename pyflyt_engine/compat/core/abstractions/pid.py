"""The reference's ``core.abstractions.pid`` module path (see :mod:`pyflyt_engine.compat.core.abstractions`)."""

from pyflyt_engine.compat.core.abstractions import PID

__all__ = ["PID"]

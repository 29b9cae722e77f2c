"""The reference's ``core.abstractions.base_drone`` module path (see :mod:`pyflyt_engine.compat.core.abstractions`)."""

from pyflyt_engine.compat.core.abstractions import DroneClass

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.abstractions import Camera, ControlClass

__all__ = ["Camera", "ControlClass", "DroneClass"]

"""The reference's ``core.abstractions.base_controller`` module path."""

from pyflyt_engine.compat.core.abstractions import ControlClass

__all__ = ["ControlClass"]

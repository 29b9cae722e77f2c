"""The reference's ``core.abstractions.base_wind_field`` module path."""

from pyflyt_engine.compat.core.abstractions import WindFieldClass

__all__ = ["WindFieldClass"]

"""The reference's ``core.abstractions.camera`` module path (see :mod:`pyflyt_engine.compat.core.abstractions`)."""

from pyflyt_engine.compat.core.abstractions import Camera

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.utils.compile_helpers import check_numpy

__all__ = ["Camera", "check_numpy"]

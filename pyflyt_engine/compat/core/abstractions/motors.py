"""The reference's ``core.abstractions.motors`` module path (see :mod:`pyflyt_engine.compat.core.abstractions`)."""

from pyflyt_engine.compat.core.abstractions import Motors

# the names the reference's module holds through its own imports, for code that takes them from here
from pyflyt_engine.compat.core.utils.compile_helpers import jitter

__all__ = ["Motors", "jitter"]

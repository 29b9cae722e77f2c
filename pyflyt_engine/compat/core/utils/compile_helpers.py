"""The reference's ``core.utils.compile_helpers`` module path: ``jitter`` and ``check_numpy``.

PyFlyt 0.29.0 compiles its hot functions with numba (``jitter``); nothing here needs it,
so ``jitter`` returns the function as it is, and ``check_numpy`` is the no-op the
reference's is in 0.29.0.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["check_numpy", "jitter"]


def jitter(func: Callable[..., Any], **kwargs: Any) -> Callable[..., Any]:
    """``func`` itself (the reference's numba options in ``kwargs`` are accepted and unused)."""
    return func


def check_numpy() -> None:
    """Nothing to check (PyFlyt 0.29.0's returns at once as well)."""

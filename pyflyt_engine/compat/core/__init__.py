"""The reference's ``PyFlyt.core``: :class:`Aviary` (see :mod:`.aviary`) and :mod:`.abstractions`."""

from __future__ import annotations

from pyflyt_engine.compat.core.aviary import Aviary

__all__ = ["Aviary"]

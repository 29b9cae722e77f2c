"""The reference's ``PyFlyt.core``: :class:`Aviary` (see :mod:`.aviary`), :mod:`.abstractions`
and the OBJ helpers ``loadOBJ``, ``obj_visual``, ``obj_collision`` (:mod:`.utils.load_objs`)."""

from __future__ import annotations

from pyflyt_engine.compat.core.aviary import Aviary, AviaryInitException
from pyflyt_engine.compat.core.utils.load_objs import loadOBJ, obj_collision, obj_visual

__all__ = ["Aviary", "AviaryInitException", "loadOBJ", "obj_collision", "obj_visual"]

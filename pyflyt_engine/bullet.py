"""PyBullet, imported without the banner its C extension prints.

``import pybullet`` writes ``pybullet build time: <date>`` from C straight to file
descriptor 2, where Python's ``sys.stderr`` cannot intercept it, and every command (and
every subprocess worker) would show it.  Every module of the toolkit imports PyBullet
from here::

    from pyflyt_engine.bullet import pybullet as p

For the duration of the first import only, descriptors 1 and 2 point at the null device;
they are restored right after, so nothing printed before or after -- warnings, errors,
PyBullet's own messages while it runs -- is ever hidden.
"""

from __future__ import annotations

import ctypes
import importlib
import os
import sys
from types import ModuleType


def _flush_c_streams() -> None:
    """Flush C's stdio buffers, so text the import buffered goes where it was written to."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):  # no C library handle on this platform
        pass


def import_quietly(name: str) -> ModuleType:
    """Import module ``name`` with descriptors 1 and 2 silenced during the import only."""
    if name in sys.modules:
        return sys.modules[name]
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    try:
        sink = os.open(os.devnull, os.O_WRONLY)
    except OSError:  # no null device: import as is
        return importlib.import_module(name)
    saved: list[tuple[int, int]] = []
    try:
        for fd in (1, 2):
            try:
                saved.append((fd, os.dup(fd)))
            except OSError:  # this descriptor is closed: nothing to silence
                continue
            os.dup2(sink, fd)
        return importlib.import_module(name)
    finally:
        _flush_c_streams()
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)
        os.close(sink)


pybullet = import_quietly("pybullet")

__all__ = ["import_quietly", "pybullet"]

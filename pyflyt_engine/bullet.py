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
from typing import BinaryIO


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


class CapturedOutput:
    """What C code wrote to descriptors 1 and 2 inside a ``with`` block (:attr:`text`), kept off the terminal.

    PyBullet gives its reasons (``b3Error[...]: expected a robot element``) through C's stdout,
    without a line break, and raises only ``Cannot load URDF file.``: uncaptured, the reason was
    glued to the front of the one-line error that follows.  The caller decides what to show:
    the reason inside its error, or -- when nothing failed -- the text as it was written
    (:meth:`replay`, to stderr), so no warning is hidden."""

    def __init__(self) -> None:
        self.text = ""
        self._saved: list[tuple[int, int]] = []
        self._file: BinaryIO | None = None

    def __enter__(self) -> CapturedOutput:
        import tempfile

        for stream in (sys.stdout, sys.stderr):
            if stream is not None:
                stream.flush()
        _flush_c_streams()
        try:
            self._file = tempfile.TemporaryFile()
        except OSError:  # no temporary file: capture nothing
            return self
        for fd in (1, 2):
            try:
                self._saved.append((fd, os.dup(fd)))
            except OSError:  # this descriptor is closed: nothing to capture
                continue
            os.dup2(self._file.fileno(), fd)
        return self

    def __exit__(self, *exc: object) -> None:
        _flush_c_streams()
        for fd, copy in self._saved:
            os.dup2(copy, fd)
            os.close(copy)
        self._saved = []
        if self._file is not None:
            self._file.seek(0)
            self.text = self._file.read(1 << 16).decode("utf-8", "replace")
            self._file.close()
            self._file = None

    def reason(self) -> str:
        """The captured text's last non-empty line (PyBullet's reason), or ``""``."""
        lines = [line.strip() for line in self.text.splitlines() if line.strip()]
        return lines[-1] if lines else ""

    def replay(self) -> None:
        """Write the captured text to stderr as it came, ending its last line."""
        if self.text and sys.stderr is not None:
            sys.stderr.write(self.text if self.text.endswith("\n") else self.text + "\n")
            sys.stderr.flush()


pybullet = import_quietly("pybullet")

__all__ = ["CapturedOutput", "import_quietly", "pybullet"]

"""The error the learning library raises for a request it cannot carry out as given.

An unknown experiment, an override that cannot be applied, an output file that would
overwrite something: the message names what is wrong and how to fix it.  It is a
:class:`~pyflyt_engine.errors.PyFlytError`, like the engine's own errors, so a caller
catches both with one ``except``; the ``pyflyt`` command prints either without a
traceback and exits with code 2.
"""

from __future__ import annotations

from pyflyt_engine.errors import PyFlytError


class UsageError(PyFlytError):
    """A request the library cannot carry out as given; the message says what to change."""


__all__ = ["UsageError"]

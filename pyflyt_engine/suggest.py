"""The one "did you mean" of every name a user types: config keys, group choices (``env=``,
``algo=``), task, reward, mode and randomisation names, zoo agents, oracles, run
directories, the keys of ``pyflyt eval``/``replay``/``plot``/``export``/``benchmark``.

A name that differs from an option only in case is that option (``SAC`` -> ``sac``);
otherwise the closest option by :func:`difflib.get_close_matches` (its ratio of matching
characters, cutoff 0.6), compared case-folded.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from pathlib import Path


def closest(name: object, options: Iterable[object]) -> str | None:
    """The option ``name`` most likely meant, or None when none is close (or ``name`` is one)."""
    choices = [str(o) for o in options]
    text = str(name)
    if text in choices:
        return None
    folded = text.casefold()
    same = [c for c in choices if c.casefold() == folded and c != text]
    if same:
        return same[0]
    by_fold: dict[str, str] = {}
    for c in choices:
        by_fold.setdefault(c.casefold(), c)
    close = difflib.get_close_matches(folded, list(by_fold), n=1)
    return by_fold[close[0]] if close else None


#: how many entries of a folder :func:`nearest_path` compares a missing name with
NEAREST_SCAN = 10_000


def nearest_path(path: Path, dirs_only: bool = False) -> tuple[Path, Path | None]:
    """For a missing ``path``: (the first existing folder above it, its entry closest to the
    missing part's name or None).  Looks at that one folder only (at most
    :data:`NEAREST_SCAN` entries); links are not followed.  ``dirs_only``: folders only."""
    import itertools

    missing, parent = path.name, path.parent
    while not parent.is_dir() and parent != parent.parent:
        missing, parent = parent.name, parent.parent
    try:
        entries = [
            e.name
            for e in itertools.islice(parent.iterdir(), NEAREST_SCAN)
            if not e.is_symlink() and (e.is_dir() or not dirs_only)
        ]
    except OSError:
        return parent, None
    meant = closest(missing, entries)
    return parent, (parent / meant if meant is not None else None)


def did_you_mean_path(path: Path, dirs_only: bool = False) -> str:
    """``" Did you mean '<path>'?"`` for a missing ``path`` (:func:`nearest_path`), or ``""``."""
    meant = nearest_path(path, dirs_only)[1]
    return f" Did you mean '{meant}'?" if meant is not None else ""


def did_you_mean(name: object, options: Iterable[object]) -> str:
    """``" Did you mean 'x'?"`` for the closest option (:func:`closest`), or ``""``."""
    meant = closest(name, options)
    return f" Did you mean '{meant}'?" if meant is not None else ""

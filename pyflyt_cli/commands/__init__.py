"""The ``pyflyt`` commands: each parses its arguments, calls one library function and prints.

Nothing in the libraries imports this package or :mod:`pyflyt_cli.main`.
"""

from __future__ import annotations

from collections.abc import Sequence

from pyflyt_cli.errors import UsageError


def parse_overrides(overrides: Sequence[str] | None) -> list[str]:
    """Overrides as given; rejects bare words that are not key=value."""
    result = []
    for item in overrides or []:
        if "=" not in item and not item.startswith("~"):
            raise UsageError(f"'{item}' is not an override: write key=value (e.g. duration=5)")
        result.append(item)
    return result

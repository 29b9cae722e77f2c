"""``python -m pyflyt_cli.commands.env_manuals DOC.md``: regenerate the env manuals embedded in a document.

The manuals are :func:`pyflyt_engine.envs.manual.manuals_markdown` (what ``pyflyt envs <id>``
prints for each registered env), between the markers of :mod:`pyflyt_engine.envs.manual`.
"""

from __future__ import annotations

import sys
from pathlib import Path

from pyflyt_engine.envs.manual import replace_embedded_manuals


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m pyflyt_cli.commands.env_manuals docs/environments.md", file=sys.stderr)
        return 2
    path = Path(args[0])
    text = path.read_text()
    try:
        updated = replace_embedded_manuals(text)
    except ValueError as exc:  # no markers: nothing to regenerate in this document
        print(f"error: {path}: {exc}", file=sys.stderr)
        return 2
    if updated != text:
        path.write_text(updated)
        print(f"updated the env manuals in {path}")
    else:
        print(f"{path} is up to date")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())

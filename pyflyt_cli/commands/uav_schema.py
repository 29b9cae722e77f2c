"""``python -m pyflyt_cli.commands.uav_schema DOC.md``: regenerate the UAV field reference embedded in a document.

The reference is :func:`pyflyt_cli.airframes.schema.schema_markdown` (what ``pyflyt uav
schema`` prints), between the markers of :mod:`pyflyt_cli.airframes.schema`.
"""

from __future__ import annotations

import sys
from pathlib import Path

from pyflyt_cli.airframes.schema import replace_embedded_schema


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m pyflyt_cli.commands.uav_schema docs/uav_authoring.md", file=sys.stderr)
        return 2
    path = Path(args[0])
    text = path.read_text()
    updated = replace_embedded_schema(text)
    if updated != text:
        path.write_text(updated)
        print(f"updated the UAV field reference in {path}")
    else:
        print(f"{path} is up to date")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())

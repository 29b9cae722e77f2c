"""``python -m pyflyt_cli.commands.uav_schema DOC.md``: regenerate the UAV field reference embedded in a document.

The reference is :func:`pyflyt_cli.airframes.schema.schema_markdown` (what ``pyflyt uav
schema`` prints), between the markers of :mod:`pyflyt_cli.airframes.schema`
(:func:`pyflyt_cli.commands.embedded.regenerate`).
"""

from __future__ import annotations

from pyflyt_cli.airframes.schema import replace_embedded_schema
from pyflyt_cli.commands.embedded import regenerate


def main(argv: list[str] | None = None) -> int:
    return regenerate(
        argv,
        command="pyflyt_cli.commands.uav_schema",
        example="docs/uav_authoring.md",
        what="the UAV field reference",
        replace=replace_embedded_schema,
    )


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())

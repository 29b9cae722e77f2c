"""``python -m pyflyt_cli.commands.env_manuals DOC.md``: regenerate the env manuals embedded in a document.

The manuals are :func:`pyflyt_engine.envs.manual.manuals_markdown` (what ``pyflyt envs <id>``
prints for each registered env), between the markers of :mod:`pyflyt_engine.envs.manual`
(:func:`pyflyt_cli.commands.embedded.regenerate`).
"""

from __future__ import annotations

from pyflyt_cli.commands.embedded import regenerate
from pyflyt_engine.envs.manual import replace_embedded_manuals


def main(argv: list[str] | None = None) -> int:
    return regenerate(
        argv,
        command="pyflyt_cli.commands.env_manuals",
        example="docs/environments.md",
        what="the env manuals",
        replace=replace_embedded_manuals,
    )


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())

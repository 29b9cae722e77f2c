"""The one ``python -m pyflyt_cli.commands.<name> DOC.md`` of every generated section of the docs.

A section generated from the code (the UAV field reference, the env manuals) sits between two
markers in its document; its command rewrites what is between them and says whether anything
changed.  A wrong number of arguments, or a document without the markers, is one line on
stderr and exit code 2; the document is left as it was.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path


def regenerate(argv: list[str] | None, *, command: str, example: str, what: str, replace: Callable[[str], str]) -> int:
    """Rewrite the section ``replace`` regenerates in the document ``argv`` names.

    Args:
        argv: the arguments (None: ``sys.argv[1:]``): one document path.
        command: the module, for the usage line (``pyflyt_cli.commands.uav_schema``).
        example: the document the usage line shows (``docs/uav_authoring.md``).
        what: the section, for the report (``the UAV field reference``).
        replace: the document's text -> the text with the section regenerated (ValueError: no markers).
    """
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print(f"usage: python -m {command} {example}", file=sys.stderr)
        return 2
    path = Path(args[0])
    text = path.read_text()
    try:
        updated = replace(text)
    except ValueError as exc:  # no markers: nothing to regenerate in this document
        print(f"error: {path}: {exc}", file=sys.stderr)
        return 2
    if updated != text:
        path.write_text(updated)
        print(f"updated {what} in {path}")
    else:
        print(f"{path} is up to date")
    return 0

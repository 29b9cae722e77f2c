"""``pyflyt speed``: measure (:func:`pyflyt_cli.speed.run_speed`), optionally save the JSON, print the tables."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

from pyflyt_cli.outputs import atomic_output, make_output_dir
from pyflyt_cli.speed import format_report, run_speed, speed_settings


def speed_command(
    repeats: int = 5,
    quick: bool = False,
    vector: bool = False,
    markdown: bool = False,
    envs: Sequence[str] | None = None,
    vehicles: str | None = None,
    agents: str | None = None,
    json_path: Path | None = None,
    progress: Callable[[str], None] | None = None,
    backend: str = "pybullet",
    batch_sizes: str | None = None,
) -> str:
    """What ``pyflyt speed`` does: measure, optionally save the JSON, return the printed report."""
    settings = speed_settings(
        repeats=repeats,
        quick=quick,
        vector=vector,
        envs=envs,
        vehicles=vehicles,
        agents=agents,
        backend=backend,
        batch_sizes=batch_sizes,
    )
    report = run_speed(settings, progress=progress)
    if json_path is not None:
        make_output_dir(json_path.parent, "--json")
        with atomic_output(json_path, "--json") as tmp:
            tmp.write_text(json.dumps(report, indent=2))
    return format_report(report, markdown=markdown)

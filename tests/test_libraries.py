"""The libraries behind the commands stand on their own.

Every module of the libraries imports in a fresh interpreter without pulling in Typer
(only ``pyflyt_cli.main`` and ``pyflyt_cli.commands`` know the command line exists), and
the product never drives or names the reference PyFlyt package: comparisons with it
live in ``experiments/``.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIBRARIES = (
    "pyflyt_cli.training",
    "pyflyt_cli.benchmark",
    "pyflyt_cli.plotting",
    "pyflyt_cli.airframes",
    "pyflyt_cli.speed",
    "pyflyt_cli.zoo",
    "pyflyt_cli.export",
    "pyflyt_cli.catalog",
    "pyflyt_cli.compose",
    "pyflyt_cli.errors",
    "pyflyt_cli.outputs",
)

IMPORT_ALL = """
import importlib, pkgutil, sys
imported = []
for name in sys.argv[1:]:
    package = importlib.import_module(name)
    imported.append(name)
    for info in pkgutil.walk_packages(getattr(package, "__path__", []), name + "."):
        importlib.import_module(info.name)
        imported.append(info.name)
print(len(imported), sorted(m for m in sys.modules if m.split(".")[0] == "typer"))
"""


def test_every_library_module_imports_without_typer():
    done = subprocess.run(
        [sys.executable, "-c", IMPORT_ALL, *LIBRARIES], capture_output=True, text=True, cwd=ROOT, check=False
    )
    assert done.returncode == 0, done.stderr
    count, typer_modules = done.stdout.strip().splitlines()[-1].split(" ", 1)
    assert int(count) >= 30  # the packages' modules were walked, not just their __init__
    assert typer_modules == "[]", f"a library module imports Typer: {typer_modules}"


def test_the_product_never_drives_the_reference_package():
    pattern = re.compile(r"^\s*(import|from)\s+PyFlyt\b|reference[_-]python|pyflyt==0\.29", re.MULTILINE)
    found = [
        str(path.relative_to(ROOT))
        for path in sorted((ROOT / "pyflyt_cli").rglob("*.py"))
        if pattern.search(path.read_text())
    ]
    assert found == []

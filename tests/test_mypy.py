"""The packages type-check: mypy passes on the files ``[tool.mypy]`` in pyproject.toml names.

The annotations are only worth reading if they are true: unchecked, they drifted (a value that
may be None used unchecked, a list passed where an array was declared).  mypy is pinned in the
``test`` extra, as ruff is (tests/test_lint.py).  A run from scratch takes a minute or two on a
2-core machine, so that test is marked ``long`` (CI runs it after the default suite); by hand,
``mypy`` from the repository root runs the same check.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: tomli, a dependency of mypy there
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]


def _checked_files() -> list[str]:
    """The source files mypy checks: those under ``files``, less those ``exclude`` matches."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]
    excluded = [re.compile(pattern) for pattern in config.get("exclude", [])]
    found = []
    for name in config.get("files", []):
        for path in sorted((ROOT / name).rglob("*.py")):
            relative = path.relative_to(ROOT).as_posix()
            if not any(pattern.search(relative) for pattern in excluded):
                found.append(relative)
    return found


def test_the_mypy_config_names_source_files():
    files = _checked_files()
    assert files, "[tool.mypy] names no file to check (files empty, or exclude matches every one)"
    assert {"pyflyt_engine/world.py", "pyflyt_cli/main.py"} <= set(files)
    # every package is checked: none left out by exclude, none of the project's silenced by an override
    assert {"pyflyt_engine/batched/env.py", "pyflyt_cli/training/loop.py"} <= set(files)
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]
    silenced = [o["module"] for o in config.get("overrides", []) if o.get("ignore_errors")]
    assert not silenced, f"[tool.mypy] overrides silence the errors of {silenced}"


@pytest.mark.long
def test_the_packages_pass_mypy():
    # the mypy of this interpreter's environment: without it this fails (No module named mypy),
    # it does not skip; no arguments, so mypy takes files, exclude and overrides from pyproject.toml
    done = subprocess.run([sys.executable, "-m", "mypy"], capture_output=True, text=True, cwd=ROOT)
    output = done.stdout + done.stderr
    assert done.returncode == 0, f"mypy found errors (exit {done.returncode}):\n{output}"
    # a run that checked nothing would pass too: it must have read every configured file
    checked = re.search(r"no issues found in (\d+) source files?", output)
    assert checked is not None, output
    assert int(checked.group(1)) == len(_checked_files()), output

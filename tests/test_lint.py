"""The tree passes ruff's pyflakes and syntax checks (``[tool.ruff.lint]`` in pyproject.toml) and is
formatted as ``ruff format`` formats it (``[tool.ruff.format]``).

These find bugs rather than style: a test function defined twice in one module silently replaced
the first (F811), an import left unused hides a missing dependency, a name used but never defined
fails only on the path that reaches it.  ruff is pinned in the ``test`` extra.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_tree_passes_the_lint_rules():
    ruff = shutil.which("ruff") or str(Path(sys.executable).with_name("ruff"))
    done = subprocess.run(
        [ruff, "check", "--no-cache", "--output-format", "concise", str(ROOT)], capture_output=True, text=True, cwd=ROOT
    )
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_tree_is_formatted():
    """``ruff format --check``: every Python file as the formatter writes it (run ``ruff format .``)."""
    ruff = shutil.which("ruff") or str(Path(sys.executable).with_name("ruff"))
    done = subprocess.run(
        [ruff, "format", "--check", "--no-cache", str(ROOT)], capture_output=True, text=True, cwd=ROOT
    )
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr

"""``experiments/architecture_counts.py`` reads the tree as the closing measurements quote it: the
library has no import cycle between modules and replaces no method at run time, and the script's
parser finds what it is shown (an import cycle, a method-assign suppression) when there is one."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _script():
    spec = importlib.util.spec_from_file_location(
        "architecture_counts", ROOT / "experiments" / "architecture_counts.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_library_has_no_module_cycle_and_no_method_replaced_at_run_time():
    text = _script().report(None)
    assert "cycles among modules: none" in text
    assert "method-assign suppressions: 0" in text
    # the configs no longer import the multi-agent package (the upward arrow the task registry removed)
    arrows = [line for line in text.splitlines() if line.startswith("  pyflyt_engine.envs -> ")]
    assert arrows and "pyflyt_engine.envs.multi_agent" not in arrows[0]


def test_the_parser_sees_a_cycle_and_a_lazy_import_apart(monkeypatch):
    script = _script()
    files = {
        "pyflyt_engine/__init__.py": "",
        "pyflyt_engine/a.py": "from pyflyt_engine import b\n",
        "pyflyt_engine/b.py": "import pyflyt_engine.a\nx = 1  # type: ignore[method-assign]\n",
        "pyflyt_engine/c.py": "def f():\n    from pyflyt_engine import a\n",
    }
    monkeypatch.setattr(script, "sources", lambda rev: files)
    text = script.report("synthetic")
    assert "cycles among modules: pyflyt_engine.a <-> pyflyt_engine.b" in text
    assert "method-assign suppressions: 1" in text
    # c imports a only inside a function: fan-out counts it, the import graph does not
    assert "   1  pyflyt_engine.c" in text

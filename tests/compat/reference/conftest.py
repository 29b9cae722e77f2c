"""Runs the reference PyFlyt's own test files (0.29.0) against ``pyflyt_engine.compat``.

The files here are the upstream ones with the import prefix rewritten.  A few cases
cannot run here; they are deselected (listed in the run's summary, never skipped
silently), each for the reason given in :data:`DESELECTED` and in
docs/migrating_from_pyflyt.md.  The upstream cases take minutes, so they are marked
``slow``: run them with ``pytest tests/compat/reference -m slow``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
# upstream test_core.py imports ``custom_uavs.rocket_brick`` from beside itself
sys.path.insert(0, str(HERE))

#: (test file, test name or name prefix) -> why it cannot run against the compat layer
DESELECTED: dict[tuple[str, str], str] = {
    ("test_gym_envs.py", "test_render[human-"): "render_mode='human' opens a PyBullet GUI window: needs a display",
    ("test_core.py", "test_custom_uav"): (
        "custom Python drone classes (drone_type_mappings) are refused by design: "
        "author a YAML airframe instead (docs/uav_authoring.md)"
    ),
}


def _reason(item) -> str | None:
    name = Path(str(item.fspath)).name
    for (file, prefix), reason in DESELECTED.items():
        if name == file and item.name.startswith(prefix):
            return reason
    return None


@pytest.hookimpl(tryfirst=True)  # before `-m` selects by marker
def pytest_collection_modifyitems(config, items):
    keep, dropped = [], []
    for item in items:
        if HERE not in Path(str(item.fspath)).resolve().parents:  # a hook of this conftest sees every item
            keep.append(item)
            continue
        # the upstream files run every env for hundreds of steps: minutes, so `-m slow`
        item.add_marker(pytest.mark.slow)
        reason = _reason(item)
        if reason is None:
            keep.append(item)
        else:
            dropped.append(item)
            config._compat_deselected = getattr(config, "_compat_deselected", {})
            config._compat_deselected.setdefault(reason, []).append(item.nodeid)
    if dropped:
        config.hook.pytest_deselected(items=dropped)
        items[:] = keep


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    deselected = getattr(config, "_compat_deselected", {})
    if deselected:
        terminalreporter.section("reference cases deselected (pyflyt_engine.compat)")
        for reason, ids in deselected.items():
            terminalreporter.write_line(f"{len(ids)} deselected: {reason}")

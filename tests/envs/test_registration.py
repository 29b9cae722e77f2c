"""Importing pyflyt_engine registers the ids cheaply (no PyBullet, no env modules)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from pyflyt_engine.envs import ENVS

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """
import sys
import pyflyt_engine
import gymnasium
heavy = [m for m in ("pybullet", "pyflyt_engine.world", "pyflyt_engine.envs.env", "pydantic") if m in sys.modules]
print(sorted(i for i in gymnasium.registry if i.startswith("PyFlyt/")), heavy)
"""


def test_import_registers_every_id_without_heavy_imports():
    result = subprocess.run(
        [sys.executable, "-c", SCRIPT],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        check=True,
    )
    assert result.stdout.strip() == f"{sorted(ENVS)} []"


def test_entry_points_resolve_to_classes_bound_to_their_configs():
    import importlib

    import gymnasium

    for env_id, entry in ENVS.items():
        spec = gymnasium.spec(env_id)
        assert spec.entry_point == entry.entry_point and spec.max_episode_steps is None  # the env truncates itself
        module, _, name = entry.entry_point.partition(":")
        cls = getattr(importlib.import_module(module), name)
        assert cls.config_name == entry.config
        assert env_id in cls.__doc__ and "Version history" in cls.__doc__


def test_every_registered_class_is_a_lazy_export_of_the_package():
    """``ENVS`` alone names the registered classes: the package's lazy exports and ``__all__`` follow it."""
    import pyflyt_engine.envs as envs

    for entry in ENVS.values():
        module, _, name = entry.entry_point.partition(":")
        assert name in envs.__all__ and getattr(envs, name).__module__ == module
    assert len(envs.__all__) == len(set(envs.__all__)) == 11 + len(ENVS)


def test_quadx_gates_has_its_own_module_and_keeps_its_old_import_path():
    from pyflyt_engine.envs.quadx_gates import QuadXGatesEnv
    from pyflyt_engine.envs.quadx_payloads import QuadXGatesEnv as Old

    assert (
        Old is QuadXGatesEnv
        and ENVS["PyFlyt/QuadX-Gates-v0"].entry_point == "pyflyt_engine.envs.quadx_gates:QuadXGatesEnv"
    )

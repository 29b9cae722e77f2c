"""The wheel: a non-editable install in a fresh virtual environment finds conf/ and runs.

Dependencies are borrowed from the running environment through a .pth file, so the test
needs no network; the project itself comes only from the built wheel.
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(args, cwd, env=None):
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, env=env, timeout=600)


def test_wheel_installs_and_runs_from_another_directory(tmp_path):
    pytest.importorskip("hatchling", reason="building the wheel needs hatchling (pip install hatchling)")
    wheel_dir = tmp_path / "wheel"
    built = _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-w", str(wheel_dir), str(ROOT)], cwd=tmp_path)
    assert built.returncode == 0, built.stderr
    wheel = next(wheel_dir.glob("*.whl"))

    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    python = env_dir / "bin" / "python"
    installed = _run([str(python), "-m", "pip", "install", "--no-deps", "--no-index", str(wheel)], cwd=tmp_path)
    assert installed.returncode == 0, installed.stderr
    # borrow the dependencies only now, so pip could not mistake an installed copy of
    # the project in the running environment for this one; the venv's own
    # site-packages comes first on sys.path, so its copy of the project wins
    site = _run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], cwd=tmp_path).stdout.strip()
    Path(site, "borrowed_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    where = _run([str(python), "-c", "import pyflyt_engine, pyflyt_cli; from pyflyt_engine.paths import conf_dir; "
                  "print(pyflyt_engine.__file__); print(conf_dir())"], cwd=elsewhere, env=env)
    assert where.returncode == 0, where.stderr
    module_file, conf = where.stdout.strip().splitlines()[-2:]
    assert module_file.startswith(str(env_dir)), module_file
    assert conf.startswith(str(env_dir)) and Path(conf, "uav", "quadx_cf2x.yaml").is_file()

    flown = _run([str(env_dir / "bin" / "pyflyt"), "fly", "duration=1", "rows=2"], cwd=elsewhere, env=env)
    assert flown.returncode == 0, flown.stderr
    assert "final position" in flown.stdout
    bad = _run([str(env_dir / "bin" / "pyflyt"), "fly", "uav=nope"], cwd=elsewhere, env=env)
    assert bad.returncode == 2 and "unknown uav 'nope'" in bad.stderr

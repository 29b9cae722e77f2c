"""`pyflyt train` and `pyflyt eval` from a non-editable install, in an empty directory.

The wheel is built from the checkout and installed into a fresh virtual environment;
dependencies are borrowed from the running environment through a .pth file written
*after* the wheel is installed (as tests/test_packaging.py does), so no network is needed
and the project itself comes only from the wheel.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

from .conftest import ROOT


def _run(args, cwd, env=None, timeout=600):
    return subprocess.run(args, check=False, cwd=cwd, capture_output=True, text=True, env=env, timeout=timeout)


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(pyflyt executable, environment) of a fresh venv holding only the built wheel."""
    pytest.importorskip("hatchling", reason="building the wheel needs hatchling (pip install hatchling)")
    tmp = tmp_path_factory.mktemp("install")
    wheel_dir = tmp / "wheel"
    built = _run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-w", str(wheel_dir), str(ROOT)],
        tmp,
    )
    assert built.returncode == 0, built.stderr
    wheel = next(wheel_dir.glob("*.whl"))
    env_dir = tmp / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    python = env_dir / "bin" / "python"
    done = _run([str(python), "-m", "pip", "install", "--no-deps", "--no-index", str(wheel)], tmp)
    assert done.returncode == 0, done.stderr
    site = _run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], tmp).stdout.strip()
    Path(site, "borrowed_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return env_dir / "bin" / "pyflyt", env


@pytest.mark.slow  # a whole sweep / install: run with -m slow
def test_train_and_eval_from_the_wheel_in_an_empty_directory(installed, tmp_path):
    pyflyt, env = installed
    work = tmp_path / "empty"
    work.mkdir()
    trained = _run(
        [
            str(pyflyt),
            "train",
            "env=quadx_hover",
            "algo=ppo",
            "train.total_timesteps=1024",
            "train.n_envs=2",  # 2 x 256 steps per rollout: ends at exactly 1024
            "algo.n_steps=256",
            "train.eval_freq=512",
            "train.eval_episodes=2",
            "train.checkpoint_freq=512",
        ],
        work,
        env,
    )
    assert trained.returncode == 0, trained.stderr
    assert "Traceback" not in trained.stderr and "done: 1024 steps" in trained.stderr
    runs = list((work / "runs" / "quadx_hover" / "ppo").iterdir())
    assert len(runs) == 1
    run = runs[0]
    for name in ("config.yaml", "run.yaml", "state.json", "model.pt", "best_model.pt", "metrics.mcap"):
        assert (run / name).is_file(), name
    assert (run / "checkpoints" / "model_1024_steps.pt").is_file()
    assert json.loads((run / "state.json").read_text())["status"] == "complete"
    assert sorted(p.name for p in work.iterdir()) == ["runs"]  # no outputs/ or .hydra from Hydra
    # the installed package, not the checkout, ran
    import yaml

    assert yaml.safe_load((run / "run.yaml").read_text())["versions"]["pyflyt-toolkit"] == "0.1.0"

    evaluated = _run([str(pyflyt), "eval", str(run), "episodes=2"], work, env)
    assert evaluated.returncode == 0, evaluated.stderr
    assert "return" in evaluated.stdout and "±" in evaluated.stdout and "success rate" in evaluated.stdout
    assert len(list((run / "episodes").glob("ep_*.mcap"))) == 2

    missing = _run([str(pyflyt), "eval", str(work / "nope")], work, env)
    assert missing.returncode == 2 and "does not exist" in missing.stderr and "Traceback" not in missing.stderr

"""The wheel: a non-editable install in a fresh virtual environment finds conf/ and runs;
the simulator runs without the learning stack and installs without it.

The first test borrows its dependencies from the running environment through a .pth
file, so it needs no network; the project itself comes only from the built wheel.  The
simulator's own tests block the learning stack's modules in a fresh interpreter, and a
slow test installs the wheel with its core dependencies from the package index into a
fresh virtual environment, without torch, Stable-Baselines3, Hydra or Typer.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(args, cwd, env=None):
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, env=env, timeout=600)


@pytest.mark.long
def test_wheel_installs_and_runs_from_another_directory(tmp_path):
    pytest.importorskip("hatchling", reason="building the wheel needs hatchling (pip install hatchling)")
    wheel_dir = tmp_path / "wheel"
    built = _run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-w", str(wheel_dir), str(ROOT)],
        cwd=tmp_path,
    )
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
    site = _run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], cwd=tmp_path
    ).stdout.strip()
    Path(site, "borrowed_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    where = _run(
        [
            str(python),
            "-c",
            "import pyflyt_engine, pyflyt_cli; from pyflyt_engine.paths import conf_dir; "
            "print(pyflyt_engine.__file__); print(conf_dir())",
        ],
        cwd=elsewhere,
        env=env,
    )
    assert where.returncode == 0, where.stderr
    module_file, conf = where.stdout.strip().splitlines()[-2:]
    assert module_file.startswith(str(env_dir)), module_file
    assert conf.startswith(str(env_dir)) and Path(conf, "uav", "quadx_cf2x.yaml").is_file()

    flown = _run([str(env_dir / "bin" / "pyflyt"), "fly", "duration=1", "rows=2"], cwd=elsewhere, env=env)
    assert flown.returncode == 0, flown.stderr
    assert "final position" in flown.stdout
    bad = _run([str(env_dir / "bin" / "pyflyt"), "fly", "uav=nope"], cwd=elsewhere, env=env)
    assert bad.returncode == 2 and "unknown uav 'nope'" in bad.stderr


#: what the simulator never needs: the learning library's stack, the command's, and the
#: figures and videos of [plots]
LEARNING_STACK = (
    "torch", "stable_baselines3", "sb3_contrib", "hydra", "omegaconf", "typer", "optuna",
    "rliable", "pandas", "tqdm", "matplotlib", "imageio", "imageio_ffmpeg", "supersuit",
)  # fmt: skip

#: the README's first flight without the learning stack: every import of one of BLOCKED
#: fails as if it were not installed (a meta-path finder raising ImportError), then the
#: env is made, reset, stepped and recorded to MCAP, and the recording read back
SIMULATOR_ONLY = """
import importlib.abc, sys
BLOCKED = set(sys.argv[1].split(","))

class Missing(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError(f"No module named {name!r} (blocked: not part of the simulator)", name=name)
        return None

sys.meta_path.insert(0, Missing())

import gymnasium
import pyflyt_engine
from pyflyt_engine.telemetry import RecordEpisode, load_episode

env = RecordEpisode(gymnasium.make("PyFlyt/QuadX-Hover-v0"), sys.argv[2])
for seed in (0, 1):
    env.reset(seed=seed)
    for _ in range(60):
        *_, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            break
env.close()
episode = load_episode(sys.argv[2] + "/ep_0000.mcap")
print("steps", len(episode.actions))
print("loaded", sorted({m.split(".")[0] for m in sys.modules} & BLOCKED))
"""


def test_the_simulator_runs_records_and_replays_without_the_learning_stack(tmp_path):
    done = _run([sys.executable, "-c", SIMULATOR_ONLY, ",".join(LEARNING_STACK), str(tmp_path / "episodes")], ROOT)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = done.stdout.strip().splitlines()
    assert int(lines[-2].split()[1]) > 0 and lines[-1] == "loaded []"
    assert (tmp_path / "episodes" / "ep_0001.mcap").is_file()


def test_importing_the_engine_imports_no_learning_stack():
    done = _run([sys.executable, "-X", "importtime", "-c", "import pyflyt_engine, pyflyt_engine.envs"], ROOT)
    assert done.returncode == 0, done.stderr[-3000:]
    # importtime lines: "import time: <self us> | <cumulative us> | <indented module name>"
    imported = {m.group(1).split(".")[0] for m in re.finditer(r"\|\s+([\w.]+)\s*$", done.stderr, re.MULTILINE)}
    assert "pyflyt_engine" in imported
    assert sorted(imported & set(LEARNING_STACK)) == []


@pytest.mark.slow  # downloads the core dependencies from the package index: run with -m slow
def test_the_wheel_installs_the_simulator_alone_from_the_index(tmp_path):
    """``pip install <wheel>``: the core dependencies only, and the first flight runs."""
    pytest.importorskip("hatchling", reason="building the wheel needs hatchling (pip install hatchling)")
    wheel_dir = tmp_path / "wheel"
    built = _run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-w", str(wheel_dir), str(ROOT)],
        cwd=tmp_path,
    )
    assert built.returncode == 0, built.stderr
    wheel = next(wheel_dir.glob("*.whl"))
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    python = str(env_dir / "bin" / "python")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    installed = _run([python, "-m", "pip", "install", str(wheel)], cwd=tmp_path, env=env)
    assert installed.returncode == 0, installed.stderr[-3000:]
    listed = _run([python, "-m", "pip", "list", "--format=freeze"], cwd=tmp_path, env=env).stdout.lower()
    names = {line.split("==")[0].replace("-", "_") for line in listed.splitlines()}
    assert "pyflyt_toolkit" in names
    assert sorted(names & {n.lower() for n in LEARNING_STACK} | names & {"stable_baselines3", "hydra_core"}) == []
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    flown = _run(
        [python, "-c", SIMULATOR_ONLY, ",".join(LEARNING_STACK), str(tmp_path / "episodes")], elsewhere, env=env
    )
    assert flown.returncode == 0, flown.stderr[-3000:]
    assert flown.stdout.strip().splitlines()[-1] == "loaded []"
    # the command names the extra it needs instead of a traceback
    command = _run([str(env_dir / "bin" / "pyflyt"), "fly"], elsewhere, env=env)
    assert command.returncode != 0 and "pip install 'pyflyt-toolkit[cli]'" in command.stderr
    assert "Traceback" not in command.stderr

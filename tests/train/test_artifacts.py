"""Run files are data: loading a run never executes code from it; broken files give one clear message.

The attack files are built the way an attacker would: SB3's ``model.zip`` keeps
cloudpickled entries in its JSON (``:serialized:``), a ``vecnormalize.pkl`` is a pickle,
and a ``.pt`` file can hold pickled objects besides tensors.  Each payload would create a
marker file when unpickled; the tests check the marker never appears.
"""

from __future__ import annotations

import base64
import builtins
import json
import pickle
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_cli.training import evaluate_run, train
from pyflyt_cli.training.artifacts import (
    ArtifactError,
    load_replay_buffer,
    normalizer_state,
    observation_normalizer,
    read_payload,
)
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.telemetry import read_metrics

from .conftest import TINY_AWAC, TINY_PPO, load


class Payload:
    """Unpickling this creates ``path``: proof that code from the file ran."""

    def __init__(self, path: Path) -> None:
        self.path = str(path)

    def __reduce__(self):
        return (builtins.open, (self.path, "w"))


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    """A finished tiny PPO run (observation and reward normalisation on)."""
    return train(load(TINY_PPO, tmp_path_factory.mktemp("runs"))).run_dir


@pytest.fixture
def run(trained, tmp_path) -> Path:
    """A private copy of the trained run, free to tamper with."""
    copy = tmp_path / "run"
    shutil.copytree(trained, copy)
    return copy


def _cli(*args: str):
    return CliRunner().invoke(app, list(args))


def _sb3_zip_with_payload(run: Path, marker: Path) -> Path:
    """An SB3 model.zip (as older versions wrote) whose JSON carries a pickled payload."""
    from stable_baselines3 import PPO

    model = PPO("MlpPolicy", "Pendulum-v1", n_steps=64, batch_size=64, device="cpu")
    path = run / "model.zip"
    model.save(path)
    with zipfile.ZipFile(path) as archive:
        files = {name: archive.read(name) for name in archive.namelist()}
    data = json.loads(files["data"])
    data["observation_space"][":serialized:"] = base64.b64encode(pickle.dumps(Payload(marker))).decode()
    files["data"] = json.dumps(data).encode()
    with zipfile.ZipFile(path, "w") as archive:
        for name, content in files.items():
            archive.writestr(name, content)
    return path


def test_the_final_model_evaluates_to_the_returns_training_logged(trained):
    """The policy rebuilt from config.yaml + tensors is the trained policy: same seeds, same returns."""
    last = read_metrics(trained)["/eval"][-1]
    report = evaluate_run(trained, {"episodes": 2, "model": "final", "record": False})
    assert report.summary["mean_return"] == last["mean_return"]


def test_a_pickled_model_zip_is_never_unpickled_by_eval_or_init_from(run, tmp_path):
    marker = tmp_path / "ran"
    (run / "model.pt").unlink()
    (run / "best_model.pt").unlink()
    shutil.rmtree(run / "checkpoints")
    _sb3_zip_with_payload(run, marker)
    (run / "vecnormalize.pkl").write_bytes(pickle.dumps(Payload(marker)))

    result = _cli("eval", str(run), "episodes=1", "record=false")
    assert result.exit_code == 2 and "trust_pickle=true" in result.output and "older version" in result.output
    with pytest.raises(ConfigError, match="trust_pickle=true"):
        train(load([*TINY_PPO, f"init_from={run}"], tmp_path / "runs"))
    with pytest.raises(ConfigError, match="trust_pickle=true"):
        train(load([*TINY_PPO, f"init_from={run / 'model.zip'}"], tmp_path / "runs"))
    assert not marker.exists()


def test_a_pt_file_holding_pickled_objects_is_refused_without_running_them(run, tmp_path):
    marker = tmp_path / "ran"
    data = torch.load(run / "model.pt", weights_only=True)
    torch.save({**data, "extra": Payload(marker)}, run / "model.pt")
    result = _cli("eval", str(run), "model=final", "episodes=1", "record=false")
    assert result.exit_code == 2 and "refused" in result.output and "model.pt" in result.output
    assert not marker.exists()


@pytest.mark.parametrize("damage", ["truncated", "empty", "not a model"])
def test_a_damaged_model_file_gives_one_clear_message(run, damage):
    path = run / "model.pt"
    content = path.read_bytes()
    path.write_bytes({"truncated": content[: len(content) // 2], "empty": b"", "not a model": b"hello"}[damage])
    result = _cli("eval", str(run), "model=final", "episodes=1")
    assert result.exit_code == 2, result.output
    assert "model.pt" in result.output and "Traceback" not in result.output
    assert not list(run.glob("episodes/*.mcap"))  # nothing recorded for a model that cannot load
    with pytest.raises(ArtifactError, match="not a readable model file"):
        read_payload(path)


def test_legacy_files_load_when_trusted(run, tmp_path):
    """trust_pickle=true is the opt-in for files an older version wrote (and says what it risks)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    from pyflyt_cli.training.envs import EnvFactory
    from pyflyt_cli.training.rundir import load_run_config

    cfg = load_run_config(run)
    vec = VecNormalize(make_vec_env(EnvFactory(cfg.env, monitor=False), 1), norm_obs=True, norm_reward=False)
    model = PPO(
        "MlpPolicy", vec, n_steps=64, batch_size=64, device="cpu", policy_kwargs=cfg.algo.policy_kwargs.kwargs()
    )
    model.learn(64)
    for name in ("model.pt", "best_model.pt"):
        (run / name).unlink()
    shutil.rmtree(run / "checkpoints")
    model.save(run / "model.zip")
    vec.save(run / "vecnormalize.pkl")
    report = evaluate_run(run, {"episodes": 1, "record": False, "trust_pickle": True})
    assert report.model.name == "model.zip" and np.isfinite(report.summary["mean_return"])


def test_the_normaliser_formula_is_sb3s():
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    import gymnasium

    vec = VecNormalize(DummyVecEnv([lambda: gymnasium.make("Pendulum-v1")]), clip_obs=1.5)
    rng = np.random.default_rng(0)
    vec.obs_rms.mean, vec.obs_rms.var = rng.normal(size=3), rng.uniform(0.1, 2, size=3)
    obs = rng.normal(scale=3, size=(5, 3))
    ours = observation_normalizer(normalizer_state(vec))
    assert np.array_equal(ours(obs), vec.normalize_obs(obs))


def test_a_replay_buffer_file_holding_objects_is_refused(tmp_path):
    from stable_baselines3.common.buffers import ReplayBuffer
    import gymnasium

    space = gymnasium.spaces.Box(-1, 1, (2,))
    buffer = ReplayBuffer(10, space, space, device="cpu")
    path = tmp_path / "buffer.npz"
    np.savez(path, observations=np.array([Payload(tmp_path / "ran")], dtype=object), pos=0, full=False, buffer_size=10)
    with pytest.raises(ArtifactError, match="not a readable replay buffer"):
        load_replay_buffer(path, buffer)
    assert not (tmp_path / "ran").exists()


def test_awac_refuses_a_pickled_offline_buffer_from_the_command_line(tmp_path):
    marker = tmp_path / "ran"
    buffer = tmp_path / "buffer.pkl"
    buffer.write_bytes(pickle.dumps(Payload(marker)))
    with pytest.raises(ConfigError, match="trust_pickle"):
        train(load([*TINY_AWAC, f"algo.offline_buffer={buffer}", "algo.offline_steps=5"], tmp_path))
    assert not marker.exists()


def test_a_model_built_directly_logs_into_the_test_folder_not_the_system_temp():
    """tests/conftest.py: SB3's own logger folder of a directly built model is the test's
    temporary folder, not a new ``SB3-<date>`` one in the system's temporary directory."""
    import os
    import tempfile

    from stable_baselines3 import PPO

    model = PPO("MlpPolicy", "Pendulum-v1", n_steps=64, batch_size=64, device="cpu").learn(64)
    folder = Path(model.logger.get_dir())
    assert folder == Path(os.environ["SB3_LOGDIR"]) and folder.is_dir()
    assert folder.parent != Path(tempfile.gettempdir())  # pytest's own base folder, not the system's temp

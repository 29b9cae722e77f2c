"""A checkpoint's trainer state is a schema, not attribute names: restoring sets a fixed list of counters,
each of its type and range, and refuses anything else by name, before training starts.

Written from the reproduction: ``state["counters"]`` of ``checkpoints/model_*.pt`` was applied with
``setattr(model, name, value)`` for every key, so ``n_epochs: 1e9`` or ``num_timesteps: -1e12`` hung a resume
and ``tensorboard_log`` pointed outside made it write there.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import torch

from pyflyt_cli.training import continuity, train

from .conftest import TINY_PPO, load
from .test_shared_runs import cli, interrupted_at_256, refused


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    return train(load(TINY_PPO, tmp_path_factory.mktemp("runs"))).run_dir


@pytest.fixture
def run(trained, tmp_path) -> Path:
    copy = tmp_path / "run"
    shutil.copytree(trained, copy)
    interrupted_at_256(copy)
    return copy


def tamper_state(run: Path, edit) -> None:
    path = run / "checkpoints" / "model_256_steps.pt"
    data = torch.load(path, weights_only=True)
    state = json.loads(data["state"])
    edit(state)
    data["state"] = json.dumps(state)
    torch.save(data, path)


def _set(name, value):
    return lambda state: state["counters"].__setitem__(name, value)


@pytest.mark.parametrize(
    "edit, fragments",
    [
        (_set("n_epochs", 1_000_000_000), ["counter 'n_epochs'", "does not hold"]),
        (_set("tensorboard_log", "/tmp/elsewhere"), ["counter 'tensorboard_log'"]),
        (_set("num_timesteps", -1_000_000_000_000), ["counter num_timesteps is -1000000000000", "[0, 1e+12]"]),
        (_set("_n_updates", 1e30), ["counter _n_updates is 1e+30", "a whole number"]),
        (_set("_episode_num", True), ["counter _episode_num is True"]),
        (_set("_current_progress_remaining", float("nan")), ["_current_progress_remaining is nan"]),
        (_set("_current_progress_remaining", "half"), ["_current_progress_remaining is 'half'"]),
        (lambda state: state["counters"].pop("num_timesteps"), ["lacks the counter 'num_timesteps'"]),
        (lambda state: state.__setitem__("counters", [1, 2]), ["counters are a list"]),
    ],
    ids=["n_epochs", "tensorboard_log", "negative-steps", "huge-updates", "bool", "nan", "text", "missing", "list"],
)
def test_a_crafted_counter_is_refused_by_name_before_training(run, tmp_path, edit, fragments):
    tamper_state(run, edit)
    before = sorted(p.name for p in (run / "checkpoints").iterdir())
    refused(cli("train", f"resume={run}"), *fragments)
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == before  # no checkpoint written
    assert not (tmp_path / "elsewhere").exists()


def test_a_variable_the_model_does_not_save_is_refused(run):
    path = run / "checkpoints" / "model_256_steps.pt"
    data = torch.load(path, weights_only=True)
    data["variables"] = {**data["variables"], "policy.action_net.weight": torch.zeros(4, 64)}
    torch.save(data, path)
    refused(cli("train", f"resume={run}"), "the variable 'policy.action_net.weight'", "does not save")


def test_the_counters_a_checkpoint_writes_pass_the_schema(trained):
    data = torch.load(trained / "checkpoints" / "model_256_steps.pt", weights_only=True)
    counters = json.loads(data["state"])["counters"]

    class PPOLike:
        resume_attributes = ()

    checked = continuity.checked_counters(PPOLike(), counters)
    assert checked == counters and checked["num_timesteps"] == 256
    assert set(continuity.COUNTER_SCHEMA) >= {*continuity.COUNTERS, "offline_steps_done", "oracle_actions"}

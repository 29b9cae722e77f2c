"""A checkpoint's trainer state is a schema, not attribute names: restoring sets a fixed list of counters,
each of its type and range, and refuses anything else by name, before training starts.  Policy files and
checkpoints carry the SHA-256 of their content, checked on load: a damaged copy is refused.

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

from pyflyt_cli.training import artifacts, continuity, train

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


def reseal(data: dict) -> dict:
    """``data`` with its content digest recomputed, as someone crafting a file would do."""
    return {**data, artifacts.DIGEST_KEY: artifacts.content_digest(data)}


def tamper_state(run: Path, edit) -> None:
    path = run / "checkpoints" / "model_256_steps.pt"
    data = torch.load(path, weights_only=True)
    state = json.loads(data["state"])
    edit(state)
    data["state"] = json.dumps(state)
    torch.save(reseal(data), path)


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
    torch.save(reseal(data), path)
    refused(cli("train", f"resume={run}"), "the variable 'policy.action_net.weight'", "does not save")


def test_the_counters_a_checkpoint_writes_pass_the_schema(trained):
    data = torch.load(trained / "checkpoints" / "model_256_steps.pt", weights_only=True)
    counters = json.loads(data["state"])["counters"]

    class PPOLike:
        resume_attributes = ()

    checked = continuity.checked_counters(PPOLike(), counters)
    assert checked == counters and checked["num_timesteps"] == 256
    assert set(continuity.COUNTER_SCHEMA) >= {*continuity.COUNTERS, "offline_steps_done", "oracle_actions"}


# ------------------------------------------------------------------ the content digest


def flip_tensor_byte(path: Path) -> None:
    """Flip one bit in the middle of the largest tensor stored in a torch archive (stored, not compressed)."""
    import struct
    import zipfile

    with zipfile.ZipFile(path) as archive:
        info = max(archive.infolist(), key=lambda i: i.file_size)
    assert info.compress_type == zipfile.ZIP_STORED
    raw = bytearray(path.read_bytes())
    name_length, extra_length = struct.unpack_from("<HH", raw, info.header_offset + 26)
    raw[info.header_offset + 30 + name_length + extra_length + info.file_size // 2] ^= 0x10
    path.write_bytes(bytes(raw))


def test_a_flipped_byte_in_a_model_file_is_refused_not_loaded(run):
    """The reproduction: a flipped byte in best_model.pt was accepted silently (torch checks no CRC)."""
    data = torch.load(run / "best_model.pt", weights_only=True)
    assert data[artifacts.DIGEST_KEY] == artifacts.content_digest(data)  # written with its digest
    flip_tensor_byte(run / "best_model.pt")
    refused(cli("eval", str(run), "model=best", "episodes=1", "record=false"), "does not match the SHA-256")
    flip_tensor_byte(run / "checkpoints" / "model_256_steps.pt")
    refused(cli("train", f"resume={run}"), "model_256_steps.pt", "does not match the SHA-256")


def test_a_file_without_a_digest_still_loads(run):
    """Files written before the digest existed (the shipped agents among them) are read as before."""
    from pyflyt_cli.zoo import agent

    assert artifacts.DIGEST_KEY not in torch.load(agent("quadx_hover_ppo").path / "model.pt", weights_only=True)
    data = torch.load(run / "best_model.pt", weights_only=True)
    del data[artifacts.DIGEST_KEY]
    torch.save(data, run / "best_model.pt")
    assert artifacts.read_payload(run / "best_model.pt")["algo"] == "ppo"


# ------------------------------------------------------------------ the normaliser's statistics


@pytest.mark.parametrize("damage", ["short", "nan"])
def test_tampered_normaliser_statistics_are_refused_by_eval_and_resume(run, damage):
    """The reproduction: a normaliser mean of 2 values for 21 observations gave a NumPy broadcasting traceback."""

    def tamper(data: dict) -> dict:
        rms = data["normalizer"]["obs_rms"]
        if damage == "short":
            rms["mean"] = rms["mean"][:2]
        else:
            rms["var"][0] = float("nan")
        return reseal(data)

    fragment = "the mean has shape [2], the observation [21]" if damage == "short" else "the variance holds NaN or inf"
    for name in ("best_model.pt", "checkpoints/model_256_steps.pt"):
        path = run / name
        torch.save(tamper(torch.load(path, weights_only=True)), path)
    refused(
        cli("eval", str(run), "model=best", "episodes=1", "record=false"),
        "its observation normaliser does not fit",
        fragment,
    )
    refused(cli("train", f"resume={run}"), fragment)

"""A shared run directory is hostile input: no code from it, no writes through its links, no hang.

Each case is a run directory rewritten the way an attacker would, from the reproductions
of issue 39, and fed to ``pyflyt train resume=``, ``pyflyt eval``, ``pyflyt benchmark``
and ``pyflyt plot``:

* its ``config.yaml`` carries ``trust_pickle: true`` and names a pickled file to start from
  (``init_from``, an AWAC ``algo.offline_buffer``), with the digests in ``state.json`` and
  ``run.yaml`` forged to match: nothing is unpickled (the payload would create a marker);
* a ``config.yaml`` changed after the run started is not resumed;
* an entry is a link leading out of the run (or benchmark) directory: refused before
  anything is read or written (nothing appears where the link leads);
* an alias-expansion bomb, deep nesting or a FIFO where a run file should be: one line,
  exit code 2, in seconds.  These cases run in a forked child (with a memory limit) whose
  timeout only detects a hang (:func:`tests.conftest.pyflyt_forked`); they answer in well
  under a second.
"""

from __future__ import annotations

import json
import os
import pickle
import shutil
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_cli.training import rundir, train
from tests.conftest import billion_laughs, pyflyt_forked

from .conftest import TINY_AWAC, TINY_PPO, load
from .test_artifacts import Payload, _sb3_zip_with_payload


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    """A finished tiny PPO run (checkpoints at 256 and 512 steps)."""
    return train(load(TINY_PPO, tmp_path_factory.mktemp("runs"))).run_dir


@pytest.fixture
def run(trained, tmp_path) -> Path:
    """A private copy of the trained run, free to tamper with."""
    copy = tmp_path / "run"
    shutil.copytree(trained, copy)
    return copy


def cli(*args: str) -> tuple[int, str]:
    """``pyflyt <args>`` in this process: (exit code, output)."""
    result = CliRunner().invoke(app, list(args))
    crash = "" if result.exception is None or isinstance(result.exception, SystemExit) else "\nTraceback"
    return result.exit_code, result.output + crash


def refused(result: tuple[int, str], *fragments: str) -> str:
    """Exit code 2 and one ``error:`` line (no traceback) holding every fragment; returns that line."""
    code, output = result
    assert code == 2, output[-3000:]
    assert "Traceback" not in output, output[-3000:]
    errors = [line for line in output.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, output[-3000:]
    for fragment in fragments:
        assert fragment in errors[0], errors[0]
    return errors[0]


def interrupted_at_256(run: Path) -> None:
    """Make ``run`` look stopped at its first checkpoint (step 256), as after a Ctrl-C."""
    (run / "checkpoints" / "model_512_steps.pt").unlink()
    (run / "model.pt").unlink()
    state = json.loads((run / "state.json").read_text())
    state.update(status="interrupted", num_timesteps=256, checkpoint=256)
    (run / "state.json").write_text(json.dumps(state))


def stopped_before_a_checkpoint(run: Path) -> None:
    for name in ("checkpoints", "model.pt", "best_model.pt"):
        path = run / name
        shutil.rmtree(path) if path.is_dir() else path.unlink(missing_ok=True)
    state = json.loads((run / "state.json").read_text())
    state.update(status="interrupted", num_timesteps=0, checkpoint=None)
    (run / "state.json").write_text(json.dumps(state))


def rewrite_config(run: Path, change) -> None:
    """Change ``config.yaml`` and forge the digests of ``state.json`` and ``run.yaml`` to match it."""
    path = run / "config.yaml"
    data = yaml.safe_load(path.read_text())
    change(data)
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    digest = rundir.config_digest(rundir.load_run_config(run), run)
    state = json.loads((run / "state.json").read_text())
    (run / "state.json").write_text(json.dumps({**state, "config_digest": digest}))
    record = yaml.safe_load((run / "run.yaml").read_text())
    (run / "run.yaml").write_text(yaml.safe_dump({**record, "config_digest": digest}))


# ------------------------------------------------------------- opt-ins


@pytest.mark.parametrize("named", ["relative", "absolute"])
def test_resume_never_takes_trust_pickle_from_the_run_it_resumes(run, tmp_path, monkeypatch, named):
    marker = tmp_path / "ran"
    stopped_before_a_checkpoint(run)
    model = _sb3_zip_with_payload(run, marker)  # <run>/model.zip, a pickle that creates the marker

    def change(data):
        data["trust_pickle"] = True
        data["init_from"] = model.name if named == "relative" else str(model)

    rewrite_config(run, change)
    monkeypatch.chdir(run)  # where a relative init_from was resolved
    result = cli("train", f"resume={run}")
    assert not marker.exists(), "the pickle named by the run's config.yaml was loaded"
    line = refused(result, str(run), "init_policy.pt", "never read by a resume")
    assert "trust_pickle=true on that command line" in line


def test_resume_never_unpickles_an_awac_offline_buffer_named_by_the_run(run, tmp_path):
    marker = tmp_path / "ran"
    buffer = run / "buffer.pkl"
    buffer.write_bytes(pickle.dumps(Payload(marker)))
    awac = load([*TINY_AWAC, f"algo.offline_buffer={buffer}", "algo.offline_steps=5", "trust_pickle=true"], tmp_path)
    stopped_before_a_checkpoint(run)
    rewrite_config(run, lambda data: data.update(rundir.config_dict(awac)))
    result = cli("train", f"resume={run}")
    assert not marker.exists(), "the pickle named by the run's config.yaml was loaded"
    line = refused(result, str(buffer), "trust_pickle=true", "never takes from the run's files")
    assert "a pickle" in line


def test_a_run_started_from_another_restarts_from_its_own_copy_of_that_policy(trained, tmp_path):
    """A resume before the first checkpoint starts over from init_policy.pt: init_from may be gone (or hostile)."""
    from pyflyt_cli.training import resume

    source = tmp_path / "source"
    shutil.copytree(trained, source)
    tiny = [*TINY_PPO, "train.total_timesteps=256", "train.eval_freq=0"]
    run = train(load([*tiny, f"init_from={source}"], tmp_path / "runs")).run_dir
    assert (run / rundir.INIT_POLICY).is_file()
    stopped_before_a_checkpoint(run)
    shutil.rmtree(source)
    messages: list[str] = []
    result = resume(run, log=messages.append)
    assert not result.interrupted and result.num_timesteps == 256
    assert f"policy initialised from {run / rundir.INIT_POLICY}" in messages


def test_an_experiment_file_cannot_opt_in_for_the_command_line(tmp_path):
    experiment = tmp_path / "trusting.yaml"
    experiment.write_text("# @package _global_\ntrust_pickle: true\n")
    result = cli("train", f"experiment={experiment}", "--cfg")
    refused(result, "trust_pickle is set by experiment=trusting", "command line only")
    assert cli("train", f"experiment={experiment}", "trust_pickle=true", "--cfg")[0] == 0


# ------------------------------------------------------------- identity


def test_a_config_changed_after_the_run_started_is_not_resumed(run):
    interrupted_at_256(run)
    path = run / "config.yaml"
    data = yaml.safe_load(path.read_text())
    data["algo"]["learning_rate"] = 0.5  # edited, or swapped in a shared copy; the digests left as they were
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    before = sorted(p.name for p in (run / "checkpoints").iterdir())
    refused(cli("train", f"resume={run}"), str(path), "does not match", f"pyflyt train from_config={path}")
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == before
    code, output = cli("train", f"from_config={path}", "--cfg")  # the way out: a new run of those settings
    assert code == 0, output
    assert "learning_rate: 0.5" in output


def test_a_wind_or_reward_file_counts_by_the_content_the_run_keeps_inline(tmp_path):
    """A run names no file outside itself, so it keeps these inline; it is still the run that was planned."""
    from pyflyt_engine.paths import conf_dir

    wind, reward = tmp_path / "my_wind.yaml", tmp_path / "my_reward.yaml"
    shutil.copyfile(conf_dir() / "wind" / "gust.yaml", wind)
    shutil.copyfile(conf_dir() / "reward" / "quadx_hover_sparse.yaml", reward)
    planned = load([*TINY_PPO, f"env.wind={wind}", f"env.reward={reward}"], tmp_path)
    kept = rundir.portable_config(planned, tmp_path)
    assert isinstance(kept.env.wind, dict) and isinstance(kept.env.reward, dict)
    assert rundir.identity(kept) == rundir.identity(planned)


# ------------------------------------------------------------- closed world


@pytest.mark.parametrize(
    ("entry", "command"),
    [
        ("checkpoints", "resume"),  # resume wrote model_*_steps.pt where the link led
        ("episodes", "eval"),  # eval wrote ep_*.mcap where the link led
        ("state.json", "resume"),
        ("metrics.mcap", "resume"),
        ("best_model.pt", "eval"),
        ("checkpoints/model_256_steps.pt", "resume"),
    ],
)
def test_a_link_out_of_the_run_directory_is_refused_before_anything_is_written(run, tmp_path, entry, command):
    interrupted_at_256(run)
    (run / "episodes").mkdir(exist_ok=True)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    target = elsewhere / Path(entry).name
    shutil.move(run / entry, target)
    (run / entry).symlink_to(target, target_is_directory=target.is_dir())
    listing = sorted(str(p) for p in elsewhere.rglob("*"))
    args = ["train", f"resume={run}"] if command == "resume" else ["eval", str(run), "episodes=1"]
    refused(cli(*args), str(run / entry), "outside")
    assert sorted(str(p) for p in elsewhere.rglob("*")) == listing  # nothing written where the link leads


# ------------------------------------------------------------- bounded readers


def _airframe_bomb(run: Path) -> None:
    from pyflyt_engine.paths import uav_dir

    spec = yaml.safe_load((uav_dir() / "quadx_cf2x.yaml").read_text())
    text = billion_laughs(10, key="z") + yaml.safe_dump(spec, sort_keys=False).replace(
        "shapes:", "shapes: *z9\n  old:", 1
    )
    (run / "airframe.yaml").write_text(text)
    path = run / "config.yaml"
    data = yaml.safe_load(path.read_text())
    data["env"]["uav"] = "airframe.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))


def _config_bomb(run: Path) -> None:
    path = run / "config.yaml"
    text = path.read_text().replace("net_arch:", "net_arch: *z9\n    old_net_arch:", 1)
    path.write_text(billion_laughs(10, key="z") + text)


def _state_deep(run: Path) -> None:
    (run / "state.json").write_text('{"status": ' + "[" * 200_000 + "]" * 200_000 + "}")


def _state_fifo(run: Path) -> None:
    (run / "state.json").unlink()
    os.mkfifo(run / "state.json")  # reading it waits for a writer for ever


@pytest.mark.parametrize(
    ("damage", "command", "fragment"),
    [
        ("config_bomb", "eval", "alias-expansion bomb"),
        ("config_bomb", "resume", "alias-expansion bomb"),
        ("airframe_bomb", "eval", "alias-expansion bomb"),
        ("state_deep", "resume", "nested too deeply"),
        ("state_fifo", "resume", "FIFO"),
    ],
)
def test_a_run_file_built_to_exhaust_the_reader_is_refused_in_seconds(run, damage, command, fragment):
    if damage == "state_fifo" and not hasattr(os, "mkfifo"):
        pytest.skip("needs FIFOs")
    interrupted_at_256(run)
    {"config_bomb": _config_bomb, "airframe_bomb": _airframe_bomb, "state_deep": _state_deep,
     "state_fifo": _state_fifo}[damage](run)  # fmt: skip
    args = ["train", f"resume={run}"] if command == "resume" else ["eval", str(run), "episodes=1", "record=false"]
    refused(pyflyt_forked(args), str(run), fragment)


# ------------------------------------------------------------- benchmark and plot


def _benchmark_with(run: Path, tmp_path: Path) -> Path:
    """A benchmark directory holding ``run`` as the first run of experiment=smoke_benchmark (seeds=1)."""
    root = tmp_path / "smoke_benchmark"
    place = root / "runs" / "quadx_hover" / "ppo" / "seed0"
    place.parent.mkdir(parents=True)
    shutil.move(run, place)
    return root


SMOKE = ["benchmark", "experiment=smoke_benchmark", "seeds=1"]


def test_benchmark_refuses_a_shared_run_built_to_exhaust_the_reader(run, tmp_path):
    _config_bomb(run)
    root = _benchmark_with(run, tmp_path)
    code, output = pyflyt_forked([*SMOKE, f"benchmark.output_dir={tmp_path}", "--dry-run"])
    assert code == 2, output[-3000:]
    assert "Traceback" not in output and "alias-expansion bomb" in output
    assert str(root / "runs" / "quadx_hover" / "ppo" / "seed0") in output


def test_benchmark_refuses_a_link_out_of_its_directory_before_taking_its_lock(run, tmp_path):
    root = _benchmark_with(run, tmp_path)
    outside = tmp_path / "precious.txt"
    outside.write_text("kept\n")
    (root / "benchmark.lock").symlink_to(outside)  # opening the lock used to truncate what it points to
    refused(cli(*SMOKE, f"benchmark.output_dir={tmp_path}"), str(root / "benchmark.lock"), "outside")
    assert outside.read_text() == "kept\n"


def test_plot_refuses_links_out_of_the_benchmark_and_its_runs(run, tmp_path):
    root = _benchmark_with(run, tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (root / "report").symlink_to(elsewhere, target_is_directory=True)  # the default output directory
    refused(cli("plot", str(root), "--reps", "10"), str(root / "report"), "outside")
    assert not any(elsewhere.iterdir())
    (root / "report").unlink()
    metrics = root / "runs" / "quadx_hover" / "ppo" / "seed0" / "metrics.mcap"
    shutil.move(metrics, elsewhere / "metrics.mcap")
    metrics.symlink_to(elsewhere / "metrics.mcap")
    refused(cli("plot", str(root), "--reps", "10"), str(metrics), "outside")
    assert not (root / "report").exists()

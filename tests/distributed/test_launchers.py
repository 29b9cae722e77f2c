"""`pyflyt benchmark` through the real Hydra launchers: Ray (a running cluster) and submitit_local.

A grid of 2 envs x 2 algorithms x 2 seeds with budgets of a few seconds is trained once
with Hydra's basic launcher (one run after another: the reference), then through each
launcher, where the worker process of one run is killed (SIGKILL, by the pid its
``run.lock`` holds, once its first checkpoint is written).  What must hold:

* the runs that were not interrupted end bit-identical to the reference: all of
  ``model.pt`` and ``best_model.pt`` (tensors, normaliser, step), every metrics record of
  every topic but the clocks, and ``state.json`` but its time stamp;
* the killed run is reported interrupted; rerunning the same command resumes it from its
  checkpoint, touches no other run and no file it had written (but those a resume replaces
  by design), and it too ends bit-identical to the reference;
* a third run of the command finds every run complete and rewrites nothing;
* a Ray instance the benchmark starts itself (``hydra.launcher.ray.init.address=local``)
  trains the same runs, bit-identical too.

Marked ``distributed``: the default suite leaves them out; CI (``.ci/run``) installs the
``ray`` and ``slurm`` extras, starts a local Ray cluster and runs ``pytest -m distributed``
with the cluster's address in ``PYFLYT_TEST_RAY_ADDRESS``.  Without a plugin or that
address they fail (saying what is missing), never skip.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path
from collections.abc import Callable
from typing import Any

import pytest
import torch

from tests.train.conftest import cli_env, pyflyt

pytestmark = pytest.mark.distributed

#: the address (host:port) of the running Ray cluster the Ray tests use (.ci/run sets it)
ADDRESS_ENV = "PYFLYT_TEST_RAY_ADDRESS"

#: 2 envs x {PPO, SAC} x 2 seeds, 512 steps each, evaluated and checkpointed every 128 steps
GRID = """# @package _global_
benchmark:
  seeds: 2
  random_episodes: 1
  groups:
    - envs: [quadx_hover]
      algos: [ppo]
      overrides: [algo.n_steps=64, algo.batch_size=32, algo.n_epochs=1]
    - envs: [quadx_waypoints]
      algos: [ppo]
      # the tuning's reach-sphere curriculum, cut to the budget (it may not outlast it)
      overrides: [algo.n_steps=64, algo.batch_size=32, algo.n_epochs=1, train.curriculum.goal_reach_distance.steps=512]
    - envs: [quadx_hover]
      algos: [sac]
      overrides: [algo.learning_starts=64, algo.batch_size=32, algo.buffer_size=2000,
                  "algo.policy_kwargs.net_arch=[32,32]"]
    - envs: [quadx_waypoints]
      algos: [sac]
      # the PyBullet path with one-step updates, as before the tuning moved to 64 batched envs
      overrides: [algo.learning_starts=64, algo.batch_size=32, algo.buffer_size=2000,
                  "algo.policy_kwargs.net_arch=[32,32]", train.curriculum.goal_reach_distance.steps=512,
                  env.backend=pybullet, algo.gradient_steps=1, algo.n_steps=1]
train: {total_timesteps: 512, n_envs: 1, eval_freq: 128, eval_episodes: 1, checkpoint_freq: 128}
"""
RUN_IDS = [f"{e}/{a}/seed{k}" for a in ("ppo", "sac") for e in ("quadx_hover", "quadx_waypoints") for k in (0, 1)]
#: the run whose worker is killed: SAC spends ~3 s on its 384 steps after the first checkpoint
VICTIM = "quadx_waypoints/sac/seed0"
#: what a launcher's process hosting a run's worker has in its command line
HOSTS = {"ray": "ray::", "submitit_local": "submitit.core._submit"}
#: metric fields that measure time, not what was computed (and any ``<part>_seconds``: /train/progress)
CLOCK_FIELDS = {"wall_time", "elapsed", "steps_per_second"}
TIMEOUT = 900


def _clock(field: str) -> bool:
    return field in CLOCK_FIELDS or field.endswith("_seconds")


def _require(module: str, extra: str) -> None:
    try:
        found = importlib.util.find_spec(module) is not None
    except ModuleNotFoundError:
        found = False
    if not found:
        pytest.fail(f"{module} is not installed: pip install '.[{extra}]' (the distributed tests need it)")


def launcher_args(name: str) -> list[str]:
    """The ``hydra/launcher=...`` overrides that train through ``name``; fails if it cannot be used here."""
    if name == "ray":
        _require("hydra_plugins.hydra_ray_launcher", "ray")
        address = os.environ.get(ADDRESS_ENV, "")
        if not address:
            pytest.fail(
                f"{ADDRESS_ENV} is not set: start a local Ray cluster (ray start --head --num-cpus=2 "
                "--include-dashboard=false --disable-usage-stats --temp-dir=<dir>) and set it to the address "
                "in <dir>/ray_current_cluster, as .ci/run does (which also binds the cluster to 127.0.0.1)"
            )
        return ["hydra/launcher=ray", f"hydra.launcher.ray.init.address={address}"]
    _require("hydra_plugins.hydra_submitit_launcher", "slurm")
    return [f"hydra/launcher={name}"]


@pytest.fixture(scope="module")
def grid(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("experiment") / "grid.yaml"
    path.write_text(GRID)
    return path


def _command(grid: Path, output_dir: Path, launcher: list[str]) -> list[str]:
    return ["benchmark", f"experiment={grid}", f"benchmark.output_dir={output_dir}", *launcher]


def outcome(run_dir: Path) -> dict[str, Any]:
    """What a run computed: its policy files whole, its metrics but the clocks, its state but the time."""
    from pyflyt_cli.training.models import read_payload
    from pyflyt_engine.telemetry import read_metrics

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a resumed run's superseded records
        metrics = read_metrics(run_dir)
    state = json.loads((run_dir / "state.json").read_text())
    state.pop("updated")
    return {
        "model": read_payload(run_dir / "model.pt"),
        "best": read_payload(run_dir / "best_model.pt"),
        "metrics": {
            topic: [{k: v for k, v in row.items() if not _clock(k)} for row in rows] for topic, rows in metrics.items()
        },
        "state": state,
    }


def assert_identical(got: Any, want: Any, where: str) -> None:
    """Equal structure, equal values, tensors equal bit for bit (dtype and shape included)."""
    if isinstance(want, torch.Tensor):
        assert isinstance(got, torch.Tensor) and got.dtype == want.dtype and torch.equal(got, want), where
    elif isinstance(want, dict):
        assert isinstance(got, dict) and got.keys() == want.keys(), f"{where}: {sorted(got)} != {sorted(want)}"
        for key in want:
            assert_identical(got[key], want[key], f"{where}/{key}")
    elif isinstance(want, list):
        assert isinstance(got, list) and len(got) == len(want), f"{where}: {len(got)} != {len(want)} entries"
        for i, (g, w) in enumerate(zip(got, want)):
            assert_identical(g, w, f"{where}[{i}]")
    else:
        assert got == want, f"{where}: {got!r} != {want!r}"


def states(root: Path) -> dict[str, str]:
    return {i: json.loads((root / "runs" / i / "state.json").read_text())["status"] for i in RUN_IDS}


def contents(folder: Path) -> dict[str, str]:
    """Every file under ``folder``: relative path -> SHA-256 of its bytes."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def mtimes(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def reference(grid: Path, tmp_path_factory: pytest.TempPathFactory) -> Callable[[], dict[str, dict]]:
    """The grid under Hydra's basic launcher, run id -> :func:`outcome`: trained at the first call
    (after a test has checked its launcher can be used: a missing plugin fails at once)."""
    done: dict[str, dict] = {}

    def get() -> dict[str, dict]:
        if not done:
            out = tmp_path_factory.mktemp("basic")
            result = pyflyt(_command(grid, out, ["hydra/launcher=basic"]), out, timeout=TIMEOUT)
            assert result.returncode == 0, result.stderr[-3000:]
            assert "8 complete" in result.stderr
            done.update({i: outcome(out / "grid" / "runs" / i) for i in RUN_IDS})
            # comparisons that can fail: 4 evaluations a run, and the seeds train different weights
            assert all(len(r["metrics"]["/eval"]) == 4 for r in done.values())
            for run_id in RUN_IDS[::2]:
                seed0, seed1 = (
                    done[run_id]["model"]["policy"],
                    done[run_id.replace("seed0", "seed1")]["model"]["policy"],
                )
                assert any(not torch.equal(seed0[k], seed1[k]) for k in seed0), run_id
        return done

    return get


def _assert_runs_match(root: Path, run_ids: list[str], reference: dict[str, dict]) -> None:
    for run_id in run_ids:
        assert_identical(outcome(root / "runs" / run_id), reference[run_id], run_id)


def restatements(run: dict[str, Any]) -> list[int]:
    """Drop from an :func:`outcome` the ``/train/curriculum`` records that restate the value in force; their steps.

    The curriculum's value is logged at every change and at the start of every training
    session (``TaskCurriculum.apply`` in pyflyt_cli/training/callbacks.py), so a run resumed
    at step k holds one record more than the uninterrupted run: the unchanged value, at k.
    """
    rows = run["metrics"].get("/train/curriculum", [])
    kept, dropped = [], []
    for row in rows:
        if kept and {k: v for k, v in row.items() if k != "step"} == {k: v for k, v in kept[-1].items() if k != "step"}:
            dropped.append(row["step"])
        else:
            kept.append(row)
    if rows:
        run["metrics"]["/train/curriculum"] = kept
    return dropped


def _parent(pid: int) -> int:
    stat = Path(f"/proc/{pid}/stat").read_text()
    return int(stat.rpartition(")")[2].split()[1])  # the fields after the command name: state, ppid


def _cmdline(pid: int) -> str:
    return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def _wait(predicate, proc: subprocess.Popen, what: str, timeout: float = TIMEOUT) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        if proc.poll() is not None:
            raise AssertionError(f"the benchmark ended (exit {proc.returncode}) before {what}")
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


def _first_checkpoint_written(run_dir: Path) -> bool:
    try:
        state = json.loads((run_dir / "state.json").read_text())
    except (OSError, ValueError):  # not there yet, or being replaced
        return False
    return state.get("status") == "running" and (state.get("checkpoint") or 0) > 0


def _train_and_kill_the_victim(args: list[str], root: Path, launcher: str, log: Path) -> tuple[int, str]:
    """Run the benchmark; SIGKILL the victim's worker once its first checkpoint is written: (exit code, output)."""
    from pyflyt_cli.training import rundir

    victim = root / "runs" / VICTIM
    with open(log, "w+") as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "pyflyt_cli.main", *args], cwd=log.parent, env=cli_env(), stdout=out, stderr=out
        )
        try:
            _wait(lambda: _first_checkpoint_written(victim), proc, f"{VICTIM}'s first checkpoint")
            worker = rundir.read_pid(victim / rundir.LOCK_FILE)
            assert worker and "pyflyt_cli.benchmark.worker" in _cmdline(worker) and VICTIM in _cmdline(worker)
            host = _cmdline(_parent(worker))
            assert HOSTS[launcher] in host, f"the worker's parent is not the launcher's: {host}"
            os.kill(worker, signal.SIGKILL)  # no handler runs: only what it had written counts
            deadline = time.monotonic() + 60
            while _alive(worker) and time.monotonic() < deadline:
                time.sleep(0.05)
            assert not _alive(worker)
            code = proc.wait(timeout=TIMEOUT)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        out.seek(0)
        return code, out.read()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="finds the worker's host process in /proc")
@pytest.mark.parametrize("launcher", ["ray", "submitit_local"])
def test_the_grid_through_a_launcher_matches_the_basic_launcher_and_a_killed_worker_resumes(
    launcher: str, grid: Path, reference: Callable[[], dict[str, dict]], tmp_path: Path
) -> None:
    from pyflyt_cli.training import rundir

    args = _command(grid, tmp_path, launcher_args(launcher))
    expected = reference()
    root = tmp_path / "grid"
    victim = root / "runs" / VICTIM
    others = [i for i in RUN_IDS if i != VICTIM]

    # 1. the grid through the launcher, one run's worker killed once it has a checkpoint
    code, first = _train_and_kill_the_victim(args, root, launcher, tmp_path / "first.out")
    assert code == 130, first[-3000:]  # a run interrupted: rerun to resume
    if launcher == "ray":  # the cluster CI started, not a Ray instance of this process
        assert "Ray Launcher is launching 8 jobs" in first
        assert f"Connecting to existing Ray cluster at address: {os.environ[ADDRESS_ENV]}" in first, first[-3000:]
    else:
        assert "Submitit 'local' sweep output dir" in first
    assert f"interrupted {VICTIM}  checkpoint at step " in first and "rerun to resume" in first, first[-3000:]
    assert states(root) == {i: "running" if i == VICTIM else "complete" for i in RUN_IDS}  # killed mid-run
    assert not (victim / "model.pt").exists()
    _assert_runs_match(root, others, expected)  # the uninterrupted runs: as under the basic launcher
    written = contents(victim)
    kept = rundir.checkpoints(victim)[-1].step  # the newest complete checkpoint: where a resume continues
    assert f"checkpoints/model_{kept}_steps.pt" in written and "metrics.mcap" in written
    untouched = {k: v for k, v in mtimes(root / "runs").items() if not k.startswith(VICTIM + "/")}

    # 2. the same command again: resumes the killed run from its checkpoint, touches nothing else
    rerun = pyflyt(args, tmp_path, timeout=TIMEOUT)
    assert rerun.returncode == 0, (rerun.stdout + rerun.stderr)[-3000:]
    assert "7 complete (skipped), 1 to resume, 0 to start" in rerun.stderr
    assert {k: v for k, v in mtimes(root / "runs").items() if k in untouched} == untouched
    after = contents(victim)
    # what a resume replaces by design: the run's state, lock and record (now naming the checkpoint
    # it continued from), the best policy when a later evaluation beats it, and older replay
    # buffers (only the newest is kept: docs/cli.md, train.keep_checkpoints)
    replaced = {"state.json", "run.lock", "run.yaml", "best_model.pt"}
    lost = {
        f
        for f, digest in written.items()
        if f not in replaced and not rundir.BUFFER_PATTERN.match(Path(f).name) and after.get(f) != digest
    }
    assert not lost, f"files written before the kill were changed or removed by the resume: {sorted(lost)}"
    assert any(f.startswith("metrics-") for f in after)  # the continuation's own metrics segment
    assert f"from_step: {kept}" in (victim / rundir.RUN_FILE).read_text()  # continued, not restarted
    assert states(root) == dict.fromkeys(RUN_IDS, "complete")
    _assert_runs_match(root, others, expected)
    resumed = outcome(victim)
    assert restatements(resumed) == [kept] and restatements(expected[VICTIM]) == []
    assert_identical(resumed, expected[VICTIM], VICTIM)  # the resumed run too: as if never interrupted

    # 3. and once more: every run complete, nothing retrained or rewritten
    before = mtimes(root / "runs")
    again = pyflyt(args, tmp_path, timeout=TIMEOUT)
    assert again.returncode == 0, again.stderr[-3000:]
    assert "8 complete (skipped), 0 to resume, 0 to start" in again.stderr
    assert mtimes(root / "runs") == before


def test_a_ray_instance_the_benchmark_starts_itself_trains_the_same_runs(
    grid: Path, reference: Callable[[], dict[str, dict]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The one-machine form of docs/benchmarks.md: ``address=local`` starts Ray in the benchmark's process."""
    _require("hydra_plugins.hydra_ray_launcher", "ray")
    if "RAY_AUTH_MODE" not in os.environ:  # unset, Ray 2.60 would write a token to ~/.ray/auth_token (.ci/run)
        monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    expected = reference()
    launcher = ["hydra/launcher=ray", "hydra.launcher.ray.init.address=local", "+hydra.launcher.ray.init.num_cpus=2"]
    args = [*_command(grid, tmp_path, launcher), "benchmark.seeds=[0]"]
    result = pyflyt(args, tmp_path, timeout=TIMEOUT)
    output = result.stdout + result.stderr
    assert result.returncode == 0, output[-3000:]
    assert "Ray Launcher is launching 4 jobs" in output and "Connecting to existing Ray cluster" not in output
    seed0 = [i for i in RUN_IDS if i.endswith("/seed0")]
    assert sorted(
        p.parent.relative_to(tmp_path / "grid" / "runs").as_posix()
        for p in (tmp_path / "grid" / "runs").glob("*/*/*/state.json")
    ) == sorted(seed0)
    _assert_runs_match(tmp_path / "grid", seed0, expected)

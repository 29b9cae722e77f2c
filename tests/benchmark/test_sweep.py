"""`pyflyt benchmark` end to end: a tiny sweep runs, a rerun skips it, a killed sweep
resumes without redoing finished runs, a failed run is reported while the others carry
on, and the result is plotted.  Each run is a real `pyflyt train` (PPO, a few hundred
steps) in its own worker process.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pyflyt_engine.telemetry.metrics import read_metrics
from tests.train.conftest import cli_env, pyflyt

SMOKE = ["experiment=smoke_benchmark", "jobs=2"]


def states(root: Path) -> dict[str, dict]:
    return {
        str(p.parent.relative_to(root / "runs")): json.loads(p.read_text())
        for p in sorted((root / "runs").glob("*/*/*/state.json"))
    }


def mtimes(root: Path) -> dict[str, int]:
    return {str(p.relative_to(root)): p.stat().st_mtime_ns for p in sorted((root / "runs").rglob("*")) if p.is_file()}


@pytest.mark.slow  # a whole sweep / install: run with -m slow
def test_tiny_sweep_runs_reruns_as_skips_and_plots(tmp_path: Path) -> None:
    args = ["benchmark", *SMOKE, f"benchmark.output_dir={tmp_path}"]
    first = pyflyt(args, tmp_path)
    assert first.returncode == 0, first.stderr[-3000:]
    root = tmp_path / "smoke_benchmark"
    done = states(root)
    assert sorted(done) == [f"{e}/ppo/seed{k}" for e in ("quadx_hover", "quadx_waypoints") for k in range(3)]
    assert all(s["status"] == "complete" and s["num_timesteps"] >= 256 for s in done.values())
    assert "0 skipped (complete before), 6 complete" in first.stderr
    assert (root / "summary.md").read_text().count("| complete |") == 6
    started = dict(re.findall(r"\[(\d)/6\] started  (\S+)", first.stderr))
    ended = re.findall(r"\[(\d)/6\] complete (\S+) .*\((\d)/6 ended\)", first.stderr)
    assert sorted(started) == list("123456") and len(ended) == 6
    assert all(started[k] == run for k, run, _ in ended)  # a run's start and end lines share its number
    assert [m for _, _, m in ended] == list("123456")
    for run in done:  # every run evaluated at least 3 times (a readable learning curve)
        assert len(read_metrics(root / "runs" / run)["/eval"]) >= 3
    for log in (root / "logs").glob("*.log"):
        assert "run directory:" in log.read_text()
    norm = (root / "normalisation.yaml").read_text()
    assert "quadx_hover:" in norm and "quadx_waypoints:" in norm  # random-policy scores recorded
    before = mtimes(root)

    again = pyflyt(args, tmp_path)
    assert again.returncode == 0, again.stderr[-3000:]
    assert "6 complete (skipped), 0 to resume, 0 to start" in again.stderr
    assert "started" not in again.stderr
    assert mtimes(root) == before  # nothing retrained, nothing rewritten

    from pyflyt_cli.plotting import plot_benchmark

    report = plot_benchmark(root, reps=100, seed=0)
    assert report.benchmark.envs == ["quadx_hover", "quadx_waypoints"]
    assert report.benchmark.algos == ["ppo"]
    assert report.benchmark.seeds[("quadx_hover", "ppo")] == [0, 1, 2]
    text = report.markdown.read_text()
    assert "a perfect hover" in text  # the reference score and its source
    assert "zoo:quadx_waypoints_ppo" in text and "no reference score given" not in text  # every task has one
    assert all(p.is_file() for p in report.figures)


def _spawn(args: list[str], cwd: Path) -> subprocess.Popen:
    """``pyflyt <args>`` in the background, its stderr readable as text."""
    return subprocess.Popen(
        [sys.executable, "-m", "pyflyt_cli.main", *args],
        cwd=cwd,
        env=cli_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait(predicate, timeout: float, what: str) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.1)
    raise AssertionError(f"timed out waiting for {what}")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="workers follow a killed launcher on Linux")
@pytest.mark.slow  # a whole sweep / install: run with -m slow
def test_killed_sweep_resumes_without_redoing_finished_runs(tmp_path: Path) -> None:
    from pyflyt_cli.training import rundir

    args = [
        "benchmark",
        "experiment=smoke_benchmark",
        "jobs=1",
        "seeds=2",
        f"benchmark.output_dir={tmp_path}",
        "train.total_timesteps=1536",
        "train.checkpoint_freq=128",
        "train.eval_freq=512",
    ]
    root = tmp_path / "smoke_benchmark"
    proc = _spawn(args, tmp_path)
    try:
        second = root / "runs" / "quadx_hover" / "ppo" / "seed1"
        _wait(
            lambda: (
                (root / "runs").is_dir()
                and any(s["status"] == "complete" for s in states(root).values())
                and bool(rundir.checkpoints(second))
            ),
            240,
            "one complete run and a checkpoint",
        )
        lock = second / "run.lock"
        worker = int(lock.read_text())
        proc.kill()  # SIGKILL: no chance to clean up; its worker gets SIGTERM and saves a checkpoint
        proc.wait()
        _wait(lambda: not _alive(worker), 60, "the orphaned worker to stop")
    finally:
        if proc.poll() is None:
            proc.kill()
    finished = {k for k, s in states(root).items() if s["status"] == "complete"}
    assert finished == {"quadx_hover/ppo/seed0"}
    assert states(root)["quadx_hover/ppo/seed1"]["status"] == "interrupted"
    kept = {k: v for k, v in mtimes(root).items() if k.startswith("runs/quadx_hover/ppo/seed0/")}

    rerun = pyflyt(args, tmp_path)
    assert rerun.returncode == 0, rerun.stderr[-3000:]
    assert "1 complete (skipped), 1 to resume, 2 to start" in rerun.stderr
    final = states(root)
    assert len(final) == 4 and all(s["status"] == "complete" and s["num_timesteps"] >= 1536 for s in final.values())
    assert {k: v for k, v in mtimes(root).items() if k in kept} == kept  # the finished run was not touched
    resumed = (second / "run.yaml").read_text()
    assert "from_step:" in resumed and "from_step: 0" not in resumed  # continued from its checkpoint


@pytest.mark.slow  # a whole sweep / install: run with -m slow
def test_a_failed_run_is_reported_and_the_others_carry_on(tmp_path: Path) -> None:
    root = tmp_path / "smoke_benchmark"
    squatter = root / "runs" / "quadx_waypoints" / "ppo" / "seed0"
    squatter.mkdir(parents=True)
    (squatter / "notes.txt").write_text("not a run: must survive")
    result = pyflyt(["benchmark", *SMOKE, "seeds=2", f"benchmark.output_dir={tmp_path}"], tmp_path)
    assert result.returncode == 1
    assert "failed   quadx_waypoints/ppo/seed0" in result.stderr
    assert "exists without a config.yaml" in result.stderr  # the reason, from the run's log
    assert "quadx_waypoints__ppo__seed0.log" in result.stderr
    assert (squatter / "notes.txt").read_text() == "not a run: must survive"
    done = states(root)
    assert {k for k, s in done.items() if s["status"] == "complete"} == {
        "quadx_hover/ppo/seed0",
        "quadx_hover/ppo/seed1",
        "quadx_waypoints/ppo/seed1",
    }
    summary = (root / "summary.md").read_text()
    assert "| quadx_waypoints/ppo/seed0 | failed (exit 2) |" in summary


@pytest.mark.slow  # a whole sweep / install: run with -m slow
def test_budget_grown_in_the_plan_extends_complete_runs(tmp_path: Path) -> None:
    args = ["benchmark", "experiment=smoke_benchmark", "seeds=1", f"benchmark.output_dir={tmp_path}"]
    assert pyflyt(args, tmp_path).returncode == 0
    root = tmp_path / "smoke_benchmark"
    longer = pyflyt([*args, "train.total_timesteps=384"], tmp_path)
    assert longer.returncode == 0, longer.stderr[-3000:]
    assert "0 complete (skipped), 2 to resume" in longer.stderr
    assert all(s["num_timesteps"] >= 384 and s["status"] == "complete" for s in states(root).values())
    shorter = pyflyt(args, tmp_path)  # a run is extended, never shortened: 384 steps are not a 256-step run
    assert shorter.returncode == 2
    assert "quadx_hover/ppo/seed0  train.total_timesteps: 384 -> 256" in shorter.stderr


@pytest.mark.slow  # two whole sweeps (~70 s): run with -m slow
def test_a_rerun_with_changed_settings_is_refused_then_restarted_on_request(tmp_path: Path) -> None:
    from pyflyt_cli.plotting.data import load_benchmark

    args = ["benchmark", "experiment=smoke_benchmark", "seeds=1", f"benchmark.output_dir={tmp_path}"]
    assert pyflyt(args, tmp_path).returncode == 0
    root = tmp_path / "smoke_benchmark"
    before = mtimes(root)
    changed = [*args, "algo.learning_rate=1e-3", "algo.n_epochs=2"]
    refused = pyflyt(changed, tmp_path)
    assert refused.returncode == 2, refused.stderr[-3000:]
    # one line per run and key: saved -> planned (hover's learning rate is its hparams file's)
    for run, saved in (("quadx_hover/ppo/seed0", "0.002"), ("quadx_waypoints/ppo/seed0", "0.0003")):
        assert f"  {run}  algo.learning_rate: {saved} -> 0.001\n" in refused.stderr
        assert f"  {run}  algo.n_epochs: 1 -> 2\n" in refused.stderr
    assert "benchmark.name=" in refused.stderr and "--restart-changed" in refused.stderr
    assert "started" not in refused.stderr and mtimes(root) == before  # nothing trained, nothing rewritten
    dry = pyflyt([*changed, "--dry-run"], tmp_path)
    assert dry.returncode == 2 and "# changed   quadx_hover/ppo/seed0" in dry.stdout

    restarted = pyflyt([*changed, "--restart-changed"], tmp_path)
    assert restarted.returncode == 0, restarted.stderr[-3000:]
    assert "2 to restart (settings changed)" in restarted.stderr
    (replaced,) = (root / "replaced").iterdir()
    old = replaced / "quadx_hover" / "ppo" / "seed0"
    assert {k.removeprefix("runs/"): v for k, v in before.items()} == {
        str(p.relative_to(replaced)): p.stat().st_mtime_ns
        for p in replaced.rglob("*")
        if p.is_file() and "logs" not in p.parts
    }  # the old runs, untouched, beside their logs
    assert (replaced / "logs" / "quadx_hover__ppo__seed0.log").is_file()
    assert "learning_rate: 0.002" in (old / "config.yaml").read_text()
    assert "learning_rate: 0.001" in (root / "runs" / "quadx_hover" / "ppo" / "seed0" / "config.yaml").read_text()
    assert all(s["status"] == "complete" for s in states(root).values())
    assert {r.run_dir.parent.parent.parent for r in load_benchmark(root).runs} == {root / "runs"}  # plots new runs only
    again = pyflyt(changed, tmp_path)
    assert again.returncode == 0 and "2 complete (skipped)" in again.stderr


@pytest.mark.slow  # a whole sweep / install: run with -m slow
def test_runs_that_start_from_a_restarted_run_restart_too(tmp_path: Path) -> None:
    study = tmp_path / "tiny_bootstrap.yaml"
    study.write_text(BOOTSTRAP)
    args = ["benchmark", f"experiment={study}", f"benchmark.output_dir={tmp_path}"]
    first = pyflyt(args, tmp_path)
    assert first.returncode == 0, first.stderr[-3000:]
    source_only = [*args, "benchmark.groups.0.overrides=['algo.tau=0.01']"]
    refused = pyflyt(source_only, tmp_path)
    assert refused.returncode == 2, refused.stderr[-3000:]
    assert "  quadx_waypoints/sac/seed0  algo.tau: 0.02 -> 0.01\n" in refused.stderr
    assert (
        "  quadx_waypoints_sparse/awac/seed0  it starts from quadx_waypoints/sac/seed0, which restarts"
        in refused.stderr
    )
    restarted = pyflyt([*source_only, "--restart-changed"], tmp_path)
    assert restarted.returncode == 0, restarted.stderr[-3000:]
    (replaced,) = (tmp_path / "tiny_bootstrap" / "replaced").iterdir()
    assert sorted(str(p.relative_to(replaced)) for p in replaced.glob("*/*/seed0")) == [
        "quadx_waypoints/sac/seed0",
        "quadx_waypoints_sparse/awac/seed0",
    ]


def test_bad_cli_input_exits_2_with_a_message(tmp_path: Path) -> None:
    missing = pyflyt(["benchmark"], tmp_path)
    assert missing.returncode == 2 and "experiment=<name>" in missing.stderr
    unknown = pyflyt(["benchmark", "experiment=paper_rll"], tmp_path)
    assert unknown.returncode == 2 and "Did you mean 'paper_rl'" in unknown.stderr
    assert not (tmp_path / "benchmarks").exists()


def test_a_hydra_callback_payload_is_refused_before_anything_runs(tmp_path: Path) -> None:
    marker = tmp_path / "payload-ran"
    payload = ["+hydra.callbacks.x._target_=builtins.open", f"+hydra.callbacks.x._args_=[{marker},w]"]
    args = ["benchmark", *SMOKE, "seeds=1", f"benchmark.output_dir={tmp_path}", "hydra/launcher=basic", *payload]
    result = pyflyt(args, tmp_path)
    assert result.returncode == 2, result.stderr[-3000:]
    assert "cannot be given to pyflyt benchmark" in result.stderr and "hydra.launcher.<key>=<value>" in result.stderr
    assert not marker.exists(), "the callback was instantiated"
    assert not (tmp_path / "smoke_benchmark").exists(), "nothing may be written"


def _start(args: list[str], cwd: Path, ready: str) -> subprocess.Popen:
    """Start ``pyflyt <args>`` and read its stderr until a line containing ``ready``."""
    proc = _spawn(args, cwd)
    seen: list[str] = []
    for line in proc.stderr:  # type: ignore[union-attr]
        seen.append(line)
        if ready in line:
            return proc
    proc.wait()
    raise AssertionError(f"exited ({proc.returncode}) before printing {ready!r}:\n{''.join(seen)}")


@pytest.mark.long
def test_a_second_benchmark_on_the_same_directory_is_refused_untouched(tmp_path: Path) -> None:
    args = [
        "benchmark",
        *SMOKE,
        "seeds=1",
        "jobs=1",
        f"benchmark.output_dir={tmp_path}",
        "train.total_timesteps=10000000",
    ]
    first = _start(args, tmp_path, "started")
    try:
        root = tmp_path / "smoke_benchmark"
        plan = (root / "plan.json").read_bytes(), (root / "plan.json").stat().st_mtime_ns
        second = pyflyt(args, tmp_path)
        assert second.returncode == 2, second.stderr[-3000:]
        assert f"benchmark directory {root} is in use by process {first.pid} (pyflyt benchmark" in second.stderr
        assert "benchmark.name=" in second.stderr and "Traceback" not in second.stderr
        assert ((root / "plan.json").read_bytes(), (root / "plan.json").stat().st_mtime_ns) == plan
        assert not (root / "summary.md").exists()
    finally:
        first.send_signal(signal.SIGTERM)  # each worker saves a checkpoint
        rest = first.communicate()[1]
    assert first.returncode == 130, rest[-3000:]
    assert "failed" not in rest


def test_the_benchmark_lock_dies_with_its_process(tmp_path: Path) -> None:
    from pyflyt_cli.benchmark.run import hold_benchmark
    from pyflyt_cli.errors import UsageError

    code = (
        "import sys, time\nfrom pathlib import Path\nfrom pyflyt_cli.benchmark.run import hold_benchmark\n"
        "with hold_benchmark(Path(sys.argv[1]), ['holder']):\n    print('held', flush=True)\n    time.sleep(3600)\n"
    )
    holder = subprocess.Popen(
        [sys.executable, "-c", code, str(tmp_path)], env=cli_env(), stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline().strip() == "held"  # type: ignore[union-attr]
        with (
            pytest.raises(UsageError, match=f"in use by process {holder.pid} \\(holder\\)"),
            hold_benchmark(tmp_path, ["second"]),
        ):
            pass
    finally:
        holder.kill()  # SIGKILL: no clean-up code runs
        holder.wait()
    with hold_benchmark(tmp_path, ["third"]):  # the kernel released the lock with the process
        assert (tmp_path / "benchmark.lock").read_text().startswith(f"{os.getpid()} third")


BOOTSTRAP = """# @package _global_
benchmark:
  seeds: 1
  random_episodes: 1
  groups:
    - envs: [quadx_waypoints]
      algos: [sac]
    - envs: [quadx_waypoints]
      algos: [awac]
      task: "{env}_sparse"
      overrides: [env.reward=sparse]
      init_from: {task: "{env}", algo: sac, checkpoint: 100}
# the PyBullet path, 4 envs, one-step updates (the SAC tuning trains 64 batched envs)
env: {backend: pybullet}
train: {total_timesteps: 160, eval_freq: 0, checkpoint_freq: 100, n_envs: 4}
algo: {learning_starts: 40, batch_size: 16, buffer_size: 1000, policy_kwargs: {net_arch: [16, 16]}, gradient_steps: 1,
       n_steps: 1}
"""


@pytest.mark.slow  # a whole sweep / install: run with -m slow
def test_the_dry_run_lines_train_the_runs_the_benchmark_plans(tmp_path: Path) -> None:
    """Run as printed, the lines train each run in its planned directory; the benchmark then finds them complete."""
    import shlex

    import yaml

    from pyflyt_cli.benchmark.plan import build_plan
    from pyflyt_cli.training import rundir
    from tests.benchmark.test_plan import dry_run_lines

    study = tmp_path / "tiny_bootstrap.yaml"
    study.write_text(BOOTSTRAP)
    args = [f"experiment={study}", f"benchmark.output_dir={tmp_path}"]
    dry = pyflyt(["benchmark", *args, "--dry-run"], tmp_path)
    assert dry.returncode == 0, dry.stderr
    lines = dry_run_lines(dry.stdout)
    assert list(lines) == ["quadx_waypoints/sac/seed0", "quadx_waypoints_sparse/awac/seed0"]  # sources first
    plan, _ = build_plan(str(study), args[1:])
    from pyflyt_cli.benchmark.worker import planned_config

    for run_id, line in lines.items():
        trained = pyflyt(["train", *line], tmp_path)
        assert trained.returncode == 0, f"{shlex.join(line)}\n{trained.stderr[-3000:]}"
        job = plan.job(run_id)
        record = yaml.safe_load((plan.run_dir(job) / rundir.RUN_FILE).read_text())
        assert record["config_digest"] == rundir.config_digest(planned_config(plan, job))
    source = plan.run_dir(plan.job("quadx_waypoints/sac/seed0"))
    first_after_100 = next(c for c in rundir.checkpoints(source) if c.step >= 100)
    assert first_after_100.step == 104  # SAC's rollouts are train_freq 8 steps long
    started = plan.run_dir(plan.job("quadx_waypoints_sparse/awac/seed0"))
    assert rundir.load_run_config(started).init_from == f"{source}@100"  # as planned
    assert yaml.safe_load((started / rundir.RUN_FILE).read_text())["init_from"]["model"] == str(first_after_100.model)

    bench = pyflyt(["benchmark", *args], tmp_path)
    assert bench.returncode == 0, bench.stderr[-3000:]
    assert "2 complete (skipped), 0 to resume, 0 to start" in bench.stderr

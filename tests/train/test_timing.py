"""The headline command is practical: budget and ETA at start, a progress line at least every
30 s without a terminal, the time split by phase, one compressed replay buffer on disk.

The progress and phase classes are driven by a fake clock: no test waits on real time.
"""

from __future__ import annotations

import zipfile
from types import SimpleNamespace

import numpy as np
import pytest

from pyflyt_cli.training import train
from pyflyt_cli.training.timing import (
    PROGRESS_INTERVAL,
    Costs,
    PhaseClock,
    ProgressLines,
    estimate_seconds,
    format_duration,
    measure_costs,
)

from .conftest import TINY_PPO, TINY_SAC, load, pyflyt


class FakeClock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def _attach(callback, model) -> None:
    callback.model = model  # what BaseCallback.init_callback sets (it also wants a logger)


def test_progress_lines_come_at_least_every_interval_with_rate_and_eta():
    clock = FakeClock()
    model = SimpleNamespace(num_timesteps=0)
    lines: list[str] = []
    progress = ProgressLines(10_000, lines.append, clock=clock)
    _attach(progress, model)
    progress.on_training_start({}, {})
    # 100 steps per fake second: a line at 30 s, 60 s, 90 s ... whenever the step after it comes
    for _ in range(95):
        clock.now += 1.0
        model.num_timesteps += 100
        progress.on_step()
    assert len(lines) == 3  # 30, 60, 90 s
    assert lines[0].startswith("step 3000/10000 (30 %) | 100 steps/s | elapsed 0:30 | ETA 1:10")
    # a long step (a slow update) still gives one line, and the schedule keeps the 30 s grid
    clock.now += 100.0
    model.num_timesteps += 100
    progress.on_step()
    assert len(lines) == 4 and "elapsed 3:15" in lines[-1]
    clock.now += 14.0  # 209 s: the next line is due at 210 s (the 30 s grid)
    progress.on_step()
    assert len(lines) == 4
    clock.now += 1.0
    progress.on_step()
    assert len(lines) == 5 and PROGRESS_INTERVAL == 30.0


def test_progress_lines_resume_counts_the_rate_from_the_resumed_step():
    clock = FakeClock()
    model = SimpleNamespace(num_timesteps=5000)
    lines: list[str] = []
    progress = ProgressLines(6000, lines.append, clock=clock)
    _attach(progress, model)
    progress.on_training_start({}, {})
    clock.now += 30.0
    model.num_timesteps = 5300
    progress.on_step()
    assert lines == ["step 5300/6000 (88 %) | 10 steps/s | elapsed 0:30 | ETA 1:10"]


def test_phase_clock_splits_collection_updates_evaluations_and_checkpoints():
    clock = FakeClock()
    model = SimpleNamespace(num_timesteps=0)
    phases = PhaseClock(clock=clock)
    _attach(phases, model)
    phases.on_training_start({}, {})
    for _ in range(3):
        clock.now += 0.5  # (first: setup before the first rollout; then: update + eval + checkpoint)
        phases.add("eval", 0.2)
        phases.add("checkpoint", 0.1)
        phases.on_rollout_start()
        clock.now += 2.0
        model.num_timesteps += 8
        phases.on_rollout_end()
    clock.now += 1.0
    phases.on_training_end()
    split = phases.split()
    assert split["collect"] == pytest.approx(6.0)
    assert split["eval"] == pytest.approx(0.6) and split["checkpoint"] == pytest.approx(0.3)
    assert split["update"] == pytest.approx(3 * 0.2 + 1.0)  # gaps less what eval and checkpoints took
    assert phases.collected == 24
    assert sum(split.values()) == pytest.approx(clock.now - 1000.0)


def test_estimate_counts_collection_updates_after_learning_starts_and_evaluations():
    cfg = load([*TINY_SAC, "train.total_timesteps=1000", "algo.learning_starts=200", "train.eval_freq=500"], "/tmp")
    costs = Costs(collect=0.001, update=0.01)
    episode = cfg.env.max_steps
    expected = 1000 * 0.001 + 800 * 0.01 + 2 * cfg.train.eval_episodes * episode * 0.001
    assert estimate_seconds(cfg, costs) == pytest.approx(expected)
    # from a checkpoint at 600: 400 steps left, all updating, one evaluation (at 1000) left
    assert estimate_seconds(cfg, costs, 600) == pytest.approx(400 * 0.011 + cfg.train.eval_episodes * episode * 0.001)


def test_format_duration():
    assert format_duration(59.4) == "0:59" and format_duration(3723) == "1:02:03"
    assert format_duration(float("inf")) == "?"


def test_measuring_costs_leaves_the_random_streams_and_the_run_unchanged(tmp_path):
    import random

    import torch

    cfg = load(TINY_SAC, tmp_path)
    np.random.seed(5)
    random.seed(5)
    torch.manual_seed(5)
    before = (np.random.random(), random.random(), torch.rand(1).item())
    np.random.seed(5)
    random.seed(5)
    torch.manual_seed(5)
    costs = measure_costs(cfg, seconds=0.0)
    after = (np.random.random(), random.random(), torch.rand(1).item())
    assert costs is not None and costs.collect > 0 and costs.update > 0
    assert before == after


def test_costs_are_measured_on_the_runs_envs_when_they_run_in_this_process(tmp_path, monkeypatch):
    """In-process envs share one policy forward pass per step, so the copy runs all of them
    (with one env, the ETA of the 16-env hover default was 3.6x too long)."""
    from pyflyt_cli.training import models

    seen = []
    real = models.build_model

    def spy(cfg, vec, *args, **kwargs):
        seen.append((vec.num_envs, cfg.algo.n_steps * vec.num_envs))
        return real(cfg, vec, *args, **kwargs)

    monkeypatch.setattr(models, "build_model", spy)
    overrides = [*TINY_PPO, "train.n_envs=2", "train.vec_env=dummy", "algo.n_steps=32", "algo.batch_size=32"]
    costs = measure_costs(load(overrides, tmp_path), seconds=0.0)
    assert costs is not None and costs.collect > 0 and costs.update > 0
    assert seen == [(2, 64)]


@pytest.mark.long
def test_the_command_prints_budget_eta_and_time_split_without_a_terminal(tmp_path):
    result = pyflyt(["train", *TINY_SAC, f"train.output_dir={tmp_path / 'runs'}"], cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    err = result.stderr
    assert "budget: 400 steps of quadx_hover with sac on 1 env(s)" in err
    assert "ETA: about " in err and "ms per collected step" in err
    assert "time in training: collect " in err and "update " in err


def test_multi_agent_runs_count_and_time_agent_steps(tmp_path):
    """Every agent's step is one of ``train.total_timesteps``: the ETA is measured per agent-step
    on the run's own slot layout, an evaluation step costs one per agent, rollouts hold
    n_steps x n_envs x agents, and the progress lines say agent-steps."""
    from pyflyt_cli.training.loop import _expected_end

    args = [
        "env=ma_quadx_hover",
        "algo=ppo",
        "env.agents=2",
        "algo.n_steps=32",
        "train.n_envs=1",
        "algo.batch_size=64",  # = 32 steps x 1 env x 2 agents: a valid rollout
        "algo.n_epochs=1",
        "train.total_timesteps=1000",
        "train.eval_freq=500",
        "train.eval_episodes=1",
    ]
    cfg = load(args, tmp_path)
    costs = measure_costs(cfg)
    assert costs is not None and costs.collect > 0 and costs.update > 0
    unit = Costs(collect=0.001, update=0.01)
    evals = 2 * cfg.env.max_steps * 2 * 0.001  # 2 evaluations x 1 episode x steps x 2 agents
    assert estimate_seconds(cfg, unit) == pytest.approx(1000 * 0.011 + evals)
    assert _expected_end(cfg) == 1024  # whole rollouts of 64 agent-steps
    with pytest.raises(Exception, match=r"n_steps x n_envs x 2 agents = 64"):
        load([*args, "algo.batch_size=128"], tmp_path)
    clock, model, lines = FakeClock(), SimpleNamespace(num_timesteps=0), []
    progress = ProgressLines(1024, lines.append, clock=clock, unit="agent-steps")
    _attach(progress, model)
    progress.on_training_start({}, {})
    clock.now += 30.0
    model.num_timesteps = 512
    progress.on_step()
    assert lines[0].startswith("agent-steps 512/1024 (50 %) | 17 agent-steps/s | elapsed 0:30 | ETA 0:30")


def test_one_compressed_replay_buffer_is_kept(tmp_path):
    run = train(load(TINY_SAC, tmp_path)).run_dir
    buffers = sorted((run / "checkpoints").glob("replay_buffer_*.npz"))
    assert [b.name for b in buffers] == ["replay_buffer_400_steps.npz"]  # the newest checkpoint's only
    with zipfile.ZipFile(buffers[0]) as archive:
        infos = archive.infolist()
    assert infos and all(i.compress_type == zipfile.ZIP_DEFLATED for i in infos)
    assert sum(i.compress_size for i in infos) < sum(i.file_size for i in infos)


def test_evaluation_steps_of_an_off_policy_run_with_n_step_returns_are_those_it_logs(tmp_path):
    """Off-policy ``algo.n_steps`` is the n-step return's length, not a rollout: a round of a SAC run on 4
    envs adds 4 steps, so a 3-step-return run is evaluated at the first multiple of 4 at or after each
    ``eval_freq`` (here 50 -> 52, 100, 150 -> 152, and the end 200), not of 3 x 4."""
    from pyflyt_cli.benchmark.plan import evaluation_steps
    from pyflyt_cli.training.loop import _expected_end
    from pyflyt_engine.telemetry import read_metrics

    overrides = [o for o in TINY_SAC if not o.startswith(("train.n_envs", "train.total_timesteps", "train.eval_freq"))]
    given = ["train.n_envs=4", "train.vec_env=dummy", "algo.n_steps=3", "algo.train_freq=1", "algo.gradient_steps=1"]
    budget = ["train.total_timesteps=200", "train.eval_freq=50", "train.eval_episodes=1", "train.checkpoint_freq=0"]
    cfg = load([*overrides, *given, *budget], tmp_path)
    planned = evaluation_steps(cfg.model_dump(mode="json"))
    assert planned == [52, 100, 152, 200] and _expected_end(cfg) == 200
    result = train(cfg)
    assert [e["step"] for e in read_metrics(result.run_dir)["/eval"]] == planned


def test_the_step_timer_adds_up_the_envs_steps_and_changes_nothing():
    import gymnasium
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize, unwrap_vec_wrapper

    from pyflyt_cli.training.timing import StepTimer

    class Ticking:  # one second per reading
        now = 0.0

        def __call__(self) -> float:
            self.now += 1.0
            return self.now

    def envs():
        vec = DummyVecEnv([lambda: gymnasium.make("CartPole-v1")] * 2)
        vec.seed(3)
        return vec

    plain, timer = envs(), StepTimer(envs(), clock=Ticking())
    wrapped = VecNormalize(timer)
    assert unwrap_vec_wrapper(wrapped, StepTimer) is timer
    assert np.array_equal(plain.reset(), timer.reset())
    actions = np.array([1, 0])
    for steps in range(1, 4):
        for a, b in zip(plain.step(actions), timer.step(actions)):
            assert np.array_equal(np.asarray(a, dtype=object), np.asarray(b, dtype=object))
        assert timer.seconds == 2.0 * steps  # step_async and step_wait: one second each


def test_a_run_accounts_its_parts_on_the_clock_it_is_given(tmp_path):
    """``train(..., clock=)``: the run's elapsed time, split and ledger read that clock (here one second per
    reading, so every interval is a positive whole number of readings); one ledger entry per checkpoint the
    run wrote (with the replay buffer's share and its transitions) and per evaluation it logged."""
    from pyflyt_engine.telemetry import read_metrics

    class Ticking:
        now = 0.0

        def __call__(self) -> float:
            self.now += 1.0
            return self.now

    clock = Ticking()
    result = train(load(TINY_SAC, tmp_path), clock=clock)
    costs = result.costs
    assert costs is not None and costs.clock is clock
    assert result.elapsed == costs.learn and costs.learn == int(costs.learn) > 0
    assert costs.startup == int(costs.startup) > 0
    # checkpoints at 200 and 400 (the end), each writing the whole buffer: 200 then 400 transitions of 1 env
    assert [c.transitions for c in costs.checkpoints] == [200, 400]
    for c in costs.checkpoints:
        assert c.seconds == int(c.seconds) and 0 < c.buffer_seconds < c.seconds
    # the evaluations at 200 and 400 (the final weights'): as many as the /eval records
    assert len(costs.evaluations) == len(read_metrics(result.run_dir)["/eval"]) == 2
    assert all(s == int(s) > 0 for s in costs.evaluations)
    # the split covers learn() (the final evaluation and checkpoint come after it) and reads the same clock
    assert set(costs.split) == {"collect", "update", "eval", "checkpoint"}
    assert all(v == int(v) >= 0 for v in costs.split.values()) and sum(costs.split.values()) <= costs.learn + 1
    assert costs.split["eval"] == costs.evaluations[0] + 2  # its two readings around the evaluation call


def test_one_time_work_of_the_first_env_step_is_not_charged_to_every_collected_step(tmp_path, monkeypatch):
    """The first step of a fresh env does work no later step repeats (the batched backend's laws
    compile on a fresh install: its ETA once said 18 hours for a 15-minute run).  The measuring copy
    steps its envs before it times anything: a first step that takes a second more adds nothing
    to the per-step cost of the 256 steps timed after it."""
    import time as _time

    from stable_baselines3.common.vec_env import DummyVecEnv

    real = DummyVecEnv.step_wait
    first = [True]

    def slow_first(self):
        if first[0]:
            first[0] = False
            _time.sleep(1.0)
        return real(self)

    monkeypatch.setattr(DummyVecEnv, "step_wait", slow_first)
    costs = measure_costs(load(TINY_PPO, tmp_path), seconds=0.0)  # one rollout: 256 collected steps
    assert not first[0]  # the slow step happened, in the copy's envs
    assert costs is not None and 0 < costs.collect < 1.0 / 256

"""``pyflyt tune``: an Optuna study over a search space from conf/, tiny trials.

Each trial is a real (tiny) PPO run; the search space of these tests is a small file so
the trials stay a few seconds each.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import optuna
import pytest
import yaml

from pyflyt_cli.training.compose import compose_config
from pyflyt_cli.training.tune import (
    _ReportEvaluations,
    load_search_space,
    overrides_of,
    tune,
)
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.paths import conf_dir

from .conftest import pyflyt

TRAIN = [
    "train.total_timesteps=256",
    "train.n_envs=1",
    "algo.n_steps=128",
    "algo.batch_size=64",
    "train.eval_freq=128",
    "train.eval_episodes=1",
    "train.checkpoint_freq=0",
    "train.progress_bar=false",
]


@pytest.fixture
def space(tmp_path: Path) -> Path:
    path = tmp_path / "space.yaml"
    path.write_text(
        "algo.learning_rate: {type: float, low: 1.0e-5, high: 1.0e-2, log: true}\n"
        "algo.n_epochs: {type: int, low: 1, high: 3}\n"
        "algo.policy_kwargs.net_arch: {type: categorical, choices: [[16], [32, 32]]}\n"
    )
    return path


def _options(study_dir: Path, space: Path, **extra) -> dict:
    return {"study_dir": str(study_dir), "space": str(space), "startup_trials": 1, **extra}


@pytest.fixture
def as_finding(monkeypatch):
    """Judge every study a finding whose parameters matter: to test the files a finding writes
    (tiny trials of one evaluation episode never are one; test_tune_verdict.py tests the rule)."""
    from pyflyt_cli.training import tune_verdict

    monkeypatch.setattr(tune_verdict.Verdict, "finding", property(lambda self: True))
    monkeypatch.setattr(tune_verdict.Verdict, "parameters_matter", property(lambda self: True))


def test_a_study_runs_continues_from_sqlite_and_writes_a_usable_best_file(tmp_path, space, as_finding):
    study_dir = tmp_path / "study"
    first = tune("quadx_hover", "ppo", _options(study_dir, space, trials=2), TRAIN)
    assert first.finished == 2 and first.ran == 2 and (study_dir / "study.db").is_file()
    assert sorted(p.name for p in (study_dir / "trials").iterdir()) == ["trial_0000", "trial_0001"]
    # the same command with a larger target continues the stored study
    again = tune("quadx_hover", "ppo", _options(study_dir, space, trials=3), TRAIN)
    assert again.finished == 3 and again.ran == 1
    with open(study_dir / "trials.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert [r["number"] for r in rows] == ["0", "1", "2"]
    assert {r["algo.policy_kwargs.net_arch"] for r in rows} <= {"[16]", "[32, 32]"}
    # the best settings: a conf/hparams-style file that pyflyt train takes as an experiment
    best = yaml.safe_load(again.best_file.read_text())
    assert set(best["algo"]) == {"learning_rate", "n_epochs", "policy_kwargs"}
    assert again.best_file.read_text().startswith("# @package _global_")
    cfg = compose_config(env="quadx_hover", algo="ppo", overrides=[*TRAIN, f"experiment={again.best_file}"])
    assert cfg.algo.learning_rate == best["algo"]["learning_rate"] and cfg.algo.n_epochs == best["algo"]["n_epochs"]
    assert cfg.algo.policy_kwargs.net_arch == best["algo"]["policy_kwargs"]["net_arch"]
    study = optuna.load_study(study_name="quadx_hover_ppo", storage=again.storage)
    assert again.best_value == max(t.value for t in study.trials if t.value is not None)
    assert {p.name for p in again.plots} == {"history.png", "importance.png"}
    assert all(p.stat().st_size > 0 for p in again.plots)


def test_the_same_seed_samples_the_same_trials_with_the_same_results(tmp_path, space):
    runs = [tune("quadx_hover", "ppo", _options(tmp_path / name, space, trials=2), TRAIN) for name in ("a", "b")]
    studies = [optuna.load_study(study_name="quadx_hover_ppo", storage=r.storage) for r in runs]
    assert [t.params for t in studies[0].trials] == [t.params for t in studies[1].trials]
    assert [t.value for t in studies[0].trials] == [t.value for t in studies[1].trials]
    other = tune("quadx_hover", "ppo", _options(tmp_path / "c", space, trials=1, sampler_seed=7), TRAIN)
    third = optuna.load_study(study_name="quadx_hover_ppo", storage=other.storage)
    assert third.trials[0].params != studies[0].trials[0].params


@pytest.mark.slow  # spawns two worker processes: tens of seconds
def test_parallel_trials_run_in_separate_processes(tmp_path, space):
    report = tune("quadx_hover", "ppo", _options(tmp_path / "jobs", space, trials=2, jobs=2), TRAIN)
    assert report.finished >= 2
    study = optuna.load_study(study_name="quadx_hover_ppo", storage=report.storage)
    states = {t.state for t in study.trials}
    assert states <= {optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED}


@pytest.mark.slow  # five trials
def test_a_trial_below_the_median_of_the_others_is_pruned_on_its_evaluation_curve(tmp_path, space):
    report = tune("quadx_hover", "ppo", _options(tmp_path / "prune", space, trials=5, startup_trials=1), TRAIN)
    study = optuna.load_study(study_name="quadx_hover_ppo", storage=report.storage)
    complete = optuna.trial.TrialState.COMPLETE
    pruned = [t for t in study.trials if t.state == optuna.trial.TrialState.PRUNED]
    assert pruned  # (same seeds: the same trials are pruned every time)

    def best_until(trial, step):  # Optuna's median pruner compares a trial's best value so far
        return max(v for s, v in trial.intermediate_values.items() if s <= step)

    for t in pruned:  # each was behind the median of the trials completed before it, at its last reported step
        step = max(t.intermediate_values)
        earlier = [
            best_until(u, step)
            for u in study.trials
            if u.number < t.number and u.state == complete and step in u.intermediate_values
        ]
        assert earlier and best_until(t, step) < np.median(earlier)
        assert step < 256  # stopped at an evaluation before the end of its budget


def test_the_report_callback_stops_the_run_when_the_pruner_says_so():
    class Trial:
        def __init__(self, prune_after: int) -> None:
            self.reported: list = []
            self.prune_after = prune_after

        def report(self, value: float, step: int) -> None:
            self.reported.append((step, value))

        def should_prune(self) -> bool:
            return len(self.reported) >= self.prune_after

    trial = Trial(prune_after=2)
    callback = _ReportEvaluations(trial)
    callback.model = SimpleNamespace(num_timesteps=0)
    callback.parent = SimpleNamespace(num_timesteps=128, last_mean_reward=-5.0)
    assert callback.on_step() is True and callback.pruned_at is None
    callback.parent = SimpleNamespace(num_timesteps=256, last_mean_reward=-4.0)
    assert callback.on_step() is False and callback.pruned_at == 256
    assert trial.reported == [(128, -5.0), (256, -4.0)]


def test_every_shipped_search_space_fits_its_algorithm():
    for path in sorted((conf_dir() / "search_space").glob("*.yaml")):
        space = load_search_space(path.stem, path.stem)
        for corner in space.corners():
            compose_config(env="quadx_hover", algo=path.stem, overrides=overrides_of(corner))


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("algo.learning_rate: {type: float, low: 1.0, high: 0.1}", "needs low < high"),
        ("algo.learning_rate: {type: float, low: 0.0, high: 0.1, log: true}", "needs low > 0"),
        ("algo.batch_size: {type: categorical, choices: []}", "non-empty list of choices"),
        ("algo.batch_size: {type: normal, low: 1, high: 2}", "algo.batch_size.type"),
        ("algo.no_such_key: {type: int, low: 1, high: 2}", "no_such_key"),
    ],
)
def test_a_bad_search_space_is_one_message_naming_the_key(tmp_path, text, message):
    path = tmp_path / "bad.yaml"
    path.write_text(text + "\n")
    with pytest.raises(ConfigError, match=message):
        tune("quadx_hover", "ppo", {"space": str(path), "study_dir": str(tmp_path / "s")}, TRAIN)


def test_the_command_line(tmp_path, space):
    missing = pyflyt(["tune", "env=quadx_hover", "trials=1"], cwd=tmp_path)
    assert missing.returncode == 2 and "needs env=<task> and algo=<algorithm>" in missing.stderr
    bad = pyflyt(["tune", "env=quadx_hover", "algo=ppo", "trials=0"], cwd=tmp_path)
    assert bad.returncode == 2 and "trials" in bad.stderr and "Traceback" not in bad.stderr
    done = pyflyt(
        ["tune", "env=quadx_hover", "algo=ppo", "trials=1", f"space={space}", "study_dir=s", *TRAIN], cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr
    # one evaluation episode per trial: no spread, so no finding, no recommendation, no importance
    assert "no finding: with one evaluation episode per trial" in done.stderr and "random policy" in done.stderr
    assert "best settings:" not in done.stderr and "pyflyt train env=" not in done.stderr
    assert not (tmp_path / "s" / "best_quadx_hover_ppo.yaml").exists()
    assert not (tmp_path / "s" / "importance.png").exists()


def test_a_new_study_starts_with_the_configuration_as_composed(tmp_path):
    """The baseline trial: trial 0 trains the composed configuration's own values (the shipped
    hover PPO tuning here); a space that cannot hold them skips it, saying which key."""
    cfg = compose_config(env="quadx_hover", algo="ppo", overrides=TRAIN)
    inside = tmp_path / "inside.yaml"
    inside.write_text(
        "algo.learning_rate: {type: float, low: 1.0e-5, high: 1.0e-2, log: true}\n"
        "algo.gamma: {type: categorical, choices: [0.9, 0.95, 0.99]}\n"
        "algo.policy_kwargs.net_arch: {type: categorical, choices: [[16], [64, 64]]}\n"
    )
    messages: list[str] = []
    report = tune("quadx_hover", "ppo", _options(tmp_path / "a", inside, trials=1), TRAIN, log=messages.append)
    first = yaml.safe_load((report.study_dir / "trials" / "trial_0000" / "run.yaml").read_text())["overrides"]
    assert f"algo.learning_rate={cfg.algo.learning_rate}" in first
    assert f"algo.gamma={cfg.algo.gamma}" in first and "algo.policy_kwargs.net_arch=[64,64]" in first
    assert any("baseline" in m for m in messages)
    # the verdict compares against the baseline trial and a random policy on the same episodes
    assert report.verdict.baseline is not None and report.verdict.baseline.label == "trial 0"
    assert math.isfinite(report.verdict.random.mean) and report.verdict.random.n == 1
    assert any(m.startswith("random policy: ") for m in messages)

    outside = tmp_path / "outside.yaml"
    outside.write_text("algo.gamma: {type: categorical, choices: [0.9, 0.99]}\n")
    messages.clear()
    tune("quadx_hover", "ppo", _options(tmp_path / "b", outside, trials=1), TRAIN, log=messages.append)
    assert any("baseline trial skipped" in m and "algo.gamma=0.95" in m for m in messages), messages


@pytest.mark.parametrize("url", ["sqlite:///study.db", "postgresql://host/db", "mysql+pymysql://u@h/d"])
def test_a_study_dir_that_looks_like_a_database_url_is_refused_with_the_hint(tmp_path, monkeypatch, url):
    """The reproduction: study_dir=sqlite:///... made a directory named 'sqlite:'."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match="looks like a database URL; give a directory"):
        tune("quadx_hover", "ppo", {"study_dir": url}, TRAIN)
    assert list(tmp_path.iterdir()) == []

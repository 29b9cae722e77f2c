"""The sb3-contrib algorithms (TQC, CrossQ, TRPO, RecurrentPPO) through the run machinery:
a tiny run, its evaluation, and an interrupted run resumed bit-identical to the uninterrupted one.
"""

from __future__ import annotations

import pytest

from pyflyt_cli.training import evaluate_run, resume, train
from pyflyt_cli.training.models import read_policy
from pyflyt_engine.errors import ConfigError

from tests.conftest import default_subset

from .conftest import load
from .test_resume import SignalAt, _assert_same, _outcome

COMMON = [
    "env=quadx_hover",
    "train.eval_freq=128",
    "train.eval_episodes=1",
    "train.checkpoint_freq=128",
    "train.progress_bar=false",
]
OFF = ["algo.buffer_size=2000", "algo.learning_starts=64", "algo.batch_size=32", "algo.policy_kwargs.net_arch=[32,32]"]
RUNS = {
    "tqc": ["algo=tqc", "train.total_timesteps=300", *OFF, "algo.policy_kwargs.n_quantiles=5"],
    "crossq": ["algo=crossq", "train.total_timesteps=300", *OFF, "algo.policy_kwargs.batch_norm_momentum=0.05"],
    "trpo": ["algo=trpo", "train.total_timesteps=384", "algo.n_steps=64", "algo.batch_size=32", "algo.use_sde=true"],
    # two envs: the LSTM states of both are carried across the resume
    "recurrent_ppo": [
        "algo=recurrent_ppo",
        "train.total_timesteps=384",
        "train.n_envs=2",
        "train.vec_env=dummy",
        "algo.n_steps=32",
        "algo.batch_size=32",
        "algo.n_epochs=2",
        "algo.policy_kwargs.lstm_hidden_size=16",
        "algo.policy_kwargs.net_arch=[16]",
    ],
}


@pytest.mark.parametrize("algo", default_subset(sorted(RUNS), lambda algo: algo == "recurrent_ppo"))
def test_a_contrib_algorithm_trains_evaluates_and_resumes_exactly(tmp_path, algo):
    overrides = [*COMMON, *RUNS[algo]]
    reference_run = train(load(overrides, tmp_path / "reference")).run_dir
    reference = _outcome(reference_run)
    assert read_policy(reference_run / "model.pt").algo == algo
    report = evaluate_run(reference_run, {"episodes": 2, "model": "final", "record": False})
    assert len(report.episodes) == 2 and all(e.length > 0 for e in report.episodes)
    # pyflyt eval of the final model reproduces the training's last evaluation (same seed, same policy)
    last = reference["evals"][-1]
    again = evaluate_run(reference_run, {"episodes": 1, "model": "final", "record": False})
    assert again.summary["mean_return"] == last[1]

    first = train(load(overrides, tmp_path / "interrupted"), callbacks=[SignalAt(150)])
    assert first.interrupted
    assert not resume(first.run_dir).interrupted
    _assert_same(_outcome(first.run_dir), reference)


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        (["algo=sac", "+algo.policy_kwargs.n_quantiles=5"], "policy_kwargs.n_quantiles applies to tqc only"),
        (["algo=ppo", "algo.policy=MlpLstmPolicy"], "is not one of ppo's"),
        (["algo=recurrent_ppo", "algo.policy=MlpPolicy"], "is not one of recurrent_ppo's"),
        (["algo=crossq", "algo.tau=0.005"], "algo.tau"),
        (["algo=tqc", "algo.ent_coef=auto_x"], "the part after auto_ must be a number"),
        (["algo=trpo", "algo.n_steps=1"], "at least 2 for trpo"),
        (["algo=tqc", "algo.top_quantiles_to_drop_per_net=-1"], "top_quantiles_to_drop_per_net"),
    ],
)
def test_contrib_settings_are_checked(tmp_path, overrides, message):
    with pytest.raises(ConfigError, match=message):
        load(overrides, tmp_path)

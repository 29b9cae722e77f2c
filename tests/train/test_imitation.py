"""``train.imitation``: DAgger from a scripted oracle before reinforcement learning.

Oracles: the mixing schedule evaluated by hand; the oracle's actions mapped into the
agent's [-1, 1] action units by hand; the fit measured against the oracle's own labels
(the policy's deterministic action must move most of the way to the oracle's on the
states it flew); a run repeated with the same seed gives the same weights; a resumed run
does not imitate again and ends as the uninterrupted one; bad settings fail before
anything runs, naming the key.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import torch as th

from pyflyt_cli.errors import UsageError
from pyflyt_cli.training import resume, train
from pyflyt_cli.training.envs import EnvFactory
from pyflyt_cli.training.imitation import IMITATION_SEED_OFFSET, agent_units, imitate, oracle_share
from pyflyt_cli.training.models import read_policy
from pyflyt_cli.training.schema import ImitationOptions
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.oracles import make_oracle
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.telemetry import read_metrics

from .conftest import load
from .test_resume import SignalAt

#: one DAgger round after the oracle's, two episodes each, then 256 PPO steps
TINY_IMITATION = [
    "env=rocket_landing",
    "algo=ppo",
    "train.total_timesteps=256",
    "algo.n_steps=256",
    "algo.batch_size=64",
    "algo.n_epochs=1",
    "train.eval_freq=256",
    "train.eval_episodes=1",
    "train.checkpoint_freq=0",
    "train.progress_bar=false",
    "train.imitation.oracle=rocket_lander",
    "train.imitation.rounds=1",
    "train.imitation.episodes=2",
    "train.imitation.epochs=3",
]


def _rocket_env():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return EnvFactory(load_env_config("rocket_landing"), monitor=False)()


def test_the_oracle_share_falls_linearly_from_mixing_after_the_oracles_round():
    assert oracle_share(0, 4, 0.5) == 1.0  # round 0: the oracle alone
    assert [oracle_share(k, 4, 0.5) for k in (1, 2, 3, 4)] == pytest.approx([0.5, 0.375, 0.25, 0.125])
    assert oracle_share(1, 1, 0.8) == pytest.approx(0.8)
    assert oracle_share(3, 4, 0.0) == 0.0


def test_the_oracles_actions_are_mapped_into_the_agents_units():
    env = _rocket_env()
    try:
        assert np.allclose(env.action_space.low, -1.0) and np.allclose(env.action_space.high, 1.0)
        to_agent = agent_units(env)
        # fins and gimbals are in [-1, 1] already; ignition and throttle [0, 1] -> [-1, 1]
        env_units = np.array([0.5, -1.0, 0.0, 1.0, 0.25, 1.0, -0.2])
        np.testing.assert_allclose(to_agent(env_units), [0.5, -1.0, 0.0, 1.0, -0.5, 1.0, -0.2])
        np.testing.assert_allclose(to_agent(np.zeros(7))[3:5], [-1.0, -1.0])
    finally:
        env.close()


def _oracle_flight(env, seed):
    """States of one oracle-flown episode and the oracle's actions there, in the agent's units."""
    oracle, to_agent = make_oracle("rocket_lander", env), agent_units(env)
    obs, _ = env.reset(seed=seed)
    states, labels, done = [], [], False
    while not done:
        act = to_agent(oracle(obs))
        states.append(obs)
        labels.append(act)
        obs, _, terminated, truncated, _ = env.step(act)
        done = terminated or truncated
    return np.array(states, dtype=np.float32), np.array(labels, dtype=np.float32)


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_the_fit_brings_the_policy_to_the_oracle_on_the_states_flown(algo):
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.vec_env import DummyVecEnv

    th.manual_seed(0)
    threads = th.get_num_threads()
    th.set_num_threads(1)  # as training runs (train.torch_threads): small networks are slower on more
    env = _rocket_env()
    try:
        vec = DummyVecEnv([_rocket_env])
        small = {"policy_kwargs": {"net_arch": [64, 64]}}  # PPO's default size
        model = (PPO if algo == "ppo" else SAC)(
            "MlpPolicy", vec, seed=0, device="cpu", **small, **({"buffer_size": 10} if algo == "sac" else {})
        )
        options = ImitationOptions(
            oracle="rocket_lander", rounds=0, episodes=1, mixing=0.5, epochs=60, batch_size=32, learning_rate=1e-3
        )
        states, labels = _oracle_flight(env, seed=IMITATION_SEED_OFFSET)  # the flight round 0 will fly

        def error() -> float:
            actions = np.array([model.policy.predict(s, deterministic=True)[0] for s in states])
            return float(np.mean((actions - labels) ** 2))

        before = error()
        rounds = imitate(model, env, options, seed=0, log=lambda _: None)
        after = error()
        vec.close()
    finally:
        env.close()
        th.set_num_threads(threads)
    assert len(rounds) == 1 and rounds[0].oracle_share == 1.0 and rounds[0].samples == len(states) > 300
    assert after < 0.3 * before, (before, after)


@pytest.mark.long
def test_a_run_imitates_then_learns_records_each_round_and_repeats_exactly(tmp_path):
    first = train(load(TINY_IMITATION, tmp_path / "a"))
    second = train(load(TINY_IMITATION, tmp_path / "b"))
    rounds = read_metrics(first.run_dir)["/imitation"]
    assert [r["step"] for r in rounds] == [0, 1]
    assert [r["oracle_share"] for r in rounds] == [1.0, 0.5]
    assert rounds[0]["success_rate"] == 1.0  # the oracle lands both of its drops
    assert rounds[1]["samples"] == rounds[0]["samples"] + rounds[1]["steps"]
    again = read_metrics(second.run_dir)["/imitation"]
    for a, b in zip(rounds, again, strict=True):
        assert {k: v for k, v in a.items() if k not in ("seconds", "wall_time")} == {
            k: v for k, v in b.items() if k not in ("seconds", "wall_time")
        }
    a, b = _final(first.run_dir), _final(second.run_dir)
    assert a["evals"] == b["evals"]
    # the imitated policy is evaluated before learning (step 0), then at the end (256)
    assert [step for step, _ in a["evals"]] == [0, 256]
    for key, value in a["policy"].items():
        assert th.equal(b["policy"][key], value), key


@pytest.mark.long
def test_a_resumed_run_does_not_imitate_again_and_ends_as_the_uninterrupted_one(tmp_path, tmp_path_factory):
    overrides = [*TINY_IMITATION, "train.total_timesteps=512", "algo.normalize.observation=true"]
    reference = _final(train(load(overrides, tmp_path_factory.mktemp("reference"))).run_dir)
    first = train(load(overrides, tmp_path), callbacks=[SignalAt(100)])
    assert first.interrupted and first.num_timesteps == 256
    lines: list[str] = []
    resume(first.run_dir, log=lines.append)
    assert not any("imitation" in line for line in lines)
    assert len(read_metrics(first.run_dir)["/imitation"]) == 2
    resumed = _final(first.run_dir)
    assert resumed["evals"] == reference["evals"] and [step for step, _ in reference["evals"]] == [0, 256, 512]
    assert reference["obs_rms"]["count"] > 512 + 1000  # 512 PPO steps, and the imitation's ~2 000 observations
    for part in ("policy", "obs_rms"):
        assert resumed[part].keys() == reference[part].keys()
        for key, value in reference[part].items():
            same = th.equal(resumed[part][key], value) if isinstance(value, th.Tensor) else resumed[part][key] == value
            assert same, (part, key)


def _final(run_dir) -> dict:
    """The final weights, observation statistics and evaluations of a run."""
    final = read_policy(run_dir / "model.pt")
    evals = [(r["step"], r["mean_return"]) for r in read_metrics(run_dir)["/eval"]]
    obs_rms = final.normalizer["obs_rms"] if final.normalizer is not None else None
    return {"policy": final.policy, "obs_rms": obs_rms, "evals": evals}


@pytest.mark.parametrize(
    ("override", "names"),
    [
        ("train.imitation.oracle=lander", ["train.imitation.oracle", "unknown oracle 'lander'", "rocket_lander"]),
        ("train.imitation.rounds=-1", ["train.imitation.rounds", "greater than or equal to 0"]),
        ("train.imitation.mixing=1.5", ["train.imitation.mixing", "less than or equal to 1"]),
        ("train.imitation.epoch=3", ["train.imitation.epoch", "epochs"]),
        ("algo=recurrent_ppo", ["train.imitation cannot fit a recurrent_ppo policy"]),
        ("env=quadx_hover", ["rocket_lander flies PyFlyt/Rocket-Landing-v0, not PyFlyt/QuadX-Hover-v0"]),
    ],
)
def test_bad_imitation_settings_fail_before_anything_runs_naming_the_key(tmp_path, override, names):
    with pytest.raises((UsageError, ConfigError)) as info:  # unknown keys: at composition; bad values: the schema
        load([*TINY_IMITATION, override], tmp_path)
    for name in names:
        assert name in str(info.value), str(info.value)
    assert not (tmp_path / "runs").exists()


def test_no_oracle_no_imitation_and_the_same_identity_as_runs_made_before_the_key(tmp_path):
    """The default (train.imitation.oracle=null) learns from scratch, with no /imitation record,
    and is the run a config without the key describes (a benchmark must not see it as changed)."""
    from pyflyt_cli.training.rundir import config_dict, identity
    from pyflyt_cli.training.schema import parse_train_config

    cfg = load([*TINY_IMITATION, "train.imitation.oracle=null", "env=quadx_hover"], tmp_path)
    assert cfg.train.imitation is None
    older = config_dict(cfg)
    del older["train"]["imitation"]
    assert identity(parse_train_config(older)) == identity(cfg)
    assert "/imitation" not in read_metrics(train(cfg).run_dir)


class _Snapshots:
    """Copies of the actor's and the value network's weights when learning starts and after each
    update (at the start of the next rollout, and at the end)."""

    def __init__(self) -> None:
        from stable_baselines3.common.callbacks import BaseCallback

        from pyflyt_cli.training.callbacks import ValueWarmup

        taken: list[tuple[int, list[th.Tensor], list[th.Tensor]]] = []
        self.taken = taken

        class Take(BaseCallback):
            def snap(self) -> None:
                policy = self.model.policy
                actor = [p.detach().clone() for p in ValueWarmup.actor_parameters(policy)]
                value = [p.detach().clone() for p in policy.value_net.parameters()]
                value += [p.detach().clone() for p in policy.mlp_extractor.value_net.parameters()]
                taken.append((self.num_timesteps, actor, value))

            def _on_training_start(self) -> None:
                self.snap()

            def _on_rollout_start(self) -> None:
                if self.num_timesteps > 0:
                    self.snap()

            def _on_training_end(self) -> None:
                self.snap()

            def _on_step(self) -> bool:
                return True

        self.callback = Take()


def _same(a: list[th.Tensor], b: list[th.Tensor]) -> bool:
    return len(a) == len(b) and all(th.equal(x, y) for x, y in zip(a, b))


@pytest.mark.long
def test_the_value_warmup_holds_the_imitated_policy_while_the_value_function_learns(tmp_path):
    """value_warmup=256 with 256-step rollouts: the first update (after step 256) changes the value
    network and not the actor (network, action head, log std); the second (after 512) both."""
    lines: list[str] = []
    snapshots = _Snapshots()
    overrides = [*TINY_IMITATION, "train.total_timesteps=512", "train.imitation.value_warmup=256"]
    train(load(overrides, tmp_path), callbacks=[snapshots.callback], log=lines.append)
    steps = [step for step, _, _ in snapshots.taken]
    assert steps == [0, 256, 512], steps
    (_, actor0, value0), (_, actor1, value1), (_, actor2, _) = snapshots.taken
    assert len(actor0) > 2  # the actor's layers and the log std
    assert _same(actor0, actor1) and not _same(value0, value1)
    assert not _same(actor1, actor2)
    assert any("value warm-up: the policy is held until step 256" in line for line in lines)
    assert any("value warm-up done at step 512" in line for line in lines)


def test_the_value_warmup_is_refused_where_it_cannot_hold_the_policy_and_is_no_change_at_zero(tmp_path):
    from pyflyt_cli.training.rundir import config_dict, identity
    from pyflyt_cli.training.schema import parse_train_config

    for algo in ("sac", "trpo"):
        with pytest.raises((UsageError, ConfigError)) as info:
            load(
                [
                    "env=rocket_landing",
                    f"algo={algo}",
                    "train.imitation.oracle=rocket_lander",
                    "train.imitation.value_warmup=100",
                ],
                tmp_path,
            )
        assert "train.imitation.value_warmup" in str(info.value) and f"not {algo}" in str(info.value), str(info.value)
    with pytest.raises((UsageError, ConfigError)) as info:
        load([*TINY_IMITATION, "train.imitation.value_warmup=-1"], tmp_path)
    assert "train.imitation.value_warmup" in str(info.value)
    # a run made before the key (no value_warmup in its config) is the same run as value_warmup=0
    cfg = load(TINY_IMITATION, tmp_path)
    assert cfg.train.imitation.value_warmup == 0
    older = config_dict(cfg)
    del older["train"]["imitation"]["value_warmup"]
    assert identity(parse_train_config(older)) == identity(cfg)
    warm = load([*TINY_IMITATION, "train.imitation.value_warmup=256"], tmp_path)
    assert identity(warm) != identity(cfg)


class _Statistics:
    """The observation normaliser's mean and count when learning starts and when it ends."""

    def __init__(self) -> None:
        from stable_baselines3.common.callbacks import BaseCallback

        seen: list[tuple[np.ndarray, float]] = []
        self.seen = seen

        class Look(BaseCallback):
            def look(self) -> None:
                rms = self.model.get_vec_normalize_env().obs_rms
                seen.append((rms.mean.copy(), float(rms.count)))

            def _on_training_start(self) -> None:
                self.look()

            def _on_training_end(self) -> None:
                self.look()

            def _on_step(self) -> bool:
                return True

        self.callback = Look()


@pytest.mark.long
@pytest.mark.parametrize("hold", [True, False])
def test_hold_normalizer_keeps_the_imitations_observation_statistics(tmp_path, hold):
    """With hold_normalizer the statistics the policy was fitted on (the imitation's ~2 000
    observations) stay as they were through 512 learning steps; without it they take in the
    learner's observations (the count grows by 512)."""
    statistics = _Statistics()
    overrides = [
        *TINY_IMITATION,
        "train.total_timesteps=512",
        "algo.normalize.observation=true",
        f"train.imitation.hold_normalizer={str(hold).lower()}",
    ]
    lines: list[str] = []
    run = train(load(overrides, tmp_path), callbacks=[statistics.callback], log=lines.append)
    (start_mean, start_count), (end_mean, end_count) = statistics.seen
    assert start_count > 1000  # the imitation's observations
    if hold:
        assert end_count == start_count and np.array_equal(end_mean, start_mean)
        assert any("observation statistics held" in line for line in lines)
        saved = read_policy(run.run_dir / "model.pt").normalizer["obs_rms"]
        assert saved["count"] == start_count  # what the model file keeps, and evaluations use
    else:
        assert end_count == pytest.approx(start_count + 512) and not np.array_equal(end_mean, start_mean)


@pytest.mark.long
def test_a_resumed_run_holds_the_statistics_and_the_policy_as_the_uninterrupted_one(tmp_path, tmp_path_factory):
    overrides = [
        *TINY_IMITATION,
        "train.total_timesteps=768",
        "algo.normalize.observation=true",
        "train.imitation.hold_normalizer=true",
        "train.imitation.value_warmup=256",
    ]
    reference = _final(train(load(overrides, tmp_path_factory.mktemp("reference"))).run_dir)
    first = train(load(overrides, tmp_path), callbacks=[SignalAt(100)])
    assert first.interrupted and first.num_timesteps == 256
    resume(first.run_dir)
    resumed = _final(first.run_dir)
    assert resumed["evals"] == reference["evals"]
    for part in ("policy", "obs_rms"):
        for key, value in reference[part].items():
            same = th.equal(resumed[part][key], value) if isinstance(value, th.Tensor) else resumed[part][key] == value
            assert same, (part, key)


def test_hold_normalizer_without_observation_normalisation_is_refused(tmp_path):
    with pytest.raises((UsageError, ConfigError)) as info:
        load([*TINY_IMITATION, "algo.normalize.observation=false", "train.imitation.hold_normalizer=true"], tmp_path)
    assert "train.imitation.hold_normalizer" in str(info.value) and "algo.normalize.observation" in str(info.value)

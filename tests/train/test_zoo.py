"""Shipped agents: a run made into a zoo agent, listed, and flown by pyflyt eval zoo:<name> with the
recorded return; every agent shipped in the package reproduces its recorded evaluation."""

from __future__ import annotations

import pytest
import yaml

from pyflyt_cli import zoo
from pyflyt_cli.training import compose_config, evaluate_run, train
from pyflyt_cli.training.models import read_policy
from pyflyt_cli.training.rundir import config_digest, load_run_config
from pyflyt_engine.errors import ConfigError

from .conftest import TINY_PPO, load, pyflyt


def test_a_run_becomes_an_agent_whose_evaluation_reproduces_the_record(tmp_path):
    run = train(load(TINY_PPO, tmp_path / "runs")).run_dir
    root = tmp_path / "agents"
    made = zoo.add_agent(run, episodes=3, root=root)
    assert made.name == "quadx_hover_ppo"
    assert sorted(p.name for p in made.path.iterdir()) == [
        "config.yaml",
        "learning_curve.png",
        "model.pt",
        "summary.yaml",
    ]
    summary = yaml.safe_load((made.path / "summary.yaml").read_text())
    assert summary["algo"] == "ppo" and summary["seed"] == 0 and summary["training"]["steps"] == 512
    # the command that trains it names the env, algorithm and seed even for a run started from Python
    words = summary["training"]["command"].split()
    assert words[:2] == ["pyflyt", "train"] and {"env=quadx_hover", "algo=ppo", "seed=0"} <= set(words)
    # ... and every setting it was trained with: the command composes the run's configuration exactly
    assert "train.total_timesteps=512" in words and "algo.n_steps=256" in words
    assert config_digest(compose_config(overrides=words[2:])) == config_digest(load_run_config(run))
    assert summary["training"]["ran"]  # the command line of the process that trained it
    assert read_policy(made.path / "model.pt").algo == "ppo"
    assert "quadx_hover_ppo" in zoo.table(root)
    copy = zoo.materialise("quadx_hover_ppo", tmp_path / "work", root=root)
    again = evaluate_run(copy, {"episodes": 3, "record": False})
    assert [e.ret for e in again.episodes] == summary["evaluation"]["returns"]
    assert again.summary["mean_return"] == summary["evaluation"]["mean_return"]

    # shipping a run again under a taken name keeps the shipped agent, unless replaced
    before = {f.name: f.read_bytes() for f in made.path.iterdir()}
    with pytest.raises(ConfigError, match="--replace"):
        zoo.add_agent(run, episodes=2, root=root)
    assert {f.name: f.read_bytes() for f in made.path.iterdir()} == before
    assert sorted(p.name for p in root.iterdir()) == ["quadx_hover_ppo"]  # no staging folder left
    replaced = zoo.add_agent(run, episodes=2, root=root, replace=True)
    assert yaml.safe_load((replaced.path / "summary.yaml").read_text())["evaluation"]["episodes"] == 2
    assert sorted(p.name for p in root.iterdir()) == ["quadx_hover_ppo"]

    # from the command line: the package's own quadx_hover_ppo is taken, and stays as shipped
    shipped = zoo.agent("quadx_hover_ppo").path
    files = {f.name: f.read_bytes() for f in shipped.iterdir()}
    done = pyflyt(["zoo", "--add", str(run)], cwd=tmp_path)
    assert done.returncode == 2 and "exists" in done.stderr and "--replace" in done.stderr, done.stderr
    assert {f.name: f.read_bytes() for f in shipped.iterdir()} == files
    alone = pyflyt(["zoo", "--replace"], cwd=tmp_path)
    assert alone.returncode == 2 and "--add" in alone.stderr, alone.stderr


#: agents whose recorded evaluation flies in seconds (10 hover episodes of 300 steps); the
#: waypoint and landing agents' episodes run to thousands of steps: slow
QUICK = {"quadx_hover_ppo"}


@pytest.mark.parametrize("name", [a.name for a in zoo.agents()])
def test_a_shipped_agent_s_command_still_composes_its_configuration(name):
    """The documented command of every shipped agent trains its configuration with today's
    defaults: a changed tuning (conf/hparams) must come with the override that restores it."""
    from pyflyt_cli.training.compose import COMMAND_KEYS

    agent = zoo.agent(name)
    words = agent.summary["training"]["command"].split()
    assert words[:2] == ["pyflyt", "train"]
    settings = [w for w in words[2:] if w.split("=", 1)[0] not in COMMAND_KEYS]
    assert config_digest(compose_config(overrides=settings)) == config_digest(load_run_config(agent.path), agent.path)


@pytest.mark.parametrize(
    "name", [pytest.param(a.name, marks=() if a.name in QUICK else pytest.mark.slow) for a in zoo.agents()]
)
def test_a_shipped_agent_flies_its_recorded_return_from_the_command_line(tmp_path, name):
    recorded = zoo.agent(name).summary["evaluation"]
    result = pyflyt(["eval", f"zoo:{name}", f"episodes={recorded['episodes']}", "record=false"], cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "(matches episode by episode)" in result.stdout, result.stdout
    assert "mini-batch" not in result.stderr  # an on-policy run's minibatch does not concern flying it
    assert not list(zoo.agent(name).path.glob("eval.json"))  # the shipped folder is not written


def test_an_agent_of_a_run_without_evaluations_gets_its_training_curve(tmp_path):
    """A run trained with train.eval_freq=0 has no /eval records: the agent's figure shows its
    training episodes' returns (and says so) rather than an empty plot."""
    from pyflyt_cli.zoo import _learning_curve

    cfg = load([*TINY_PPO, "train.eval_freq=0"], tmp_path / "runs")
    run = train(cfg).run_dir
    assert _learning_curve(run, tmp_path / "curve.png", "t") == "training episode return"
    made = zoo.add_agent(run, episodes=1, root=tmp_path / "agents")  # and --add draws it without failing
    assert (made.path / "learning_curve.png").is_file()


def test_returns_that_are_not_bit_identical_are_judged_by_where_they_were_recorded():
    """Episode by episode equality matches; otherwise, on the numeric platform the agent
    was recorded on, a difference is a change of the engine or policy (DIFFERS), and on
    another one the returns are judged by a statistical test, never DIFFERS for the
    platform alone."""
    from pyflyt_cli.training import rundir

    here = rundir.numeric_platform()["key"]
    elsewhere = {**here, "numerics": "native", "cpu": "Intel(R) Xeon(R) Gold 6338"}
    returns = [-11.2, -17.4, -11.9, -13.9, -16.5, -20.3, -11.8, -15.3, -13.0, -14.3]
    record = {"returns": returns, "success_rate": 1.0, "numerics": {"key": here}}
    assert zoo.compare(record, list(returns), 1.0) == (True, "matches episode by episode")
    nudged = [r + 1e-9 for r in returns]
    agrees, words = zoo.compare(record, nudged, 1.0)
    assert not agrees and words.startswith("DIFFERS episode by episode on the numeric platform it was recorded on")
    record["numerics"] = {"key": elsewhere}
    agrees, words = zoo.compare(record, nudged, 1.0)
    assert agrees and words.startswith("recorded under another numeric platform (cpu Intel(R) Xeon(R) Gold 6338 -> -;")
    assert (
        "not bit-identical here, consistent with the recording (mean +0.00, success 100 % vs 100 %, Mann-Whitney p = 0.73)"
        in words
    )
    agrees, words = zoo.compare(record, [r - 30.0 for r in returns], 0.0)
    assert (
        not agrees
        and "inconsistent with the recording (mean -30.00, success 0 % vs 100 %, Mann-Whitney p = 0.00)" in words
    )
    assert "DIFFERS" not in words

"""Every command, fed one misspelling, names the closest existing name (one machinery,
:mod:`pyflyt_engine.suggest`), exits 2 and leaves nothing behind.

Oracle: the name the misspelling was made from, and that nothing was written in the
working folder.
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from pyflyt_cli.main import app
from pyflyt_engine.suggest import closest, did_you_mean

runner = CliRunner()


def _cases(tmp):
    run = tmp / "runs" / "quadx_hover" / "ppo" / "20261201-101010-seed0"
    run.mkdir(parents=True)
    (run / "config.yaml").write_text("{}\n")  # enough for the key check, which comes first
    (run / "episodes").mkdir()
    (run / "episodes" / "ep_0001.mcap").write_bytes(b"")
    return {
        "train: an algo in capitals": (["train", "algo=SAC", "--cfg"], "Did you mean 'sac'?"),
        "train: an env": (["train", "env=quadx_hovr", "--cfg"], "Did you mean 'quadx_hover'?"),
        "train: a key above a key": (["train", "trian.seed=1", "--cfg"], "Did you mean 'train'? Use train.seed=1."),
        "train: a nested key": (["train", "algo.learnin_rate=1", "--cfg"], "Did you mean 'algo.learning_rate'?"),
        "eval: a key": (["eval", str(run), "episods=3"], "Did you mean 'episodes'? Use episodes=3."),
        "eval: a zoo agent": (["eval", "zoo:quadx_hovr_ppo"], "Did you mean 'quadx_hover_ppo'?"),
        "eval: a run directory": (["eval", str(run.parent / "20261201-101010-seed1")], f"Did you mean '{run}'?"),
        "eval: a folder of runs": (
            ["eval", str(tmp / "runs" / "quadx_hovr")],
            f"Did you mean '{tmp / 'runs' / 'quadx_hover'}'?",
        ),
        "eval: an oracle": (["eval", "oracle:rocket_landr"], "Did you mean 'rocket_lander'?"),
        "export: a key": (["export", "zoo:quadx_hover_ppo", "formt=c"], "Did you mean 'format'?"),
        "export: a zoo agent": (["export", "zoo:Quadx_Hover_PPO", "format=c"], "Did you mean 'quadx_hover_ppo'?"),
        "replay: an option": (["replay", str(tmp / "x.mcap"), "--vidoe", "a.gif"], "--video"),
        "plot: an option": (["plot", str(tmp), "--reeps", "3"], "--reps"),
        "benchmark: the experiment key": (["benchmark", "experment=smoke_benchmark"], "Did you mean 'experiment'?"),
        "benchmark: a key": (
            ["benchmark", "experiment=smoke_benchmark", "sedes=3", "--dry-run"],
            "Did you mean 'seed'?",
        ),
        "fly: a key": (["fly", "duraton=1"], "Did you mean 'duration'?"),
        "tune: a setting": (["tune", "env=quadx_hover", "algo=ppo", "trails=3"], "Did you mean 'trials'?"),
        "uav: an airframe": (["uav", "show", "quadx_cf2"], "Did you mean 'quadx_cf2x'?"),
        "speed: an env": (["speed", "--env", "quadx_hovr", "--quick"], "Did you mean 'PyFlyt/QuadX-Hover-v0'?"),
        "speed: an option": (["speed", "--repeets", "2"], "--repeats"),
        "zoo: a run directory": (["zoo", "--add", str(run.parent / "20261201-101010-seed1")], f"Did you mean '{run}'?"),
        "replay: a recording": (
            ["replay", str(run / "episodes" / "ep_0010.mcap")],
            f"Did you mean '{run / 'episodes' / 'ep_0001.mcap'}'?",
        ),
        "envs: an env": (["envs", "quadx_hovr"], "Did you mean 'quadx_hover'?"),
        "a command": (["evl", "x"], "Did you mean 'eval'?"),
    }


@pytest.fixture
def cases(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a zoo agent would be copied here: nothing may be
    return _cases(tmp_path)


NAMES = [
    "train: an algo in capitals",
    "train: an env",
    "train: a key above a key",
    "train: a nested key",
    "eval: a key",
    "eval: a zoo agent",
    "eval: a run directory",
    "eval: a folder of runs",
    "eval: an oracle",
    "export: a key",
    "export: a zoo agent",
    "replay: an option",
    "plot: an option",
    "benchmark: the experiment key",
    "benchmark: a key",
    "fly: a key",
    "tune: a setting",
    "uav: an airframe",
    "speed: an env",
    "speed: an option",
    "zoo: a run directory",
    "replay: a recording",
    "envs: an env",
    "a command",
]


@pytest.mark.parametrize("name", NAMES)
def test_a_misspelling_gets_the_closest_name(name, cases, tmp_path):
    args, expected = cases[name]
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert expected in " ".join(result.output.split()), result.output  # rich boxes wrap lines
    assert "Traceback" not in result.output
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before


def test_every_command_is_walked():
    import typer

    commands = typer.main.get_command(app).commands
    walked = {n.split(":")[0] for n in NAMES if ":" in n}
    takes_nothing = {name for name, c in commands.items() if not c.params}  # modes (uav: its subcommands)
    assert set(commands) - walked <= takes_nothing, set(commands) - walked - takes_nothing


def test_case_and_spelling_are_forgiven_alike():
    assert closest("SAC", ["ppo", "sac"]) == "sac"
    assert closest("QuadX_Hover", ["quadx_hover", "quadx_hover_sensors"]) == "quadx_hover"
    assert closest("episods", ["episodes", "seed"]) == "episodes"
    assert closest("zzz", ["episodes", "seed"]) is None
    assert did_you_mean("sac", ["sac"]) == ""  # the name itself is no misspelling

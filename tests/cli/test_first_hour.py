"""What a new user meets first: the unknown-key hint, `train --help`, `eval` of a folder of runs."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from pyflyt_cli.main import app

runner = CliRunner()


def _error(args: list[str]) -> str:
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    return " ".join(result.output.split())


def test_the_unknown_key_hint_suggests_an_override_that_works():
    message = _error(["train", "algo.learnign_rate=1e-3", "--cfg"])
    assert "Did you mean 'algo.learning_rate'? Use algo.learning_rate=1e-3." in message
    assert "+algo" not in message
    shown = runner.invoke(app, ["train", "algo.learning_rate=1e-3", "--cfg"])  # the suggestion is accepted
    assert shown.exit_code == 0 and "learning_rate: 0.001" in shown.output
    assert "+" not in _error(["train", "algo.foo_bar=1", "--cfg"]).split("Keys here")[1]
    assert "+" not in _error(["fly", "sead=1"])


def test_train_help_marks_the_default_of_each_group():
    text = runner.invoke(app, ["train", "--help"]).output
    assert "quadx_hover (default)" in text and "ppo (default)" in text
    assert "default: none (the env's own airframe)" in text and "default: none (the env's own reward)" in text


def test_eval_of_a_folder_of_runs_lists_them(tmp_path):
    for name in ("ppo/20260101-000000-seed0", "ppo/20260101-000001-seed1", "sac/20260101-000002-seed0"):
        run = tmp_path / "quadx_hover" / name
        (run / "episodes").mkdir(parents=True)
        (run / "config.yaml").write_text("seed: 0\n")
        (run / "state.json").write_text(json.dumps({"status": "complete", "num_timesteps": 512}))
    (tmp_path / "quadx_hover" / "ppo" / "20260101-000000-seed0" / "episodes" / "config.yaml").write_text("x: 1\n")
    result = runner.invoke(app, ["eval", str(tmp_path / "quadx_hover")])
    assert result.exit_code == 2
    lines = result.output.splitlines()
    assert "is a folder of 3 run(s)" in lines[0]
    assert [line.split()[0] for line in lines[1:4]] == [
        str(tmp_path / "quadx_hover" / name)
        for name in ("ppo/20260101-000000-seed0", "ppo/20260101-000001-seed1", "sac/20260101-000002-seed0")
    ]
    assert lines[1].endswith("(complete, 512 steps)")
    assert lines[4] == f"pick one, e.g. pyflyt eval {tmp_path / 'quadx_hover' / 'sac' / '20260101-000002-seed0'}"
    empty = tmp_path / "empty"
    empty.mkdir()
    assert "is not a run directory" in _error(["eval", str(empty)])

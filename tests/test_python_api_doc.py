"""Every Python block of docs/python_api.md runs, in order, in one namespace, on tiny budgets.

The page shows realistic budgets; ``TINY`` swaps each for a tiny one (and the test checks
that the page still says what is swapped, so a change there is seen here).  The blocks
run in a temporary working directory, where they write their runs and files.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.train.conftest import cli_env

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "python_api.md"

#: what the page says -> what the test runs instead
TINY = {
    '"train.total_timesteps=120000"': (
        '"train.total_timesteps=512", "train.n_envs=1", "algo.n_steps=256", "algo.batch_size=64", '
        '"algo.n_epochs=2", "train.eval_freq=256", "train.eval_episodes=2", "train.checkpoint_freq=256"'
    ),
    "total_timesteps=200_000": "total_timesteps=768",
    '{"episodes": 5}': '{"episodes": 2}',
    '"seeds=3"': '"seeds=1"',
    "reps=2000": "reps=20",
    "width=640, height=480": "width=64, height=48",
}


def python_blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, re.DOTALL | re.MULTILINE)


def test_every_python_block_of_the_page_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = DOC.read_text()
    missing = [old for old in TINY if old not in text]
    assert not missing, f"docs/python_api.md no longer says {missing}: update TINY"
    blocks = python_blocks(text)
    assert len(blocks) == 11
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PYTHONPATH", cli_env()["PYTHONPATH"])  # the benchmark's worker processes
    namespace: dict = {}
    for number, block in enumerate(blocks, 1):
        for old, new in TINY.items():
            block = block.replace(old, new)
        exec(compile(block, f"docs/python_api.md, Python block {number}", "exec"), namespace)  # noqa: S102

    # what the session made is where the page says it is
    assert namespace["result"].num_timesteps == 512 and namespace["more"].num_timesteps == 768
    assert len(namespace["report"].figures) >= 4 and namespace["report"].markdown.is_file()
    assert [o.status for o in namespace["outcome"].outcomes] == ["complete", "complete"]
    assert (tmp_path / "f450.png").stat().st_size > 0 and (tmp_path / "flight.png").stat().st_size > 0
    assert namespace["check"].ok
    assert [p.name for p in namespace["exported"].files] == ["policy.c", "policy.h"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "benchmarks",
        "f450.png",
        "flight.png",
        "policy.c",
        "policy.h",
        "recordings",
        "runs",
    ]

"""The defaults the documentation states are the ones in ``conf/``.

``docs/cli.md`` lists the keys of ``conf/train.yaml``, ``conf/fly.yaml`` and
``conf/eval.yaml`` with their defaults; the default run of ``pyflyt train`` (PPO on
hover) changes some of them through ``conf/hparams/quadx_hover_ppo.yaml``, which the
table says as "(`X` for hover PPO)".  Each stated value is read back here and compared
with the file, and every value the hover-PPO file changes must be stated.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
CONF = ROOT / "conf"
ROW = re.compile(r"^\| (`[^|]+`) \| ([^|]*) \|", re.M)


def _section(text: str, heading: str) -> str:
    start = text.index(heading)
    end = text.find("\n## ", start + len(heading))
    return text[start : end if end > 0 else None]


def _rows(section: str) -> list[tuple[list[str], list[Any], str]]:
    """(keys, stated defaults, default cell) of each table row whose default is literal."""
    out = []
    for keys_cell, default_cell in ROW.findall(section):
        keys = re.findall(r"`([^`]+)`", keys_cell)
        literal = re.match(r"\s*((?:`[^`]*`(?:, )?)+)", default_cell)
        if not literal:
            continue  # described in words ("run seed + 1000", "per algorithm")
        values = [yaml.safe_load(v) for v in re.findall(r"`([^`]*)`", literal.group(1))]
        if len(values) == 1 and len(keys) > 1:
            values *= len(keys)
        out.append((keys, values, default_cell))
    return out


def _lookup(data: dict, dotted: str) -> Any:
    node: Any = data
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            raise KeyError(dotted)
        node = node[part]
    return node


def _conf(name: str) -> dict:
    data = yaml.safe_load((CONF / name).read_text())
    for entry in data.pop("defaults", []):  # `uav: quadx_cf2x` of fly.yaml is a default too
        if isinstance(entry, dict):
            data.update({k: v for k, v in entry.items() if v is not None})
    return data


CLI = (DOCS / "cli.md").read_text()
TABLES = [
    ("## `pyflyt fly`", "fly.yaml"),
    ("### Keys", "train.yaml"),
    ("## `pyflyt eval`", "eval.yaml"),
]


@pytest.mark.parametrize(("heading", "conf"), TABLES, ids=[c for _, c in TABLES])
def test_documented_defaults_are_the_config_files(heading, conf):
    rows = _rows(_section(CLI, heading))
    data = _conf(conf)
    checked = 0
    for keys, values, _ in rows:
        for key, value in zip(keys, values):
            try:
                actual = _lookup(data, key)
            except KeyError:
                continue  # a group (env=) or a key of another file (algo.*)
            if isinstance(actual, list) and value == [0, 0, 0]:
                assert actual == [0.0, 0.0, 0.0], key
            else:
                assert value == actual, f"docs/cli.md states {key} = {value!r}, conf/{conf} has {actual!r}"
            checked += 1
    assert checked >= 5, f"found only {checked} documented defaults of conf/{conf}: has the table changed shape?"


def test_hover_ppo_values_are_stated_where_they_differ():
    """Every train.* value conf/hparams/quadx_hover_ppo.yaml changes is documented as
    "(`X` for hover PPO)" with that value."""
    hover = yaml.safe_load((CONF / "hparams" / "quadx_hover_ppo.yaml").read_text())["train"]
    base = _conf("train.yaml")["train"]
    rows = {keys[0]: cell for keys, _, cell in _rows(_section(CLI, "### Keys"))}
    for key, value in hover.items():
        if base.get(key) == value:
            continue
        cell = rows.get(f"train.{key}")
        assert cell is not None, f"train.{key} is not in docs/cli.md's table"
        stated = re.search(r"\(`([^`]+)` for hover PPO\)", cell)
        assert stated, f"docs/cli.md: train.{key} must say (`{value}` for hover PPO)"
        assert yaml.safe_load(stated.group(1)) == value


def test_quickstart_and_readme_state_the_default_budget():
    hover = yaml.safe_load((CONF / "hparams" / "quadx_hover_ppo.yaml").read_text())["train"]
    total = hover["total_timesteps"]
    quickstart = (DOCS / "quickstart.md").read_text()
    assert f"{total:,}".replace(",", " ") + " environment steps" in quickstart
    assert f"{hover['n_envs']} parallel" in quickstart
    assert f"{total // 1000}k steps" in (ROOT / "README.md").read_text()

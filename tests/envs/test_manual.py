"""The env manuals (:mod:`pyflyt_engine.envs.manual`) say what the configs say: QuadX-Hover's
manual checked against conf/env/quadx_hover.yaml (and its bases) and conf/reward/quadx_hover_*.yaml
read by hand; names resolve as documented; docs/environments.md embeds the current manuals."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pyflyt_engine.envs.manual import (
    BEGIN_MARKER,
    END_MARKER,
    embedded_manuals,
    env_manual,
    manuals_markdown,
    replace_embedded_manuals,
    resolve_env,
)
from pyflyt_engine.errors import ConfigError

DOC = Path(__file__).resolve().parents[2] / "docs" / "environments.md"


@pytest.fixture(scope="module")
def hover() -> str:
    return env_manual("PyFlyt/QuadX-Hover-v0")


def _rows(text: str, header: str) -> list[list[str]]:
    """The rows of the first table after the line starting with ``header``."""
    lines = text[text.index(header) :].splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]])
    return rows


def test_hover_manual_states_the_loop_rates_of_its_config(hover):
    # conf/env/_base.yaml: physics 240, control 120, agent 30 Hz: 240 / 30 = 8 physics steps per agent step
    assert "| physics | 240 Hz |" in hover
    assert "| control | 120 Hz |" in hover
    assert "| agent | 30 Hz: one agent step = 8 physics steps (0.03333 s) |" in hover
    assert "| vehicle | `quadx_cf2x` |" in hover
    assert hover.startswith(
        "### `PyFlyt/QuadX-Hover-v0`\n\nhover the QuadX at (0, 0, 1) m.  Config `conf/env/quadx_hover.yaml`"
    )


def test_hover_manual_action_table_is_the_rates_thrust_box(hover):
    # conf/env/_rates_thrust.yaml: p, q, r in [-pi, pi] rad/s, thrust in [0, 1]
    assert "**Action** `Box(4,)`, float64" in hover
    assert _rows(hover, "**Action**") == [
        ["0", "`p`", "rad/s", "-pi", "pi"],
        ["1", "`q`", "rad/s", "-pi", "pi"],
        ["2", "`r`", "rad/s", "-pi", "pi"],
        ["3", "`thrust`", "1", "0", "1"],
    ]


def test_hover_manual_observation_layout(hover):
    # 3 rates + 4 quaternion + 3 velocity + 3 position + 4 previous action + 4 motor throttles = 21
    assert "**Observation** `Box(21,)` (angle_representation quaternion; with euler: 20 entries)" in hover
    rows = _rows(hover, "**Observation**")
    assert [(r[0], r[1], r[2]) for r in rows] == [
        ("0:3", "3", "`ang_vel`"),
        ("3:7", "4", "`attitude`"),
        ("7:10", "3", "`lin_vel`"),
        ("10:13", "3", "`lin_pos`"),
        ("13:17", "4", "`previous_action`"),
        ("17:21", "4", "`aux_motors`"),
    ]


def test_hover_manual_reward_presets_and_their_weights(hover):
    # conf/reward/quadx_hover_dense.yaml and quadx_hover_sparse.yaml
    dense = _rows(hover, "`quadx_hover_dense`")
    assert [(r[0], r[1], r[2].split(":")[0], r[3]) for r in dense] == [
        ("`crash`", "-100", "`constant`", "`crash`"),
        ("`attitude_error`", "-1", "`tilt`", "`not_crash`"),
        ("`position_error`", "-1", "`target_distance`", "`not_crash`"),
    ]
    sparse = _rows(hover, "`quadx_hover_sparse`")
    assert [(r[0], r[1], r[3]) for r in sparse] == [
        ("`crash`", "-100", "`crash`"),
        ("`time_penalty`", "-0.1", "`not_crash`"),
    ]
    assert '`quadx_hover_sparse` (reward="sparse", sparse_reward=True)' in hover


def test_hover_manual_start_and_end(hover):
    # conf/env/_quadx.yaml: spawn at (0, 0, 1) +- 0.1 m, attitude +- 0.1 rad; quadx_hover.yaml: 10 s, 3 m dome
    options = {r[0]: r[1] for r in _rows(hover, "**Task and starting state**")}
    assert options["`start_position`"] == "(0, 0, 1)"
    assert options["`start_position_noise`"] == "0.1"
    assert options["`start_orientation_noise`"] == "0.1"
    assert options["`hover_point`"] == "(0, 0, 1)"
    assert "`max_duration_seconds` = 10 s = 300 agent steps, which counts as a success" in hover
    assert "`flight_dome_size` = 3 m" in hover
    ends = [(r[0], r[1]) for r in _rows(hover, "**Episode end**")]
    assert ends[0] == ("`contact`", "crash") and ends[-1] == ("`time_limit`", "truncate") and len(ends) == 7
    assert 'gymnasium.make("PyFlyt/QuadX-Hover-v0", **kwargs)' in hover


def test_a_config_overriding_a_number_shows_it():
    # conf/env/quadx_gates_state.yaml flies its agent at 40 Hz: 240 / 40 = 6 physics steps
    text = env_manual("quadx_gates_state")
    assert "| agent | 40 Hz: one agent step = 6 physics steps (0.025 s) |" in text
    assert "a variant of `PyFlyt/QuadX-Gates-v0`" in text
    assert "`gate`: `Box(12,)`" in text


def test_multi_agent_manual_lists_the_agents():
    text = env_manual("ma_fixedwing_dogfight_v0")
    assert "ma_fixedwing_dogfight_v0.parallel_env(**kwargs)" in text
    assert "per agent" in text and "`other_0`" in text and "| `uav_0` |" in text


def test_names_resolve_to_their_config():
    assert resolve_env("PyFlyt/QuadX-Hover-v0") == resolve_env("QuadX-Hover-v0") == "quadx_hover"
    assert resolve_env("ma_quadx_hover_v0") == "ma_quadx_hover"
    assert resolve_env("quadx_hover_sensors") == "quadx_hover_sensors"


def test_an_unknown_name_lists_the_known_ones():
    with pytest.raises(
        ConfigError, match=r"unknown environment 'QuadX-Hovr'\. Did you mean .*Known: .*PyFlyt/QuadX-Hover-v0"
    ):
        resolve_env("QuadX-Hovr")
    with pytest.raises(ConfigError, match="ma_quadx_hover_v0"):
        resolve_env("nothing")


def test_replace_needs_the_markers():
    with pytest.raises(ValueError, match="no <!-- BEGIN GENERATED ENV MANUALS"):
        replace_embedded_manuals("# no markers\n", manuals="x\n")
    doc = f"a\n{BEGIN_MARKER}\nold\n{END_MARKER}\nb\n"
    new = replace_embedded_manuals(doc, manuals="new\n")
    assert embedded_manuals(new) == "new\n" and new.startswith("a\n") and new.endswith(f"{END_MARKER}\nb\n")


def test_environments_doc_embeds_the_current_manuals():
    text = DOC.read_text()
    assert BEGIN_MARKER in text
    assert embedded_manuals(text) == manuals_markdown(), (
        "docs/environments.md is out of date with the env configs; regenerate it with\n"
        "  python -m pyflyt_cli.commands.env_manuals docs/environments.md"
    )


def test_a_task_whose_parts_do_not_make_up_its_space_is_refused(monkeypatch):
    from pyflyt_engine.envs.tasks.hover import HoverTask

    monkeypatch.setattr(HoverTask, "observation_parts", lambda self, attitude: {"": attitude[:-1]})
    with pytest.raises(
        ConfigError, match=r"task 'hover': its declared observation parts \(\{'': 17\}\) do not make up"
    ):
        env_manual("quadx_hover")

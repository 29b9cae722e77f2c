"""Env configs that declare a registered id with another observation or flight mode (a
"variant", e.g. ``quadx_gates_state``, ``pyflyt train env=<name>``) honour the same contract
as the registered envs: both API checkers, and a seed fixes an episode bit for bit across
processes while another seed differs."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

from pyflyt_cli.training.envs import wrap_for_agent
from pyflyt_engine.envs import ENVS, make_env
from pyflyt_engine.loading import available, bases
from pyflyt_engine.paths import conf_dir
from tests.conftest import default_subset

ROOT = Path(__file__).resolve().parents[2]
REGISTERED = {entry.config for entry in ENVS.values()}
#: single-agent configs of conf/env that no registered id is built from
VARIANTS = sorted(n for n in available("env") if n not in REGISTERED and not n.startswith("ma_"))


def test_the_state_based_gates_config_is_a_variant():
    assert "quadx_gates_state" in VARIANTS and "quadx_waypoints_velocity" in VARIANTS


@pytest.mark.parametrize("name", VARIANTS)
def test_variant_passes_both_env_checkers(name):
    env = make_env(conf_dir() / "env" / f"{name}.yaml")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # as tests/envs/test_contract.py: only the action box and infinities
            warnings.filterwarnings("ignore", message=".*(symmetric|float32|float64|infinity).*")
            check_env(env, skip_render_check=True)
            sb3_check_env(wrap_for_agent(env), warn=True)  # as the training library hands it to SB3
    finally:
        env.close()


SCRIPT = """
import hashlib, sys, warnings
import numpy as np
from pyflyt_engine.envs import make_env
warnings.simplefilter("ignore")
env = make_env(sys.argv[1])
rng = np.random.default_rng(123)  # fixed action sequence in the action box, independent of the env seed
low, high = env.action_space.low, env.action_space.high
flat = lambda o: np.concatenate([np.ravel(v) for v in o.values()]) if isinstance(o, dict) else o
obs, info = env.reset(seed=int(sys.argv[2]))
rows = [flat(obs)]
for _ in range(80):
    obs, reward, terminated, truncated, info = env.step(low + (high - low) * rng.uniform(0.3, 0.7, low.shape))
    rows.append(np.append(flat(obs), reward))
    if terminated or truncated:
        obs, info = env.reset()
        rows.append(flat(obs))
print(hashlib.sha256(np.concatenate(rows).tobytes()).hexdigest())
"""


def _digest(name: str, seed: int) -> str:
    result = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(conf_dir() / "env" / f"{name}.yaml"), str(seed)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        check=True,
    )
    return result.stdout.strip().splitlines()[-1]


@pytest.mark.parametrize("name", default_subset(VARIANTS, lambda n: n == "quadx_gates_state"))
def test_variant_is_deterministic_across_processes(name):
    first, second, other = _digest(name, 0), _digest(name, 0), _digest(name, 1)
    assert len(first) == 64 and first == second and first != other


# ---------------------------------------------------------------- variants written as deltas

#: variant -> the config it changes (its ``defaults`` list): each file holds only what differs
DELTAS = {
    "quadx_gates_state": "quadx_gates",
    "quadx_waypoints_velocity": "quadx_waypoints",
    "quadx_hover_sensors": "quadx_hover",
    "rocket_landing_velocity": "rocket_landing",
    "rocket_landing_descent": "rocket_landing",
}
SHIPPED = available("env")


@pytest.mark.parametrize("name", SHIPPED)
def test_every_env_config_composes_the_same_through_hydra_and_the_loader(name):
    """``pyflyt train env=<name>`` (Hydra's defaults list) and ``make_env(<name>)`` (the loader's
    ``with_defaults``) build the same config (a2c: no tuning of any env changes its keys)."""
    from pyflyt_cli.training.compose import compose_train_data
    from pyflyt_engine.envs.config import load_env_config, parse_env_config

    data, _ = compose_train_data([f"env={name}", "algo=a2c"])
    composed = parse_env_config(data["env"], "composed").model_dump(mode="json", exclude={"source"})
    assert composed == load_env_config(name).model_dump(mode="json", exclude={"source"})


@pytest.mark.parametrize("name, base", sorted(DELTAS.items()))
def test_a_variant_file_holds_only_what_differs_from_its_base(name, base):
    import yaml

    from pyflyt_engine.envs.config import load_env_config

    text = yaml.safe_load((conf_dir() / "env" / f"{name}.yaml").read_text())
    assert text["defaults"] == [base, "_self_"]
    variant, original = (load_env_config(n).model_dump(mode="json", exclude={"source"}) for n in (name, base))
    changed = {k for k in variant.keys() | original.keys() if variant.get(k) != original.get(k)}
    assert changed and changed <= set(text) - {"defaults"}, (changed, set(text))
    for key in set(text) - {"defaults"}:  # and each key it gives changes something
        assert key in changed, key


def test_a_variant_of_a_variant_and_a_users_own_file(tmp_path):
    """A file outside conf/ may start from shipped configs too; a later entry overrides an earlier one,
    mappings merging key by key, and the file's own keys come last when _self_ is not listed."""
    from pyflyt_engine.envs.config import load_env_config

    (tmp_path / "mine.yaml").write_text(
        "defaults: [quadx_hover_sensors]\nmax_duration_seconds: 5.0\nsensors: {estimator: {k_p: 2.0}}\n"
    )
    mine = load_env_config(tmp_path / "mine.yaml")
    sensors = load_env_config("quadx_hover_sensors")
    assert mine.max_duration_seconds == 5.0 and mine.task.name == "hover"
    assert mine.sensors.estimator.k_p == 2.0 and mine.sensors.estimator.k_i == sensors.sensors.estimator.k_i
    assert mine.sensors.imu == sensors.sensors.imu


@pytest.mark.parametrize("defaults, fragment", [
    ("/etc/quadx_hover", "is not a name"),
    ("../env/quadx_hover", "is not a name"),
    ("nope", "unknown env config 'nope'"),
    ("{quadx_hover: x}", "defaults must be a list of env config names"),
    ("loop", "a loop or a chain deeper than"),
])  # fmt: skip
def test_a_defaults_list_takes_shipped_names_only_and_no_loop(tmp_path, monkeypatch, defaults, fragment):
    from pyflyt_engine.envs.config import load_env_config
    from pyflyt_engine.errors import ConfigError

    if defaults == "loop":  # a shipped-looking config that names itself
        env_dir = tmp_path / "conf" / "env"
        env_dir.mkdir(parents=True)
        (env_dir / "loop.yaml").write_text("defaults: [loop]\n")
        monkeypatch.setattr("pyflyt_engine.loading.conf_dir", lambda: tmp_path / "conf")
        entry = "[loop]"
    else:
        entry = defaults if defaults.startswith("{") else f"[{defaults}]"
    (tmp_path / "bad.yaml").write_text(f"defaults: {entry}\n")
    with pytest.raises(ConfigError) as caught:
        load_env_config(tmp_path / "bad.yaml")
    where = "loop.yaml" if defaults == "loop" else "bad.yaml"  # the file whose list closes the loop
    assert fragment in str(caught.value) and where in str(caught.value), str(caught.value)


# ---------------------------------------------------------------- every config as a delta of bases


def _leaves(data: dict, prefix: tuple = ()) -> dict[tuple, object]:
    """{key path: value} of a mapping, through nested mappings (a list or scalar is one leaf)."""
    out: dict[tuple, object] = {}
    for key, value in data.items():
        if isinstance(value, dict) and value:
            out.update(_leaves(value, (*prefix, key)))
        else:
            out[(*prefix, key)] = value
    return out


def _inherited(defaults: list[str]) -> dict:
    """What a file's defaults list alone composes to (its own keys left out)."""
    from pyflyt_engine.loading import with_defaults

    return with_defaults({"defaults": [e for e in defaults if e != "_self_"]}, "env", "test")


def _at(data: object, path: tuple) -> object:
    for key in path:
        if not isinstance(data, dict) or key not in data:
            return KeyError
        data = data[key]
    return data


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_env_config_starts_from_a_base(name):
    """The issue's "done": no shipped env restates the keys every env shares."""
    from pyflyt_engine.safe_load import load_yaml_file

    text = load_yaml_file(conf_dir() / "env" / f"{name}.yaml")
    assert isinstance(text.get("defaults"), list) and text["defaults"][-1] == "_self_", text.get("defaults")
    assert "physics_hz" not in text and "backend" not in text  # _base's


@pytest.mark.parametrize("name", SHIPPED + bases("env"))
def test_a_file_gives_only_what_differs_from_what_it_starts_from(name):
    """Every leaf a file gives (``task.start_position``, ``agent_hz``) is new or another value
    than its defaults list composes to: the file is the lines that differ, nothing restated."""
    from pyflyt_engine.safe_load import load_yaml_file

    text = load_yaml_file(conf_dir() / "env" / f"{name}.yaml")
    inherited = _inherited(text.get("defaults", []))
    own = {k: v for k, v in text.items() if k != "defaults"}
    restated = [".".join(map(str, path)) for path, value in _leaves(own).items() if _at(inherited, path) == value]
    assert not restated, f"{name} restates {restated} of {text.get('defaults')}"


def test_every_base_is_started_from_by_a_shipped_config():
    from pyflyt_engine.safe_load import load_yaml_file

    named = {
        e for n in SHIPPED + bases("env") for e in load_yaml_file(conf_dir() / "env" / f"{n}.yaml").get("defaults", [])
    }
    assert set(bases("env")) <= named and {"_base", "_single_agent"} <= set(bases("env"))


@pytest.mark.parametrize("base", ["_base", "_quadx"])
def test_a_base_is_no_env_the_engine_loads(base):
    from pyflyt_engine.envs.config import load_env_config
    from pyflyt_engine.errors import ConfigError

    assert base in bases("env") and base not in available("env")
    for load in (load_env_config, make_env):
        with pytest.raises(ConfigError) as caught:
            load(base)
        message = str(caught.value)
        assert f"'{base}' is a base (conf/env/{base}.yaml)" in message and "quadx_hover" in message, message


def test_a_base_is_no_env_pyflyt_train_takes():
    from typer.testing import CliRunner

    from pyflyt_cli.compose import group_choices
    from pyflyt_cli.main import app

    assert not any(c.startswith("_") for c in group_choices("env"))
    result = CliRunner().invoke(app, ["train", "env=_single_agent", "--cfg"])
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    assert "'env=_single_agent': '_single_agent' is a base (conf/env/_single_agent.yaml)" in result.output
    result = CliRunner().invoke(
        app, ["train", "env=_quadxx", "--cfg"]
    )  # an unknown one: the listed choices hold no base
    assert result.exit_code == 2 and "unknown env '_quadxx'" in result.output and "_quadx," not in result.output


# ---------------------------------------------------------------- the merge rules, both ways

#: (file name, text) of a tiny conf/env; ``x`` is composed.  The expected result is written out
#: by hand from the rules (docs/environments.md, "Variants of a config").
MERGE_FILES = {
    "_a": "n: 1\nlist: [1, 2, 3]\nword: calm\nnested: {p: 1, deep: {q: 1, r: 1}}\ngone: {k: 1}\n",
    "_b": "defaults: [_a, _self_]\nn: 2\nnested: {deep: {r: 2}, s: 2}\n",
    "_c": "defaults: [_self_, _a]\nn: 3\nonly_c: 3\n",
}
MERGE_CASES = [
    # a mapping merges key by key, at every depth; a list, a scalar and null replace; a mapping replaces a scalar
    ("defaults: [_a, _self_]\nlist: [9]\nword: {preset: gust}\nnested: {deep: {q: 5}}\ngone: null\n",
     {"n": 1, "list": [9], "word": {"preset": "gust"}, "nested": {"p": 1, "deep": {"q": 5, "r": 1}}, "gone": None}),
    # _self_ left out: the file's keys last, as listed last
    ("defaults: [_a]\nn: 7\n",
     {"n": 7, "list": [1, 2, 3], "word": "calm", "nested": {"p": 1, "deep": {"q": 1, "r": 1}}, "gone": {"k": 1}}),
    # _self_ first: the bases' keys win
    ("defaults: [_self_, _a]\nn: 7\nextra: 1\n",
     {"n": 1, "extra": 1, "list": [1, 2, 3], "word": "calm", "nested": {"p": 1, "deep": {"q": 1, "r": 1}}, "gone": {"k": 1}}),
    # a base of a base; later entries win over earlier ones (_c puts _a over its own n)
    ("defaults: [_b, _c, _self_]\n",
     {"n": 1, "only_c": 3, "list": [1, 2, 3], "word": "calm", "nested": {"p": 1, "deep": {"q": 1, "r": 1}, "s": 2},
      "gone": {"k": 1}}),
    # the same base twice (a diamond): merged in order, each time
    ("defaults: [_a, _b, _self_]\nnested: {p: 0}\n",
     {"n": 2, "list": [1, 2, 3], "word": "calm", "nested": {"p": 0, "deep": {"q": 1, "r": 2}, "s": 2}, "gone": {"k": 1}}),
]  # fmt: skip


@pytest.mark.parametrize("text, expected", MERGE_CASES)
def test_the_loader_and_hydra_merge_a_defaults_list_alike(tmp_path, monkeypatch, text, expected):
    """The rules of ``pyflyt_engine.loading.with_defaults`` are Hydra's: the same files compose to
    the same mapping through both, and to the one the rules give."""
    from hydra import compose, initialize_config_dir
    from omegaconf import OmegaConf

    from pyflyt_engine.loading import with_defaults
    from pyflyt_engine.safe_load import load_yaml_file

    env_dir = tmp_path / "conf" / "env"
    env_dir.mkdir(parents=True)
    for name, body in {**MERGE_FILES, "x": text}.items():
        (env_dir / f"{name}.yaml").write_text(body)
    (tmp_path / "conf" / "train.yaml").write_text("defaults:\n  - _self_\n  - env: x\n")
    monkeypatch.setattr("pyflyt_engine.loading.conf_dir", lambda: tmp_path / "conf")
    loader = with_defaults(load_yaml_file(env_dir / "x.yaml"), "env", "x.yaml")
    with initialize_config_dir(config_dir=str(tmp_path / "conf"), version_base="1.3"):
        hydra = OmegaConf.to_container(compose(config_name="train").env)
    assert loader == expected
    assert hydra == expected


@pytest.mark.parametrize("files, defaults, fragment, where", [
    ({"_p": "defaults: [_q]\n", "_q": "defaults: [_p]\n"}, "[_p]", "defaults _p -> _q -> _p: a loop", "_q.yaml"),
    ({"_p": "defaults: [_gone]\nn: 1\n"}, "[_p]", "defaults entry '_gone': unknown env config '_gone'", "_p.yaml"),
    ({"_p": "n: 1\n"}, "[_pp]", "unknown env config '_pp'. Did you mean '_p'?", "bad.yaml"),
    ({}, "['optional quadx_hover']", "defaults entry 'optional quadx_hover' is not a name", "bad.yaml"),
    ({"_p": "n: 1\n"}, "['_p@env']", "defaults entry '_p@env' is not a name", "bad.yaml"),
    ({}, "['../uav/quadx_cf2x']", "defaults entry '../uav/quadx_cf2x' is not a name", "bad.yaml"),
    ({"_p": "n: 1\n"}, "[{env: _p}]", "defaults must be a list of env config names", "bad.yaml"),
])  # fmt: skip
def test_a_broken_defaults_list_names_the_file_and_the_entry(tmp_path, monkeypatch, files, defaults, fragment, where):
    """A loop through bases, a missing base, Hydra's other entry kinds (optional, @package, a
    mapping) and a file outside conf/env are refused, naming the file whose list is wrong."""
    from pyflyt_engine.envs.config import load_env_config
    from pyflyt_engine.errors import ConfigError

    env_dir = tmp_path / "conf" / "env"
    env_dir.mkdir(parents=True)
    for name, body in files.items():
        (env_dir / f"{name}.yaml").write_text(body)
    monkeypatch.setattr("pyflyt_engine.loading.conf_dir", lambda: tmp_path / "conf")
    (tmp_path / "bad.yaml").write_text(f"defaults: {defaults}\n")
    with pytest.raises(ConfigError) as caught:
        load_env_config(tmp_path / "bad.yaml")
    assert fragment in str(caught.value) and where in str(caught.value), str(caught.value)


# ---------------------------------------------------------------- what docs/environments.md says

DOC = (ROOT / "docs" / "environments.md").read_text()
SECTION = DOC[DOC.index("### Variants of a config") : DOC.index("## Payloads and the tasks that carry them")]


def test_the_docs_table_of_bases_is_the_shipped_bases_and_what_each_starts_from():
    from pyflyt_engine.safe_load import load_yaml_file

    rows = re.findall(r"^\| `(_\w+)` \|([^|]*)\|", SECTION, re.MULTILINE)
    assert sorted(name for name, _ in rows) == bases("env")
    for name, starts in rows:
        listed = [e for e in load_yaml_file(conf_dir() / "env" / f"{name}.yaml").get("defaults", []) if e != "_self_"]
        assert re.findall(r"`(\w+)`", starts) == listed, name


def test_the_docs_hover_example_is_the_shipped_hover_config():
    from pyflyt_engine.envs.config import load_env_config
    from pyflyt_engine.safe_load import yaml_data

    block = re.search(
        r"QuadX-Hover is then the lines that differ from `_quadx`:\n\n```yaml\n(.*?)```", SECTION, re.DOTALL
    )
    assert block is not None
    example = load_env_config(yaml_data(block.group(1), source="docs/environments.md"))
    assert example.model_dump(exclude={"source"}) == load_env_config("quadx_hover").model_dump(exclude={"source"})


def test_a_users_file_may_start_from_a_base_with_a_task_of_its_own(tmp_path):
    """docs: ``defaults: [_quadx]`` and a task of your own: the base's spawn, action and camera."""
    from pyflyt_engine.envs.config import load_env_config

    (tmp_path / "mine.yaml").write_text(
        "defaults: [_quadx]\nflight_dome_size: 4.0\nreward_presets: {dense: quadx_hover_dense, sparse: quadx_hover_sparse}\n"
        "task: {name: hover, hover_point: [1.0, 0.0, 1.5], start_position: [1.0, 0.0, 1.5]}\n"
    )
    mine, hover = load_env_config(tmp_path / "mine.yaml"), load_env_config("quadx_hover")
    assert mine.task.hover_point == (1.0, 0.0, 1.5) and mine.task.start_position == (1.0, 0.0, 1.5)
    assert mine.task.start_position_noise == hover.task.start_position_noise == 0.1
    assert mine.action == hover.action and mine.render == hover.render and mine.uav == "quadx_cf2x"
    env = make_env(tmp_path / "mine.yaml")
    try:
        obs, _ = env.reset(seed=0)
        assert env.observation_space.contains(obs)
    finally:
        env.close()

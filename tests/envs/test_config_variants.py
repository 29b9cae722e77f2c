"""Env configs that declare a registered id with another observation or flight mode (a
"variant", e.g. ``quadx_gates_state``, ``pyflyt train env=<name>``) honour the same contract
as the registered envs: both API checkers, and a seed fixes an episode bit for bit across
processes while another seed differs."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

from pyflyt_cli.training.envs import wrap_for_agent
from pyflyt_engine.envs import ENVS, make_env
from pyflyt_engine.loading import available
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
        capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)}, check=True,
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

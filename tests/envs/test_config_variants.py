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
from pyflyt_engine.paths import conf_dir
from tests.conftest import default_subset

ROOT = Path(__file__).resolve().parents[2]
REGISTERED = {entry.config for entry in ENVS.values()}
#: single-agent configs of conf/env that no registered id is built from
VARIANTS = sorted(
    p.stem for p in (conf_dir() / "env").glob("*.yaml") if p.stem not in REGISTERED and not p.stem.startswith("ma_")
)


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

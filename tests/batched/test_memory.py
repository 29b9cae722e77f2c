"""The heap kept from step to step (pyflyt_engine.batched.memory): glibc's thresholds set once
per process as a batched env is made, and a step of thousands of envs that faulted hundreds
of pages without them faulting none."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

from pyflyt_engine.batched import memory

#: 64 worlds of 64 hovering agents, random actions: ~650 page faults a step without the
#: thresholds on the machines this was measured on (experiments/speed_page_faults.py)
_FAULTS = """
import resource, sys
import numpy as np
from pyflyt_engine.batched import memory
from pyflyt_engine.batched.swarm import BatchedSwarmEnv
from pyflyt_engine.envs.config import load_env_config
config = load_env_config("ma_quadx_hover").with_overrides(agents=64, task={"layout": "grid"})
env = BatchedSwarmEnv(config, worlds=64, seed=0)
env.reset(seed=0)
rng = np.random.default_rng(0)
actions = [rng.uniform(-1, 1, size=(env.num_envs, *env.single_action_space.shape)) for _ in range(50)]
for i in range(50):
    env.step(actions[i])
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for i in range(150):
    env.step(actions[i % 50])
print(memory.keep_heap(), (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 150)
"""


def _faults(keep: bool) -> tuple[bool, float]:
    env = {**os.environ, "PYFLYT_KEEP_HEAP": "1" if keep else "0"}
    out = subprocess.run([sys.executable, "-c", _FAULTS], env=env, capture_output=True, text=True, check=True)
    kept, faults = out.stdout.split()
    return kept == "True", float(faults)


def test_a_big_step_faults_no_pages_with_the_heap_kept():
    kept, faults = _faults(keep=True)
    if platform.libc_ver()[0] != "glibc":  # nothing to set: the allocator is left as it is
        assert not kept
        return
    assert kept
    assert faults < 5.0, f"{faults} page faults a step with the heap kept"


def test_the_environment_variable_leaves_the_allocator_alone():
    kept, _ = _faults(keep=False)
    assert not kept


def test_keep_heap_is_set_once(monkeypatch):
    monkeypatch.setattr(memory, "_kept", None)
    first = memory.keep_heap()
    assert memory.keep_heap() is first
    assert first == (platform.libc_ver()[0] == "glibc" and os.environ.get("PYFLYT_KEEP_HEAP", "1") != "0")

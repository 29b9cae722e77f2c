"""Page faults and kernel time of the batched step at large N (QuadX-Hover, random actions).

A step that allocates and frees a few large arrays (an observation is N x 20 doubles, 655
KiB at N = 4096) can make glibc's allocator hand the top of its heap back to the kernel and
take it again at the next step: every page of it then faults on first touch.  This script
steps the env for a while and prints, per step, the minor page faults and the CPU time spent
in the kernel (``resource.getrusage``), beside the user time.

    python experiments/speed_page_faults.py [--envs 4096] [--seconds 10]
    python experiments/speed_page_faults.py --envs 64 --agents 64   # 64 worlds of 64 agents (ma_quadx_hover)

Run it on a checkout of another commit (``PYTHONPATH=that/checkout``) to compare, or with
``PYFLYT_KEEP_HEAP=0`` to leave glibc's thresholds as they are (``pyflyt_engine.batched.memory``).
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from pyflyt_engine.batched.memory import keep_heap
from pyflyt_engine.batched.swarm import BatchedSwarmEnv
from pyflyt_engine.envs import make_batched_env
from pyflyt_engine.envs.config import load_env_config


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", type=int, default=4096)
    parser.add_argument("--seconds", type=float, default=10.0, help="wall time to step for")
    parser.add_argument("--agents", type=int, default=0, help="agents per world: --envs worlds of ma_quadx_hover")
    args = parser.parse_args()
    if args.agents:  # a grid of agents per world (a ring of many would spawn them touching)
        config = load_env_config("ma_quadx_hover").with_overrides(agents=args.agents, task={"layout": "grid"})
        env = BatchedSwarmEnv(config, worlds=args.envs, seed=0)
        name = f"ma_quadx_hover, {args.envs} worlds of {args.agents} agents ({env.num_envs} slots)"
    else:
        env = make_batched_env("PyFlyt/QuadX-Hover-v0", n_envs=args.envs, seed=0)
        name = f"QuadX-Hover, N = {args.envs}"
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, size=(env.num_envs, *env.single_action_space.shape)) for _ in range(50)]
    for i in range(50):  # compiled, warm
        env.step(actions[i])
    before = resource.getrusage(resource.RUSAGE_SELF)
    start, steps = time.perf_counter(), 0
    while time.perf_counter() - start < args.seconds:
        env.step(actions[steps % 50])
        steps += 1
    after = resource.getrusage(resource.RUSAGE_SELF)
    faults = after.ru_minflt - before.ru_minflt
    user, system = after.ru_utime - before.ru_utime, after.ru_stime - before.ru_stime
    print(f"{name}: {steps} steps in {args.seconds:.0f} s (heap kept: {keep_heap()}, pyflyt_engine.batched.memory)")
    print(f"minor page faults per step: {faults / steps:.1f}")
    print(f"CPU per step: user {user / steps * 1e3:.3f} ms, kernel {system / steps * 1e3:.3f} ms "
          f"({system / (user + system):.1%} of the CPU time)")  # fmt: skip


if __name__ == "__main__":
    main()

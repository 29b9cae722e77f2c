"""Page faults and kernel time of the batched step at large N (QuadX-Hover, random actions).

A step that allocates and frees a few large arrays (an observation is N x 20 doubles, 655
KiB at N = 4096) can make glibc's allocator hand the top of its heap back to the kernel and
take it again at the next step: every page of it then faults on first touch.  This script
steps the env for a while and prints, per step, the minor page faults and the CPU time spent
in the kernel (``resource.getrusage``), beside the user time.

    python experiments/speed_page_faults.py [--envs 4096] [--seconds 10]

Run it on a checkout of another commit (``PYTHONPATH=that/checkout``) to compare.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from pyflyt_engine.envs import make_batched_env


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", type=int, default=4096)
    parser.add_argument("--seconds", type=float, default=10.0, help="wall time to step for")
    args = parser.parse_args()
    env = make_batched_env("PyFlyt/QuadX-Hover-v0", n_envs=args.envs, seed=0)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, size=(args.envs, *env.single_action_space.shape)) for _ in range(50)]
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
    print(f"QuadX-Hover, N = {args.envs}: {steps} steps in {args.seconds:.0f} s")
    print(f"minor page faults per step: {faults / steps:.1f}")
    print(f"CPU per step: user {user / steps * 1e3:.3f} ms, kernel {system / steps * 1e3:.3f} ms "
          f"({system / (user + system):.1%} of the CPU time)")  # fmt: skip


if __name__ == "__main__":
    main()

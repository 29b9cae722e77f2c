"""The batched reward preset: one compiled pass (``terms.reward_rows``) against its entries' NumPy vector forms.

Records the context of a real QuadX-Hover step (N envs, its dense preset), checks that both
forms give the same rewards, and times them interleaved (CPU us per call and per env).

    python experiments/speed_reward.py [--envs 256] [--calls 5000]
"""

from __future__ import annotations

import argparse
import copy
import time

import numpy as np

from pyflyt_engine.batched.terms import BatchedReward
from pyflyt_engine.envs import make_batched_env


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", type=int, default=256)
    parser.add_argument("--calls", type=int, default=5000, help="timed calls per form")
    args = parser.parse_args()
    env = make_batched_env("PyFlyt/QuadX-Hover-v0", n_envs=args.envs, seed=0)
    env.reset(seed=0)
    seen = {}
    shipped = BatchedReward.__call__

    def recording(self, ctx):
        seen["ctx"] = ctx
        return shipped(self, ctx)

    BatchedReward.__call__ = recording
    try:
        env.step(np.zeros((args.envs, *env.single_action_space.shape)))
    finally:
        BatchedReward.__call__ = shipped
    compiled = env.reward_function
    vector = copy.copy(compiled)
    vector._program = None  # the entries' vector forms
    ctx = seen["ctx"]
    forms = {"compiled": compiled, "vector forms": vector}
    same = np.array_equal(compiled(ctx)[0], vector(ctx)[0])
    times: dict[str, list[float]] = {name: [] for name in forms}
    for _ in range(args.calls):
        for name, fn in forms.items():
            start = time.process_time_ns()
            fn(ctx)
            times[name].append((time.process_time_ns() - start) / 1e3)
    print(f"QuadX-Hover's reward preset {compiled.name}, N = {args.envs}, {args.calls} calls per form, interleaved")
    print(f"same rewards in both forms: {same}")
    print(f"{'form':<13} {'p10 us/call':>12} {'median':>8}")
    for name, t in times.items():
        print(f"{name:<13} {np.percentile(t, 10):>12.2f} {np.median(t):>8.2f}")


if __name__ == "__main__":
    main()

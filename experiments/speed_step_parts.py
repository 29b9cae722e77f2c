"""Where a batched step's time goes: wall-clock timers around each part of ``BatchedUAVEnv.step``.

Wraps the env's physics (``advance``: the motor noise is drawn before it, in the step), state
read-out, episode ends and reward (``_judge``), observation (``_observe``, twice in a step
whose episodes end) and resets -- or, for a plain env stepped in one compiled call, that call
(``bookkeeping.plain_step``) -- steps QuadX-Hover with random actions (which crash and reset
often), and prints microseconds per step call for each part and for the rest of the step.

    python experiments/speed_step_parts.py [--envs 256] [--steps 3000] [--env PyFlyt/QuadX-Hover-v0]
"""

from __future__ import annotations

import argparse
import time


from pyflyt_engine.batched import bookkeeping
from pyflyt_engine.batched import env as batched_env
from pyflyt_engine.batched import normals
from pyflyt_engine.envs import make_batched_env

#: the timed parts, by method name
PARTS = ("advance", "_read", "_judge", "_observe", "_reset_envs")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", type=int, default=256)
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--env", default="PyFlyt/QuadX-Hover-v0")
    args = parser.parse_args()
    spent = dict.fromkeys(PARTS, 0)
    cls = batched_env.BatchedUAVEnv

    def timed(name):
        method = getattr(cls, name)

        def wrapper(self, *a, **k):
            start = time.perf_counter_ns()
            try:
                return method(self, *a, **k)
            finally:
                spent[name] += time.perf_counter_ns() - start

        return wrapper

    for name in PARTS:
        setattr(cls, name, timed(name))
    one_call = bookkeeping.plain_step

    def timed_call(*a):
        start = time.perf_counter_ns()
        try:
            return one_call(*a)
        finally:
            spent["plain_step"] += time.perf_counter_ns() - start

    spent["plain_step"] = 0
    bookkeeping.plain_step = timed_call
    env = make_batched_env(args.env, n_envs=args.envs, seed=0)
    env.reset(seed=0)
    actions = [env.action_space.sample() for _ in range(50)]
    for i in range(200):  # compiled, warm
        env.step(actions[i % 50])
    for name in spent:
        spent[name] = 0
    start = time.perf_counter_ns()
    for i in range(args.steps):
        env.step(actions[i % 50])
    total = time.perf_counter_ns() - start
    print(f"{args.env}, N = {args.envs}: us per step call ({args.steps} calls), wall clock")
    print(f"{'step':<12} {total / args.steps / 1e3:8.1f}")
    for name in spent:
        print(f"{name:<12} {spent[name] / args.steps / 1e3:8.1f}")
    rest = total - sum(spent.values())
    print(
        f"{'the rest':<12} {rest / args.steps / 1e3:8.1f}  (clipping, statistics, info; the motor noise, unless in plain_step)"
    )
    if env.motor_noise:  # the motor noise's draws, timed alone on the env's own buffers
        start = time.perf_counter_ns()
        for _ in range(args.steps):
            normals.noise_factors(env.noise_rng, env._noise_ratio, env._noise_buffer)
        print(f"{'noise alone':<12} {(time.perf_counter_ns() - start) / args.steps / 1e3:8.1f}")


if __name__ == "__main__":
    main()

"""Env steps per second and reset time of every registered environment.

Each env is built once through ``gymnasium.make`` (so with Gymnasium's default
wrappers: order enforcing and the passive checker), warmed up, then stepped with random
actions at the default agent rate (30 Hz, 8 physics steps per env step), resetting
whenever an episode ends (those resets are included in the step timing, as in a
training loop): the "random" column.  Reset time is the median of ``--resets`` seeded
resets.  Each timing is repeated ``--repeats`` times; the median is kept.

The env's own cost per step (action clipping, observation, task, reward terms, info) is
the time the unwrapped env's ``step`` spends outside ``World.step``: the "overhead"
column.  The bare World hovering the same vehicle is shown for scale.

    python experiments/speed_envs.py [--steps 3000] [--repeats 5] [--resets 5]

Yardstick (DESIGN.md, 2-core machine): reference PyFlyt 0.29.0 does about 1,300 env
steps/s on QuadX hover and resets in 20-35 ms (it rebuilds the world at every reset).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time

import gymnasium
import numpy as np

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_engine.envs import ENVS
from pyflyt_engine.world import VehicleConfig, World


def time_steps(env: gymnasium.Env, steps: int, seed: int) -> float:
    """Seconds per env step, random actions, resetting at episode ends."""
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(steps)]
    for action in actions[:100]:  # warm up
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return (time.perf_counter() - start) / steps


def time_overhead(env: gymnasium.Env, steps: int) -> float:
    """Seconds per step the unwrapped env spends outside ``World.step`` (random actions).

    ``World.step`` is wrapped with a timer for the measurement, so the physics of both
    timings is the same flight.
    """
    raw = env.unwrapped
    world_step = raw.world.step
    in_world = 0.0

    def timed_step() -> None:
        nonlocal in_world
        start = time.perf_counter()
        world_step()
        in_world += time.perf_counter() - start

    raw.world.step = timed_step
    try:
        raw.reset(seed=0)
        raw.action_space.seed(0)
        actions = [raw.action_space.sample() for _ in range(steps)]
        total = 0.0
        for action in actions:
            start = time.perf_counter()
            _, _, terminated, truncated, _ = raw.step(action)
            total += time.perf_counter() - start
            if terminated or truncated:
                raw.reset()
    finally:
        del raw.world.step
    return (total - in_world) / steps


def time_resets(env: gymnasium.Env, count: int) -> float:
    """Median seconds per seeded reset (after a few steps, so state must be restored)."""
    times = []
    for i in range(count):
        for _ in range(5):
            env.step(env.action_space.sample())
        start = time.perf_counter()
        env.reset(seed=i)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def time_world(steps: int) -> float:
    """Seconds per agent step of the bare World (same vehicle, rates_thrust, hover thrust)."""
    world = World([VehicleConfig("quadx_cf2x", (0.0, 0.0, 1.0), mode="rates_thrust")], seed=0)
    world.set_setpoint(0, [0.0, 0.0, 0.0, 0.125])
    for _ in range(100):
        world.step()
    start = time.perf_counter()
    for _ in range(steps):
        world.step()
    elapsed = time.perf_counter() - start
    world.close()
    return elapsed / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=3000, help="env steps per timing")
    parser.add_argument("--repeats", type=int, default=5, help="timings per env; the median is kept")
    parser.add_argument("--resets", type=int, default=5, help="resets per reset timing; the median is kept")
    args = parser.parse_args()

    print(
        f"machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
        f"numpy {np.__version__}, gymnasium {gymnasium.__version__}"
    )
    world = statistics.median(time_world(args.steps) for _ in range(args.repeats))
    print(f"{'case':<30}{'steps/s':>10}{'us/step':>10}{'env overhead us':>17}{'reset ms':>10}")
    print(f"{'bare World hover, rates_thrust':<30}{1 / world:>10.0f}{world * 1e6:>10.1f}{'-':>17}{'-':>10}")
    for env_id in ENVS:
        env = gymnasium.make(env_id)
        step = statistics.median(time_steps(env, args.steps, seed=r) for r in range(args.repeats))
        overhead = statistics.median(time_overhead(env, args.steps) for _ in range(args.repeats))
        reset = statistics.median(time_resets(env, args.resets) for _ in range(args.repeats))
        env.close()
        print(f"{env_id:<30}{1 / step:>10.0f}{step * 1e6:>10.1f}{overhead * 1e6:>17.1f}{reset * 1e3:>10.2f}")


if __name__ == "__main__":
    main()

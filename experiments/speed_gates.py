"""Steps per second of QuadX-Gates-v0 with its camera image at 64 x 64 and 128 x 128.

The env is stepped with random body-rate actions around hover (thrust 0.125 +- 0.02),
resetting whenever an episode ends (resets included, as in a training loop), after a
warm-up; each timing is repeated ``--repeats`` times and the median kept.  Steps/s are
given per second of wall time and per second of this process's CPU time (the CPU
figure does not move when other processes share the machine).  The same env
without the camera image (``camera_observation: null``) is timed side by side, so the
camera's cost shows as a ratio measured in the same run.

    python experiments/speed_gates.py [--steps 1500] [--repeats 3]

The reference PyFlyt 0.29.0 QuadX-Gates-v0 cannot load its gate model, so its speed cannot
be measured; its camera cost is estimated from what is measured: one 128 x 128 capture of
its QuadX camera (``experiments/compare_reference.py``, docs/performance.md) times the
captures it makes per agent step (every physics step when ``camera_fps`` is unset: 6 at
240 / 40 Hz).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
import warnings

import numpy as np

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config


def steps_per_second(env, steps: int, seed: int) -> tuple[float, float]:
    """(steps per second of wall time, steps per second of this process's CPU time)."""
    rng = np.random.default_rng(seed)
    actions = np.column_stack(
        [rng.uniform(-0.3, 0.3, (steps + 100, 3)), 0.125 + 0.02 * rng.standard_normal(steps + 100)]
    )
    env.reset(seed=seed)
    for a in actions[:100]:  # warm up
        if any(env.step(a)[2:4]):
            env.reset()
    start, cpu = time.perf_counter(), time.process_time()
    for a in actions[100:]:
        if any(env.step(a)[2:4]):
            env.reset()
    return steps / (time.perf_counter() - start), steps / (time.process_time() - cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=1500)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    if args.steps < 1 or args.repeats < 1:
        parser.error("--steps and --repeats must be >= 1")

    base = load_env_config("quadx_gates").model_dump(exclude={"source"})
    camera = base["camera_observation"]
    variants = {"no image": None}
    for size in (64, 128):
        variants[f"{size} x {size} RGB"] = {**camera, "camera": {**camera["camera"], "width": size, "height": size}}
    rows = []
    for name, obs in variants.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = make_env({**base, "camera_observation": obs})
        rates = [steps_per_second(env, args.steps, seed) for seed in range(args.repeats)]
        env.close()
        rows.append((name, statistics.median(r[0] for r in rates), statistics.median(r[1] for r in rates)))
    print(
        f"QuadX-Gates-v0, agent 40 Hz, {args.steps} steps x {args.repeats} repeats, {platform.processor() or platform.machine()}"
    )
    print()
    print("| observation | steps/s (wall) | steps/s (CPU) | ms/step (CPU) | x no image (CPU) |")
    print("|---|---:|---:|---:|---:|")
    reference = rows[0][2]
    for name, wall, cpu in rows:
        print(f"| {name} | {wall:,.0f} | {cpu:,.0f} | {1000 / cpu:.2f} | {cpu / reference:.2f} |")


if __name__ == "__main__":
    main()

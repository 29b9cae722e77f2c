"""What the state estimator costs on a QuadX-Hover step (docs/environments.md, "Estimated state").

``conf/env/quadx_hover_sensors.yaml`` (BMI088 IMU at 1 kHz, motion capture at 100 Hz) is
stepped at hover thrust with ``sensors.estimator`` ``none`` and ``complementary``, and
without sensors at all (the shipped QuadX-Hover-v0), resetting whenever an episode ends,
after a warm-up.  CPU time of this process is measured (it does not move when other
processes share the machine), each variant ``--repeats`` times, interleaved round-robin so
a change of load hits every variant alike, and the median kept.  With a 1 kHz gyro and
240 Hz physics the estimator makes about 4.2 updates per physics step, 33 per agent step.

    python experiments/speed_estimator.py [--steps 600] [--repeats 5]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
import warnings

import gymnasium
import numpy as np

import pyflyt_engine.envs  # noqa: F401  (registers the ids)
from pyflyt_engine.envs.config import load_env_config


def make(variant: str) -> gymnasium.Env:
    if variant == "no sensors":
        return gymnasium.make("PyFlyt/QuadX-Hover-v0", disable_env_checker=True)
    sensors = load_env_config("quadx_hover_sensors").sensors.model_dump()
    sensors["estimator"] = {"type": "complementary"} if variant == "complementary" else {"type": "none"}
    return gymnasium.make(
        "PyFlyt/QuadX-Hover-v0", config="quadx_hover_sensors", sensors=sensors, disable_env_checker=True
    )


def time_steps(env: gymnasium.Env, steps: int, seed: int) -> float:
    """CPU seconds per agent step."""
    env.reset(seed=seed)
    action = np.array([0.0, 0.0, 0.0, 0.125])
    start = time.process_time()
    for _ in range(steps):
        *_, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return (time.process_time() - start) / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    variants = ["no sensors", "none", "complementary"]
    envs = {v: make(v) for v in variants}
    for env in envs.values():  # warm-up
        time_steps(env, 60, 0)
    load_before = os.getloadavg()
    times: dict[str, list[float]] = {v: [] for v in variants}
    for r in range(args.repeats):
        for v in variants:
            times[v].append(time_steps(envs[v], args.steps, r))
    load_after = os.getloadavg()
    median = {v: statistics.median(t) * 1e6 for v, t in times.items()}
    print(
        f"{platform.machine()}, Python {platform.python_version()}, {os.cpu_count()} CPUs; load (1/5/15 min) "
        f"before {'/'.join(f'{x:.1f}' for x in load_before)}, after {'/'.join(f'{x:.1f}' for x in load_after)}; "
        f"{args.repeats} x {args.steps} steps, median CPU time\n"
    )
    print("| variant | CPU us per agent step | vs sensors without estimator |")
    print("|---|---|---|")
    for v in variants:
        print(f"| {v} | {median[v]:.0f} | {100 * (median[v] / median['none'] - 1):+.0f} % |")
    for env in envs.values():
        env.close()


if __name__ == "__main__":
    main()

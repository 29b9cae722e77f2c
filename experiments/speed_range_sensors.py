"""What ray-cast range sensors cost on a QuadX env step, against the rendered camera.

A QuadX-Hover-v0 env is stepped with random body-rate actions around hover (thrust
0.125 +- 0.02), resetting whenever an episode ends, after a warm-up; CPU time of this
process is measured (it does not move when other processes share the machine), each
variant ``--repeats`` times, interleaved round-robin with the others so a change of load
hits every variant alike, and the median kept.  Variants:

* the plain env (no sensor), the reference of every ratio;
* a 64-beam planar LiDAR (``range_sensors``, 5 m range), refreshed every agent step and
  at 10 Hz;
* ray-cast depth cameras (``range_sensors`` of ``type: depth``) at several resolutions;
* the rendered camera (``camera_observation``, PyBullet's TinyRenderer, RGB) at the same
  resolutions, the engine's other way to see depth (its ``depth`` image comes from the
  same render).

The world holds the QuadX-Obstacles-v0 forest (12 trunks) in every variant, so the rays
have something to hit and the plain step pays for the same bodies.

    python experiments/speed_range_sensors.py [--steps 1000] [--repeats 5]

Prints a Markdown table: CPU ms per step, the added ms per step over the plain env, and
the added cost as a percentage of the plain step.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
import warnings

import numpy as np

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config

RESOLUTIONS = ((8, 6), (16, 12), (32, 24), (64, 48))


def cpu_ms_per_step(env, steps: int, seed: int) -> float:
    """CPU milliseconds of this process per env step (resets included)."""
    rng = np.random.default_rng(seed)
    low, high = env.action_space.low, env.action_space.high
    actions = np.column_stack(
        [rng.uniform(-0.3, 0.3, (steps + 50, 3)), 0.125 + 0.02 * rng.standard_normal(steps + 50)]
    ).clip(low, high)
    env.reset(seed=seed)
    for a in actions[:50]:  # warm up
        if any(env.step(a)[2:4]):
            env.reset()
    cpu = time.process_time()
    for a in actions[50:]:
        if any(env.step(a)[2:4]):
            env.reset()
    return 1000.0 * (time.process_time() - cpu) / steps


def variants() -> dict[str, dict]:
    hover = load_env_config("quadx_hover").model_dump(exclude={"source"})
    forest = load_env_config("quadx_obstacles").model_dump(exclude={"source"})["obstacles"]
    base = {**hover, "obstacles": forest, "flight_dome_size": 7.0}
    out = {"plain": base}
    lidar = {"name": "lidar", "type": "lidar", "horizontal_beams": 64, "max_range": 5.0, "min_range": 0.1}
    out["LiDAR 64 beams"] = {**base, "range_sensors": [lidar]}
    # a spinning LiDAR's usual 10 Hz (every third agent step; the last scan in between)
    out["LiDAR 64 beams, 10 Hz"] = {**base, "range_sensors": [{**lidar, "rate_hz": 10.0}]}
    for w, h in RESOLUTIONS:
        depth = {"name": "depth", "type": "depth", "width": w, "height": h, "fov": 90.0, "max_range": 10.0, "min_range": 0.1}
        out[f"ray-cast depth {w} x {h}"] = {**base, "range_sensors": [depth]}
        camera = {"camera": {"name": "eye", "width": w, "height": h, "fov": 90.0, "near": 0.1, "far": 10.0}}
        out[f"rendered camera {w} x {h}"] = {**base, "camera_observation": camera}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    if args.steps < 1 or args.repeats < 1:
        parser.error("--steps and --repeats must be >= 1")
    envs = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, config in variants().items():
            envs[name] = make_env(config)
    times: dict[str, list[float]] = {name: [] for name in envs}
    for repeat in range(args.repeats):
        for name, env in envs.items():
            times[name].append(cpu_ms_per_step(env, args.steps, repeat))
    for env in envs.values():
        env.close()
    median = {name: statistics.median(t) for name, t in times.items()}
    plain = median["plain"]
    print(
        f"QuadX-Hover-v0 + 12-trunk forest, agent 30 Hz, {args.steps} steps x {args.repeats} repeats (median), "
        f"{platform.processor() or platform.machine()}, load average {os.getloadavg()[0]:.1f} at the end"
    )
    print()
    print("| observation | CPU ms/step | added ms/step | added % of plain step |")
    print("|---|---:|---:|---:|")
    for name, ms in median.items():
        added = ms - plain
        print(f"| {name} | {ms:.3f} | {added:+.3f} | {100 * added / plain:+.0f} % |")


if __name__ == "__main__":
    main()

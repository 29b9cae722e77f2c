"""What ray-cast range sensors cost on a QuadX env step, against the rendered camera.

A QuadX-Hover-v0 env is stepped with random body-rate actions around hover (thrust
0.125 +- 0.02), resetting whenever an episode ends, after a warm-up; CPU time of this
process is measured (it does not move when other processes share the machine), each
variant ``--repeats`` times, interleaved round-robin with the others so a change of load
hits every variant alike, and the median kept.  Variants:

* the plain env (no sensor), the reference of every ratio;
* a 64-beam planar LiDAR (``range_sensors``, 5 m range), refreshed every agent step and
  at 10 Hz;
* the same LiDAR cast the previous way (:func:`previous_scan`: the rays handed to PyBullet
  as lists of lists, every result tuple read into a list), kept here only to measure the
  engine's cast against it in the same run; before timing, both are stepped through the
  same seeded episodes and their readings compared bit for bit;
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
import gc
import os
import platform
import statistics
import time
import warnings

import numpy as np

import pyflyt_engine  # noqa: F401  (registers the ids)
from pyflyt_engine import exact
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.components.range_sensor import RAY_MASK, RangeSensor
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.frames import quaternion_to_rows

RESOLUTIONS = ((8, 6), (16, 12), (32, 24), (64, 48))
PREVIOUS = "LiDAR 64 beams, previous cast"


def previous_scan(self: RangeSensor, client, position, quaternion, time=None) -> np.ndarray:
    """The engine's cast before the ray arrays went to PyBullet as they are (a reference for
    this benchmark only; a LiDAR below 16 384 rays, one ``rayTestBatch`` call)."""
    cached = self._last
    if time is not None and cached is not None and time - cached[0] < 1.0 / self.spec.rate_hz - 1e-9:
        return cached[1].copy()
    r = quaternion_to_rows(quaternion)
    origin = np.array(exact.rotate(r, self.offset)) + np.asarray(position, dtype=np.float64)
    rt = np.array(r).T
    dx, dy, dz = self._columns
    ground = dx * rt[0] + dy * rt[1] + dz * rt[2]
    starts, ends = origin + self.min_range * ground, origin + self.max_range * ground
    collecting = gc.isenabled()
    gc.disable()
    try:
        results = p.rayTestBatch(starts.tolist(), ends.tolist(), collisionFilterMask=RAY_MASK, physicsClientId=client)
        fractions = np.array([r[2] for r in results])
        del results
    finally:
        if collecting:
            gc.enable()
    hit = fractions < 1.0
    ranges = self.min_range + fractions * (self.max_range - self.min_range)
    if self.spec.noise_std > 0:
        eta = self.rng.standard_normal(self.count)
        ranges = np.where(hit, np.clip(ranges + self.spec.noise_std * eta, self.min_range, self.max_range), ranges)
    readings = ranges.reshape(self.shape).astype(np.float32)
    self._last = (time if time is not None else float("nan"), readings)
    return readings.copy()


def use_previous_scan(env) -> None:
    """Make ``env``'s LiDAR cast the previous way."""
    for sensor in env.unwrapped.world.vehicles[0].range_sensors:
        sensor.scan = previous_scan.__get__(sensor)


def check_identical(current, previous, steps: int) -> int:
    """Step both envs with the same seeded actions; every LiDAR reading must be the same bit
    for bit (noisy readings: the noise stream is drawn alike), and most scans must see an
    obstacle. Returns the scans compared."""
    rng = np.random.default_rng(7)
    compared = hits = 0
    for env in (current, previous):
        env.reset(seed=7)
    for _ in range(steps):
        a = np.array([*rng.uniform(-0.6, 0.6, 3), 0.125 + 0.03 * rng.standard_normal()])
        a = a.clip(current.action_space.low, current.action_space.high)
        out = [env.step(a) for env in (current, previous)]
        x, y = out[0][0]["lidar"], out[1][0]["lidar"]
        if x.tobytes() != y.tobytes():
            raise SystemExit(f"the engine's LiDAR readings differ from the previous cast after {compared} steps")
        compared += 1
        hits += bool((x < 5.0).any())  # the LiDAR's max_range: something was hit
        if any(out[0][2:4]):
            for env in (current, previous):
                env.reset()
    if hits < compared // 2:
        raise SystemExit(f"only {hits} of {compared} scans saw an obstacle: the comparison would prove little")
    return compared


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
    out[PREVIOUS] = {**base, "range_sensors": [lidar]}
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
        use_previous_scan(envs[PREVIOUS])
        noisy = {**variants()["LiDAR 64 beams"]}
        noisy["range_sensors"] = [{**noisy["range_sensors"][0], "noise_std": 0.01}]
        pair = [make_env(noisy) for _ in range(2)]
    use_previous_scan(pair[1])
    compared = check_identical(envs["LiDAR 64 beams"], envs[PREVIOUS], 500)
    compared += check_identical(*pair, 500)
    for env in pair:
        env.close()
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
    print(f"LiDAR readings of the engine and the previous cast: {compared} scans compared, identical bit for bit")
    print()
    print("| observation | CPU ms/step | added ms/step | added % of plain step |")
    print("|---|---:|---:|---:|")
    for name, ms in median.items():
        added = ms - plain
        print(f"| {name} | {ms:.3f} | {added:+.3f} | {100 * added / plain:+.0f} % |")


if __name__ == "__main__":
    main()

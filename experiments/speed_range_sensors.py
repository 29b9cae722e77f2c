"""What ray-cast range sensors cost on a QuadX env step, against the rendered camera.

A QuadX-Hover-v0 env is stepped with random body-rate actions around hover (thrust
0.125 +- 0.02), resetting whenever an episode ends, after a warm-up; CPU time of this
process is measured (it does not move when other processes share the machine), each
variant ``--repeats`` times, interleaved round-robin with the others so a change of load
hits every variant alike, and the median kept.  Variants:

* the plain env (no sensor), the reference of every ratio;
* a 64-beam planar LiDAR (``range_sensors``, 5 m range), refreshed every agent step and
  at 10 Hz;
* the same LiDAR cast the previous way (:func:`use_previous_scan`: the rays placed in the
  ground frame by NumPy in Python each scan, :meth:`RangeSensor.rays`, instead of handed to
  PyBullet once in the body's frame with the body as their parent), to measure the engine's
  cast against it in the same run; before timing, both are stepped through the same seeded
  episodes (with and without noise) and their readings compared (the count of readings that
  differ and the largest difference are printed; more than 1e-6 m stops the script);
* with ``--lidar-only``: the LiDAR env with its scan replaced by a constant, and the plain
  env with its vehicle in the rays' skip group (what the step costs around the scan);
* ray-cast depth cameras (``range_sensors`` of ``type: depth``) at several resolutions;
* the rendered camera (``camera_observation``, PyBullet's TinyRenderer, RGB) at the same
  resolutions, the engine's other way to see depth (its ``depth`` image comes from the
  same render).

The world holds the QuadX-Obstacles-v0 forest (12 trunks) in every variant, so the rays
have something to hit and the plain step pays for the same bodies.

    python experiments/speed_range_sensors.py [--steps 1000] [--repeats 5] [--rounds-table] [--lidar-only]

Prints a Markdown table: CPU ms per step, the added ms per step over the plain env, and
the added cost as a percentage of the plain step (with ``--rounds-table`` also each round's
plain and 64-beam LiDAR step); then where a 64-beam scan's time goes in isolation
(:func:`breakdown`: the bare ``rayTestBatch`` of 64 rays -- the floor of any cast through
PyBullet's API -- the Python ray placement, a whole scan each way, the Dict observation's
finiteness check) against the bare env step.
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
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.components.range_sensor import RAY_MASK, RAY_SKIP_GROUP
from pyflyt_engine.envs import make_env
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.envs.guard import all_finite

RESOLUTIONS = ((8, 6), (16, 12), (32, 24), (64, 48))
PREVIOUS = "LiDAR 64 beams, previous cast"
STUB = "LiDAR 64 beams, scan replaced by a constant"
GROUP = "plain, vehicle in the rays' skip group"


def use_previous_scan(env) -> None:
    """Make ``env``'s LiDAR cast the previous way: the rays placed in the ground frame in Python
    (:meth:`RangeSensor.rays`, what a sensor without a body does), not by PyBullet from the
    body's frame."""
    for sensor in env.unwrapped.world.vehicles[0].range_sensors:
        sensor.body = None


def fraction_gap(env) -> float:
    """The largest difference of the 64 hit fractions PyBullet returns for ``env``'s LiDAR at
    its vehicle's present pose, cast from the body frame and placed in the ground frame."""
    vehicle = env.unwrapped.world.vehicles[0]
    sensor, client, state = vehicle.range_sensors[0], env.unwrapped.world.client, vehicle.state
    ground = p.rayTestBatch(
        *sensor.rays(state.lin_pos, state.quaternion), collisionFilterMask=RAY_MASK, physicsClientId=client
    )
    body = p.rayTestBatch(
        *sensor._local,
        parentObjectUniqueId=vehicle.body_id,
        parentLinkIndex=-1,
        collisionFilterMask=RAY_MASK,
        physicsClientId=client,
    )
    return max(abs(a[2] - b[2]) for a, b in zip(ground, body))


def check_identical(current, previous, steps: int) -> tuple[int, int, float, float]:
    """Step both envs with the same seeded actions and compare every LiDAR reading (noisy
    readings: the noise stream is drawn alike); most scans must see an obstacle. Returns the
    scans compared, the readings that differ, the largest difference [m] (exits if one
    differs by more than 1e-6 m: more than rounding) and the largest difference of a hit
    fraction between the two placements (:func:`fraction_gap`)."""
    rng = np.random.default_rng(7)
    compared = hits = differ = 0
    worst = gap = 0.0
    for env in (current, previous):
        env.reset(seed=7)
    for _ in range(steps):
        a = np.array([*rng.uniform(-0.6, 0.6, 3), 0.125 + 0.03 * rng.standard_normal()])
        a = a.clip(current.action_space.low, current.action_space.high)
        out = [env.step(a) for env in (current, previous)]
        x, y = out[0][0]["lidar"], out[1][0]["lidar"]
        differ += int((x != y).sum())
        worst = max(worst, float(np.abs(x.astype(np.float64) - y).max()))
        if worst > 1e-6:
            raise SystemExit(f"the LiDAR readings of the two casts differ by {worst} m after {compared} steps")
        gap = max(gap, fraction_gap(current))
        compared += 1
        hits += bool((x < 5.0).any())  # the LiDAR's max_range: something was hit
        if any(out[0][2:4]):
            for env in (current, previous):
                env.reset()
    if hits < compared // 2:
        raise SystemExit(f"only {hits} of {compared} scans saw an obstacle: the comparison would prove little")
    return compared, differ, worst, gap


def thread_us(call, repeats: int, rounds: int = 15) -> float:
    """Median over ``rounds`` of the thread CPU microseconds per call of ``call``."""
    out = []
    for _ in range(rounds):
        t = time.thread_time()
        for _ in range(repeats):
            call()
        out.append(1e6 * (time.thread_time() - t) / repeats)
    return statistics.median(out)


def in_step(plain, lidar, steps: int, rounds: int) -> tuple[float, float, float, float]:
    """The 64-beam scan as it runs inside env steps (caches cold after the physics steps):
    ``(plain step, LiDAR step, scan, rayTestBatch)`` in CPU µs, the steps the median of
    ``rounds`` alternating rounds of ``steps`` steps each, the scan and its ``rayTestBatch``
    call the thread CPU time they took in the LiDAR rounds per scan."""
    import pyflyt_engine.components.range_sensor as module

    sensor = lidar.unwrapped.world.vehicles[0].range_sensors[0]
    spent = {"scan": 0.0, "cast": 0.0, "scans": 0}
    bullet = module.p

    class TimedBullet:
        def __getattr__(self, name):
            return getattr(bullet, name)

        def rayTestBatch(self, *args, **kwargs):  # noqa: N802 (PyBullet's name)
            t = time.thread_time()
            out = bullet.rayTestBatch(*args, **kwargs)
            spent["cast"] += time.thread_time() - t
            return out

    def timed_scan(*args, **kwargs):
        t = time.thread_time()
        out = scan(*args, **kwargs)
        spent["scan"] += time.thread_time() - t
        spent["scans"] += 1
        return out

    scan = sensor.scan
    module.p, sensor.scan = TimedBullet(), timed_scan
    try:
        steps_us: dict[str, list[float]] = {"plain": [], "lidar": []}
        for k in range(rounds):
            for name, env in (("plain", plain), ("lidar", lidar)):
                steps_us[name].append(1000.0 * cpu_ms_per_step(env, steps, 100 + k))
    finally:
        module.p = bullet
        del sensor.scan
    n = spent["scans"]
    return (
        statistics.median(steps_us["plain"]),
        statistics.median(steps_us["lidar"]),
        1e6 * spent["scan"] / n,
        1e6 * spent["cast"] / n,
    )


def breakdown(plain, lidar, steps: int) -> list[tuple[str, float]]:
    """Where a 64-beam scan's time goes, in isolation (thread CPU µs, median of 15 rounds), at
    the pose ``lidar`` reaches after ``steps`` seeded steps, against the bare step of ``plain``."""
    rng = np.random.default_rng(3)
    lidar.reset(seed=3)
    for _ in range(steps):
        if any(lidar.step(np.array([*rng.uniform(-0.3, 0.3, 3), 0.125]))[2:4]):
            lidar.reset()
    world = lidar.unwrapped.world
    vehicle, client = world.vehicles[0], world.client
    sensor = vehicle.range_sensors[0]
    state = vehicle.state
    starts, ends = (np.ascontiguousarray(a) for a in sensor.rays(state.lin_pos, state.quaternion))
    local_starts, local_ends = sensor._local
    n = 2000

    def world_cast():
        return p.rayTestBatch(starts, ends, collisionFilterMask=RAY_MASK, physicsClientId=client)

    def body_cast():
        return p.rayTestBatch(
            local_starts,
            local_ends,
            parentObjectUniqueId=vehicle.body_id,
            parentLinkIndex=-1,
            collisionFilterMask=RAY_MASK,
            physicsClientId=client,
        )

    def scan_previous():
        sensor.body = None
        try:
            return sensor.scan(client, state.lin_pos, state.quaternion)
        finally:
            sensor.body = vehicle.body_id

    action = np.array([0.0, 0.0, 0.0, 0.125])

    def plain_step():
        if any(plain.step(action)[2:4]):
            plain.reset()

    plain.reset(seed=3)
    rows = [
        ("bare env step, no sensor (QuadX-Hover + forest)", thread_us(plain_step, 300)),
        ("rayTestBatch, 64 rays in the ground frame", thread_us(world_cast, n)),
        ("rayTestBatch, 64 rays from the body frame (parent body)", thread_us(body_cast, n)),
        (
            "RangeSensor.rays: the 64 rays placed in the ground frame in NumPy",
            thread_us(lambda: sensor.rays(state.lin_pos, state.quaternion), n),
        ),
        (
            "RangeSensor.scan, rays from the body frame (the engine's)",
            thread_us(lambda: sensor.scan(client, state.lin_pos, state.quaternion), n),
        ),
        ("RangeSensor.scan, rays placed in Python (the previous cast)", thread_us(scan_previous, n)),
        (
            "the Dict observation's finiteness check",
            thread_us(lambda: all_finite(0.0, {"attitude": np.zeros(21), "lidar": np.zeros(64, np.float32)}), n),
        ),
    ]
    return rows


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
        depth = {
            "name": "depth",
            "type": "depth",
            "width": w,
            "height": h,
            "fov": 90.0,
            "max_range": 10.0,
            "min_range": 0.1,
        }
        out[f"ray-cast depth {w} x {h}"] = {**base, "range_sensors": [depth]}
        camera = {"camera": {"name": "eye", "width": w, "height": h, "fov": 90.0, "near": 0.1, "far": 10.0}}
        out[f"rendered camera {w} x {h}"] = {**base, "camera_observation": camera}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--rounds-table", action="store_true", help="also print each round of plain and LiDAR 64")
    parser.add_argument(
        "--lidar-only",
        action="store_true",
        help="time only the plain env and the 64-beam LiDAR both ways: short rounds, so a round's variants share its load",
    )
    args = parser.parse_args()
    if args.steps < 1 or args.repeats < 1:
        parser.error("--steps and --repeats must be >= 1")
    envs = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, config in variants().items():
            if not args.lidar_only or name in ("plain", "LiDAR 64 beams", PREVIOUS):
                envs[name] = make_env(config)
        if args.lidar_only:  # what the step costs around the scan: the scan replaced, the skip group alone
            envs[STUB] = make_env(variants()["LiDAR 64 beams"])
            constant = np.full(64, 5.0, np.float32)
            envs[STUB].unwrapped.world.vehicles[0].range_sensors[0].scan = lambda *_, **__: constant.copy()
            envs[GROUP] = make_env(variants()["plain"])
            world = envs[GROUP].unwrapped.world
            p.setCollisionFilterGroupMask(
                world.vehicles[0].body_id, -1, RAY_SKIP_GROUP, -1, physicsClientId=world.client
            )
        use_previous_scan(envs[PREVIOUS])
        noisy = {**variants()["LiDAR 64 beams"]}
        noisy["range_sensors"] = [{**noisy["range_sensors"][0], "noise_std": 0.01}]
        pair = [make_env(noisy) for _ in range(2)]
    use_previous_scan(pair[1])
    checks = [check_identical(envs["LiDAR 64 beams"], envs[PREVIOUS], 500), check_identical(*pair, 500)]
    for env in pair:
        env.close()
    compared, differ = sum(c[0] for c in checks), sum(c[1] for c in checks)
    worst, gap = max(c[2] for c in checks), max(c[3] for c in checks)
    loads = [os.getloadavg()[0]]
    times: dict[str, list[float]] = {name: [] for name in envs}
    for repeat in range(args.repeats):
        for name, env in envs.items():
            times[name].append(cpu_ms_per_step(env, args.steps, repeat))
        loads.append(os.getloadavg()[0])
    rows = breakdown(envs["plain"], envs["LiDAR 64 beams"], 200)
    steps_plain, steps_lidar, scan_us, cast_us = in_step(envs["plain"], envs["LiDAR 64 beams"], 300, 10)
    for env in envs.values():
        env.close()
    median = {name: statistics.median(t) for name, t in times.items()}
    plain = median["plain"]
    print(
        f"QuadX-Hover-v0 + 12-trunk forest, agent 30 Hz, {args.steps} steps x {args.repeats} rounds (median), "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
        f"1-min load average {min(loads):.1f}-{max(loads):.1f} over the rounds"
    )
    print(
        f"LiDAR readings, body-frame cast against the previous cast: {compared} scans compared, "
        + ("identical bit for bit" if differ == 0 else f"{differ} readings differ, by at most {worst:.2e} m")
        + f"; hit fractions of the two placements differ by at most {gap:.1e}"
    )
    print()
    print("| observation | CPU ms/step | added ms/step | added % of plain step |")
    print("|---|---:|---:|---:|")
    for name, ms in median.items():
        added = ms - plain
        print(f"| {name} | {ms:.3f} | {added:+.3f} | {100 * added / plain:+.0f} % |")
    added = [100 * (b - a) / a for a, b in zip(times["plain"], times["LiDAR 64 beams"])]
    fastest = 100 * (min(times["LiDAR 64 beams"]) - min(times["plain"])) / min(times["plain"])
    print()
    print(
        f"LiDAR 64 beams, added % of the plain step per round: median {statistics.median(added):+.0f} % "
        f"(range {min(added):+.0f} to {max(added):+.0f} %); fastest round of each: {fastest:+.0f} %"
    )
    if args.rounds_table:
        print()
        print("| round | plain ms/step | LiDAR 64 ms/step | added % |")
        print("|---:|---:|---:|---:|")
        for k, (a, b) in enumerate(zip(times["plain"], times["LiDAR 64 beams"])):
            print(f"| {k + 1} | {a:.3f} | {b:.3f} | {100 * (b - a) / a:+.0f} % |")
    print()
    print(f"Breakdown in isolation (thread CPU µs per call, median of 15 rounds; load {os.getloadavg()[0]:.1f}):")
    print()
    print("| what | µs | % of the bare env step |")
    print("|---|---:|---:|")
    step_us = rows[0][1]
    for name, us in rows:
        print(f"| {name} | {us:.1f} | {100 * us / step_us:.0f} % |")
    print()
    print(f"Inside env steps (10 alternating rounds of 300 steps; load {os.getloadavg()[0]:.1f}):")
    print()
    print("| what | µs | % of the plain step |")
    print("|---|---:|---:|")
    for name, us in (
        ("plain env step (median round)", steps_plain),
        ("LiDAR 64 env step (median round)", steps_lidar),
        ("  its scan (RangeSensor.scan), per step", scan_us),
        ("  of which rayTestBatch", cast_us),
    ):
        print(f"| {name} | {us:.1f} | {100 * us / steps_plain:.0f} % |")


if __name__ == "__main__":
    main()

"""The timing protocols of ``pyflyt speed``, as functions of what they time.

Each protocol takes the thing to time (an env, a step function, a capture function) and
returns plain numbers; :mod:`pyflyt_cli.speed.probes` applies them to this package.
This module imports only the standard library, so another interpreter can load the file
by its path and time another package with exactly the same protocols.

A probe process runs one measurement and prints its result as the last line of its
output, ``RESULT_MARKER`` + JSON (:func:`main`); whatever else the process prints is
ignored.
"""

from __future__ import annotations

import json
import math
import os
import platform
import statistics
import sys
import time
import warnings
from collections.abc import Callable, Mapping
from typing import Any

#: Marker in front of the JSON result line (a simulator may print to stdout too).
RESULT_MARKER = "PYFLYT_SPEED_RESULT "
#: Agent rate of every env measurement [Hz].
AGENT_HZ = 30
#: Spacing of the vehicles in the world measurements [m].
GRID_SPACING = 1.0
#: Seeded resets are timed after this many steps, so the state must really be restored.
STEPS_BEFORE_RESET = 5


def time_env(env, agent_hz: float, steps: int = 2000, resets: int = 10, warmup: int = 200) -> dict:
    """Env steps per second, reset time and real-time factor of a Gymnasium env.

    Seeded reset, ``warmup`` steps, then ``steps`` steps of pre-drawn random actions,
    resetting at episode ends (those resets are part of the step timing, as in a
    training loop); then the median of ``resets`` seeded resets, each after
    ``STEPS_BEFORE_RESET`` steps.  Real-time factor = simulated seconds per wall second.
    """
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(warmup + steps)]

    def run(batch) -> int:
        episodes = 0
        for action in batch:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
                episodes += 1
        return episodes

    run(actions[:warmup])
    start, start_cpu = time.perf_counter(), time.process_time()
    episodes = run(actions[warmup:])
    step_s = (time.perf_counter() - start) / steps
    step_cpu_s = (time.process_time() - start_cpu) / steps
    times = []
    for seed in range(resets):
        for action in actions[:STEPS_BEFORE_RESET]:
            env.step(action)
        start = time.perf_counter()
        env.reset(seed=seed + 1)
        times.append(time.perf_counter() - start)
    return {
        "step_s": step_s,
        "step_cpu_s": step_cpu_s,
        "steps_per_s": 1.0 / step_s,
        "rtf": 1.0 / (step_s * agent_hz),
        "reset_s": statistics.median(times) if times else None,
        "episodes": episodes,
        "peak_rss_mb": peak_rss_mb(),
        "rss_mb": rss_mb(),
    }


def time_parallel_env(env, agent_hz: float, steps: int, warmup: int = 20, seed: int = 0) -> dict:
    """Env steps and agent-steps per second of a PettingZoo parallel env.

    Seeded reset, ``warmup`` steps, then ``steps`` steps in which every live agent takes a
    uniformly random action from its action space (seeded), resetting when no agent is
    left (those resets are part of the timing, as in training).  Agent-steps count the
    live agents stepped; real-time factor = simulated seconds per wall second.
    """
    env.reset(seed=seed)
    spaces = {name: env.action_space(name) for name in env.possible_agents}
    for offset, space in enumerate(spaces.values()):
        space.seed(seed + offset)

    def run(count: int) -> tuple[int, int]:
        agent_steps = episodes = 0
        for _ in range(count):
            if not env.agents:
                env.reset()
                episodes += 1
            agent_steps += len(env.agents)
            env.step({name: spaces[name].sample() for name in env.agents})
        return agent_steps, episodes

    run(warmup)
    start, start_cpu = time.perf_counter(), time.process_time()
    agent_steps, episodes = run(steps)
    wall = time.perf_counter() - start
    cpu = time.process_time() - start_cpu
    return {
        "agents": len(env.possible_agents),
        "env_steps_per_s": steps / wall,
        "agent_steps_per_s": agent_steps / wall,
        "agent_steps_per_cpu_s": agent_steps / max(cpu, 1e-9),
        "live_fraction": agent_steps / (steps * len(env.possible_agents)),
        "rtf": steps / (wall * agent_hz),
        "cpu_rtf": steps / (max(cpu, 1e-9) * agent_hz),
        "episodes": episodes,
        "peak_rss_mb": peak_rss_mb(),
    }


def centred_grid(n: int, spacing: float = 1.0, height: float = 1.0) -> list[tuple[float, float, float]]:
    """``n`` points on a square grid ``spacing`` apart at ``height``, centred on the z axis:
    ``ceil(sqrt(n))`` columns filled row by row (the ``grid`` layout of the multi-agent envs)."""
    columns = math.ceil(math.sqrt(n))
    rows = math.ceil(n / columns)
    return (
        [
            ((i % columns - (columns - 1) / 2.0) * spacing, (i // columns - (rows - 1) / 2.0) * spacing, height)
            for i in range(n)
        ]
        if n > 1
        else [(0.0, 0.0, height)]
    )


def time_world(step: Callable[[], object], period: float, seconds: float) -> dict:
    """Wall and CPU time of ``step`` (advancing ``period`` simulated seconds) over ``seconds``
    of simulated time, after a quarter-second warm-up; RTF = simulated s per wall s."""
    for _ in range(max(1, round(0.25 / period))):
        step()
    count = max(1, round(seconds / period))
    start, start_cpu = time.perf_counter(), time.process_time()
    for _ in range(count):
        step()
    wall = time.perf_counter() - start
    cpu = time.process_time() - start_cpu
    return {
        "step_s": wall / count,
        "steps_per_s": count / wall,
        "rtf": count * period / wall,
        "cpu_rtf": count * period / max(cpu, 1e-9),
        "peak_rss_mb": peak_rss_mb(),
    }


def time_captures(shoot: Callable[[], object], captures: int = 50, repeats: int = 5) -> dict:
    """Seconds of wall and CPU time per call of ``shoot``: the median of ``repeats`` timings
    of ``captures`` calls, after one call."""
    shoot()
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        for _ in range(captures):
            shoot()
        wall.append((time.perf_counter() - start) / captures)
        cpu.append((time.process_time() - start_cpu) / captures)
    return {"capture_s": statistics.median(wall), "capture_cpu_s": statistics.median(cpu)}


def time_floor(
    pybullet,
    urdf: str,
    mass: float,
    motor_positions: list[tuple[float, float, float]],
    steps: int,
    n: int = 1,
    clock: Callable[[], float] = time.perf_counter,
) -> float:
    """Seconds per physics step of the bare-PyBullet floor (timed by ``clock``).

    ``n`` bodies from ``urdf`` on :func:`grid_positions` over a ground plane, 240 Hz; per
    physics step and body one pose and one velocity read, one force of ``mass * g / 4``
    at each of ``motor_positions`` and one zero torque; one ``stepSimulation``.  Client
    ids are passed positionally (the binding's fastest calling form).  ``pybullet`` is
    the module to use, so any interpreter with PyBullet times the same floor.
    """
    p = pybullet
    cid = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=cid)
    p.setTimeStep(1 / 240, physicsClientId=cid)
    p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
    bodies = [
        p.loadURDF(urdf, list(pos), flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
        for pos in grid_positions(n)
    ]
    weight = mass * 9.81 / 4
    motors = [tuple(m) for m in motor_positions]
    frame = p.LINK_FRAME
    start = clock()
    for _ in range(steps):
        for body in bodies:
            p.getBasePositionAndOrientation(body, cid)
            p.getBaseVelocity(body, cid)
            for position in motors:
                p.applyExternalForce(body, -1, (0.0, 0.0, weight), position, frame, cid)
            p.applyExternalTorque(body, -1, (0.0, 0.0, 0.0), frame, cid)
        p.stepSimulation(cid)
    elapsed = clock() - start
    p.disconnect(cid)
    return elapsed / steps


def grid_positions(n: int) -> list[tuple[float, float, float]]:
    """Spawn positions of ``n`` vehicles: a square grid ``GRID_SPACING`` apart at 1 m."""
    side = math.ceil(math.sqrt(n))
    return [((i % side) * GRID_SPACING, (i // side) * GRID_SPACING, 1.0) for i in range(n)]


def peak_rss_mb() -> float:
    """Peak resident set size of this process so far [MiB] (NaN where unavailable)."""
    try:
        import resource
    except ImportError:  # Windows
        return float("nan")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 2**10  # bytes on macOS, KiB elsewhere


def rss_mb() -> float:
    """Current resident set size of this process [MiB] (the peak where /proc is missing)."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 2**10
    except OSError:
        pass
    return peak_rss_mb()


def machine(packages: tuple[str, ...] = ("numpy", "pybullet", "gymnasium")) -> dict:
    """What the numbers were measured on: processor, cores, memory, load, package versions."""
    info: dict[str, Any] = {
        "python": platform.python_version(),
        "machine": platform.machine(),
        "processor": platform.processor(),
        "cores": os.cpu_count(),
        "system": platform.system(),
    }
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    info["processor"] = line.split(":", 1)[1].strip()
                    break
        with open("/proc/meminfo") as meminfo:
            info["memory_gib"] = round(int(meminfo.readline().split()[1]) / 2**20, 1)
    except OSError:
        pass
    if hasattr(os, "getloadavg"):
        info["load_average"] = [round(x, 2) for x in os.getloadavg()]
    from importlib import metadata

    for package in packages:
        try:
            info[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            info[package] = None
    return info


def main(argv: list[str], probes: Mapping[str, Callable[..., dict]]) -> int:
    """``<probe program> '{"probe": NAME, ...arguments}'``: run ``probes[NAME]`` and print its result line."""
    case = json.loads(argv[0])
    measure = probes[case.pop("probe")]
    warnings.filterwarnings("ignore")  # only the result line matters
    result = measure(**case)
    sys.stdout.flush()
    print(RESULT_MARKER + json.dumps(result), flush=True)
    return 0

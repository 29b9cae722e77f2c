"""Timing probes behind ``pyflyt speed``: one measurement per process, printed as JSON.

:mod:`pyflyt_cli.commands.speed` runs it once per measurement in a fresh process
(``python -m pyflyt_cli.commands.speed_probe '<json case>'``, or its source with ``-c``
in another interpreter), so import cost and memory peaks belong to that one case; the
last output line is ``RESULT_MARKER`` + the JSON result.  It is also a plain module (the
``measure_*`` functions) for tests and for ``experiments/``.

It imports only the standard library at load time, so the *same* file can measure the
reference PyFlyt package in its own interpreter (``side="reference"``: it imports
``PyFlyt`` there, which pins numpy < 2 and cannot share our environment).  Our side
imports :mod:`pyflyt_engine`.  Neither side imports the other.

Protocols (identical on both sides):

* **env** -- ``gymnasium.make(id)`` (Gymnasium's default wrappers), agent 30 Hz, seeded
  reset, ``warmup`` steps, then ``steps`` steps of pre-drawn random actions, resetting
  at episode ends (those resets are part of the step timing, as in a training loop);
  then the median of ``resets`` seeded resets, each after 5 steps so the state must be
  restored.  Real-time factor = simulated seconds per wall second.  Memory: the
  process's peak resident set (``ru_maxrss``) after import, make, the steps and resets.
* **world** -- ``n`` QuadX (cf2x) on a square grid 1 m apart at 1 m altitude, each
  holding its spawn position in position mode (ours ``position_yaw``, the reference's
  mode 7), stepped for ``seconds`` of simulated time after a quarter-second warm-up.
* **floor** -- bare PyBullet doing the physical work of ``n`` hovering QuadX with
  nothing around it: per body one pose and one velocity read, four motor forces and
  one torque; one ``stepSimulation``; client ids passed positionally.
* **camera** -- one 128 x 128 capture (RGBA, depth, segmentation unless ``channels``
  narrows it) from a cf2x at 1 m over the ground plane: the reference QuadX's default
  camera (90 deg field of view, pitched 20 deg down, on its front-right propeller
  link) and ours at the same mount, pose and field of view; the median of
  ``repeats`` timings of ``captures`` captures (wall and CPU time).
* **vector** -- ``workers`` copies of an env in subprocesses (``gymnasium.make_vec``
  async, or SB3 ``SubprocVecEnv``), ``steps`` vector steps of random actions after a
  warm-up; throughput in env steps per second summed over workers.  With
  ``stand_in`` the workers step a stand-in of the same in-process cost instead (pure
  CPU work, empty ``info``, no episode ends).
* **parallel** -- ``processes`` processes of pure CPU work started together: the
  machine's own 1 -> 2 process scaling, next to which the vector figures are read.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import sys
import time
import warnings

#: Marker in front of the JSON result line (the reference's PyBullet prints to stdout).
RESULT_MARKER = "PYFLYT_SPEED_RESULT "
#: Agent rate of every env measurement [Hz] (both sides).
AGENT_HZ = 30
#: Spacing of the vehicles in the world measurements [m].
GRID_SPACING = 1.0
#: Where the reference QuadX carries its camera (its URDF link 0, the front-right
#: propeller) [m], body frame; ours is mounted there too, so both render the same view.
REFERENCE_CAMERA_MOUNT = (0.028, -0.028, 0.0)


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


def _quiet() -> None:
    warnings.filterwarnings("ignore")


def _reference_id(env_id: str) -> str:
    """The reference's id for one of ours: same name, the reference's newest version."""
    import gymnasium

    base = env_id.rsplit("-v", 1)[0]
    versions = [
        (int(key.rsplit("-v", 1)[1]), key)
        for key in gymnasium.registry
        if key.rsplit("-v", 1)[0] == base and key.rsplit("-v", 1)[-1].isdigit()
    ]
    if not versions:
        raise KeyError(f"the reference registers no environment named {base}")
    return max(versions)[1]


def _make_env(env_id: str, side: str):
    import gymnasium

    if side == "reference":
        import PyFlyt.gym_envs  # noqa: F401  (registers the reference ids)

        return gymnasium.make(_reference_id(env_id), agent_hz=AGENT_HZ), AGENT_HZ
    import pyflyt_engine  # noqa: F401  (registers our ids)

    env = gymnasium.make(env_id, agent_hz=AGENT_HZ)
    return env, float(env.unwrapped.config.agent_hz)


# ----------------------------------------------------------------------------- probes


def measure_env(env_id: str, side: str = "ours", steps: int = 2000, resets: int = 10, warmup: int = 200) -> dict:
    """Env steps per second, reset time, real-time factor and peak memory of one env."""
    _quiet()
    env, agent_hz = _make_env(env_id, side)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(warmup + steps)]
    for action in actions[:warmup]:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    episodes = 0
    start, start_cpu = time.perf_counter(), time.process_time()
    for action in actions[warmup:]:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
            episodes += 1
    step_s = (time.perf_counter() - start) / steps
    step_cpu_s = (time.process_time() - start_cpu) / steps
    times = []
    for seed in range(resets):
        for action in actions[:5]:
            env.step(action)
        start = time.perf_counter()
        env.reset(seed=seed + 1)
        times.append(time.perf_counter() - start)
    env.close()
    return {
        "id": env_id if side == "ours" else _reference_id(env_id),
        "step_s": step_s,
        "step_cpu_s": step_cpu_s,
        "steps_per_s": 1.0 / step_s,
        "rtf": 1.0 / (step_s * agent_hz),
        "reset_s": statistics.median(times),
        "episodes": episodes,
        "peak_rss_mb": peak_rss_mb(),
        "rss_mb": rss_mb(),
    }


def grid_positions(n: int) -> list[tuple[float, float, float]]:
    """Spawn positions of ``n`` vehicles: a square grid ``GRID_SPACING`` apart at 1 m."""
    import math

    side = math.ceil(math.sqrt(n))
    return [((i % side) * GRID_SPACING, (i // side) * GRID_SPACING, 1.0) for i in range(n)]


def measure_world(n: int, side: str = "ours", seconds: float = 4.0) -> dict:
    """Wall time per simulated second of ``n`` QuadX holding position in one world."""
    _quiet()
    positions = grid_positions(n)
    if side == "reference":
        import numpy as np
        from PyFlyt.core import Aviary

        world = Aviary(
            start_pos=np.array(positions), start_orn=np.zeros((n, 3)), drone_type="quadx", render=False, seed=0
        )
        world.set_mode(7)  # x, y, yaw, z
        world.set_all_setpoints(np.array([[x, y, 0.0, z] for x, y, z in positions]))
        period = float(world.step_period)
        step = world.step
        close = lambda: world.disconnect()  # noqa: E731  (reading the attribute disconnects)
        collided = lambda: bool(world.contact_array.any())  # noqa: E731
    else:
        from pyflyt_engine.world import VehicleConfig, World

        world = World([VehicleConfig("quadx_cf2x", pos, mode="position_yaw") for pos in positions], seed=0)
        for i, (x, y, z) in enumerate(positions):
            world.set_setpoint(i, [x, y, 0.0, z])
        period = 1.0 / world.agent_hz
        step, close = world.step, world.close
        collided = lambda: any(world.collided(i) for i in range(n))  # noqa: E731
    for _ in range(max(1, round(0.25 / period))):
        step()
    count = max(1, round(seconds / period))
    start, start_cpu = time.perf_counter(), time.process_time()
    for _ in range(count):
        step()
    wall = time.perf_counter() - start
    cpu = time.process_time() - start_cpu
    any_contact = collided()
    close()
    return {
        "n": n,
        "step_s": wall / count,
        "steps_per_s": count / wall,
        "rtf": count * period / wall,
        "cpu_rtf": count * period / max(cpu, 1e-9),
        "contacts": any_contact,
        "peak_rss_mb": peak_rss_mb(),
    }


def bare_pybullet(steps: int, uav: str = "quadx_cf2x", n: int = 1) -> float:
    """Seconds per physics step of the floor: ``n`` bodies, bare PyBullet (our side only)."""
    import pybullet as p

    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.urdf import urdf_path

    spec = load_uav_spec(uav)
    cid = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=cid)
    p.setTimeStep(1 / 240, physicsClientId=cid)
    p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
    path = str(urdf_path(spec))
    bodies = [
        p.loadURDF(path, list(pos), flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
        for pos in grid_positions(n)
    ]
    weight = spec.body.mass * 9.81 / 4
    motors = [tuple(m) for m in spec.motors.positions]
    frame = p.LINK_FRAME
    start = time.perf_counter()
    for _ in range(steps):  # positional client ids: the binding's fastest calling form
        for body in bodies:
            p.getBasePositionAndOrientation(body, cid)
            p.getBaseVelocity(body, cid)
            for position in motors:
                p.applyExternalForce(body, -1, (0.0, 0.0, weight), position, frame, cid)
            p.applyExternalTorque(body, -1, (0.0, 0.0, 0.0), frame, cid)
        p.stepSimulation(cid)
    elapsed = time.perf_counter() - start
    p.disconnect(cid)
    return elapsed / steps


def measure_floor(n: int = 1, seconds: float = 4.0, physics_hz: float = 240.0) -> dict:
    """The bare-PyBullet floor for ``n`` bodies as a real-time factor (our side only)."""
    steps = max(1, round(seconds * physics_hz))
    bare_pybullet(min(steps, 240))  # warm up
    per_step = bare_pybullet(steps, n=n)
    return {"n": n, "physics_step_s": per_step, "rtf": 1.0 / (per_step * physics_hz), "peak_rss_mb": peak_rss_mb()}


def measure_camera(
    side: str = "ours", captures: int = 50, repeats: int = 5, channels: tuple[str, ...] | None = None
) -> dict:
    """Milliseconds per 128 x 128 onboard capture (median of ``repeats`` timings)."""
    _quiet()
    if side == "reference":
        import numpy as np
        from PyFlyt.core import Aviary

        world = Aviary(
            start_pos=np.array([[0.0, 0.0, 1.0]]),
            start_orn=np.zeros((1, 3)),
            drone_type="quadx",
            drone_options={"use_camera": True, "camera_resolution": (128, 128)},
            render=False,
            seed=0,
        )
        world.step()
        shoot = world.drones[0].camera.capture_image
        close = lambda: world.disconnect()  # noqa: E731  (reading the attribute disconnects)
    else:
        import math

        from pyflyt_engine.components.camera import CHANNELS, CameraParams, capture
        from pyflyt_engine.world import VehicleConfig, World

        world = World([VehicleConfig("quadx_cf2x", (0.0, 0.0, 1.0))], seed=0)
        world.step()
        params = CameraParams(
            position=REFERENCE_CAMERA_MOUNT,
            orientation=(0.0, math.radians(20.0), 0.0),  # positive pitch looks down
            fov=90.0,
            width=128,
            height=128,
            channels=channels or CHANNELS,
        )
        state = world.state(0)

        def shoot() -> None:
            capture(world.client, params, state.lin_pos, state.quaternion)

        close = world.close
    shoot()
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        for _ in range(captures):
            shoot()
        wall.append((time.perf_counter() - start) / captures)
        cpu.append((time.process_time() - start_cpu) / captures)
    close()
    return {
        "capture_s": statistics.median(wall),
        "capture_cpu_s": statistics.median(cpu),
        "channels": list(channels) if channels else None,
    }


def _has_dynamic_shape(space) -> bool:
    from gymnasium import spaces

    if isinstance(space, (spaces.Sequence, spaces.Graph)):
        return True
    if isinstance(space, spaces.Dict):
        return any(_has_dynamic_shape(s) for s in space.spaces.values())
    if isinstance(space, spaces.Tuple):
        return any(_has_dynamic_shape(s) for s in space.spaces)
    return False


def _flat_env_factory(env_id: str):
    """A picklable factory: the env, with FlattenWaypointEnv when its observation is variable-size."""
    import functools

    return functools.partial(_make_flat_env, env_id)


def _make_flat_env(env_id: str):
    import gymnasium

    import pyflyt_engine  # noqa: F401
    from pyflyt_engine.envs.wrappers import FlattenWaypointEnv

    env = gymnasium.make(env_id)
    return FlattenWaypointEnv(env) if _has_dynamic_shape(env.observation_space) else env


def measure_vector(
    env_id: str,
    workers: int = 2,
    steps: int = 500,
    backend: str = "gymnasium",
    warmup: int = 50,
    stand_in: bool = False,
) -> dict:
    """Env steps per second (summed over workers) of a subprocess vector env (our side).

    ``stand_in`` replaces the env in the workers by :func:`_make_stand_in`: an env with
    the same spaces whose step is pure CPU work costing what the env's step costs in
    this process (measured here first, resets included), with an empty ``info`` and no
    episode ends -- what the vector env and the machine give an env of that cost, so the
    env's own share of any shortfall is the difference.  (For the waypoint envs, whose
    observation has a variable size, the stand-in takes the spaces of the env wrapped in
    ``FlattenWaypointEnv``, and Gymnasium's workers then use shared memory.)
    """
    _quiet()
    import functools

    import gymnasium

    import pyflyt_engine  # noqa: F401

    env_step_cpu_s = None
    if stand_in:
        env_step_cpu_s, observation_space, action_space = _in_process_step_cpu(env_id, steps=max(steps, 300))
        iterations = max(0, round(env_step_cpu_s * _spin_rate()))
        factory = functools.partial(_make_stand_in, observation_space, action_space, iterations)
    else:
        factory = _flat_env_factory(env_id)
    if backend == "sb3":
        from stable_baselines3.common.vec_env import SubprocVecEnv

        envs = SubprocVecEnv([factory for _ in range(workers)])
        envs.seed(0)
        envs.reset()
        envs.action_space.seed(0)
        sample = lambda: [envs.action_space.sample() for _ in range(workers)]  # noqa: E731
    else:
        if stand_in:
            envs = gymnasium.vector.AsyncVectorEnv([factory for _ in range(workers)])
        else:
            probe = gymnasium.make(env_id)
            shared = not _has_dynamic_shape(probe.observation_space)
            probe.close()
            envs = gymnasium.make_vec(env_id, workers, vectorization_mode="async", vector_kwargs={"shared_memory": shared})
        envs.reset(seed=0)
        envs.action_space.seed(0)
        sample = envs.action_space.sample
    actions = [sample() for _ in range(warmup + steps)]
    for action in actions[:warmup]:
        envs.step(action)
    pids = [process.pid for process in getattr(envs, "processes", [])]
    start, start_cpu, start_workers = time.perf_counter(), time.process_time(), _cpu_seconds(pids)
    for action in actions[warmup:]:
        envs.step(action)
    wall = time.perf_counter() - start
    cpu = time.process_time() - start_cpu + _cpu_seconds(pids) - start_workers
    envs.close()
    return {
        "workers": workers,
        "backend": backend,
        "stand_in": stand_in,
        "steps_per_s": steps * workers / wall,
        # CPU of this process and the workers per env step: with it unchanged from 1 to 2
        # workers, throughput scales with the free cores whatever else runs on the machine
        "cpu_per_step_s": cpu / (steps * workers) if pids else None,
        "env_step_cpu_s": env_step_cpu_s,
    }


def _spin(iterations: int) -> float:
    """Pure-Python CPU work (no memory traffic, no system calls): ``iterations`` additions."""
    total = 0.0
    for i in range(iterations):
        total += i * 0.5
    return total


def _spin_rate(seconds: float = 0.05) -> float:
    """Iterations of :func:`_spin` per CPU second in this process (the fastest of 3 timings)."""
    iterations = 20_000
    while True:  # grow the count until one timing lasts long enough to trust
        start = time.process_time()
        _spin(iterations)
        if time.process_time() - start >= seconds / 4:
            break
        iterations *= 4
    best = 0.0
    for _ in range(3):
        start = time.process_time()
        _spin(iterations)
        best = max(best, iterations / max(time.process_time() - start, 1e-9))
    return best


def _in_process_step_cpu(env_id: str, steps: int = 500, warmup: int = 100):
    """CPU time of one step of the (flattened) env in this process [s], resets at
    episode ends included, and its observation and action spaces."""
    env = _make_flat_env(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(warmup + steps)]
    start = 0.0
    for i, action in enumerate(actions):
        if i == warmup:
            start = time.process_time()
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    cost = (time.process_time() - start) / steps
    spaces = env.observation_space, env.action_space
    env.close()
    return cost, *spaces


def _make_stand_in(observation_space, action_space, iterations: int):
    """An env with these spaces whose step is ``iterations`` of :func:`_spin`: zero
    observations, reward 0, empty ``info``, no episode end (see :func:`measure_vector`)."""
    import gymnasium

    class StandIn(gymnasium.Env):
        def __init__(self):
            self.observation_space, self.action_space = observation_space, action_space
            self._template = observation_space.sample()

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            return _zeros_like(self._template), {}

        def step(self, action):
            _spin(iterations)
            return _zeros_like(self._template), 0.0, False, False, {}  # new arrays, as a real env returns

    return StandIn()


def _zeros_like(value):
    import numpy as np

    if isinstance(value, dict):
        return {key: _zeros_like(v) for key, v in value.items()}
    if isinstance(value, tuple):
        return tuple(_zeros_like(v) for v in value)
    return np.zeros_like(value)


def measure_parallel(processes: int = 2, seconds: float = 0.5) -> dict:
    """The machine's own scaling: ``processes`` processes each doing ``seconds`` of
    :func:`_spin` work (calibrated alone), started together; work per wall second.

    The 2-process figure over the 1-process one is what two cores give pure CPU work
    right now, with no pipes and no shared data (a shared virtual machine often gives
    less than 2). It is context for the vector figures measured next to it, not a
    bound: a vector env spends much of a step waiting on pipes rather than computing.
    """
    import multiprocessing

    iterations = max(1, round(_spin_rate() * seconds))
    context = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods() else None)
    go, done = context.Event(), context.Queue()
    ready = context.Queue()
    children = [context.Process(target=_spin_child, args=(iterations, go, ready, done)) for _ in range(processes)]
    for child in children:
        child.start()
    for _ in children:
        ready.get()
    start = time.perf_counter()
    go.set()
    for _ in children:
        done.get()
    wall = time.perf_counter() - start
    for child in children:
        child.join()
    # work done per wall second, in units of one process's calibrated work per second
    return {"processes": processes, "work_per_s": processes * seconds / wall}


def _spin_child(iterations: int, go, ready, done) -> None:
    ready.put(True)
    go.wait()
    _spin(iterations)
    done.put(True)


def _cpu_seconds(pids: list[int]) -> float:
    """User + system CPU time of processes [s] (Linux /proc; 0 where unreadable)."""
    total = 0.0
    tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    for pid in pids:
        try:
            with open(f"/proc/{pid}/stat") as stat:
                fields = stat.read().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / tick  # utime, stime
        except (OSError, IndexError, ValueError):
            pass
    return total


def machine() -> dict:
    """What the numbers were measured on."""
    info = {
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

    for package in ("numpy", "pybullet", "gymnasium"):
        try:
            info[package] = metadata.version(package)
        except metadata.PackageNotFoundError:  # pragma: no cover - reported as missing
            info[package] = None
    return info


PROBES = {
    "env": measure_env,
    "world": measure_world,
    "floor": measure_floor,
    "camera": measure_camera,
    "vector": measure_vector,
    "parallel": measure_parallel,
    "machine": machine,
}


def main(argv: list[str]) -> int:
    """``speed_probe.py '{"probe": "env", "env_id": ..., ...}'``: print one result line."""
    case = json.loads(argv[0])
    kind = case.pop("probe")
    if "channels" in case and case["channels"] is not None:
        case["channels"] = tuple(case["channels"])
    result = PROBES[kind](**case)
    sys.stdout.flush()
    print(RESULT_MARKER + json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

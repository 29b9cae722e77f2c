"""What ``pyflyt speed`` measures, one measurement per process.

``python -m pyflyt_cli.speed.probes '{"probe": "env", "env_id": ..., ...}'`` runs one
probe and prints its result line (:func:`pyflyt_cli.speed.protocols.main`), so import
cost and memory peaks belong to that one case.  The ``measure_*`` functions are plain
functions too, for tests and ``experiments/``.

* **env** -- ``gymnasium.make(id, agent_hz=30)`` (Gymnasium's default wrappers) timed by
  :func:`~pyflyt_cli.speed.protocols.time_env`; memory is the process's peak resident
  set after import, make, the steps and the resets.
* **world** -- ``n`` QuadX (cf2x) on a square grid 1 m apart at 1 m, each holding its
  spawn point in ``position_yaw`` mode, timed by :func:`~pyflyt_cli.speed.protocols.time_world`.
* **swarm** -- a multi-agent env with ``agents`` agents (``hover``: MAQuadX-Hover on the
  ``grid`` layout 1 m apart at 1 m; ``formation``: MAQuadX-Formation as shipped, downwash
  on; ``dogfight``: MAFixedwing-Dogfight, ``agents / 2`` a side), timed by
  :func:`~pyflyt_cli.speed.protocols.time_parallel_env`: agent-steps/s and real-time factor.
* **floor** -- bare PyBullet doing the physical work of ``n`` hovering QuadX with
  nothing around it: per body one pose and one velocity read, four motor forces and one
  torque; one ``stepSimulation``; client ids passed positionally.
* **camera** -- one 128 x 128 capture (RGBA, depth, segmentation unless ``channels``
  narrows it) from a cf2x at 1 m over the ground plane, mounted on its front-right
  propeller, 90 deg field of view, pitched 20 deg down.
* **vector** -- ``workers`` copies of an env in subprocesses (``gymnasium.make_vec``
  async, or SB3 ``SubprocVecEnv``), ``steps`` vector steps of random actions after a
  warm-up; env steps per second summed over workers.  With ``stand_in`` the workers
  step a stand-in of the same in-process cost instead (pure CPU work, empty ``info``,
  no episode ends).
* **parallel** -- ``processes`` processes of pure CPU work started together: the
  machine's own 1 -> 2 process scaling, next to which the vector figures are read.
* **batched** -- ``n`` copies of an env on the batched backend
  (:class:`pyflyt_engine.batched.BatchedUAVEnv`, motor noise on, autoreset), stepped with
  random actions drawn beforehand: agent-steps per second (wall and CPU); the time to
  build a first env and step it once (which loads, or the first time compiles, the laws)
  apart; memory per env (the peak resident set beyond the process's after that first env,
  over ``n``: the arrays, the actions drawn, the step's temporaries).
"""

from __future__ import annotations

import functools
import math
import os
import sys
import time
from collections.abc import Callable
from typing import Any

from pyflyt_cli.speed import protocols
from pyflyt_cli.speed.protocols import AGENT_HZ, grid_positions, peak_rss_mb

#: Where the camera sits on the cf2x: its front-right propeller [m], body frame.
CAMERA_MOUNT = (0.028, -0.028, 0.0)


def measure_env(env_id: str, steps: int = 2000, resets: int = 10, warmup: int = 200) -> dict:
    """Env steps per second, reset time, real-time factor and peak memory of one env (a
    registered id, or an env config such as a variant sharing its id)."""
    import gymnasium

    from pyflyt_engine.envs import ENVS, make_env

    if env_id in ENVS:
        env = gymnasium.make(env_id, agent_hz=AGENT_HZ)
    else:
        env = make_env(env_id, agent_hz=AGENT_HZ)
    uav_env: Any = env.unwrapped  # a UAVEnv (gymnasium types it as a bare Env)
    try:
        timing = protocols.time_env(env, uav_env.config.agent_hz, steps, resets, warmup)
    finally:
        env.close()
    return {"id": env_id, **timing}


#: swarm cases: name -> (module of pyflyt_engine.envs.multi_agent, keyword arguments)
SWARM_ENVS = {
    "hover": ("ma_quadx_hover_v0", {"layout": "grid", "layout_spacing": protocols.GRID_SPACING, "layout_height": 1.0}),
    "formation": ("ma_quadx_formation_v0", {}),
    "dogfight": ("ma_fixedwing_dogfight_v0", {}),
}


def swarm_env(env: str, agents: int):
    """The parallel env of swarm case ``env`` with ``agents`` agents (see :data:`SWARM_ENVS`)."""
    import importlib

    module, kwargs = SWARM_ENVS[env]
    return importlib.import_module(f"pyflyt_engine.envs.multi_agent.{module}").parallel_env(agents=agents, **kwargs)


def measure_swarm(env: str, agents: int, steps: int = 300, warmup: int = 20) -> dict:
    """Agent-steps per second and real-time factor of a multi-agent env with ``agents`` agents."""
    parallel = swarm_env(env, agents)
    try:
        timing = protocols.time_parallel_env(parallel, parallel.config.agent_hz, steps, warmup)
    finally:
        parallel.close()
    return {"env": env, **timing}


def hover_grid(n: int):
    """A World of ``n`` cf2x on :func:`grid_positions`, each holding its spawn point."""
    from pyflyt_engine.world import VehicleConfig, World

    positions = grid_positions(n)
    world = World([VehicleConfig("quadx_cf2x", pos, mode="position_yaw") for pos in positions], seed=0)
    for i, (x, y, z) in enumerate(positions):
        world.set_setpoint(i, [x, y, 0.0, z])
    return world


def measure_world(n: int, seconds: float = 4.0) -> dict:
    """Wall time per simulated second of ``n`` QuadX holding position in one world."""
    world = hover_grid(n)
    timing = protocols.time_world(world.step, 1.0 / world.agent_hz, seconds)
    contacts = any(world.collided(i) for i in range(n))
    world.close()
    return {"n": n, **timing, "contacts": contacts}


def bare_pybullet(
    steps: int, uav: str = "quadx_cf2x", n: int = 1, clock: Callable[[], float] = time.perf_counter
) -> float:
    """Seconds per physics step of the floor: ``n`` bodies, bare PyBullet (timed by
    ``clock``: wall time, or ``time.process_time`` for the CPU time this process used)."""
    from pyflyt_engine.bullet import pybullet as p
    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.urdf import urdf_path

    spec = load_uav_spec(uav)
    if spec.motors is None:
        raise ValueError(f"the floor probe spins motors, and the airframe {uav!r} has none: give a multirotor")
    motors = [(x, y, z) for x, y, z in spec.motors.positions]
    # the airframe's mass: body.mass, or its parts' sum where body.mass is left out
    return protocols.time_floor(p, str(urdf_path(spec)), spec.body.total_mass(), motors, steps, n, clock)


def measure_floor(n: int = 1, seconds: float = 4.0, physics_hz: float = 240.0) -> dict:
    """The bare-PyBullet floor for ``n`` bodies as a real-time factor."""
    steps = max(1, round(seconds * physics_hz))
    bare_pybullet(min(steps, 240))  # warm up
    per_step = bare_pybullet(steps, n=n)
    return {"n": n, "physics_step_s": per_step, "rtf": 1.0 / (per_step * physics_hz), "peak_rss_mb": peak_rss_mb()}


def measure_camera(captures: int = 50, repeats: int = 5, channels: list[str] | None = None) -> dict:
    """Seconds per 128 x 128 onboard capture (median of ``repeats`` timings)."""
    from pyflyt_engine.components.camera import CHANNELS, CameraParams, capture
    from pyflyt_engine.world import VehicleConfig, World

    world = World([VehicleConfig("quadx_cf2x", (0.0, 0.0, 1.0))], seed=0)
    world.step()
    params = CameraParams(
        position=CAMERA_MOUNT,
        orientation=(0.0, math.radians(20.0), 0.0),  # positive pitch looks down
        fov=90.0,
        width=128,
        height=128,
        channels=tuple(channels) if channels else CHANNELS,
    )
    state = world.state(0)
    timing = protocols.time_captures(lambda: capture(world.client, params, state.lin_pos, state.quaternion),
                                     captures, repeats)  # fmt: skip
    world.close()
    return {**timing, "channels": list(channels) if channels else None}


# ----------------------------------------------------------------------------- vector envs


def _has_dynamic_shape(space) -> bool:
    from gymnasium import spaces

    if isinstance(space, (spaces.Sequence, spaces.Graph)):
        return True
    if isinstance(space, spaces.Dict):
        return any(_has_dynamic_shape(s) for s in space.spaces.values())
    if isinstance(space, spaces.Tuple):
        return any(_has_dynamic_shape(s) for s in space.spaces)
    return False


def _make_flat_env(env_id: str):
    """The env, with FlattenWaypointEnv when its observation is variable-size."""
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
    """Env steps per second (summed over workers) of a subprocess vector env.

    ``stand_in`` replaces the env in the workers by :func:`_make_stand_in`: an env with
    the same spaces whose step is pure CPU work costing what the env's step costs in
    this process (measured here first, resets included), with an empty ``info`` and no
    episode ends -- what the vector env and the machine give an env of that cost, so the
    env's own share of any shortfall is the difference.  (For the waypoint envs, whose
    observation has a variable size, the stand-in takes the spaces of the env wrapped in
    ``FlattenWaypointEnv``, and Gymnasium's workers then use shared memory.)
    """
    import gymnasium

    import pyflyt_engine  # noqa: F401

    env_step_cpu_s = None
    if stand_in:
        env_step_cpu_s, observation_space, action_space = _in_process_step_cpu(env_id, steps=max(steps, 300))
        iterations = max(0, round(env_step_cpu_s * _spin_rate()))
        factory = functools.partial(_make_stand_in, observation_space, action_space, iterations)
    else:
        factory = functools.partial(_make_flat_env, env_id)
    # SB3's SubprocVecEnv or a gymnasium vector env: stepped, timed and closed alike below
    envs: Any
    if backend == "sb3":
        from stable_baselines3.common.vec_env import SubprocVecEnv

        envs = SubprocVecEnv([factory for _ in range(workers)])
        envs.seed(0)
        envs.reset()
        envs.action_space.seed(0)
        sample = lambda: [envs.action_space.sample() for _ in range(workers)]
    else:
        if stand_in:
            envs = gymnasium.vector.AsyncVectorEnv([factory for _ in range(workers)])
        else:
            probe = gymnasium.make(env_id)
            shared = not _has_dynamic_shape(probe.observation_space)
            probe.close()
            envs = gymnasium.make_vec(
                env_id, workers, vectorization_mode="async", vector_kwargs={"shared_memory": shared}
            )
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
    timing = protocols.time_env(env, AGENT_HZ, steps=steps, resets=0, warmup=warmup)
    spaces = env.observation_space, env.action_space
    env.close()
    return timing["step_cpu_s"], *spaces


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


def measure_batched(env_id: str, n: int, agent_steps: int = 200_000, warmup: int = 20) -> dict:
    """Agent-steps per second and memory per env of ``n`` copies of ``env_id`` (a registered id
    or an env config) on the batched backend."""
    import gymnasium
    import numpy as np

    from pyflyt_engine.batched import BatchedUAVEnv
    from pyflyt_engine.envs import ENVS

    config = ENVS[env_id].config if env_id in ENVS else env_id
    started = time.perf_counter()
    probe = BatchedUAVEnv(config, num_envs=1, seed=0)  # loads (or compiles) the laws
    probe.reset(seed=0)
    probe.step(probe.action_space.sample())
    first = time.perf_counter() - started
    before = protocols.rss_mb()
    env = BatchedUAVEnv(config, num_envs=n, seed=0)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    space = env.single_action_space
    assert isinstance(space, gymnasium.spaces.Box)  # the UAV envs' actions are boxes
    low, high = space.low, space.high
    steps = max(warmup + 5, -(-agent_steps // n))
    actions = rng.uniform(low, high, (min(steps, 256), n, low.size))
    env.step(actions[0])
    for k in range(warmup):
        env.step(actions[k % len(actions)])
    timed = steps - warmup
    wall, cpu = time.perf_counter(), time.process_time()
    for k in range(timed):
        env.step(actions[k % len(actions)])
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    env.close()
    return {
        "id": env_id,
        "n": n,
        "agent_steps": n * timed,
        "steps_per_s": n * timed / wall,
        "cpu_per_agent_step_s": cpu / (n * timed),
        "first_step_s": first,
        "memory_per_env_kb": max(peak_rss_mb() - before, 0.0) * 1024 / n,
    }


PROBES: dict[str, Callable[..., dict]] = {
    "env": measure_env,
    "batched": measure_batched,
    "world": measure_world,
    "floor": measure_floor,
    "swarm": measure_swarm,
    "camera": measure_camera,
    "vector": measure_vector,
    "parallel": measure_parallel,
    "machine": protocols.machine,
}


if __name__ == "__main__":
    sys.exit(protocols.main(sys.argv[1:], PROBES))

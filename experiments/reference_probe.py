"""One case of ``compare_reference.py`` on the reference PyFlyt 0.29.0, in the reference's interpreter.

    /path/to/ref-venv/bin/python experiments/reference_probe.py '{"probe": "env", "env_id": ..., ...}'

The cases are those of ``pyflyt speed`` (``pyflyt_cli/speed/probes.py``), timed by the same
protocol functions (``pyflyt_cli/speed/protocols.py``, loaded by its path: the
reference's environment does not have this package, and the file needs only the
standard library), on the reference's counterparts:

* **env** -- the reference's newest version of the env's name, ``gymnasium.make(id, agent_hz=30)``;
* **world** -- its ``Aviary`` with ``n`` QuadX on the same grid, in its mode 7 (x, y,
  yaw, z) holding their spawn points;
* **swarm** -- ``MAQuadXHoverEnvV2`` on the same grid, ``MAFixedwingDogfightEnvV2`` (no
  formation task), by the same parallel-env protocol;
* **camera** -- its QuadX's default camera at 128 x 128 (on its front-right propeller
  link, 90 deg field of view, pitched 20 deg down: where ``pyflyt speed`` mounts ours).

The last line printed is the result (``RESULT_MARKER`` + JSON).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

PROTOCOLS = Path(__file__).resolve().parents[1] / "pyflyt_cli" / "speed" / "protocols.py"


def _load_protocols():
    spec = importlib.util.spec_from_file_location("speed_protocols", PROTOCOLS)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


protocols = _load_protocols()


def reference_id(env_id: str) -> str:
    """The reference's id for one of ours: same name, the reference's newest version."""
    import gymnasium
    import PyFlyt.gym_envs  # noqa: F401  (registers the reference ids)

    base = env_id.rsplit("-v", 1)[0]
    versions = [
        (int(key.rsplit("-v", 1)[1]), key)
        for key in gymnasium.registry
        if key.rsplit("-v", 1)[0] == base and key.rsplit("-v", 1)[-1].isdigit()
    ]
    if not versions:
        raise KeyError(f"the reference registers no environment named {base}")
    return max(versions)[1]


def measure_env(env_id: str, steps: int = 2000, resets: int = 10, warmup: int = 200) -> dict:
    import gymnasium

    ref_id = reference_id(env_id)
    env = gymnasium.make(ref_id, agent_hz=protocols.AGENT_HZ)
    try:
        return {"id": ref_id, **protocols.time_env(env, protocols.AGENT_HZ, steps, resets, warmup)}
    finally:
        env.close()


def _aviary(positions, **options):
    import numpy as np
    from PyFlyt.core import Aviary

    return Aviary(start_pos=np.array(positions), start_orn=np.zeros((len(positions), 3)), drone_type="quadx",
                  render=False, seed=0, **options)  # fmt: skip


def measure_world(n: int, seconds: float = 4.0) -> dict:
    import numpy as np

    positions = protocols.grid_positions(n)
    world = _aviary(positions)
    world.set_mode(7)  # x, y, yaw, z
    world.set_all_setpoints(np.array([[x, y, 0.0, z] for x, y, z in positions]))
    timing = protocols.time_world(world.step, float(world.step_period), seconds)
    contacts = bool(world.contact_array.any())
    world.disconnect()
    return {"n": n, **timing, "contacts": contacts}


def measure_camera(captures: int = 50, repeats: int = 5, channels: list[str] | None = None) -> dict:
    if channels:
        raise ValueError("the reference camera captures every channel at once")
    world = _aviary([(0.0, 0.0, 1.0)], drone_options={"use_camera": True, "camera_resolution": (128, 128)})
    world.step()
    timing = protocols.time_captures(world.drones[0].camera.capture_image, captures, repeats)
    world.disconnect()
    return {**timing, "channels": None}


def measure_swarm(env: str, agents: int, steps: int = 300, warmup: int = 20) -> dict:
    """The reference's counterpart of a swarm case: ``MAQuadXHoverEnvV2`` with the agents on
    the same centred grid, or ``MAFixedwingDogfightEnvV2`` with ``agents / 2`` a side (it
    has no formation task), timed by the same protocol."""
    import numpy as np

    if env == "hover":
        from PyFlyt.pz_envs import MAQuadXHoverEnvV2

        start = np.array(protocols.centred_grid(agents, protocols.GRID_SPACING, 1.0))
        parallel = MAQuadXHoverEnvV2(start_pos=start, start_orn=np.zeros((agents, 3)), agent_hz=protocols.AGENT_HZ)
    elif env == "dogfight":
        from PyFlyt.pz_envs import MAFixedwingDogfightEnvV2

        parallel = MAFixedwingDogfightEnvV2(team_size=agents // 2, agent_hz=protocols.AGENT_HZ)
    else:
        raise KeyError(f"the reference has no {env} env")
    try:
        timing = protocols.time_parallel_env(parallel, protocols.AGENT_HZ, steps, warmup)
    finally:
        parallel.close()
    return {"env": env, **timing}


def machine() -> dict:
    return protocols.machine(("numpy", "pybullet", "gymnasium", "PyFlyt"))


if __name__ == "__main__":
    sys.exit(protocols.main(sys.argv[1:], {"env": measure_env, "world": measure_world, "camera": measure_camera,
                                           "swarm": measure_swarm, "machine": machine}))  # fmt: skip

"""One process of ``speed_targets.py``: one env of one side, interleaved with the floor.

    <python> experiments/speed_targets_probe.py '{"side": "ours" | "reference", "env_id": ..., ...}'

Runs in our interpreter (``side: ours``, this checkout or a baseline's on ``PYTHONPATH``)
or in the reference's (``side: reference``, PyFlyt 0.29.0 in its own virtual
environment): it imports only the standard library, NumPy, Gymnasium and PyBullet at
the top, and the timing protocols and PyBullet's quiet importer by their paths
(``pyflyt_cli/speed/protocols.py``, ``pyflyt_engine/bullet.py``: standard library only).  The env is built once; then ``rounds`` times, alternately,
``8 * steps`` physics steps of the bare-PyBullet floor
(:func:`~pyflyt_cli.speed.protocols.time_floor`, on the URDF, mass and motor positions
given) and ``steps`` env steps, each timed by the CPU time of this thread
(``time.thread_time``).  The last line printed is the result (``RESULT_MARKER`` + JSON):
per round, seconds per env step and per 8 floor physics steps.

The action protocol, the same on both sides:

* ``hover`` -- a level-holding feedback on the env's body rates and thrust (QuadX-Hover:
  the action is [p, q, r, thrust]); the dome and the time limit are widened so the
  episode never ends: the step cost of a hovering vehicle, resets excluded;
* ``random`` -- pre-drawn seeded random actions, resetting at episode ends (the resets
  inside the timing, as in a training loop).
"""

from __future__ import annotations

import importlib.util
import json
import sys
import time
import warnings
from pathlib import Path

PROTOCOLS = Path(__file__).resolve().parents[1] / "pyflyt_cli" / "speed" / "protocols.py"
#: PyBullet's quiet importer (standard library only), loaded by path like the protocols:
#: the reference's interpreter has no pyflyt_engine to import it from.
BULLET = Path(__file__).resolve().parents[1] / "pyflyt_engine" / "bullet.py"
#: Thrust that holds a QuadX level at 1 m, per side (found by flying each: our QuadX-Hover
#: action's thrust is a fraction of the full collective, the reference's a motor command).
HOVER_THRUST = {"ours": 0.125, "reference": 0.3}
#: The reference's id for each of ours: the same name at its newest version.
REFERENCE_IDS = {
    "PyFlyt/QuadX-Hover-v0": "PyFlyt/QuadX-Hover-v4",
    "PyFlyt/QuadX-Waypoints-v0": "PyFlyt/QuadX-Waypoints-v4",
    "PyFlyt/Fixedwing-Waypoints-v0": "PyFlyt/Fixedwing-Waypoints-v3",
    "PyFlyt/Rocket-Landing-v0": "PyFlyt/Rocket-Landing-v4",
}


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _load_protocols():
    return _load("speed_protocols", PROTOCOLS)


def _make(side: str, env_id: str, hover: bool):
    import gymnasium

    widen = {"flight_dome_size": 1e6, "max_duration_seconds": 1e6} if hover else {}
    if side == "ours":
        import pyflyt_engine

        env = gymnasium.make(env_id, agent_hz=30, **widen)
        return env, pyflyt_engine.__file__
    import PyFlyt
    import PyFlyt.gym_envs  # noqa: F401  (registers the reference ids)

    env = gymnasium.make(REFERENCE_IDS[env_id], agent_hz=30, **widen)
    return env, PyFlyt.__file__


def _hover_law(side: str, env):
    """``() -> action``: the level-holding feedback on the side's current state."""
    import numpy as np

    thrust = HOVER_THRUST[side]
    raw = env.unwrapped
    if side == "ours":

        def state():
            s = raw.state
            return s.ang_vel, s.ang_pos, s.lin_pos[2], s.lin_vel_ground[2]

    else:

        def state():
            (p, q, r), angles, (_, _, w), (_, _, z) = raw.env.state(0)
            return (p, q, r), angles, z, w

    def action():
        (p, q, r), (roll, pitch, _), z, vz = state()
        return np.array([-4 * roll - 0.5 * p, -4 * pitch - 0.5 * q, -0.5 * r, thrust + 0.1 * (1 - z) - 0.05 * vz])

    return action


def measure(side: str, env_id: str, floor: dict, actions: str = "random", steps: int = 300, rounds: int = 7) -> dict:
    """Per round: CPU seconds per env step and per 8 floor physics steps (the module docstring)."""
    pybullet = _load("speed_bullet", BULLET).pybullet
    protocols = _load_protocols()
    warnings.filterwarnings("ignore")
    hover = actions == "hover"
    env, where = _make(side, env_id, hover)
    env.reset(seed=0)
    env.action_space.seed(0)
    if hover:
        law = _hover_law(side, env)
        step = lambda _: env.step(law())  # noqa: E731
        batch = [None] * steps
    else:
        batch = [env.action_space.sample() for _ in range(steps)]

        def step(action):
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()

    clock = time.thread_time
    for action in batch[: max(1, steps // 5)]:  # warm up
        step(action)
    env_s, floor_s = [], []
    for _ in range(rounds):
        floor_s.append(
            8 * protocols.time_floor(pybullet, floor["urdf"], floor["mass"], floor["motors"], 8 * steps, clock=clock)
        )
        start = clock()
        for action in batch:
            step(action)
        env_s.append((clock() - start) / steps)
    env.close()
    return {"side": side, "env_id": env_id, "engine": where, "env_s": env_s, "floor_s": floor_s}


if __name__ == "__main__":
    case = json.loads(sys.argv[1])
    result = measure(**case)
    sys.stdout.flush()
    print(_load_protocols().RESULT_MARKER + json.dumps(result), flush=True)

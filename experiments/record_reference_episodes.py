"""Record the reference PyFlyt 0.29.0's episodes and read-outs that the compat tests compare with.

    /work/refvenv/bin/python experiments/record_reference_episodes.py \
        [--out tests/compat/data/reference_episodes.json]

Runs in the reference's own interpreter (it pins numpy < 2) and imports nothing of this
project, so the tests never import the reference: they read the file this writes
(``tests/compat/test_reference_episodes.py``).  Recorded:

* **episodes**: for every reference id, fixed seeds and a constant action, the episode's
  length, how it ended (terminated / truncated and the info flags), its return and the
  first and last rewards (or the error the reference raises: its Gates-v3 cannot load
  its gate model);
* **pz_episodes**: the same for the PettingZoo envs: per agent, the step it left, how and
  its return;
* **public_names**: every module of its ``core``, ``gym_envs``, ``pz_envs`` and the public
  classes and functions each defines;
* **facts**: what user code reads off the env and the Aviary: a spawn moved by assigning
  ``env.unwrapped.start_pos``, the Rocket's ``aux_state`` at the start and its fuel
  entry, ``metadata["render_fps"]``, ``max_steps``, the camera's depth range, a drone's
  state after ``disconnect``.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = ROOT / "tests" / "compat" / "data" / "reference_episodes.json"

#: name -> (id, kwargs, constant action, seeds); the actions: the reference's hover command
#: (mode 0 thrust 0.3, motors 0.3), mode 6 zero velocity, the rocket idle, the fixed-wing at
#: neutral stick and half thrust
EPISODES = {
    "hover_mode6_still": ("PyFlyt/QuadX-Hover-v4", {"flight_mode": 6, "max_duration_seconds": 15.0}, [0.0] * 4),
    "hover_mode0_hover_command": ("PyFlyt/QuadX-Hover-v4", {}, [0.0, 0.0, 0.0, 0.3]),
    "hover_mode0_sparse": ("PyFlyt/QuadX-Hover-v4", {"sparse_reward": True}, [0.0, 0.0, 0.0, 0.3]),
    "waypoints_mode6_still": ("PyFlyt/QuadX-Waypoints-v4", {"flight_mode": 6}, [0.0] * 4),
    "pole_balance_motors": ("PyFlyt/QuadX-Pole-Balance-v4", {}, [0.3] * 4),
    "pole_waypoints_motors": ("PyFlyt/QuadX-Pole-Waypoints-v4", {}, [0.3] * 4),
    "ball_in_cup_hover_command": ("PyFlyt/QuadX-Ball-In-Cup-v4", {}, [0.0, 0.0, 0.0, 0.3]),
    "fixedwing_neutral_half_thrust": ("PyFlyt/Fixedwing-Waypoints-v3", {}, [0.0, 0.0, 0.0, 0.5]),
    "rocket_idle": ("PyFlyt/Rocket-Landing-v4", {}, [0.0] * 7),
    "gates_hover_command": ("PyFlyt/QuadX-Gates-v3", {}, [0.0, 0.0, 0.0, 0.3]),
}
SEEDS = (0, 1, 2)



def record_episodes() -> dict:
    import gymnasium
    import numpy as np

    import PyFlyt.gym_envs  # noqa: F401

    out = {}
    for name, (env_id, kwargs, action, *_) in EPISODES.items():
        runs = []
        try:  # the reference's Gates-v3 cannot load its gate model in 0.29.0: recorded as such
            gymnasium.make(env_id, **kwargs).reset(seed=SEEDS[0])
        except Exception as error:  # noqa: BLE001 - a fact about the reference, recorded
            out[name] = {"id": env_id, "kwargs": kwargs, "action": action, "error": f"{type(error).__name__}: {error}"}
            continue
        for seed in SEEDS:
            env = gymnasium.make(env_id, **kwargs)
            env.reset(seed=seed)
            rewards, term, trunc, info = [], False, False, {}
            while not (term or trunc):
                _, r, term, trunc, info = env.step(np.array(action, dtype=np.float64))
                rewards.append(float(r))
            runs.append(
                {
                    "seed": seed,
                    "length": len(rewards),
                    "terminated": bool(term),
                    "truncated": bool(trunc),
                    "info": {k: (int(v) if k == "num_targets_reached" else bool(v)) for k, v in info.items()
                             if isinstance(v, (bool, int, np.bool_)) and not isinstance(v, float)},
                    "return": float(sum(rewards)),
                    "first_reward": rewards[0],
                    "last_reward": rewards[-1],
                }
            )
            env.close()
        out[name] = {"id": env_id, "kwargs": kwargs, "action": action, "runs": runs}
    return out


#: PettingZoo cases: name -> (class name, kwargs, constant action per agent)
PZ_EPISODES = {
    "ma_hover_hover_command": ("MAQuadXHoverEnvV2", {}, [0.0, 0.0, 0.0, 0.3]),
    "ma_hover_mode6_still": ("MAQuadXHoverEnvV2", {"flight_mode": 6, "max_duration_seconds": 5.0}, [0.0] * 4),
}


def record_pz_episodes() -> dict:
    import numpy as np

    import PyFlyt.pz_envs as pz

    out = {}
    for name, (cls, kwargs, action) in PZ_EPISODES.items():
        runs = []
        for seed in SEEDS:
            env = getattr(pz, cls)(**kwargs)
            env.reset(seed=seed)
            steps, returns, ends = 0, {}, {}
            while env.agents:
                live = list(env.agents)
                _, rewards, terms, truncs, infos = env.step({a: np.array(action, dtype=np.float64) for a in live})
                steps += 1
                for a in live:
                    returns[a] = returns.get(a, 0.0) + float(rewards[a])
                    if terms[a] or truncs[a]:
                        ends[a] = {"step": steps, "terminated": bool(terms[a]), "truncated": bool(truncs[a]),
                                   "info": {k: bool(v) for k, v in infos[a].items()}}
            runs.append({"seed": seed, "steps": steps, "returns": returns, "ends": ends})
            env.close()
        out[name] = {"class": cls, "kwargs": kwargs, "action": action, "runs": runs}
    return out


def record_facts() -> dict:
    import gymnasium
    import numpy as np

    import PyFlyt.gym_envs  # noqa: F401
    from PyFlyt.core import Aviary

    facts: dict = {}
    env = gymnasium.make("PyFlyt/QuadX-Hover-v4", angle_representation="euler")
    base = env.unwrapped
    facts["hover_max_steps"] = int(base.max_steps)
    facts["hover_env_step_ratio"] = int(base.env_step_ratio)
    facts["render_fps"] = {}
    base.start_pos = np.array([[1.0, -2.0, 3.0]])
    obs, info = env.reset(seed=0)
    facts["hover_moved_spawn_first_position"] = [float(v) for v in obs[9:12]]
    facts["hover_reset_info"] = {k: bool(v) for k, v in info.items()}
    facts["hover_unwrapped_env_state_shape"] = list(base.env.state(0).shape)
    env.close()
    for env_id in ("PyFlyt/QuadX-Hover-v4", "PyFlyt/Fixedwing-Waypoints-v3", "PyFlyt/Rocket-Landing-v4"):
        e = gymnasium.make(env_id)
        facts["render_fps"][env_id] = e.metadata["render_fps"]
        e.close()

    env = gymnasium.make("PyFlyt/Rocket-Landing-v4")
    env.reset(seed=0)
    facts["rocket_env_aux_at_reset"] = [float(v) for v in env.unwrapped.env.aux_state(0)]
    env.close()

    aviary = Aviary(start_pos=np.array([[0.0, 0.0, 10.0]]), start_orn=np.zeros((1, 3)), drone_type="rocket")
    facts["aviary_rocket_aux_at_start"] = [float(v) for v in aviary.aux_state(0)]
    aviary.set_mode(0)
    aviary.set_setpoint(0, np.array([0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0]))  # ignition, full throttle
    for _ in range(30):
        aviary.step()
    facts["aviary_rocket_aux_burning"] = [float(v) for v in aviary.aux_state(0)]
    aviary.disconnect()

    aviary = Aviary(
        start_pos=np.array([[0.0, 0.0, 1.0]]),
        start_orn=np.zeros((1, 3)),
        drone_type="quadx",
        drone_options={"use_camera": True},
    )
    aviary.set_mode(0)
    for _ in range(5):
        aviary.step()
    depth = np.asarray(aviary.drones[0].depthImg, dtype=np.float64)
    facts["camera_depth_range"] = [float(depth.min()), float(depth.max())]
    last = aviary.state(0).copy()
    facts["armed_drones_count"] = len(aviary.armed_drones)
    aviary.disconnect()
    try:
        after = aviary.drones[0].state
        facts["state_after_disconnect_is_last"] = bool(np.allclose(after, last))
    except Exception as error:  # noqa: BLE001 - recorded, not raised
        facts["state_after_disconnect_is_last"] = f"raises {type(error).__name__}"
    return facts


def record_public_names() -> dict:
    """Every module of the reference's ``core``, ``gym_envs`` and ``pz_envs`` and the public
    classes and functions it defines (not the ones it imports)."""
    import importlib
    import inspect

    import PyFlyt

    root = Path(PyFlyt.__file__).parent
    names: dict = {}
    for package in ("core", "gym_envs", "pz_envs"):
        paths = sorted((root / package).rglob("*.py"))
        for path in paths:
            parts = path.relative_to(root).with_suffix("").parts
            module_name = ".".join(p for p in parts if p != "__init__")
            module = importlib.import_module(f"PyFlyt.{module_name}")
            names[module_name] = sorted(
                n
                for n, obj in vars(module).items()
                if not n.startswith("_")
                and (inspect.isclass(obj) or inspect.isfunction(obj))
                and getattr(obj, "__module__", "") == module.__name__
            )
    return names


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args()
    warnings.filterwarnings("ignore")
    import PyFlyt

    record = {
        "reference": f"PyFlyt {getattr(PyFlyt, '__version__', '0.29.0')}",
        "python": platform.python_version(),
        "script": "experiments/record_reference_episodes.py",
        "seeds": list(SEEDS),
        "episodes": record_episodes(),
        "pz_episodes": record_pz_episodes(),
        "facts": record_facts(),
        "public_names": record_public_names(),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()

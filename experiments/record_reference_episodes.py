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
* **pz_episodes**: the same for the PettingZoo envs (MAQuadXHoverEnvV2 and
  MAFixedwingDogfightEnvV2): per agent, the step it left, how (the info at its end: flags,
  dogfight ``health`` and ``received_hits``) and its return; the dogfight's spawn too;
* **checker_warnings**: per Gymnasium id, the warnings Gymnasium's ``check_env`` gives on
  the reference's env and the error it ends with (if any); per PettingZoo env, those of
  ``parallel_api_test`` and of ``api_test`` on its AEC conversion;
* **public_names**: every module of its ``core``, ``gym_envs``, ``pz_envs`` and the public
  classes and functions each defines;
* **facts**: what user code reads off the env and the Aviary: a spawn moved by assigning
  ``env.unwrapped.start_pos``, the Rocket's ``aux_state`` at the start and its fuel
  entry, ``metadata["render_fps"]``, ``max_steps``, the camera's depth range, a drone's
  state after ``disconnect``, the courses of waypoints and the Rocket's drops seeded resets draw.
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
                    "info": {
                        k: (int(v) if k == "num_targets_reached" else bool(v))
                        for k, v in info.items()
                        if isinstance(v, (bool, int, np.bool_)) and not isinstance(v, float)
                    },
                    "return": float(sum(rewards)),
                    "first_reward": rewards[0],
                    "last_reward": rewards[-1],
                }
            )
            env.close()
        out[name] = {"id": env_id, "kwargs": kwargs, "action": action, "runs": runs}
    return out


#: PettingZoo cases: name -> (class name, kwargs, constant action per agent); the dogfight at
#: neutral stick and the env's thrust entry 0.5 (0.75 of full thrust), as the fixed-wing case
PZ_EPISODES = {
    "ma_hover_hover_command": ("MAQuadXHoverEnvV2", {}, [0.0, 0.0, 0.0, 0.3]),
    "ma_hover_mode6_still": ("MAQuadXHoverEnvV2", {"flight_mode": 6, "max_duration_seconds": 5.0}, [0.0] * 4),
    "dogfight_neutral_half_thrust": ("MAFixedwingDogfightEnvV2", {}, [0.0, 0.0, 0.0, 0.5]),
    "dogfight_1v1_sparse_glide": (
        "MAFixedwingDogfightEnvV2",
        {"team_size": 1, "sparse_reward": True, "max_duration_seconds": 20.0},
        [0.0, 0.0, 0.0, -1.0],
    ),
}


def _info_entry(value):
    """An info value as JSON: flags as bools, the dogfight's health as a float, counts as ints."""
    import numpy as np

    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    return float(value)


def record_pz_episodes() -> dict:
    import numpy as np

    import PyFlyt.pz_envs as pz

    out = {}
    for name, (cls, kwargs, action) in PZ_EPISODES.items():
        runs = []
        for seed in SEEDS:
            env = getattr(pz, cls)(**kwargs)
            env.reset(seed=seed)
            run = {"seed": seed}
            if hasattr(env, "start_pos") and cls == "MAFixedwingDogfightEnvV2":
                run["start_pos"] = np.asarray(env.start_pos, dtype=float).tolist()
                run["start_orn"] = np.asarray(env.start_orn, dtype=float).tolist()
            steps, returns, ends = 0, {}, {}
            while env.agents:
                live = list(env.agents)
                _, rewards, terms, truncs, infos = env.step({a: np.array(action, dtype=np.float64) for a in live})
                steps += 1
                for a in live:
                    returns[a] = returns.get(a, 0.0) + float(rewards[a])
                    if terms[a] or truncs[a]:
                        ends[a] = {
                            "step": steps,
                            "terminated": bool(terms[a]),
                            "truncated": bool(truncs[a]),
                            "info": {k: _info_entry(v) for k, v in infos[a].items()},
                        }
            runs.append({**run, "steps": steps, "returns": returns, "ends": ends})
            env.close()
        out[name] = {"class": cls, "kwargs": kwargs, "action": action, "runs": runs}
    return out


def _caught(run) -> dict:
    """The distinct warnings ``run()`` gives (colour codes stripped) and the error it ends with."""
    import re

    error = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            run()
        except Exception as exc:  # noqa: BLE001 - a fact about the reference, recorded
            error = f"{type(exc).__name__}: {str(exc)[:200]}"
    messages = sorted({re.sub(r"\x1b\[[0-9;]*m", "", str(w.message)) for w in caught})
    return {"warnings": messages, "error": error}


def record_checker_warnings() -> dict:
    """What Gymnasium's and PettingZoo's checkers say about the reference's envs."""
    import gymnasium
    from gymnasium.utils.env_checker import check_env
    from pettingzoo.test import api_test, parallel_api_test
    from pettingzoo.utils.conversions import parallel_to_aec

    import PyFlyt.gym_envs  # noqa: F401
    import PyFlyt.pz_envs as pz

    out: dict = {"gymnasium": {}, "pettingzoo": {}}
    for env_id in sorted(i for i in gymnasium.registry if i.startswith("PyFlyt/")):

        def check(env_id=env_id):
            env = gymnasium.make(env_id)
            try:
                check_env(env.unwrapped, skip_render_check=True)
            finally:
                env.close()

        out["gymnasium"][env_id] = _caught(check)
    for cls in ("MAQuadXHoverEnvV2", "MAFixedwingDogfightEnvV2"):

        def parallel(cls=cls):
            env = getattr(pz, cls)()
            try:
                parallel_api_test(env, num_cycles=100)
            finally:
                env.close()

        def aec(cls=cls):
            env = parallel_to_aec(getattr(pz, cls)())
            try:
                api_test(env, num_cycles=100)
            finally:
                env.close()

        out["pettingzoo"][cls] = {"parallel_api_test": _caught(parallel), "api_test": _caught(aec)}
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

    # the courses a seeded reset draws (the first draws of the env's seeded np_random)
    facts["waypoint_targets"] = {}
    for env_id, kwargs in (
        ("PyFlyt/QuadX-Waypoints-v4", {}),
        ("PyFlyt/QuadX-Waypoints-v4", {"use_yaw_targets": True}),
        ("PyFlyt/QuadX-Pole-Waypoints-v4", {}),
        ("PyFlyt/Fixedwing-Waypoints-v3", {}),
    ):
        key = env_id + (" use_yaw_targets" if kwargs else "")
        facts["waypoint_targets"][key] = {}
        for seed in SEEDS:
            e = gymnasium.make(env_id, **kwargs)
            e.reset(seed=seed)
            w = e.unwrapped.waypoints
            entry = {"targets": np.asarray(w.targets, dtype=float).tolist()}
            if kwargs:
                entry["yaw_targets"] = np.asarray(w.yaw_targets, dtype=float).tolist()
            facts["waypoint_targets"][key][str(seed)] = entry
            e.close()

    # the Rocket's drop (its default reset options: randomize_drop, from the seeded np_random)
    facts["rocket_drop"] = {}
    for seed in SEEDS:
        e = gymnasium.make("PyFlyt/Rocket-Landing-v4")
        e.reset(seed=seed)
        facts["rocket_drop"][str(seed)] = {
            "start_pos": np.asarray(e.unwrapped.start_pos, dtype=float).tolist(),
            "start_orn": np.asarray(e.unwrapped.start_orn, dtype=float).tolist(),
        }
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


def record_public_imports() -> dict:
    """Per module, the public names it holds that come from elsewhere in the package (``from
    PyFlyt.core.aviary import DroneClass`` works on the reference, so ported code may use it),
    and its plain type aliases (``DroneIndex = int``)."""
    import importlib
    import inspect

    import PyFlyt

    root = Path(PyFlyt.__file__).parent
    names: dict = {}
    for package in ("core", "gym_envs", "pz_envs"):
        for path in sorted((root / package).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            module_name = ".".join(p for p in parts if p != "__init__")
            module = importlib.import_module(f"PyFlyt.{module_name}")
            names[module_name] = sorted(
                n
                for n, obj in vars(module).items()
                if not n.startswith("_")
                and (
                    (
                        (inspect.isclass(obj) or inspect.isfunction(obj))
                        and getattr(obj, "__module__", "").startswith("PyFlyt.")
                        and obj.__module__ != module.__name__
                    )
                    or any(obj is t for t in (int, float, str))
                )
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
        "public_imports": record_public_imports(),
        "checker_warnings": record_checker_warnings(),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()

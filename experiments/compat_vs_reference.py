"""The compat layer beside the reference PyFlyt 0.29.0: same seed, same actions, trajectories and speed.

    python experiments/compat_vs_reference.py [--reference-python /work/refvenv/bin/python]
                                              [--out experiments/results/compat_vs_reference.md]

The reference pins numpy < 2, so it runs in its own interpreter (``--reference-python``,
default $PYFLYT_REFERENCE_PYTHON or /work/refvenv/bin/python), in a subprocess fed the
same cases as JSON; nothing of this project is imported there.  Without it, only the
compat side is run and the report says so.

Trajectories: each case is flown with one action sequence drawn here from a seeded
generator, by ``pyflyt_engine.compat`` and by the reference.  Compared: the displacement
from the first observed position, the Euler attitude and the body velocity per step;
reported as the largest and final differences, and the first step at which the
displacement differs by more than the case's tolerance.  Known causes of differences are
listed per case (``WHY``).

Speed: env steps per second (random actions, resets included, construction excluded)
of the compat id, the reference id and the native ``-v0`` id at the reference's agent
rate, interleaved in one run so load hits them alike; the ratios compat / reference and
native / reference (the target for compat is the native ratio).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: steps run before timing (the reference compiles its numba kernels on first use)
WARMUP = 100
DEFAULT_REFERENCE = os.environ.get("PYFLYT_REFERENCE_PYTHON", "/work/refvenv/bin/python")

# ---------------------------------------------------------------------------------- cases

#: env cases: name -> (id, kwargs, steps, action kind, displacement tolerance [m])
ENV_CASES: dict[str, tuple[str, dict[str, Any], int, str, float]] = {
    "hover": ("PyFlyt/QuadX-Hover-v4", {"angle_representation": "euler"}, 120, "quadx_rates", 0.1),
    "waypoints": ("PyFlyt/QuadX-Waypoints-v4", {"angle_representation": "euler"}, 90, "quadx_rates", 0.1),
    "pole_balance": ("PyFlyt/QuadX-Pole-Balance-v4", {"angle_representation": "euler"}, 80, "quadx_motors", 0.1),
    "fixedwing": ("PyFlyt/Fixedwing-Waypoints-v3", {"angle_representation": "euler"}, 150, "fixedwing", 1.0),
    "rocket_fall": ("PyFlyt/Rocket-Landing-v4", {"angle_representation": "euler"}, 80, "rocket_idle", 1.0),
}

#: Aviary cases: name -> (drone type, steps, tolerance [m])
AVIARY_CASES: dict[str, tuple[str, int, float]] = {
    "aviary_position_mode": ("quadx", 720, 0.05),
    "aviary_custom_controller": ("quadx", 1000, 0.1),
    "aviary_fixedwing_glide": ("fixedwing", 240, 1.0),
}

WHY = {
    "hover": "the reference's motor noise N(4, 1) x 2 % biases its thrust (the command is matched at hover "
    "only, so climb and sink rates differ a little); different rate-loop gains, motor lag and drag; open loop, "
    "so small differences in attitude grow into drift",
    "waypoints": "as hover; targets drawn from different random streams (rewards differ, the flight does not)",
    "pole_balance": "as hover, in motor mode, the commands matched at the reference primitive_drone's hover "
    "command; the pole: the reference's URDF pole resting free vs the native payload on a ball joint",
    "fixedwing": "different airframe models (surface areas, coefficients, mass): neutral elevator trims the native "
    "airframe near 14 m/s, so at the 20 m/s spawn it pitches up (docs/migrating_from_pyflyt.md), the reference's "
    "speeds up and flies nearly straight until its propeller torque roll grows; the reference v3 drives the vertical tail from the pitch entry and ignores yaw (fixed in its "
    "later v4, which compat follows); its spawn 10 m at 20 m/s and its thrust mapping T / 2 + 0.5 are copied",
    "rocket_fall": "spawn drawn from different random streams (x, y, z and attitude differ; displacements "
    "compared); both drop at 100 m/s; the drag models of the two rockets differ",
    "aviary_position_mode": "different cascade gains: both hold (0, 0, 1) and reach (1, 0, 1), by different paths",
    "aviary_custom_controller": "the same user controller over different velocity loops",
    "aviary_fixedwing_glide": "different airframe models (lift, drag, trim)",
}

# The reference side: runs in the reference's interpreter, reads the cases from stdin.
REFERENCE_SCRIPT = r"""
import json, sys, time, warnings
warnings.filterwarnings("ignore")
import numpy as np
import gymnasium
import PyFlyt.gym_envs  # noqa: F401
from PyFlyt.core import Aviary
from PyFlyt.core.abstractions import ControlClass

job = json.loads(sys.stdin.read())
out = {"envs": {}, "aviary": {}, "speed": {}}

def attitude(obs):
    a = np.asarray(obs["attitude"] if isinstance(obs, dict) else obs, dtype=float)
    return a[:12].tolist()

for name, case in job["envs"].items():
    env = gymnasium.make(case["id"], **case["kwargs"])
    obs, _ = env.reset(seed=case["seed"])
    rows, rewards, ends = [attitude(obs)], [], None
    for i, a in enumerate(case["actions"]):
        obs, r, term, trunc, info = env.step(np.array(a))
        rows.append(attitude(obs)); rewards.append(float(r))
        if term or trunc:
            ends = i + 1
            break
    env.close()
    out["envs"][name] = {"rows": rows, "rewards": rewards, "ended": ends}

class Towards111(ControlClass):
    def __init__(self):
        pass
    def reset(self):
        pass
    def step(self, state, setpoint):
        v = np.array([1.0, 1.0, 1.0]) - state[-1]
        return np.array([*v[:2], 0.5, v[-1]])

for name, case in job["aviary"].items():
    kind, steps = case["kind"], case["steps"]
    start = np.array([[0.0, 0.0, 1.0 if kind == "quadx" else 20.0]])
    env = Aviary(start_pos=start, start_orn=np.zeros((1, 3)), drone_type=kind, render=False, seed=0)
    if name == "aviary_custom_controller":
        env.drones[0].register_controller(controller_constructor=Towards111, controller_id=8, base_mode=6)
        env.set_mode(8)
    elif kind == "quadx":
        env.set_mode(7)
    else:
        env.set_mode(0)
        env.set_setpoint(0, np.array([0.0, 0.0, 0.0, 0.5]))
    rows = [env.state(0).reshape(-1).tolist()]
    for i in range(steps):
        if name == "aviary_position_mode" and i == 240:
            env.set_setpoint(0, np.array([1.0, 0.0, 0.0, 1.0]))
        env.step()
        rows.append(env.state(0).reshape(-1).tolist())
    out["aviary"][name] = {"rows": rows, "elapsed": env.elapsed_time}
    env.disconnect()

for env_id, case in job["speed"].items():
    env = gymnasium.make(env_id, **case["kwargs"])
    env.action_space.seed(0)
    env.reset(seed=0)
    for _ in range(job["warmup"]):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
    t0 = time.perf_counter()
    for _ in range(case["steps"]):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
    out["speed"][env_id] = case["steps"] / (time.perf_counter() - t0)
    env.close()

if job.get("aviary_speed"):
    env = Aviary(start_pos=np.array([[0.0, 0.0, 1.0]]), start_orn=np.zeros((1, 3)), drone_type="quadx", render=False)
    env.set_mode(7)
    for _ in range(job["warmup"]):
        env.step()
    t0 = time.perf_counter()
    for _ in range(job["aviary_speed"]):
        env.step()
    out["speed"]["Aviary"] = job["aviary_speed"] / (time.perf_counter() - t0)
    env.disconnect()

print("RESULT " + json.dumps(out))
"""


def actions_for(kind: str, steps: int, rng: np.random.Generator) -> list[list[float]]:
    """Actions that keep the vehicle flying: the reference's hover command (0.300) with noise."""
    if kind == "quadx_rates":
        return [[*rng.normal(0.0, 0.1, 3), 0.300 + rng.normal(0.0, 0.01)] for _ in range(steps)]
    if kind == "quadx_motors":
        return [list(np.clip(0.300 + rng.normal(0.0, 0.01, 4), 0.0, 0.8)) for _ in range(steps)]
    if kind == "fixedwing":
        return [[rng.normal(0.0, 0.1), 0.0, 0.0, 0.6] for _ in range(steps)]
    return [[0.0] * 7 for _ in range(steps)]


def build_job(seed: int, speed_steps: int) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    envs = {
        name: {"id": env_id, "kwargs": kwargs, "seed": seed, "actions": actions_for(kind, steps, rng)}
        for name, (env_id, kwargs, steps, kind, _) in ENV_CASES.items()
    }
    aviary = {name: {"kind": kind, "steps": steps} for name, (kind, steps, _) in AVIARY_CASES.items()}
    speed = {
        "PyFlyt/QuadX-Hover-v4": {"kwargs": {}, "steps": speed_steps},
        "PyFlyt/QuadX-Waypoints-v4": {"kwargs": {}, "steps": speed_steps},
        "PyFlyt/Fixedwing-Waypoints-v3": {"kwargs": {}, "steps": speed_steps},
        "PyFlyt/Rocket-Landing-v4": {"kwargs": {}, "steps": speed_steps},
    }
    return {"envs": envs, "aviary": aviary, "speed": speed, "aviary_speed": 4 * speed_steps, "warmup": WARMUP}


# ---------------------------------------------------------------------------------- compat side


def run_compat(job: dict[str, Any]) -> dict[str, Any]:
    import gymnasium

    import pyflyt_engine.compat.gym_envs  # noqa: F401
    from pyflyt_engine.compat.core import Aviary
    from pyflyt_engine.compat.core.abstractions import ControlClass

    out: dict[str, Any] = {"envs": {}, "aviary": {}, "speed": {}, "native_speed": {}}

    def attitude(obs: Any) -> list[float]:
        a = np.asarray(obs["attitude"] if isinstance(obs, dict) else obs, dtype=float)
        return a[:12].tolist()

    for name, case in job["envs"].items():
        env = gymnasium.make(case["id"], **case["kwargs"])
        obs, _ = env.reset(seed=case["seed"])
        rows, rewards, ended = [attitude(obs)], [], None
        for i, a in enumerate(case["actions"]):
            obs, r, term, trunc, _ = env.step(np.array(a))
            rows.append(attitude(obs))
            rewards.append(float(r))
            if term or trunc:
                ended = i + 1
                break
        env.close()
        out["envs"][name] = {"rows": rows, "rewards": rewards, "ended": ended}

    class Towards111(ControlClass):
        def __init__(self) -> None:
            pass

        def reset(self) -> None:
            pass

        def step(self, state: np.ndarray, setpoint: np.ndarray) -> np.ndarray:
            v = np.array([1.0, 1.0, 1.0]) - state[-1]
            return np.array([*v[:2], 0.5, v[-1]])

    for name, case in job["aviary"].items():
        kind, steps = case["kind"], case["steps"]
        start = np.array([[0.0, 0.0, 1.0 if kind == "quadx" else 20.0]])
        env = Aviary(start_pos=start, start_orn=np.zeros((1, 3)), drone_type=kind, render=False, seed=0)
        if name == "aviary_custom_controller":
            env.drones[0].register_controller(controller_constructor=Towards111, controller_id=8, base_mode=6)
            env.set_mode(8)
        elif kind == "quadx":
            env.set_mode(7)
        else:
            env.set_mode(0)
            env.set_setpoint(0, np.array([0.0, 0.0, 0.0, 0.5]))
        rows = [env.state(0).reshape(-1).tolist()]
        for i in range(steps):
            if name == "aviary_position_mode" and i == 240:
                env.set_setpoint(0, np.array([1.0, 0.0, 0.0, 1.0]))
            env.step()
            rows.append(env.state(0).reshape(-1).tolist())
        out["aviary"][name] = {"rows": rows, "elapsed": env.elapsed_time}
        env.disconnect()
    return out


def time_env(env_id: str, kwargs: dict[str, Any], steps: int) -> float:
    import gymnasium

    import pyflyt_engine.compat.gym_envs  # noqa: F401

    env = gymnasium.make(env_id, **kwargs)
    env.action_space.seed(0)
    env.reset(seed=0)
    for _ in range(WARMUP):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
    t0 = time.perf_counter()
    for _ in range(steps):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
    rate = steps / (time.perf_counter() - t0)
    env.close()
    return rate


def time_aviary(steps: int) -> float:
    from pyflyt_engine.compat.core import Aviary

    env = Aviary(start_pos=np.array([[0.0, 0.0, 1.0]]), start_orn=np.zeros((1, 3)), drone_type="quadx", render=False)
    env.set_mode(7)
    for _ in range(WARMUP):
        env.step()
    t0 = time.perf_counter()
    for _ in range(steps):
        env.step()
    rate = steps / (time.perf_counter() - t0)
    env.disconnect()
    return rate


#: compat id -> (native id, the reference's agent rate for it)
NATIVE = {
    "PyFlyt/QuadX-Hover-v4": ("PyFlyt/QuadX-Hover-v0", 40),
    "PyFlyt/QuadX-Waypoints-v4": ("PyFlyt/QuadX-Waypoints-v0", 30),
    "PyFlyt/Fixedwing-Waypoints-v3": ("PyFlyt/Fixedwing-Waypoints-v0", 30),
    "PyFlyt/Rocket-Landing-v4": ("PyFlyt/Rocket-Landing-v0", 40),
}


# ---------------------------------------------------------------------------------- comparing


def compare_rows(ours: list[list[float]], ref: list[list[float]], layout: str, tolerance: float) -> dict[str, Any]:
    """Displacement, attitude and velocity differences over the common horizon."""
    n = min(len(ours), len(ref))
    a, b = np.asarray(ours[:n]), np.asarray(ref[:n])
    if layout == "obs":  # [ang_vel, ang_pos, lin_vel, lin_pos]
        pos_a, pos_b, att_a, att_b, vel_a, vel_b = a[:, 9:12], b[:, 9:12], a[:, 3:6], b[:, 3:6], a[:, 6:9], b[:, 6:9]
    else:  # the Aviary's (4, 3) state, flattened: the same rows
        pos_a, pos_b, att_a, att_b, vel_a, vel_b = a[:, 9:12], b[:, 9:12], a[:, 3:6], b[:, 3:6], a[:, 6:9], b[:, 6:9]
    disp = np.linalg.norm((pos_a - pos_a[0]) - (pos_b - pos_b[0]), axis=1)
    start = float(np.linalg.norm(pos_a[0] - pos_b[0]))
    wrapped = (att_a - att_b + np.pi) % (2 * np.pi) - np.pi
    beyond = np.flatnonzero(disp > tolerance)
    return {
        "steps": n - 1,
        "start_offset": start,
        "max_disp_diff": float(disp.max()),
        "final_disp_diff": float(disp[-1]),
        "diverges_at": int(beyond[0]) if beyond.size else None,
        "max_att_diff": float(np.abs(wrapped).max()),
        "max_vel_diff": float(np.linalg.norm(vel_a - vel_b, axis=1).max()),
        "final_pos_ours": pos_a[-1].round(3).tolist(),
        "final_pos_ref": pos_b[-1].round(3).tolist(),
    }


def machine() -> dict[str, Any]:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "load": os.getloadavg()}


def git_commit() -> str:
    try:
        done = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
        return done.stdout.strip()
    except OSError:
        return "?"


def run_reference(python: str, job: dict[str, Any]) -> dict[str, Any] | None:
    if not python or not Path(python).exists():
        return None
    result = subprocess.run(
        [python, "-c", REFERENCE_SCRIPT], input=json.dumps(job), capture_output=True, text=True, cwd="/"
    )
    for line in reversed(result.stdout.splitlines()):
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT ") :])
    raise RuntimeError(f"the reference run failed:\n{result.stderr[-3000:]}")


def fmt(value: Any, digits: int = 3) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return str(value)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--reference-python", default=DEFAULT_REFERENCE)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--speed-steps", type=int, default=1000)
    parser.add_argument("--out", type=Path, default=ROOT / "experiments" / "results" / "compat_vs_reference.md")
    args = parser.parse_args()

    start_machine = machine()
    t_start = time.perf_counter()
    job = build_job(args.seed, args.speed_steps)
    ours = run_compat(job)
    ref = run_reference(args.reference_python, {**job, "speed": {}, "aviary_speed": 0})

    # speed: ours, then the reference's same case, then the native id, case by case
    speed: dict[str, dict[str, float | None]] = {}
    for env_id, case in job["speed"].items():
        native_id, hz = NATIVE[env_id]
        compat_rate = time_env(env_id, case["kwargs"], case["steps"])
        ref_rate = None
        if ref is not None:
            one = run_reference(
                args.reference_python, {"envs": {}, "aviary": {}, "speed": {env_id: case}, "warmup": WARMUP}
            )
            ref_rate = one["speed"][env_id] if one else None
        native_rate = time_env(native_id, {"agent_hz": hz}, case["steps"])
        speed[env_id] = {"compat": compat_rate, "reference": ref_rate, "native": native_rate}
    aviary_rate = time_aviary(job["aviary_speed"])
    ref_aviary = None
    if ref is not None:
        one = run_reference(
            args.reference_python,
            {"envs": {}, "aviary": {}, "speed": {}, "aviary_speed": job["aviary_speed"], "warmup": WARMUP},
        )
        ref_aviary = one["speed"].get("Aviary") if one else None
    speed["Aviary (1 QuadX, mode 7)"] = {"compat": aviary_rate, "reference": ref_aviary, "native": None}
    end_machine = machine()
    seconds = time.perf_counter() - t_start

    lines = [
        "# The compat layer beside the reference PyFlyt 0.29.0",
        "",
        f"`python experiments/compat_vs_reference.py` at commit {git_commit()}, "
        f"{datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}, {seconds:.0f} s.",
        f"Machine: {start_machine['cpu']}, {start_machine['cores']} cores, Python {start_machine['python']}; "
        f"load average (1, 5, 15 min) {tuple(round(x, 2) for x in start_machine['load'])} at the start, "
        f"{tuple(round(x, 2) for x in end_machine['load'])} at the end (the machine is shared: speeds are "
        "indicative, ratios are taken between runs made one right after the other).",
        "",
    ]
    if ref is None:
        lines += [f"No reference interpreter at `{args.reference_python}`: the compat side only.", ""]
    lines += [
        "## Trajectories (same seed, same actions)",
        "",
        "Displacement = position minus the first observed one; *diverges at* = first step where the two "
        "displacements differ by more than the tolerance.",
        "",
        "| case | steps | tol. [m] | start offset [m] | max / final disp. diff [m] | diverges at | "
        "max attitude diff [rad] | max body-velocity diff [m/s] | end position compat / reference |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    results: dict[str, Any] = {}
    for name, (_, _, _, _, tol) in ENV_CASES.items():
        if ref is None:
            continue
        r = compare_rows(ours["envs"][name]["rows"], ref["envs"][name]["rows"], "obs", tol)
        r["ended"] = (ours["envs"][name]["ended"], ref["envs"][name]["ended"])
        results[name] = r
    for name, (_, _, tol) in AVIARY_CASES.items():
        if ref is None:
            continue
        results[name] = compare_rows(ours["aviary"][name]["rows"], ref["aviary"][name]["rows"], "state", tol)
    for name, r in results.items():
        tol = ENV_CASES[name][4] if name in ENV_CASES else AVIARY_CASES[name][2]
        lines.append(
            f"| {name} | {r['steps']} | {tol:g} | {fmt(r['start_offset'])} | {fmt(r['max_disp_diff'])} / "
            f"{fmt(r['final_disp_diff'])} | {fmt(r['diverges_at'])} | {fmt(r['max_att_diff'])} | "
            f"{fmt(r['max_vel_diff'])} | {r['final_pos_ours']} / {r['final_pos_ref']} |"
        )
    if results:
        lines += [
            "",
            "Episode ends (step, compat / reference): "
            + ", ".join(
                f"{n} {r['ended'][0] or '-'} / {r['ended'][1] or '-'}" for n, r in results.items() if "ended" in r
            )
            + ".",
            "",
            "Why they differ:",
            "",
        ]
        lines += [f"- **{name}**: {WHY[name]}" for name in results]
    lines += [
        "",
        "## Speed (env steps per second, random actions)",
        "",
        "| env | compat | reference | native -v0 (reference's agent rate) | compat / reference | native / reference |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for env_id, s in speed.items():
        c, r_, n = s["compat"], s["reference"], s["native"]
        lines.append(
            f"| {env_id} | {fmt(c, 4)} | {fmt(r_, 4)} | {fmt(n, 4)} | "
            f"{fmt(c / r_ if c and r_ else None)} | {fmt(n / r_ if n and r_ else None)} |"
        )
    text = "\n".join(lines) + "\n"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    args.out.with_suffix(".json").write_text(
        json.dumps({"machine": [start_machine, end_machine], "trajectories": results, "speed": speed}, indent=1) + "\n"
    )
    print(text)


if __name__ == "__main__":
    sys.exit(main())

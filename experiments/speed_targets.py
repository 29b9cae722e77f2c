"""The engine's speed targets, in one run: our env step against the bare-PyBullet floor,
against a baseline checkout and against the reference PyFlyt 0.29.0.

Targets (``docs/performance.md``): QuadX-Hover, hovering, within 2.5x the floor; the
QuadX envs at least 12x faster than the reference, Fixedwing and Rocket at least 8x; no
env slower than the baseline.

Protocol.  Per env, ``--rounds`` rounds; each round runs one fresh process per side --
this checkout, then ``--baseline`` (another checkout, e.g. a ``git archive``), then the
reference (``--reference-python``: an interpreter with ``pyflyt==0.29.0``, which pins
numpy < 2, so it lives in its own virtual environment) -- so load from other jobs hits
every side alike.  Each process (``speed_targets_probe.py``) builds its env once and
alternates ``--chunks`` times 8 x ``--steps`` physics steps of the same bare-PyBullet
floor (one cf2x body: pose and velocity read, four motor forces, one torque, one
``stepSimulation``) with ``--steps`` env steps, by the CPU time of its thread; its
figures are the medians over its chunks.  Each side's env step is also divided by the
floor measured in its own process: "x floor" is that ratio, and the ratios between
sides ("x baseline", "x ref": how many times faster we are) are taken between those
floor-normalised figures of the same round, then their median over rounds is printed
with its range, so a machine that changes speed between processes cancels out.

QuadX-Hover is flown by a level-holding feedback on body rates and thrust (both sides,
no episode end): the step of a hovering vehicle.  The other envs take seeded random
actions, resetting at episode ends inside the timing (the reference rebuilds its world
at every reset, ours restores a saved state).

    python experiments/speed_targets.py --baseline /tmp/base --reference-python /path/ref-venv/bin/python
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
PROBE = Path(__file__).resolve().with_name("speed_targets_probe.py")
RESULT_MARKER = "PYFLYT_SPEED_RESULT "
ENVS = {  # env id -> action protocol
    "PyFlyt/QuadX-Hover-v0": "hover",
    "PyFlyt/QuadX-Waypoints-v0": "random",
    "PyFlyt/Fixedwing-Waypoints-v0": "random",
    "PyFlyt/Rocket-Landing-v0": "random",
}
#: minimum speed-up over the reference per env (docs/performance.md)
TARGET_X_REF = {
    "PyFlyt/QuadX-Hover-v0": 12.0,
    "PyFlyt/QuadX-Waypoints-v0": 12.0,
    "PyFlyt/Fixedwing-Waypoints-v0": 8.0,
    "PyFlyt/Rocket-Landing-v0": 8.0,
}
TARGET_X_FLOOR = {"PyFlyt/QuadX-Hover-v0": 2.5}


def floor_body() -> dict:
    """The floor's body: the generated cf2x URDF, its mass and motor positions."""
    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.urdf import urdf_path

    spec = load_uav_spec("quadx_cf2x")
    return {"urdf": str(urdf_path(spec)), "mass": spec.body.mass, "motors": [list(m) for m in spec.motors.positions]}


def run(python: str, root: Path | None, case: dict) -> dict:
    """One probe process; ``root`` on PYTHONPATH (None: nothing of ours, for the reference)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    if root is not None:
        env["PYTHONPATH"] = str(root)
    out = subprocess.run(
        [python, str(PROBE), json.dumps(case)], cwd=root or HERE, env=env, capture_output=True, text=True
    )
    lines = [line for line in out.stdout.splitlines() if line.startswith(RESULT_MARKER)]
    if out.returncode != 0 or not lines:
        raise SystemExit(f"probe failed ({python}, {root}):\n{out.stderr[-3000:]}")
    result = json.loads(lines[-1][len(RESULT_MARKER) :])
    if root is not None and not Path(result["engine"]).resolve().is_relative_to(root.resolve()):
        raise SystemExit(f"the probe in {root} imported {result['engine']}: not that checkout's engine")
    env_s, floor_s = statistics.median(result["env_s"]), statistics.median(result["floor_s"])
    return {"env_s": env_s, "floor_s": floor_s, "x_floor": env_s / floor_s}


def _spread(values: list[float]) -> str:
    return f"{statistics.median(values):.2f} ({min(values):.2f}-{max(values):.2f})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--baseline", type=Path, help="another checkout to compare with")
    parser.add_argument("--reference-python", default=os.environ.get("PYFLYT_REFERENCE_PYTHON"),
                        help="interpreter of a virtual environment with pyflyt==0.29.0")  # fmt: skip
    parser.add_argument("--env", action="append", help="env id (repeatable; default: the four of ENVS)")
    parser.add_argument("--rounds", type=int, default=5, help="processes per side and env")
    parser.add_argument("--chunks", type=int, default=7, help="floor/env alternations per process")
    parser.add_argument("--steps", type=int, default=300, help="env steps per chunk")
    parser.add_argument("--json", type=Path, help="also write every figure to this file")
    args = parser.parse_args()
    if args.baseline is not None and not (args.baseline / "pyflyt_engine").is_dir():
        parser.error(f"--baseline {args.baseline}: no pyflyt_engine package there")
    floor = floor_body()
    sides: list[tuple[str, str, Path | None, str]] = [("ours", sys.executable, HERE, "ours")]
    if args.baseline is not None:
        sides.append(("baseline", sys.executable, args.baseline, "ours"))
    if args.reference_python:
        sides.append(("reference", args.reference_python, None, "reference"))

    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}; load {load}")
    print(
        f"CPU time of the stepping thread; per env {args.rounds} rounds x {len(sides)} processes, "
        f"each {args.chunks} alternations of {args.steps} env steps with 8 x {args.steps} floor physics steps"
    )
    report: dict = {}
    for env_id in args.env or list(ENVS):
        actions = ENVS.get(env_id, "random")
        rounds: list[dict[str, dict]] = []
        for _ in range(args.rounds):
            case = {"env_id": env_id, "floor": floor, "actions": actions, "steps": args.steps, "rounds": args.chunks}
            rounds.append({name: run(python, root, {**case, "side": kind}) for name, python, root, kind in sides})
        report[env_id] = rounds
        print(f"\n{env_id} ({actions} actions)")
        print(f"  {'side':<10}{'us/step':>10}{'floor us':>10}{'x floor':>20}")
        for name, *_ in sides:
            env_us = statistics.median(r[name]["env_s"] for r in rounds) * 1e6
            floor_us = statistics.median(r[name]["floor_s"] for r in rounds) * 1e6
            print(f"  {name:<10}{env_us:>10.1f}{floor_us:>10.1f}{_spread([r[name]['x_floor'] for r in rounds]):>20}")
        target = TARGET_X_FLOOR.get(env_id)
        if target:
            print(f"  target: ours <= {target} x floor")
        for name in ("baseline", "reference"):
            if any(name == side[0] for side in sides):
                faster = [r[name]["x_floor"] / r["ours"]["x_floor"] for r in rounds]
                goal = (
                    f" (target >= {TARGET_X_REF[env_id]:g})" if name == "reference" and env_id in TARGET_X_REF else ""
                )
                goal = " (target >= 1)" if name == "baseline" else goal
                print(f"  ours faster than {name}: x {_spread(faster)}{goal}")
    if args.json:
        args.json.write_text(json.dumps({"load": load, "floor": floor, "report": report}, indent=2))


if __name__ == "__main__":
    main()

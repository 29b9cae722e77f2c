"""The batched backend's throughput against N, beside the PyBullet env and the reference PyFlyt, in one run.

Measures, each case in a fresh process (``pyflyt speed --backend batched``'s probes):

* the batched backend at N = 1 ... 4096 envs (``--sizes``): agent-steps per second, CPU
  per agent-step, memory per env;
* the PyBullet engine's env of the same id (one env per call, through ``gymnasium.make``):
  its steps per second and CPU per step, so each size's "x PyBullet env per core" is the
  ratio of the CPU times of the two processes (robust to other jobs' load, which slows the
  wall clock of both);
* with ``--reference-python`` (an interpreter of a virtual environment with
  ``pyflyt==0.29.0``, which pins numpy < 2), the reference's env of the same name, by
  ``speed_targets_probe.py`` (random actions, resets inside the timing, CPU time of the
  stepping thread).

Rounds alternate the sides (``--rounds``), so load from other jobs hits every side
alike; the figures are medians over rounds, and each ratio is taken within a round.  The
target (issue: batched backend) is >= 100x the PyBullet env's steps/s per core on
QuadX-Hover at N >= 256, with a cost per agent-step that falls with N.

    python experiments/speed_batched.py [--rounds 3] [--reference-python /path/ref-venv/bin/python]

Writes ``experiments/results/speed_batched.md`` (and ``.json``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

from pyflyt_cli.speed import run_probe

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "speed_batched.md"
PROBE = HERE / "speed_targets_probe.py"
RESULT_MARKER = "PYFLYT_SPEED_RESULT "
ENV_IDS = ("PyFlyt/QuadX-Hover-v0", "PyFlyt/QuadX-Waypoints-v0")


def _floor() -> dict:
    from pyflyt_engine.spec import load_uav_spec
    from pyflyt_engine.urdf import urdf_path

    spec = load_uav_spec("quadx_cf2x")
    return {"urdf": str(urdf_path(spec)), "mass": spec.body.mass, "motors": [list(m) for m in spec.motors.positions]}


def reference(python: str, env_id: str, steps: int, chunks: int) -> float:
    """The reference env's steps/s (CPU time of its stepping thread), by speed_targets_probe.py."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    case = {"env_id": env_id, "floor": _floor(), "actions": "random", "steps": steps, "rounds": chunks,
            "side": "reference"}  # fmt: skip
    out = subprocess.run([python, str(PROBE), json.dumps(case)], env=env, capture_output=True, text=True)
    lines = [line for line in out.stdout.splitlines() if line.startswith(RESULT_MARKER)]
    if out.returncode != 0 or not lines:
        raise SystemExit(f"reference probe failed ({python}):\n{out.stderr[-2000:]}")
    return 1.0 / statistics.median(json.loads(lines[-1][len(RESULT_MARKER) :])["env_s"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 16, 64, 256, 1024, 4096])
    parser.add_argument("--agent-steps", type=int, default=200_000, help="agent-steps timed per batched case")
    parser.add_argument("--env-steps", type=int, default=2000, help="steps timed per PyBullet env case")
    parser.add_argument("--env", action="append", help="env id (default: QuadX-Hover and QuadX-Waypoints)")
    parser.add_argument("--reference-python", default=os.environ.get("PYFLYT_REFERENCE_PYTHON"))
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    env_ids = args.env or list(ENV_IDS)
    load_before = os.getloadavg()
    machine = run_probe({"probe": "machine"})
    rounds: list[dict] = []
    for r in range(args.rounds):
        row: dict = {}
        for env_id in env_ids:
            print(f"[{r + 1}/{args.rounds}] {env_id}", file=sys.stderr, flush=True)
            ours = run_probe({"probe": "env", "env_id": env_id, "steps": args.env_steps, "resets": 5, "warmup": 200})
            row[(env_id, "pybullet")] = ours["steps_per_s"]
            row[(env_id, "pybullet_cpu")] = ours["step_cpu_s"]
            if args.reference_python:
                row[(env_id, "reference")] = reference(args.reference_python, env_id, 300, 5)
            for n in args.sizes:
                result = run_probe({"probe": "batched", "env_id": env_id, "n": n, "agent_steps": args.agent_steps})
                row[(env_id, n)] = result
        rounds.append(row)
    load_after = os.getloadavg()

    def med(values):
        return statistics.median(values)

    lines = [
        f"\n## {time.strftime('%Y-%m-%d %H:%M')} — {machine.get('processor') or platform.processor()}, "
        f"{os.cpu_count()} cores, Python {platform.python_version()}; load average {load_before[0]:.2f} before, "
        f"{load_after[0]:.2f} after; {args.rounds} rounds, medians (ratios within a round)\n",
        f"`python experiments/speed_batched.py {' '.join(sys.argv[1:])}`\n",
    ]
    for env_id in env_ids:
        pb = [row[(env_id, "pybullet")] for row in rounds]
        pb_cpu = [row[(env_id, "pybullet_cpu")] for row in rounds]
        lines += [
            f"### {env_id}\n",
            f"PyBullet env (one env per call): {med(pb):,.0f} steps/s, {med(pb_cpu) * 1e6:.1f} us of CPU per step"
            + (
                f"; reference PyFlyt 0.29.0: {med([row[(env_id, 'reference')] for row in rounds]):,.0f} steps/s"
                if args.reference_python
                else ""
            )
            + "\n",  # fmt: skip
            "| N | agent-steps/s | CPU us / agent-step | x PyBullet env | x PyBullet env per core | x reference | KiB per env |",
            "|---|---|---|---|---|---|---|",
        ]
        for n in args.sizes:
            res = [row[(env_id, n)] for row in rounds]
            x_pb = [row[(env_id, n)]["steps_per_s"] / row[(env_id, "pybullet")] for row in rounds]
            x_core = [row[(env_id, "pybullet_cpu")] / row[(env_id, n)]["cpu_per_agent_step_s"] for row in rounds]
            x_ref = ([row[(env_id, n)]["steps_per_s"] / row[(env_id, "reference")] for row in rounds]
                     if args.reference_python else None)  # fmt: skip
            lines.append(
                f"| {n} | {med([x['steps_per_s'] for x in res]):,.0f} | "
                f"{med([x['cpu_per_agent_step_s'] for x in res]) * 1e6:.2f} | {med(x_pb):.0f}x | {med(x_core):.0f}x | "
                f"{f'{med(x_ref):.0f}x' if x_ref else '-'} | {med([x['memory_per_env_kb'] for x in res]):.1f} |"
            )
        lines.append("")
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        if not RESULTS.exists():
            RESULTS.write_text(
                "# Batched backend throughput (experiments/speed_batched.py)\n\n"
                "Agent-steps per second of N envs stepped by one call, motor noise on, random actions,\n"
                "autoreset; beside the PyBullet env (one env per call) and the reference PyFlyt.\n"
            )
        with RESULTS.open("a") as fh:
            fh.write(text + "\n")
        data = [{f"{k[0]}|{k[1]}": v for k, v in row.items()} for row in rounds]
        RESULTS.with_suffix(".json").write_text(json.dumps({"command": sys.argv, "rounds": data}, indent=1) + "\n")


if __name__ == "__main__":
    main()

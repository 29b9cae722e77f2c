"""Side-by-side env speed against the reference PyFlyt 0.29.0 package, measured in one run.

The reference pins numpy < 2, so it lives in its own virtual environment; give its
interpreter with ``--reference-python`` (default: $PYFLYT_REFERENCE_PYTHON).  Without
it, only our numbers are printed.  Both sides run the same protocol, alternately, in
separate processes: build the env with ``gymnasium.make``, agent rate 30 Hz, warm up,
then step with random actions (resetting at episode ends, included in the timing), and
time seeded resets separately.  The median of ``--repeats`` timings is kept.

    python experiments/compare_reference.py --reference-python /path/to/ref-venv/bin/python

Pairs compared (ours -> reference id: its newest version of the same name):
    PyFlyt/QuadX-Hover-v0           -> PyFlyt/QuadX-Hover-v4
    PyFlyt/QuadX-Waypoints-v0       -> PyFlyt/QuadX-Waypoints-v4
    PyFlyt/Fixedwing-Waypoints-v0   -> PyFlyt/Fixedwing-Waypoints-v3
    PyFlyt/Rocket-Landing-v0        -> PyFlyt/Rocket-Landing-v4

``pyflyt speed --reference-python ...`` runs the same protocol and adds worlds, camera,
memory and vector envs.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys

from pyflyt_cli.commands.speed import SpeedError, run_probe
from pyflyt_engine.envs import ENVS

# The protocol (gymnasium.make, agent 30 Hz, warm-up, random actions with resets at
# episode ends, seeded resets timed apart) is speed_probe.measure_env, shared with
# ``pyflyt speed``; the reference id is the reference's newest version of the same name.


def probe(python: str | None, env_id: str, steps: int, resets: int) -> dict | None:
    """One measurement in a fresh process (``python`` None: ours); None when the env is unavailable."""
    case = {"probe": "env", "env_id": env_id, "steps": steps, "resets": resets, "warmup": 200}
    if python is not None:
        case["side"] = "reference"
    try:
        return run_probe(case, python=python)
    except SpeedError as exc:
        print(f"  ({env_id} unavailable in {python or sys.executable}: {str(exc).splitlines()[-1]})", file=sys.stderr)
        return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--reference-python", default=os.environ.get("PYFLYT_REFERENCE_PYTHON"))
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--resets", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()

    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}")
    header = f"{'env':<32}{'ours steps/s':>14}{'ref steps/s':>13}{'ratio':>8}{'ours reset ms':>15}{'ref reset ms':>14}{'ratio':>8}"
    print(header)
    for ours_id in ENVS:
        ours, ref = [], []
        for _ in range(args.repeats):
            o = probe(None, ours_id, args.steps, args.resets)
            if o is None:
                break
            ours.append(o)
            if args.reference_python:
                r = probe(args.reference_python, ours_id, args.steps, args.resets)
                if r is not None:
                    ref.append(r)
        if not ours:
            continue
        o_step = statistics.median(x["step_s"] for x in ours)
        o_reset = statistics.median(x["reset_s"] for x in ours)
        row = f"{ours_id:<32}{1 / o_step:>14.0f}"
        if ref:
            r_step = statistics.median(x["step_s"] for x in ref)
            r_reset = statistics.median(x["reset_s"] for x in ref)
            row += f"{1 / r_step:>13.0f}{r_step / o_step:>8.1f}{o_reset * 1e3:>15.2f}{r_reset * 1e3:>14.2f}{r_reset / o_reset:>8.0f}"
        else:
            row += f"{'-':>13}{'-':>8}{o_reset * 1e3:>15.2f}{'-':>14}{'-':>8}"
        print(row)


if __name__ == "__main__":
    main()

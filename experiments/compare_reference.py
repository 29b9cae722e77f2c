"""Side-by-side env speed against the reference PyFlyt 0.29.0 package, measured in one run.

The reference pins numpy < 2, so it lives in its own virtual environment; give its
interpreter with ``--reference-python`` (default: $PYFLYT_REFERENCE_PYTHON).  Without
it, only our numbers are printed.  Both sides run the same protocol, alternately, in
separate processes: build the env with ``gymnasium.make``, agent rate 30 Hz, warm up,
then step with random actions (resetting at episode ends, included in the timing), and
time seeded resets separately.  The median of ``--repeats`` timings is kept.

    python experiments/compare_reference.py --reference-python /path/to/ref-venv/bin/python

Pairs compared (ours -> reference id):
    PyFlyt/QuadX-Hover-v0           -> PyFlyt/QuadX-Hover-v4
    PyFlyt/QuadX-Waypoints-v0       -> PyFlyt/QuadX-Waypoints-v4
    PyFlyt/Fixedwing-Waypoints-v0   -> PyFlyt/Fixedwing-Waypoints-v3
    PyFlyt/Rocket-Landing-v0        -> PyFlyt/Rocket-Landing-v4
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import textwrap

PAIRS = [
    ("PyFlyt/QuadX-Hover-v0", "PyFlyt/QuadX-Hover-v4"),
    ("PyFlyt/QuadX-Waypoints-v0", "PyFlyt/QuadX-Waypoints-v4"),
    ("PyFlyt/Fixedwing-Waypoints-v0", "PyFlyt/Fixedwing-Waypoints-v3"),
    ("PyFlyt/Rocket-Landing-v0", "PyFlyt/Rocket-Landing-v4"),
]

# Runs in either interpreter: prints {"step_s": ..., "reset_s": ...} as JSON.
PROBE = textwrap.dedent(
    """
    import json, statistics, sys, time, warnings
    warnings.filterwarnings("ignore")
    import gymnasium
    env_id, module, steps, resets = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    __import__(module)
    kwargs = {"agent_hz": 30} if module == "PyFlyt.gym_envs" else {}
    env = gymnasium.make(env_id, **kwargs)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps + 200)]
    for a in actions[:200]:
        _, _, term, trunc, _ = env.step(a)
        if term or trunc:
            env.reset()
    start = time.perf_counter()
    for a in actions[200:]:
        _, _, term, trunc, _ = env.step(a)
        if term or trunc:
            env.reset()
    step_s = (time.perf_counter() - start) / steps
    times = []
    for seed in range(resets):
        t0 = time.perf_counter()
        env.reset(seed=seed + 1)
        times.append(time.perf_counter() - t0)
    env.close()
    print(json.dumps({"step_s": step_s, "reset_s": statistics.median(times)}))
    """
)


def probe(python: str, env_id: str, module: str, steps: int, resets: int) -> dict | None:
    """Run the probe in ``python``; None when the env is unavailable there."""
    result = subprocess.run(
        [python, "-c", PROBE, env_id, module, str(steps), str(resets)], capture_output=True, text=True
    )
    if result.returncode != 0:
        print(f"  ({env_id} unavailable in {python}: {result.stderr.strip().splitlines()[-1:]})", file=sys.stderr)
        return None
    return json.loads(result.stdout.strip().splitlines()[-1])


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
    for ours_id, ref_id in PAIRS:
        ours, ref = [], []
        for _ in range(args.repeats):
            o = probe(sys.executable, ours_id, "pyflyt_engine", args.steps, args.resets)
            if o is None:
                break
            ours.append(o)
            if args.reference_python:
                r = probe(args.reference_python, ref_id, "PyFlyt.gym_envs", args.steps, args.resets)
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

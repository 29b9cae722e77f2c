"""Still air costs nothing: the calm env step of this checkout against another checkout's.

The same timing loop (a level-holding QuadX hover, ``--steps`` agent steps, CPU time of
the process's thread per step) runs in a fresh subprocess per round, alternately with
this checkout and with ``--baseline`` (e.g. a checkout of the commit before the
atmosphere), ``--repeats`` rounds each; the medians and their ratio are printed.

    python experiments/speed_calm.py --baseline /path/to/other/checkout [--steps 3000] [--repeats 9]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

LOOP = """
import time, warnings, gymnasium, numpy as np
import pyflyt_engine
warnings.simplefilter("ignore")
env = gymnasium.make("PyFlyt/QuadX-Hover-v0", flight_dome_size=1e6, max_duration_seconds=1e6).unwrapped
def hold(s):
    roll, pitch, _ = s.ang_pos; p, q, r = s.ang_vel
    return np.array([-4 * roll - 0.5 * p, -4 * pitch - 0.5 * q, -0.5 * r, 0.125 + 0.1 * (1 - s.lin_pos[2]) - 0.05 * s.lin_vel_ground[2]])
best = None
for _ in range(3):
    env.reset(seed=0); s = env.state
    cpu = time.thread_time()
    for _ in range({steps}):
        env.step(hold(s)); s = env.state
    t = (time.thread_time() - cpu) / {steps}
    best = t if best is None else min(best, t)
print(pyflyt_engine.__file__)
print(best)
"""


def _run(root: Path, steps: int) -> float:
    env = {**os.environ, "PYTHONPATH": str(root)}
    out = subprocess.run(
        [sys.executable, "-c", LOOP.format(steps=steps)], cwd=root, env=env, capture_output=True, text=True, check=True
    )
    where, value = out.stdout.strip().splitlines()[-2:]
    if not Path(where).resolve().is_relative_to(root.resolve()):
        raise SystemExit(f"the loop in {root} imported {where}: not that checkout's engine")
    return float(value)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, required=True)
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=9)
    args = parser.parse_args()
    if not (args.baseline / "pyflyt_engine").is_dir():
        parser.error(f"--baseline {args.baseline}: no pyflyt_engine package there")
    times: dict[str, list[float]] = {"this checkout": [], "baseline": []}
    for _ in range(args.repeats):
        times["this checkout"].append(_run(HERE, args.steps))
        times["baseline"].append(_run(args.baseline, args.steps))
    base = statistics.median(times["baseline"])
    print(f"calm QuadX hover, {args.steps} steps, best of 3 per process, median of {args.repeats} processes each")
    for name, values in times.items():
        t = statistics.median(values)
        print(
            f"{name:<16}{t * 1e6:>10.1f} us CPU/step{t / base:>8.3f}  (range {min(values) * 1e6:.1f}-{max(values) * 1e6:.1f})"
        )


if __name__ == "__main__":
    main()

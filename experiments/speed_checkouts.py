"""Env step time of this checkout against another checkout's, env by env.

For each env, the same timing loop runs in a fresh subprocess per round, alternately with
this checkout and with ``--baseline`` (e.g. ``git worktree add`` or ``git archive`` of an
earlier commit), ``--repeats`` rounds each: a seeded reset, ``--steps`` agent steps of
pre-drawn seeded random actions, resetting at episode ends; steps and those resets are
timed apart, by the CPU time of the process's thread (``time.thread_time``: on a shared
machine it moves less than wall time), best of 3 passes per process.  Printed: the
median per checkout, in microseconds per env step and per reset, and the median of the
per-round ratios this / baseline (pairing the rounds keeps the ratio meaningful when the
machine's speed drifts).

    python experiments/speed_checkouts.py --baseline /path/to/other/checkout \\
        [--env PyFlyt/QuadX-Hover-v0 --env PyFlyt/Fixedwing-Waypoints-v0] [--steps 3000] [--repeats 9]
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
import time, warnings, gymnasium
import pyflyt_engine
warnings.simplefilter("ignore")
env = gymnasium.make({env_id!r}, disable_env_checker=True).unwrapped
env.action_space.seed(0)
actions = [env.action_space.sample() for _ in range({steps})]
clock = time.thread_time
best_step = best_reset = None
for _ in range(3):
    env.reset(seed=0)
    in_steps = in_resets = 0.0
    resets = 0
    for action in actions:
        start = clock()
        _, _, terminated, truncated, _ = env.step(action)
        in_steps += clock() - start
        if terminated or truncated:
            start = clock()
            env.reset()
            in_resets += clock() - start
            resets += 1
    step = in_steps / {steps}
    reset = in_resets / max(resets, 1)
    best_step = step if best_step is None else min(best_step, step)
    best_reset = reset if best_reset is None else min(best_reset, reset)
print(pyflyt_engine.__file__)
print(best_step, best_reset)
"""


def _run(root: Path, env_id: str, steps: int) -> tuple[float, float]:
    env = {**os.environ, "PYTHONPATH": str(root)}
    out = subprocess.run(
        [sys.executable, "-c", LOOP.format(env_id=env_id, steps=steps)],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    where, value = out.stdout.strip().splitlines()[-2:]
    if not Path(where).resolve().is_relative_to(root.resolve()):
        raise SystemExit(f"the loop in {root} imported {where}: not that checkout's engine")
    step, reset = value.split()
    return float(step), float(reset)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, required=True)
    parser.add_argument(
        "--env", action="append", help="env id (repeatable); default QuadX-Hover and Fixedwing-Waypoints"
    )
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=9)
    args = parser.parse_args()
    if not (args.baseline / "pyflyt_engine").is_dir():
        parser.error(f"--baseline {args.baseline}: no pyflyt_engine package there")
    env_ids = args.env or ["PyFlyt/QuadX-Hover-v0", "PyFlyt/Fixedwing-Waypoints-v0"]
    print(f"{args.steps} random-action steps, best of 3 passes per process, {args.repeats} processes per checkout")
    print("CPU time of the thread per env step and per reset (the resets at episode ends), this / baseline")
    header = f"{'env':<31}{'step: this':>11}{'baseline':>10}{'ratio':>7}{'range':>13}"
    print(header + f"   {'reset: this':>11}{'baseline':>10}{'ratio':>7}")
    for env_id in env_ids:
        this, base = [], []
        for _ in range(args.repeats):
            this.append(_run(HERE, env_id, args.steps))
            base.append(_run(args.baseline, env_id, args.steps))
        cells = []
        for k in (0, 1):
            ratios = [a[k] / b[k] for a, b in zip(this, base)]
            a, b = statistics.median(x[k] for x in this), statistics.median(x[k] for x in base)
            cells.append((a * 1e6, b * 1e6, statistics.median(ratios), min(ratios), max(ratios)))
        (sa, sb, sr, lo, hi), (ra, rb, rr, _, _) = cells
        print(f"{env_id:<31}{sa:>9.1f}us{sb:>8.1f}us{sr:>7.3f}  {lo:.3f}-{hi:.3f}   {ra:>9.0f}us{rb:>8.0f}us{rr:>7.3f}")


if __name__ == "__main__":
    main()

"""The episode core's own cost per agent step -- judging (terminations, reward, info) and
observing -- of this checkout against another checkout's, env by env.

``World.step`` is the bulk of an env step (hundreds of microseconds) and moves with the
machine's load by more than the core costs, so this times the core's two per-step calls
alone: after a seeded reset and one step, ``env._judge([0], states)`` and
``env._observe(0, states)`` are called ``--calls`` times each on that step's states (the
task's signals are recomputed each time, the physics is not stepped), by the CPU time of
the process's thread (``time.thread_time``), best of 5 passes.  Each round runs a fresh
subprocess per checkout, alternately this one and ``--baseline`` (a ``git archive`` of an
earlier commit), ``--repeats`` rounds; printed: the medians per checkout [us per call] and
the median of the per-round ratios this / baseline.

    python experiments/speed_episode_core.py --baseline /path/to/other/checkout \\
        [--env quadx_hover --env quadx_ball_in_cup] [--calls 20000] [--repeats 7]
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
import time, warnings
import numpy as np
import pyflyt_engine
from pyflyt_engine.envs.env import UAVEnv
warnings.simplefilter("ignore")
env = UAVEnv({config!r}, info_reward_terms=True)
env.reset(seed=0)
env.action_space.seed(0)
env.step(env.action_space.sample())
states = [env.vehicle.state]
clock = time.thread_time
best_judge = best_observe = None
for _ in range(5):
    start = clock()
    for _ in range({calls}):
        env._judge([0], states)
    judge = (clock() - start) / {calls}
    start = clock()
    for _ in range({calls}):
        env._observe(0, states)
    observe = (clock() - start) / {calls}
    best_judge = judge if best_judge is None else min(best_judge, judge)
    best_observe = observe if best_observe is None else min(best_observe, observe)
print(pyflyt_engine.__file__)
print(best_judge, best_observe)
"""


def _run(root: Path, config: str, calls: int) -> tuple[float, float]:
    env = {**os.environ, "PYTHONPATH": str(root)}
    out = subprocess.run(
        [sys.executable, "-c", LOOP.format(config=config, calls=calls)],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    where, value = out.stdout.strip().splitlines()[-2:]
    if not Path(where).resolve().is_relative_to(root.resolve()):
        raise SystemExit(f"the loop in {root} imported {where}: not that checkout's engine")
    judge, observe = value.split()
    return float(judge), float(observe)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, required=True)
    parser.add_argument(
        "--env", action="append", help="env config (repeatable); default quadx_hover, quadx_ball_in_cup"
    )
    parser.add_argument("--calls", type=int, default=20000)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    if not (args.baseline / "pyflyt_engine").is_dir():
        parser.error(f"--baseline {args.baseline}: no pyflyt_engine package there")
    configs = args.env or ["quadx_hover", "quadx_ball_in_cup"]
    print(f"{args.calls} calls each, best of 5 passes per process, {args.repeats} processes per checkout")
    print("CPU time of the thread per call, this / baseline")
    print(
        f"{'env':<22}{'judge: this':>12}{'baseline':>10}{'ratio':>7}   {'observe: this':>13}{'baseline':>10}{'ratio':>7}"
    )
    for config in configs:
        this, base = [], []
        for _ in range(args.repeats):
            this.append(_run(HERE, config, args.calls))
            base.append(_run(args.baseline, config, args.calls))
        cells = []
        for k in (0, 1):
            a, b = statistics.median(x[k] for x in this), statistics.median(x[k] for x in base)
            cells.append((a * 1e6, b * 1e6, statistics.median(x[k] / y[k] for x, y in zip(this, base))))
        (ja, jb, jr), (oa, ob, orr) = cells
        print(f"{config:<22}{ja:>10.2f}us{jb:>8.2f}us{jr:>7.3f}   {oa:>11.2f}us{ob:>8.2f}us{orr:>7.3f}")


if __name__ == "__main__":
    main()

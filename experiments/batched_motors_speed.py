"""What the optional motor models and the battery cost the batched backend, and that the
static motors' path costs what it cost before they were compiled: CPU time per agent-step,
the figures docs/batched.md quotes.

Each case runs in a fresh process: N envs of QuadX-Hover (random body rates around the
thrust that holds the airframe at its pack's present voltage) or Fixedwing-Waypoints
(random channels) take 5 agent steps to warm up (the compilation among them), then
``--steps`` agent steps are timed by the process's CPU clock, five times over, and the
fastest block is kept (the motor noise's draws and the resets of ended episodes included).  With ``--before <checkout>`` the static cases run
in that checkout too, round by round alternating with this one, so both see the same load;
the median of the rounds is printed.

    python experiments/batched_motors_speed.py [--before /path/to/old/checkout] [--rounds 3]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "conf" / "uav" / "examples" / "quadx_cf2x_battery.yaml"

CASE = """
import time
import numpy as np
from pyflyt_engine.batched import BatchedUAVEnv
from pyflyt_engine.envs.config import load_env_config
env_name, uav, n, steps = {env!r}, {uav!r}, {n}, {steps}
cfg = load_env_config(env_name)
if uav:
    cfg = cfg.with_overrides(uav=uav)
env = BatchedUAVEnv(cfg, num_envs=n)
env.reset(seed=0)
rng = np.random.default_rng(0)
pack = getattr(env, "battery", np.zeros((n, 0)))
def action(k):
    if env.model.channel_driven:
        return rng.uniform(env._low, env._high, (n, env._low.size))
    sag = pack[:, 3] ** 2 if pack.shape[1] else 1.0
    return np.c_[rng.uniform(-0.5, 0.5, (n, 3)), np.broadcast_to(env.model.hover_thrust_fraction / sag, (n,))]
for k in range(5):
    env.step(action(k))
times = []
for block in range(5):  # the fastest of 5 blocks: the one least disturbed by other jobs' load
    start = time.process_time()
    for k in range(steps):
        env.step(action(k))
    times.append((time.process_time() - start) / (steps * n) * 1e6)
print(min(times))
"""

#: (label, env config, airframe file or "" for the config's own, whether the old checkout flies it)
CASES = (
    ("QuadX-Hover, quadx_cf2x (static motors)", "quadx_hover", "", True),
    ("Fixedwing-Waypoints (static motor)", "fixedwing_waypoints", "", True),
    ("QuadX-Hover, quadx_cf2x_battery (every model, battery)", "quadx_hover", str(EXAMPLE), False),
    ("QuadX-Hover, tricopter (its tail on the mixer's servo)", "quadx_hover", "tricopter", False),
)


def _time(root: Path, env: str, uav: str, n: int, steps: int) -> float:
    code = CASE.format(env=env, uav=uav, n=n, steps=steps)
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        cwd=str(root),
        env=dict(os.environ, PYTHONPATH=str(root)),
    )
    if out.returncode:
        raise SystemExit(f"the case {env} {uav or ''} N = {n} failed in {root}:\n{out.stderr}")
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[1, 1024], help="envs per batch")
    parser.add_argument("--steps", type=int, default=200, help="timed agent steps (x 10 at N = 1)")
    parser.add_argument("--rounds", type=int, default=3, help="fresh processes per case and checkout")
    parser.add_argument("--before", type=Path, default=None, help="an older checkout to time the static cases in")
    args = parser.parse_args()
    print(f"rounds {args.rounds}, {args.steps} agent steps; load average {os.getloadavg()[0]:.1f} at the start")
    print("| case | N | this checkout: CPU us per agent-step | before |")
    print("|---|---:|---:|---:|")
    for label, env, uav, old in CASES:
        for n in args.n:
            steps = args.steps * (10 if n == 1 else 1)
            now, before = [], []
            for _ in range(args.rounds):
                if args.before is not None and old:
                    before.append(_time(args.before, env, uav, n, steps))
                now.append(_time(ROOT, env, uav, n, steps))
            cell = f"{statistics.median(before):.2f}" if before else "-"
            print(f"| {label} | {n} | {statistics.median(now):.2f} | {cell} |", flush=True)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()

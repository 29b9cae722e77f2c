"""What the noisy sensors cost the batched backend, and that the path without them costs
what it did: CPU time per agent-step, the figures docs/batched.md quotes.

Each case runs in a fresh process: N envs of QuadX-Hover (random body rates around hover
thrust) take 5 agent steps to warm up, then ``--steps`` agent steps are timed by the
process's CPU clock (motor noise, resets of ended episodes and the sensors' draws included).
Cases: no sensors; the sensed state (``sensors.observe`` with the IMU and position fix of
``conf/env/quadx_hover_sensors.yaml``, no estimator); the estimated state
(``env=quadx_hover_sensors``).  With ``--before PATH`` the no-sensor case is also run on
the checkout at PATH (e.g. the branch point), alternating with this one, so both are timed
under the same load.

    python experiments/batched_sensors_speed.py [--n 256] [--steps 200] [--before /path/to/checkout]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path
from statistics import median

CASE = """
import time
import numpy as np
from pyflyt_engine.batched import BatchedUAVEnv
from pyflyt_engine.envs.config import load_env_config
case, n, steps = {case!r}, {n}, {steps}
if case == "none":
    cfg = load_env_config("quadx_hover")
elif case == "sensed":
    full = load_env_config("quadx_hover_sensors").sensors
    cfg = load_env_config("quadx_hover").with_overrides(
        sensors={{"observe": True, "imu": full.imu.model_dump(), "position": full.position.model_dump()}})
else:
    cfg = load_env_config("quadx_hover_sensors")
env = BatchedUAVEnv(cfg, num_envs=n)
env.reset(seed=0)
rng = np.random.default_rng(0)
hover = env.model.hover_thrust_fraction
actions = [np.c_[rng.uniform(-0.5, 0.5, (n, 3)), np.full(n, hover)] for _ in range(20)]
for a in actions[:5]:
    env.step(a)
start = time.process_time()
for k in range(steps):
    env.step(actions[k % 20])
print((time.process_time() - start) / (steps * n) * 1e6)
"""

HERE = Path(__file__).resolve().parents[1]


def _time(case: str, n: int, steps: int, tree: Path) -> float:
    code = CASE.format(case=case, n=n, steps=steps)
    env = {**os.environ, "PYTHONPATH": str(tree)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env, cwd=tree)
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=256, help="envs per batch")
    parser.add_argument("--steps", type=int, default=200, help="timed agent steps")
    parser.add_argument("--before", type=Path, default=None, help="another checkout to time the no-sensor case on")
    parser.add_argument("--repeats", type=int, default=3, help="alternating runs of the no-sensor case")
    args = parser.parse_args()
    print(f"N = {args.n}, {args.steps} agent steps; load average {os.getloadavg()[0]:.1f} at the start")
    if args.before is not None:
        before, after = [], []
        for _ in range(args.repeats):
            before.append(_time("none", args.n, args.steps, args.before))
            after.append(_time("none", args.n, args.steps, HERE))
        for tree, runs in ((args.before, before), (HERE, after)):
            cells = ", ".join(f"{v:.2f}" for v in runs)
            print(f"no sensors, {tree}: CPU us per agent-step {cells} (min {min(runs):.2f}, median {median(runs):.2f})")
    print("| observation | CPU us per agent-step |")
    print("|---|---:|")
    for case, name in (("none", "true state"), ("sensed", "sensed"), ("estimated", "estimated")):
        print(f"| {name} | {_time(case, args.n, args.steps, HERE):.2f} |")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()

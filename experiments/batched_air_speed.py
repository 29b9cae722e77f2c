"""What the air costs the batched backend: CPU time per agent-step in calm air, in a gust and
in Dryden turbulence, the figures docs/batched.md quotes.

Each case runs in a fresh process: N envs of QuadX-Hover (random body rates around hover
thrust) or Fixedwing-Waypoints (random channels) take 5 agent steps to warm up, then
``--steps`` agent steps are timed by the process's CPU clock (the draws of the motor noise
and of the turbulence's white noise included, the resets of ended episodes too).

    python experiments/batched_air_speed.py [--n 1024] [--steps 200]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

CASE = """
import time
import numpy as np
from pyflyt_engine.batched import BatchedUAVEnv
from pyflyt_engine.envs.config import load_env_config
env_name, wind, n, steps = {env!r}, {wind!r}, {n}, {steps}
env = BatchedUAVEnv(load_env_config(env_name).with_overrides(wind=wind), num_envs=n)
env.reset(seed=0)
rng = np.random.default_rng(0)
if env.model.channel_driven:
    actions = [env.action_space.sample() for _ in range(20)]
else:
    hover = env.model.hover_thrust_fraction
    actions = [np.c_[rng.uniform(-0.5, 0.5, (n, 3)), np.full(n, hover)] for _ in range(20)]
for a in actions[:5]:
    env.step(a)
start = time.process_time()
for k in range(steps):
    env.step(actions[k % 20])
print((time.process_time() - start) / (steps * n) * 1e6)
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1024, help="envs per batch")
    parser.add_argument("--steps", type=int, default=200, help="timed agent steps")
    args = parser.parse_args()
    print(f"N = {args.n}, {args.steps} agent steps; load average {os.getloadavg()[0]:.1f} at the start")
    print("| task | calm: CPU us per agent-step | gust | dryden_light |")
    print("|---|---:|---:|---:|")
    for env in ("quadx_hover", "fixedwing_waypoints"):
        cells = []
        for wind in ("calm", "gust", "dryden_light"):
            code = CASE.format(env=env, wind=wind, n=args.n, steps=args.steps)
            out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
            cells.append(f"{float(out.stdout.strip().splitlines()[-1]):.2f}")
        print(f"| {env} | " + " | ".join(cells) + " |")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()

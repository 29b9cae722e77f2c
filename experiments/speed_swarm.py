"""CPU per agent-step of the batched multi-agent hover against the PyBullet engine's env.

One world of A Crazyflies on the task's grid (1 m apart, 1 m high) at hover thrust,
downwash on and off: the batched swarm (``pyflyt_engine.batched.swarm.BatchedSwarmEnv``,
one compiled call per agent step for every agent) and the PyBullet engine's
MAQuadX-Hover env with the same agents (one env step moves all of them).  CPU time of this
process (``time.process_time``), after a warm-up step (the compiled laws are cached).
Results are appended to ``experiments/results/speed_swarm.md``.

    python experiments/speed_swarm.py [--agents 4 16 64] [--steps 300] [--pybullet-steps 60] [--no-write]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from pyflyt_engine.batched.swarm import make_batched_swarm

RESULTS = Path(__file__).resolve().parent / "results" / "speed_swarm.md"


def batched_cost(agents: int, downwash: bool, steps: int) -> float:
    """CPU seconds per agent-step of one batched world of ``agents``."""
    env = make_batched_swarm("ma_quadx_hover", worlds=1, seed=0, agents=agents, layout="grid", downwash=downwash)
    env.reset(seed=0)
    action = np.tile(np.r_[0.0, 0.0, 0.0, env.model.hover_thrust_fraction], (env.num_envs, 1))
    env.step(action)
    started = time.process_time()
    for _ in range(steps):
        env.step(action)
    return (time.process_time() - started) / (steps * agents)


def pybullet_cost(agents: int, downwash: bool, steps: int) -> float:
    """CPU seconds per agent-step of the PyBullet engine's env of the same agents."""
    from pyflyt_engine.envs.multi_agent.hover import MAQuadXHoverEnv

    env = MAQuadXHoverEnv(agents=agents, layout="grid", downwash=downwash)
    env.reset(seed=0)
    hover = None
    try:
        from pyflyt_engine.batched.model import batched_model

        hover = batched_model(env.airframe, 1 / 240, 1 / 120).hover_thrust_fraction
        moved = 0
        started = time.process_time()
        for _ in range(steps):
            if not env.agents:
                env.reset()
            live = list(env.agents)
            env.step({name: np.r_[0.0, 0.0, 0.0, hover] for name in live})
            moved += len(live)
        return (time.process_time() - started) / moved
    finally:
        env.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--agents", type=int, nargs="+", default=[4, 16, 64])
    parser.add_argument("--steps", type=int, default=300, help="batched agent steps per case")
    parser.add_argument("--pybullet-steps", type=int, default=60, help="PyBullet env steps per case")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    load_before = os.getloadavg()[0]
    lines = [
        (
            f"\n## {time.strftime('%Y-%m-%d %H:%M')} -- {platform.machine()}, {platform.python_version()}, "
            f"one world, hover thrust, {args.steps} batched / {args.pybullet_steps} PyBullet steps per case\n"
        ),
        f"Command: `python experiments/speed_swarm.py {' '.join(sys.argv[1:])}`\n",
        "| agents | downwash | batched: CPU us per agent-step | PyBullet env: CPU us per agent-step | ratio |",
        "|---:|---|---:|---:|---:|",
    ]
    for agents in args.agents:
        for downwash in (False, True):
            b = batched_cost(agents, downwash, args.steps)
            pb = pybullet_cost(agents, downwash, args.pybullet_steps)
            lines.append(
                f"| {agents} | {'on' if downwash else 'off'} | {1e6 * b:.1f} | {1e6 * pb:.0f} | {pb / b:.0f}x |"
            )
            print(lines[-1], flush=True)
    lines.append(f"\nLoad average (1 min): {load_before:.1f} at the start, {os.getloadavg()[0]:.1f} at the end.")
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_write:
        if not RESULTS.exists():
            RESULTS.write_text(
                "# The batched multi-agent hover against the PyBullet engine (experiments/speed_swarm.py)\n"
            )
        with RESULTS.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()

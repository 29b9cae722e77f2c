"""Latency on the batched backend: the figures docs/batched.md quotes.

``crosscheck``: for every flight of ``tests/batched/test_latency.py`` (QuadX-Hover in
rates_thrust, QuadX-Waypoints by velocity, Fixedwing-Waypoints on its channels and
through its autopilot) and every (action, observation) delay it holds, both backends fly
2 s of random actions from one start with the motor noise off (``fly_delayed_pair``);
prints the largest difference of the positions [m], observations and rewards per case,
then the largest over all.

``speed``: CPU time per agent-step of QuadX-Hover on the batched backend without delays,
with an action delay (0.02 s), with both (0.02 s, 0.0125 s) and with both drawn per
episode (uniform 0-20 ms, ``conf/randomize/sim2real.yaml``'s ranges), at N envs; one
process, random actions around hover, CPU time of the process (``time.process_time``).

    python experiments/batched_latency.py crosscheck [--markdown]
    python experiments/batched_latency.py speed [--n 64 256 1024] [--steps 300]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from pyflyt_engine.batched import BatchedUAVEnv
from pyflyt_engine.envs.config import load_env_config
from pyflyt_engine.paths import uav_dir
from tests.batched.test_latency import DELAYS, FLIGHTS, fly_delayed_pair

FIELDS = ("position", "observation", "reward")
DRAWN = {
    "action_delay": {"distribution": "uniform", "low": 0.0, "high": 0.02},
    "observation_delay": {"distribution": "uniform", "low": 0.0, "high": 0.02},
}
SPEED_CASES = {
    "none": {},
    "action 0.02 s": {"latency": {"action_delay": 0.02}},
    "action 0.02 s, observation 0.0125 s": {"latency": {"action_delay": 0.02, "observation_delay": 0.0125}},
    "both drawn, 0-20 ms": {"randomize": DRAWN},
}


def _table(header: list[str], rows: list[list[str]], markdown: bool) -> None:
    sep = " | " if markdown else "  "
    for k, line in enumerate([header, *rows]):
        print(("| " if markdown else "") + sep.join(line) + (" |" if markdown else ""))
        if markdown and k == 0:
            print("|" + "---|" * len(header))


def crosscheck(markdown: bool) -> None:
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        paths = {}
        for _, uav, _ in FLIGHTS.values():
            data = yaml.safe_load((uav_dir() / f"{uav}.yaml").read_text())
            data["motors"]["noise_ratio"] = 0.0  # the two backends draw their noise apart
            paths[uav] = Path(folder) / f"{uav}.yaml"
            paths[uav].write_text(yaml.safe_dump(data))
        for flight, (_, uav, _) in FLIGHTS.items():
            for delays in DELAYS:
                worst, flown = fly_delayed_pair(str(paths[uav]), flight, delays)
                rows.append((flight, delays, flown, worst))
    lines = [
        [flight, f"{a}, {o}", str(flown), *(f"{worst[f]:.1e}" for f in FIELDS)] for flight, (a, o), flown, worst in rows
    ]
    lines.append(["all", "-", "-", *(f"{max(r[3][f] for r in rows):.1e}" for f in FIELDS)])
    _table(["flight", "delays [physics steps]", "steps", *FIELDS], lines, markdown)


def speed(sizes: list[int], steps: int, markdown: bool) -> None:
    base = load_env_config("quadx_hover")
    lines = []
    for n in sizes:
        line = [str(n)]
        for overrides in SPEED_CASES.values():
            env = BatchedUAVEnv(base.with_overrides(**overrides), num_envs=n, seed=0)
            env.reset(seed=0)
            rng = np.random.default_rng(0)
            hover = env.model.hover_thrust_fraction
            actions = np.concatenate(
                [rng.uniform(-0.3, 0.3, (steps, n, 3)), hover * rng.uniform(0.97, 1.05, (steps, n, 1))], 2
            )
            for a in actions[:20]:  # compiled and warm
                env.step(a)
            start = time.process_time()
            for a in actions:
                env.step(a)
            line.append(f"{(time.process_time() - start) / (steps * n) * 1e6:.2f}")
        lines.append(line)
    _table(["N", *(f"{name}: CPU us per agent-step" for name in SPEED_CASES)], lines, markdown)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=("crosscheck", "speed"))
    parser.add_argument("--n", type=int, nargs="+", default=[64, 256, 1024], help="env counts (speed)")
    parser.add_argument("--steps", type=int, default=300, help="agent steps timed per case (speed)")
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    args = parser.parse_args()
    if args.what == "crosscheck":
        crosscheck(args.markdown)
    else:
        speed(args.n, args.steps, args.markdown)


if __name__ == "__main__":
    main()

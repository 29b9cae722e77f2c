"""What an SAC gradient step costs here: SB3 (the library the toolkit trains with) against SBX.

SAC on the waypoint tasks is bound by its gradient updates (the batched backend makes the env
steps nearly free), so the update's cost decides how long ``algo=sac`` takes.  This script
times, in CPU seconds per update on one thread, SB3's SAC (with the toolkit's pinned
kernels when ``pyflyt_engine`` is importable, else the libraries' own) and, when ``sbx``
(the JAX Stable Baselines, ``pip install sbx-rl``) is importable, SBX's SAC, for the
waypoint tunings' network sizes and batch sizes, on a 30-dimensional dummy observation and
a 4-dimensional action (QuadX-Waypoints' sizes).

``--determinism`` also trains SBX's SAC for 2 500 steps of Pendulum in fresh processes,
with XLA free to choose the CPU's instruction set and with it capped
(``XLA_FLAGS=--xla_cpu_max_isa=AVX2`` / ``AVX``), and prints a hash of the final weights:
equal hashes mean the same numbers.

    python experiments/sac_update_cost.py [--nets 128,128 256,256] [--batches 256 512 1024] [--determinism]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import time

try:  # the toolkit's pinned kernels (docs/reproducibility.md), when it is installed here
    import pyflyt_engine  # noqa: F401

    PINNED = True
except ImportError:
    PINNED = False

import gymnasium as gym
import numpy as np


class Dummy(gym.Env):
    observation_space = gym.spaces.Box(-np.inf, np.inf, (30,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)

    def reset(self, seed=None, options=None):
        return np.zeros(30, np.float32), {}

    def step(self, action):
        return np.random.standard_normal(30).astype(np.float32), 0.0, False, False, {}


def cost(cls, net: list[int], batch: int, updates: int = 100) -> float:
    """CPU seconds per gradient step of ``cls`` (an SAC class with SB3's API)."""
    model = cls(
        "MlpPolicy",
        Dummy(),
        batch_size=batch,
        learning_starts=2000,
        buffer_size=20_000,
        seed=0,
        policy_kwargs={"net_arch": net},
    )
    model.learn(2000)  # fills the buffer; no update yet
    model.train(gradient_steps=5, batch_size=batch)  # compiles (SBX) / warms up
    t0 = time.process_time()
    model.train(gradient_steps=updates, batch_size=batch)
    return (time.process_time() - t0) / updates


def weights_hash() -> str:
    import jax
    from sbx import SAC

    model = SAC(
        "MlpPolicy",
        gym.make("Pendulum-v1"),
        seed=0,
        learning_starts=500,
        batch_size=256,
        policy_kwargs={"net_arch": [128, 128]},
    )
    model.learn(2500)
    leaves = jax.tree_util.tree_leaves(model.policy.actor_state.params) + jax.tree_util.tree_leaves(
        model.policy.qf_state.params
    )
    return hashlib.sha256(b"".join(np.asarray(x).tobytes() for x in leaves)).hexdigest()[:16]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--nets", nargs="+", default=["128,128", "256,256"])
    parser.add_argument("--batches", type=int, nargs="+", default=[256, 512, 1024])
    parser.add_argument("--determinism", action="store_true")
    parser.add_argument("--hash-only", action="store_true", help=argparse.SUPPRESS)  # a child of --determinism
    args = parser.parse_args()
    if args.hash_only:
        print(weights_hash())
        return
    import torch

    torch.set_num_threads(1)
    from stable_baselines3 import SAC as SB3SAC

    try:
        from sbx import SAC as SBXSAC
    except ImportError:
        SBXSAC = None
    print(f"SB3 kernels: {'pinned (pyflyt_engine)' if PINNED else 'the libraries own'}; load {os.getloadavg()[0]:.1f}")
    print("| network | batch | SB3 [ms/update] | SBX [ms/update] |")
    print("|---|---|---|---|")
    for net_text in args.nets:
        net = [int(x) for x in net_text.split(",")]
        for batch in args.batches:
            sb3 = 1e3 * cost(SB3SAC, net, batch)
            sbx = f"{1e3 * cost(SBXSAC, net, batch):.2f}" if SBXSAC is not None else "-"
            print(f"| {net} | {batch} | {sb3:.2f} | {sbx} |", flush=True)
    if args.determinism and SBXSAC is not None:
        for flags in ("", "", "--xla_cpu_max_isa=AVX2", "--xla_cpu_max_isa=AVX"):
            env = {**os.environ, "XLA_FLAGS": flags}
            out = subprocess.run(
                [sys.executable, __file__, "--hash-only"], env=env, capture_output=True, text=True, check=True
            )
            print(f"SBX SAC, XLA_FLAGS={flags or '(none)'}: weights {out.stdout.strip().splitlines()[-1]}", flush=True)


if __name__ == "__main__":
    main()

"""What an SAC gradient step costs here: SB3 (the library the toolkit trains with) against SBX.

SAC on the waypoint tasks is bound by its gradient updates (the batched backend makes the env
steps nearly free), so the update's cost decides how long ``algo=sac`` takes.  This script
times SAC's gradient steps in CPU seconds of the whole process (every thread) and in
wall-clock seconds per update, each variant in a fresh process (XLA reads its flags once,
when JAX loads):

* ``sb3``: SB3's ``SAC`` (the toolkit's pinned kernels when ``pyflyt_engine`` is importable,
  else the libraries' own), torch on one thread;
* ``pyflyt``: the toolkit's ``algo=sac`` class (``pyflyt_cli.training.sac``: SB3's numbers,
  fewer operations), torch on one thread;
* ``sbx``: SBX's SAC (the JAX Stable Baselines, ``pip install sbx-rl``) with XLA left to
  itself (its thread pool over every CPU the process may use, the CPU's widest instruction set);
* ``sbx-pinned``: what ``algo=sac_jax`` runs with (pyflyt_engine/numerics.py): code for AVX2
  (``--xla_cpu_max_isa=AVX2``) and no multi-threaded Eigen kernels
  (``--xla_cpu_multi_thread_eigen=false``); XLA's thread pool still has a thread per CPU;
* ``sbx-pinned-1cpu``: the same in a process allowed one CPU (its affinity, set before JAX
  loads), so that XLA's pool has one thread: SBX on one thread;
* ``sbx-avx2`` / ``sbx-avx``: the instruction set capped at AVX2 / AVX (for ``--determinism``).

on a 30-dimensional dummy observation and a 4-dimensional action (QuadX-Waypoints' sizes),
for ``--steps-per-call`` gradient steps per ``train()`` call (SBX compiles the loop over them
into one XLA call; the shipped tuning takes 4 per vector step).  Which threads did the work
is read from each thread's CPU time (``/proc/self/task/*/stat``), which a loaded machine does
not blur as it does the ratio of CPU time to wall-clock.

``--determinism`` also trains SBX's SAC for 2 500 steps of Pendulum in fresh processes under
each XLA setting and prints a hash of the final weights: equal hashes mean the same numbers.

    python experiments/sac_update_cost.py [--variants sb3 pyflyt sbx sbx-pinned sbx-pinned-1cpu]
        [--nets 128,128] [--batches 256] [--steps-per-call 1 4] [--determinism [--hash-variants ...]]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import time

#: XLA's flags per SBX variant (the environment variable is read once, when JAX loads)
PINNED = "--xla_cpu_max_isa=AVX2 --xla_cpu_multi_thread_eigen=false"  # what pyflyt_engine.numerics sets
XLA_FLAGS = {
    "sbx": "",
    "sbx-pinned": PINNED,
    "sbx-pinned-1cpu": PINNED,
    "sbx-avx2": "--xla_cpu_max_isa=AVX2",
    "sbx-avx": "--xla_cpu_max_isa=AVX --xla_cpu_multi_thread_eigen=false",
}
#: variants run on one CPU (the process's affinity, set before JAX loads: XLA sizes its thread pool by it)
ONE_CPU = ("sbx-pinned-1cpu",)
VARIANTS = ("sb3", "pyflyt", *XLA_FLAGS)


def _pinned() -> bool:
    try:  # the toolkit's pinned kernels (docs/reproducibility.md), when it is installed here
        import pyflyt_engine  # noqa: F401
    except ImportError:
        return False
    return os.environ.get("PYFLYT_NUMERICS", "pinned") != "native"


def _dummy_env():
    import gymnasium as gym
    import numpy as np

    class Dummy(gym.Env):
        observation_space = gym.spaces.Box(-np.inf, np.inf, (30,), np.float32)
        action_space = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)

        def reset(self, seed=None, options=None):
            return np.zeros(30, np.float32), {}

        def step(self, action):
            return np.random.standard_normal(30).astype(np.float32), 0.0, False, False, {}

    return Dummy()


def _sac_class(variant: str):
    if variant == "sb3":
        from stable_baselines3 import SAC
    elif variant == "pyflyt":
        from pyflyt_cli.training.sac import SAC  # type: ignore[no-redef]
    else:
        from sbx import SAC  # type: ignore[no-redef]
    return SAC


def _thread_ticks() -> dict[tuple[str, str], int]:
    """CPU clock ticks (user + system) of each thread of this process so far, by (id, name)."""
    ticks = {}
    for tid in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{tid}/stat") as f:
                name, rest = f.read().split("(", 1)[1].rsplit(")", 1)
        except OSError:  # the thread ended
            continue
        fields = rest.split()
        ticks[(tid, name)] = int(fields[11]) + int(fields[12])  # utime, stime (fields 14 and 15 of stat)
    return ticks


def cost(variant: str, net: list[int], batch: int, per_call: int, updates: int = 200) -> dict[str, float]:
    """CPU and wall-clock seconds per gradient step of ``variant``, ``per_call`` steps a ``train()`` call."""
    import torch

    torch.set_num_threads(1)
    cls = _sac_class(variant)
    model = cls(
        "MlpPolicy",
        _dummy_env(),
        batch_size=batch,
        learning_starts=2000,
        buffer_size=20_000,
        seed=0,
        n_steps=3,  # the shipped tuning's 3-step returns (SB3's NStepReplayBuffer)
        policy_kwargs={"net_arch": net},
    )
    model.learn(2000)  # fills the buffer; no update yet
    for _ in range(3):  # compiles (SBX: once per number of steps a call) / warms up
        model.train(gradient_steps=per_call, batch_size=batch)
    calls = max(1, updates // per_call)
    t0 = _thread_ticks()
    c0, w0 = time.process_time(), time.perf_counter()
    for _ in range(calls):
        model.train(gradient_steps=per_call, batch_size=batch)
    if variant.startswith("sbx"):  # JAX dispatches asynchronously: wait for the last update
        import jax

        jax.block_until_ready(model.policy.actor_state.params)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    spent = {tid: ticks - t0.get(tid, 0) for tid, ticks in _thread_ticks().items()}
    total = sum(spent.values()) or 1
    busy = sorted((t for t in spent.items() if t[1] > 0.05 * total), key=lambda t: -t[1])  # > 5 % of the CPU time
    n = calls * per_call
    return {"cpu": cpu / n, "wall": wall / n, "threads": len(spent),
            "busy": ", ".join(f"{name} {100 * ticks / total:.0f} %" for (_, name), ticks in busy)}  # fmt: skip


def weights_hash() -> str:
    import gymnasium as gym
    import jax
    import numpy as np
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


def _child(args: list[str], variant: str) -> str:
    env = dict(os.environ)
    env.pop("XLA_FLAGS", None)  # the SBX children import SBX alone: exactly these flags
    env.pop("SAC_COST_ONE_CPU", None)
    if variant in XLA_FLAGS:
        env["XLA_FLAGS"] = XLA_FLAGS[variant]
    if variant in ONE_CPU:
        env["SAC_COST_ONE_CPU"] = "1"
    out = subprocess.run([sys.executable, __file__, *args], env=env, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{variant}: {out.stderr.strip().splitlines()[-1] if out.stderr.strip() else 'failed'}")
    return out.stdout.strip().splitlines()[-1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument(
        "--variants", nargs="+", default=["sb3", "pyflyt", "sbx", "sbx-pinned", "sbx-pinned-1cpu"], choices=VARIANTS
    )
    parser.add_argument("--nets", nargs="+", default=["128,128"])
    parser.add_argument("--batches", type=int, nargs="+", default=[256])
    parser.add_argument("--steps-per-call", type=int, nargs="+", default=[1, 4])
    parser.add_argument("--updates", type=int, default=200, help="gradient steps timed per case")
    parser.add_argument("--determinism", action="store_true")
    parser.add_argument(
        "--hash-variants", nargs="+", choices=list(XLA_FLAGS),
        default=["sbx", "sbx-pinned", "sbx-pinned", "sbx-pinned-1cpu", "sbx-avx2", "sbx-avx"],
    )  # fmt: skip
    parser.add_argument("--child", nargs=4, metavar=("VARIANT", "NET", "BATCH", "PER_CALL"), help=argparse.SUPPRESS)
    parser.add_argument("--hash-only", action="store_true", help=argparse.SUPPRESS)  # a child of --determinism
    args = parser.parse_args()
    if args.hash_only:
        if os.environ.get("SAC_COST_ONE_CPU"):
            os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        print(weights_hash())
        return
    if args.child:
        variant, net_text, batch, per_call = args.child
        if variant in ("sb3", "pyflyt"):  # the toolkit's kernels, chosen when it is imported (before torch)
            _pinned()
        if variant in ONE_CPU:
            os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        net = [int(x) for x in net_text.split(",")]
        print(json.dumps(cost(variant, net, int(batch), int(per_call), args.updates)))
        return

    try:
        import sbx  # noqa: F401

        have_sbx = True
    except ImportError:
        have_sbx = False
    print(
        f"SB3 kernels: {'pinned (pyflyt_engine)' if _pinned() else 'the libraries own'}; "
        f"load {os.getloadavg()[0]:.1f} at the start; {os.cpu_count()} CPUs"
    )
    print(
        "| variant | network | batch | steps per call | CPU [ms/update] | wall [ms/update] | CPU / wall "
        "| threads | the threads with > 5 % of its CPU time |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for net_text in args.nets:
        for batch in args.batches:
            for per_call in args.steps_per_call:
                for variant in args.variants:
                    if variant.startswith("sbx") and not have_sbx:
                        continue
                    r = json.loads(
                        _child(
                            ["--child", variant, net_text, str(batch), str(per_call), "--updates", str(args.updates)],
                            variant,
                        )
                    )
                    print(
                        f"| {variant} | [{net_text.replace(',', ', ')}] | {batch} | {per_call} | {1e3 * r['cpu']:.2f} | "
                        f"{1e3 * r['wall']:.2f} | {r['cpu'] / r['wall']:.2f} | {r['threads']} | {r['busy']} |",
                        flush=True,
                    )
    print(f"load {os.getloadavg()[0]:.1f} at the end")
    if args.determinism and have_sbx:
        for variant in args.hash_variants:
            digest = _child(["--hash-only"], variant)
            cpus = "one CPU" if variant in ONE_CPU else f"{len(os.sched_getaffinity(0))} CPUs"
            print(f"- {variant}, XLA_FLAGS={XLA_FLAGS[variant] or '(none)'}, {cpus}: weights {digest}", flush=True)


if __name__ == "__main__":
    main()

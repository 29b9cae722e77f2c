"""What a PPO update of the QuadX-Waypoints tuning costs here: SB3 on 1 and 2 torch threads, and SBX.

The shipped QuadX-Waypoints PPO (``conf/hparams/quadx_waypoints_ppo.yaml``: 256 envs x 64
steps, 4 epochs of minibatch 4096, [128, 128] tanh networks) spends ~2/3 of its time in the
updates (``experiments/results/learn_waypoints.md``).  This script times one update (the
16 minibatch steps of ``PPO.train()`` on a full rollout buffer of random data with
QuadX-Waypoints' sizes: 29 observations, 4 actions) in CPU seconds of the whole process
(every thread) and wall-clock seconds, each variant in a fresh process:

* ``sb3``: SB3's ``PPO`` (what ``algo=ppo`` trains), torch on one thread (``train.torch_threads``: 1);
* ``sb3-2threads``: the same on two torch threads;
* ``sb3-native``: ``sb3`` with ``PYFLYT_NUMERICS=native`` (every library's own kernels, not the
  pinned ones of ``pyflyt_engine.numerics``);
* ``sb3-mkl-avx2``: ``sb3`` pinned but for MKL, which gets ``MKL_CBWR=AVX2,STRICT`` instead of
  ``COMPATIBLE,STRICT`` (what the pinned mode's extra cost in the update comes from);
* ``sbx``: SBX's ``PPO`` (JAX, the update compiled by XLA; ``pip install 'pyflyt-toolkit[jax]'``)
  with the XLA settings ``algo=sac_jax`` runs with (``pyflyt_engine.numerics``).

``--profile`` adds where SB3's update spends its time (cProfile, the top entries by own time).

    python experiments/ppo_update_cost.py [--variants sb3 sb3-2threads sb3-native sb3-mkl-avx2 sbx] [--updates 8] [--profile] [--write]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results" / "ppo_update_cost.md"
OBS, ACT, N_ENVS, N_STEPS, BATCH, EPOCHS, NET = 29, 4, 256, 64, 4096, 4, [128, 128]


def _env_class():
    import gymnasium as gym
    import numpy as np

    class Dummy(gym.Env):
        observation_space = gym.spaces.Box(-np.inf, np.inf, (OBS,), np.float32)
        action_space = gym.spaces.Box(-1.0, 1.0, (ACT,), np.float32)

        def reset(self, seed=None, options=None):
            return np.zeros(OBS, np.float32), {}

        def step(self, action):
            return (
                np.random.standard_normal(OBS).astype(np.float32),
                float(np.random.standard_normal()),
                False,
                False,
                {},
            )

    return Dummy


def time_sb3(threads: int, updates: int, profile: bool) -> dict:
    import numpy as np
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.buffers import RolloutBuffer
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.vec_env import DummyVecEnv

    from pyflyt_engine.numerics import apply_torch, platform_info

    apply_torch()  # as a run does
    torch.set_num_threads(threads)
    venv = DummyVecEnv([_env_class()] * N_ENVS)
    kwargs = {"net_arch": NET, "log_std_init": -1.0}
    model = PPO(
        "MlpPolicy", venv, n_steps=N_STEPS, batch_size=BATCH, n_epochs=EPOCHS, policy_kwargs=kwargs, seed=0, verbose=0
    )
    model.set_logger(configure(None, [""]))
    buf = RolloutBuffer(
        N_STEPS, venv.observation_space, venv.action_space, "cpu", gamma=0.99, gae_lambda=0.95, n_envs=N_ENVS
    )
    rng = np.random.default_rng(0)
    buf.observations[:] = rng.standard_normal(buf.observations.shape)
    buf.actions[:] = rng.uniform(-1, 1, buf.actions.shape)
    buf.rewards[:] = rng.standard_normal(buf.rewards.shape)
    with torch.no_grad():
        values, log_prob, _ = model.policy.evaluate_actions(
            torch.as_tensor(buf.observations.reshape(-1, OBS)), torch.as_tensor(buf.actions.reshape(-1, ACT))
        )
    buf.values[:] = values.numpy().reshape(N_STEPS, N_ENVS)
    buf.log_probs[:] = log_prob.numpy().reshape(N_STEPS, N_ENVS)
    buf.compute_returns_and_advantage(torch.zeros(N_ENVS), np.zeros(N_ENVS))
    buf.full = True
    fields = ("observations", "actions", "rewards", "values", "log_probs", "advantages", "returns", "episode_starts")
    saved = {k: getattr(buf, k).copy() for k in fields}
    model.rollout_buffer = buf

    def update() -> None:
        for k, v in saved.items():  # train() flattens the buffer: give it the rollout again
            setattr(buf, k, v.copy())
        buf.generator_ready = False
        model.train()

    update()
    update()  # warm
    cpu, wall = time.process_time(), time.perf_counter()
    for _ in range(updates):
        update()
    out = {
        "cpu_ms": 1000 * (time.process_time() - cpu) / updates,
        "wall_ms": 1000 * (time.perf_counter() - wall) / updates,
        "kernels": str(platform_info().get("kernels", {}).get("torch", "")),
    }
    if profile:
        import cProfile
        import io
        import pstats

        profiler = cProfile.Profile()
        profiler.enable()
        for _ in range(updates):
            update()
        profiler.disable()
        text = io.StringIO()
        pstats.Stats(profiler, stream=text).sort_stats("tottime").print_stats(8)
        out["profile"] = text.getvalue()
    return out


def time_sbx(updates: int) -> dict:
    import pyflyt_engine  # noqa: F401  (XLA's flags set before JAX loads, as algo=sac_jax runs)
    from sbx import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    venv = DummyVecEnv([_env_class()] * N_ENVS)
    kwargs = {"net_arch": NET, "log_std_init": -1.0}
    model = PPO(
        "MlpPolicy", venv, n_steps=N_STEPS, batch_size=BATCH, n_epochs=EPOCHS, policy_kwargs=kwargs, seed=0, verbose=0
    )
    from stable_baselines3.common.callbacks import BaseCallback

    model.learn(2 * N_STEPS * N_ENVS)  # compiled
    times: list[tuple[float, float]] = []

    class UpdateTimes(BaseCallback):
        """Each update's CPU and wall-clock seconds: from a rollout's end to the next rollout's
        start (or the end of learn()), which is where the learning loop calls ``train()``."""

        mark: tuple[float, float] | None = None

        def _on_rollout_end(self) -> None:
            self.mark = (time.process_time(), time.perf_counter())

        def _on_rollout_start(self) -> None:
            if self.mark is not None:
                times.append((time.process_time() - self.mark[0], time.perf_counter() - self.mark[1]))
                self.mark = None

        def _on_training_end(self) -> None:
            self._on_rollout_start()

        def _on_step(self) -> bool:
            return True

    model.learn(updates * N_STEPS * N_ENVS, reset_num_timesteps=False, callback=UpdateTimes())
    return {
        "cpu_ms": 1000 * sum(c for c, _ in times) / len(times),
        "wall_ms": 1000 * sum(w for _, w in times) / len(times),
    }


#: variant -> environment of its process (PYFLYT_NUMERICS: read by ``import pyflyt_engine``)
ENVIRONMENTS = {"sb3-native": {"PYFLYT_NUMERICS": "native"}}
#: variant -> variables set after ``pyflyt_engine`` has pinned, before torch loads
AFTER_PIN = {"sb3-mkl-avx2": {"MKL_CBWR": "AVX2,STRICT"}}


def child(variant: str, updates: int, profile: bool) -> dict:
    import pyflyt_engine  # noqa: F401  (pins the kernels, or not, before NumPy and torch load)

    os.environ.update(AFTER_PIN.get(variant, {}))
    if variant in ("sb3", "sb3-native", "sb3-mkl-avx2"):
        return time_sb3(1, updates, profile)
    if variant == "sb3-2threads":
        return time_sb3(2, updates, False)
    if variant == "sbx":
        return time_sbx(updates)
    raise SystemExit(f"unknown variant {variant!r}: choose sb3, sb3-2threads, sb3-native, sb3-mkl-avx2 or sbx")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--variants", nargs="+", default=["sb3", "sb3-2threads", "sb3-native", "sb3-mkl-avx2", "sbx"])
    parser.add_argument("--updates", type=int, default=8, help="updates timed per variant")
    parser.add_argument("--profile", action="store_true", help="also cProfile SB3's update")
    parser.add_argument(
        "--write", action="store_true", help="append the table to experiments/results/ppo_update_cost.md"
    )
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(args.child, args.updates, args.profile)))
        return
    rows = []
    for variant in args.variants:
        command = [sys.executable, __file__, "--child", variant, "--updates", str(args.updates)]
        if args.profile and variant == "sb3":
            command.append("--profile")
        load = os.getloadavg()[0]
        env = {**os.environ, **ENVIRONMENTS.get(variant, {})}
        done = subprocess.run(command, capture_output=True, text=True, check=True, env=env)
        rows.append((variant, json.loads(done.stdout.strip().splitlines()[-1]), load))
        print(variant, rows[-1][1]["cpu_ms"], rows[-1][1].get("kernels", ""), flush=True)
    lines = [
        f"\n## {time.strftime('%Y-%m-%d %H:%M')} — one PPO update of the QuadX-Waypoints tuning "
        f"({N_ENVS} x {N_STEPS} samples, {EPOCHS} epochs of {BATCH}, {NET} tanh; {platform.machine()}, "
        f"{platform.python_version()})\n",
        f"```bash\npython experiments/ppo_update_cost.py {' '.join(sys.argv[1:])}\n```\n",
        "| variant | CPU time per update [ms] | wall-clock per update [ms] | x 153 updates (a 2.5 M-step run) [s CPU] | torch's kernels | load |",
        "|---|---|---|---|---|---|",
    ]
    for variant, r, load in rows:
        lines.append(
            f"| {variant} | {r['cpu_ms']:.0f} | {r['wall_ms']:.0f} | {r['cpu_ms'] * 153 / 1000:.0f} | "
            f"{r.get('kernels') or '-'} | {load:.1f} |"
        )
    for _, r, _ in rows:
        if "profile" in r:
            lines += ["", "SB3 (one thread), cProfile by own time:", "", "```", r["profile"].strip(), "```"]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.write:
        with RESULTS.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()

"""What pinning the numeric kernels costs: env step, SAC update, PPO update, policy inference.

Each measurement runs in a fresh process under ``PYFLYT_NUMERICS=pinned`` and ``=native``
in turn (the kernels are chosen when the libraries load), alternating the two for
``--rounds`` rounds so that the machine's load falls on both alike; it prints the median
CPU time of each figure per mode and the ratio pinned / native::

    python experiments/numerics_cost.py             # 3 rounds (36 min at load 5-8 on 2 cores)
    python experiments/numerics_cost.py --rounds 5

Figures (CPU time of this process, one torch thread as training uses):

* ``env step``: one ``PyFlyt/QuadX-Hover-v0`` step with random actions [us];
* ``SAC update 256``: one SB3 SAC gradient step, [256, 256] networks (SB3's default),
  batch 256 [ms];  ``SAC update 128``: the same with the waypoint tunings' [128, 128];
* ``PPO update``: one SB3 PPO ``train()`` on a 2048-step rollout, [64, 64], batch 64,
  10 epochs (SB3's defaults) [s];
* ``predict``: one deterministic ``PPO.predict`` of one observation [us];
* ``SAC training``: CPU time per env step of SB3 SAC learning in the shape
  of the waypoint tunings (``conf/hparams/quadx_waypoints_sac.yaml``: 4
  ``PyFlyt/QuadX-Waypoints-v0`` envs stepped in the process, one gradient step of batch
  256 per vector step, [128, 128]), after its warm-up [ms]: what a training run's length
  scales with.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

CHILD = r"""
import json, time
import pyflyt_engine
import gymnasium, numpy as np, torch
from pyflyt_engine import numerics
from stable_baselines3 import PPO, SAC
torch.set_num_threads(1)
numerics.apply_torch()
cpu = time.process_time
env = gymnasium.make("PyFlyt/QuadX-Hover-v0")
env.reset(seed=0); env.action_space.seed(0)
t = cpu()
for _ in range(3000):
    *_, term, trunc, _ = env.step(env.action_space.sample())
    if term or trunc:
        env.reset()
out = {"env step [us]": (cpu() - t) / 3000 * 1e6}
for width in (256, 128):
    sac = SAC("MlpPolicy", env, learning_starts=0, batch_size=256, seed=0, verbose=0, device="cpu",
              policy_kwargs={"net_arch": [width, width]})
    sac.learn(1000)
    t = cpu(); sac.train(gradient_steps=200, batch_size=256)
    out[f"SAC update {width} [ms]"] = (cpu() - t) / 200 * 1e3
ppo = PPO("MlpPolicy", env, seed=0, verbose=0, device="cpu")
ppo.learn(2048)
t = cpu(); ppo.train()
out["PPO update [s]"] = cpu() - t
obs, _ = env.reset(seed=0)
t = cpu()
for _ in range(2000):
    ppo.predict(obs, deterministic=True)
out["predict [us]"] = (cpu() - t) / 2000 * 1e6
from stable_baselines3.common.env_util import make_vec_env
from pyflyt_engine.envs.wrappers import FlattenWaypointEnv
venv = make_vec_env("PyFlyt/QuadX-Waypoints-v0", n_envs=4, seed=0, wrapper_class=FlattenWaypointEnv)
sac = SAC("MlpPolicy", venv, learning_starts=1000, batch_size=256, train_freq=1, gradient_steps=1,
          seed=0, verbose=0, device="cpu", policy_kwargs={"net_arch": [128, 128]})
sac.learn(2000)
t = cpu(); sac.learn(6000, reset_num_timesteps=False)
out["SAC training [ms/step]"] = (cpu() - t) / 6000 * 1e3
out["status"] = numerics.platform_info()["status"]
print(json.dumps(out))
"""


def measure(mode: str) -> dict:
    env = {**os.environ, "PYFLYT_NUMERICS": mode}
    done = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    results: dict[str, list[dict]] = {"pinned": [], "native": []}
    started = time.time()
    for r in range(args.rounds):
        for mode in ("pinned", "native") if r % 2 == 0 else ("native", "pinned"):
            results[mode].append(measure(mode))
            print(f"round {r + 1} {mode}: " + ", ".join(f"{k} {v:.3g}" for k, v in results[mode][-1].items()
                                                        if k != "status"), flush=True)  # fmt: skip
    keys = [k for k in results["pinned"][0] if k != "status"]
    load = os.getloadavg()
    print(
        f"\n{args.rounds} rounds, {time.time() - started:.0f} s, load average {load[0]:.1f} / {load[1]:.1f} at the end"
    )
    print(f"pinned: {results['pinned'][0]['status']}\nnative: {results['native'][0]['status']}\n")
    print(f"{'figure':<22}{'pinned':>10}{'native':>10}{'pinned / native':>18}")
    for k in keys:
        p = statistics.median(x[k] for x in results["pinned"])
        n = statistics.median(x[k] for x in results["native"])
        print(f"{k:<22}{p:>10.3g}{n:>10.3g}{p / n:>18.2f}")


if __name__ == "__main__":
    main()

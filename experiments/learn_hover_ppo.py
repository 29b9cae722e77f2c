"""Does PPO with the shipped defaults learn to hover on QuadX-Hover, and how fast?

Trains exactly what ``pyflyt train`` (no overrides) trains — ``conf/train.yaml`` with
``env=quadx_hover algo=ppo`` and its tuning ``conf/hparams/quadx_hover_ppo.yaml`` — with
a larger step budget, and every ``--probe-every`` steps flies the current policy
(deterministic) for ``--episodes`` seeded episodes.  **Hovering** means, in every
episode: no crash for the whole 10 s episode (it reaches the time limit) and a mean
distance to the hover point (0, 0, 1) m below 0.2 m.

Reported: the first probe at which the policy hovers (environment steps, wall-clock
time of the run so far, and that time without the probes' own cost), the training
throughput, and the final policy's numbers.  Results are appended as a table to
``experiments/results/learn_hover_ppo.md``.

    python experiments/learn_hover_ppo.py [--seeds 0 1 2] [--budget 200000] [--probe-every 10000]

Yardstick (task brief): the reference PyFlyt QuadX-Hover with SB3 PPO defaults hovers
after ~160-200k steps, 250-310 s on 2 cores.
"""

from __future__ import annotations

import argparse
import platform
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from pyflyt_cli.training import compose_config, train
from pyflyt_cli.training.envs import EnvFactory

RESULTS = Path(__file__).resolve().parent / "results" / "learn_hover_ppo.md"
MAX_DISTANCE = 0.2  # [m]


def hover_probe(model, env, episodes: int, seed: int) -> dict[str, float]:
    """Fly ``episodes`` episodes; crash-free fraction, mean distance to the hover point, return."""
    vec = model.get_vec_normalize_env()
    base = env.unwrapped
    point = np.asarray(base.task.options.hover_point)
    survived, distances, returns = [], [], []
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i)
        done, total, dist = False, 0.0, []
        while not done:
            x = vec.normalize_obs(obs) if vec is not None and vec.norm_obs else obs
            action, _ = model.predict(x, deterministic=True)
            obs, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            dist.append(float(np.linalg.norm(base.state.lin_pos - point)))
            done = terminated or truncated
        survived.append(truncated and not terminated)
        distances.append(float(np.mean(dist)))
        returns.append(total)
    return {
        "survived": float(np.mean(survived)),
        "worst_distance": float(np.max(distances)),
        "mean_distance": float(np.mean(distances)),
        "mean_return": float(np.mean(returns)),
    }


class HoverProbe(BaseCallback):
    """Every ``every`` steps: run :func:`hover_probe`; remember the first step that hovers."""

    def __init__(self, cfg, every: int, episodes: int) -> None:
        super().__init__()
        self.env = EnvFactory(cfg.env, monitor=False)()
        self.every, self.episodes = every, episodes
        self.next = every
        self.started = time.perf_counter()
        self.probe_time = 0.0
        self.history: list[tuple[int, float, dict[str, float]]] = []
        self.hover_at: tuple[int, float, float] | None = None

    def _on_training_start(self) -> None:
        self.started = time.perf_counter()

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next:
            self.next += self.every
            self.probe()
        return True

    def _on_training_end(self) -> None:
        if not self.history or self.history[-1][0] != self.num_timesteps:
            self.probe()  # the final policy

    def probe(self) -> None:
        t0 = time.perf_counter()
        probe = hover_probe(self.model, self.env, self.episodes, seed=10_000)
        self.probe_time += time.perf_counter() - t0
        wall = time.perf_counter() - self.started
        self.history.append((self.num_timesteps, wall, probe))
        print(
            f"  {self.num_timesteps:>7} steps  {wall:6.1f} s  survived {100 * probe['survived']:3.0f} %  "
            f"distance mean {probe['mean_distance']:.3f} / worst {probe['worst_distance']:.3f} m  "
            f"return {probe['mean_return']:8.2f}",
            flush=True,
        )
        if self.hover_at is None and probe["survived"] == 1.0 and probe["worst_distance"] < MAX_DISTANCE:
            self.hover_at = (self.num_timesteps, wall, wall - self.probe_time)


def run(seed: int, budget: int | None, every: int, episodes: int, output: Path, extra: Sequence[str] = ()) -> dict:
    overrides = [
        *extra,
        f"seed={seed}",
        f"train.output_dir={output}",
        "train.progress_bar=false",
    ]
    if budget is not None:
        overrides.append(f"train.total_timesteps={budget}")
    cfg = compose_config(env="quadx_hover", algo="ppo", overrides=overrides)
    probe = HoverProbe(cfg, every, episodes)
    start = time.perf_counter()
    result = train(cfg, callbacks=[probe])
    total = time.perf_counter() - start
    final = probe.history[-1][2] if probe.history else {}
    return {
        "seed": seed,
        "budget": cfg.train.total_timesteps,
        "steps": result.num_timesteps,
        "hover_at": probe.hover_at,
        "final": final,
        "steps_per_second": result.num_timesteps / max(total - probe.probe_time, 1e-9),
        "wall": total,
        "n_envs": cfg.train.n_envs,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--budget", type=int, default=None, help="steps per run (default: the shipped default budget)")
    parser.add_argument("--probe-every", type=int, default=10_000)
    parser.add_argument("--episodes", type=int, default=10, help="episodes per probe")
    parser.add_argument("--no-write", action="store_true", help="do not append to the results file")
    parser.add_argument("--set", nargs="*", default=[], help="config overrides, e.g. train.eval_freq=0")
    args = parser.parse_args()

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            print(f"seed {seed}:", flush=True)
            rows.append(run(seed, args.budget, args.probe_every, args.episodes, Path(tmp), args.set))

    cfg = compose_config()
    lines = [
        (
            f"\n## {time.strftime('%Y-%m-%d %H:%M')} — {platform.machine()}, {platform.python_version()}, "
            f"budget {rows[0]['budget']} steps, {rows[0]['n_envs']} envs, "
            f"probe every {args.probe_every} steps x {args.episodes} episodes\n"
        ),
        f"Shipped default budget (`pyflyt train`): {cfg.train.total_timesteps} steps.\n",
        "| seed | hovers at [steps] | wall-clock then [s] | without probes [s] | final: survived | final: mean / worst distance [m] | training steps/s | run wall-clock [s] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        h = r["hover_at"]
        f = r["final"]
        lines.append(
            f"| {r['seed']} | {h[0] if h else 'not within budget'} | {f'{h[1]:.0f}' if h else '-'} | "
            f"{f'{h[2]:.0f}' if h else '-'} | {100 * f.get('survived', 0):.0f} % | "
            f"{f.get('mean_distance', float('nan')):.3f} / {f.get('worst_distance', float('nan')):.3f} | "
            f"{r['steps_per_second']:.0f} | {r['wall']:.0f} |"
        )
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_write:
        RESULTS.parent.mkdir(exist_ok=True)
        if not RESULTS.exists():
            RESULTS.write_text(
                "# PPO learns to hover (experiments/learn_hover_ppo.py)\n\n"
                "Hovering = in every probe episode (deterministic policy, 10 s): no crash and mean distance to\n"
                "the hover point below 0.2 m.  Wall-clock includes environment start-up and evaluations.\n"
            )
        with RESULTS.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()

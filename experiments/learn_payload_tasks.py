"""Are the payload and camera tasks learnable?  Short PPO runs over seeds against a random policy.

For each task (``--tasks``, env config names), trains PPO through the same library as
``pyflyt train env=<task> algo=ppo`` with the QuadX-Hover PPO tuning
(``conf/hparams/quadx_hover_ppo.yaml``: normalised observations and rewards, 2 envs x
1024 steps, 20 epochs, [64, 64] ReLU networks) and a step budget (``--budget``, per task
with ``task=steps``), for every seed (``--seeds``).  The final policy is evaluated like
``pyflyt eval`` (deterministic, ``--episodes`` seeded episodes); a uniformly random policy
in the agent's action space is flown on the same episode seeds.  Dense rewards.

Reported per task: mean episode return and length, success rate, for the random policy
and for each seed's policy; written to ``experiments/results/learn_payload_tasks.md``
(a table) and ``experiments/results/learn_payload_tasks.png`` (a figure: returns per
seed against the random policy); raw numbers accumulate in ``learn_payload_tasks.json``
(a task run again replaces its entry; ``--report-only`` redraws from it).

    python experiments/learn_payload_tasks.py [--tasks quadx_pole_balance ...] [--seeds 0 1 2]
        [--budget 50000 quadx_gates=8000] [--episodes 10]
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from pyflyt_cli.training import compose_config, evaluate_run, train
from pyflyt_cli.training.envs import EnvFactory

RESULTS = Path(__file__).resolve().parent / "results"
TASKS = ["quadx_pole_balance", "quadx_pole_waypoints", "quadx_ball_in_cup", "quadx_gates"]
#: conf/hparams/quadx_hover_ppo.yaml, applied to every task
HOVER_PPO = [
    "algo.learning_rate=3e-4",
    "algo.n_steps=1024",
    "algo.batch_size=128",
    "algo.n_epochs=20",
    "algo.gamma=0.99",
    "algo.gae_lambda=0.9",
    "algo.clip_range=0.2",
    "algo.ent_coef=0.0",
    "algo.normalize.observation=true",
    "algo.normalize.reward=true",
    "algo.policy_kwargs.net_arch=[64,64]",
    "algo.policy_kwargs.activation_fn=relu",
    "algo.policy_kwargs.log_std_init=-1.0",
    "algo.policy_kwargs.ortho_init=false",
    "train.n_envs=2",
]


def random_policy(task: str, episodes: int, seed: int) -> dict[str, float]:
    """Uniform random actions in the agent's action space ([-1, 1] after rescaling), episodes seeded seed + i."""
    cfg = compose_config(env=task, algo="ppo")
    env = EnvFactory(cfg.env, monitor=False)()
    rng = np.random.default_rng(seed)
    returns, lengths, successes = [], [], []
    for i in range(episodes):
        env.reset(seed=seed + i)
        total, steps, done, info = 0.0, 0, False, {}
        while not done:
            action = rng.uniform(env.action_space.low, env.action_space.high)
            _, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            steps += 1
            done = terminated or truncated
        returns.append(total)
        lengths.append(steps)
        successes.append(bool(info.get("success", False)))
    env.close()
    return {
        "return": float(np.mean(returns)),
        "return_std": float(np.std(returns)),
        "length": float(np.mean(lengths)),
        "success": float(np.mean(successes)),
    }


def learned_policy(task: str, seed: int, budget: int, episodes: int, output: Path) -> dict[str, float]:
    overrides = [
        *HOVER_PPO,
        f"seed={seed}",
        f"train.total_timesteps={budget}",
        f"train.output_dir={output}",
        "train.progress_bar=false",
        "train.eval_freq=0",
        f"train.checkpoint_freq={budget}",
    ]
    cfg = compose_config(env=task, algo="ppo", overrides=overrides)
    start = time.perf_counter()
    result = train(cfg, overrides=overrides, command=["experiments/learn_payload_tasks.py"])
    wall = time.perf_counter() - start
    report = evaluate_run(result.run_dir, {"episodes": episodes, "record": False, "model": "final"})
    eps = report.episodes
    return {
        "return": float(np.mean([e.ret for e in eps])),
        "return_std": float(np.std([e.ret for e in eps])),
        "length": float(np.mean([e.length for e in eps])),
        "success": float(np.mean([e.success for e in eps])),
        "steps": result.num_timesteps,
        "wall": wall,
        "eval_seed": report.seed,
    }


def parse_budgets(values: list[str]) -> tuple[int, dict[str, int]]:
    default, per_task = 50_000, {}
    for value in values:
        if "=" in value:
            task, _, steps = value.partition("=")
            per_task[task] = int(float(steps))
        else:
            default = int(float(value))
    return default, per_task


def figure(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = list(results)
    fig, axes = plt.subplots(1, len(tasks), figsize=(3.2 * len(tasks), 3.2), squeeze=False)
    for ax, task in zip(axes[0], tasks):
        r = results[task]
        seeds = sorted(r["learned"], key=int)
        values = [r["random"]["return"]] + [r["learned"][s]["return"] for s in seeds]
        errors = [r["random"]["return_std"]] + [r["learned"][s]["return_std"] for s in seeds]
        labels = ["random"] + [f"PPO s{s}" for s in seeds]
        colors = ["0.6"] + ["C0"] * len(seeds)
        ax.bar(range(len(values)), values, yerr=errors, color=colors, capsize=3)
        ax.set_xticks(range(len(values)), labels, rotation=45, ha="right", fontsize=8)
        steps = max(s["steps"] for s in r["learned"].values())
        ax.set_title(f"{task}\n{steps / 1000:.1f}k steps", fontsize=9)
        ax.axhline(0.0, color="k", linewidth=0.5)
    axes[0][0].set_ylabel("mean episode return (dense), ± std")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tasks", nargs="+", default=TASKS)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--budget", nargs="+", default=["50000"], help="steps per run; task=steps for one task")
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--output", type=Path, default=None, help="run directories (default: a temporary one)")
    parser.add_argument("--report-only", action="store_true", help="rewrite the table and figure from the JSON results")
    args = parser.parse_args()
    if args.report_only:
        results = json.loads((RESULTS / "learn_payload_tasks.json").read_text())
        write_table(results)
        figure(results, RESULTS / "learn_payload_tasks.png")
        return
    default, per_task = parse_budgets(args.budget)
    unknown = sorted(set(per_task) - set(args.tasks))
    if unknown:
        parser.error(f"--budget names tasks not in --tasks: {', '.join(unknown)}")

    RESULTS.mkdir(parents=True, exist_ok=True)
    raw = RESULTS / "learn_payload_tasks.json"
    results = json.loads(raw.read_text()) if raw.exists() else {}
    with tempfile.TemporaryDirectory() as tmp:
        output = args.output or Path(tmp)
        for task in args.tasks:
            budget = per_task.get(task, default)
            entry = {"budget": budget, "episodes": args.episodes, "learned": {}}
            entry["random"] = random_policy(task, args.episodes, seed=1000)
            print(f"{task}: random {entry['random']}", flush=True)
            for seed in args.seeds:
                entry["learned"][str(seed)] = learned_policy(task, seed, budget, args.episodes, output)
                print(f"{task}: seed {seed} {entry['learned'][str(seed)]}", flush=True)
            results[task] = entry
            raw.write_text(json.dumps(results, indent=1))
    write_table(results)
    figure(results, RESULTS / "learn_payload_tasks.png")


def write_table(results: dict) -> None:
    lines = [
        "# Learnability of the payload and camera tasks (`experiments/learn_payload_tasks.py`)",
        "",
        (
            "PPO with the QuadX-Hover tuning, dense rewards, final policy evaluated deterministically on "
            "seeded episodes (seed + 1000 + i, as `pyflyt eval`); random: uniform actions on episode seeds "
            f"1000 + i. Machine: {platform.machine()}, 2 shared cores."
        ),
        "",
        "| task | steps trained | policy | return (mean ± std) | length | success | train wall [s] |",
        "|---|---:|---|---:|---:|---:|---:|",
    ]
    for task, r in results.items():
        rnd = r["random"]
        steps = max((s["steps"] for s in r["learned"].values()), default=r["budget"])  # whole PPO rollouts
        lines.append(
            f"| {task} | {steps:,} | random ({r['episodes']} episodes) | {rnd['return']:.1f} ± "
            f"{rnd['return_std']:.1f} | {rnd['length']:.0f} | {rnd['success']:.0%} | |"
        )
        for seed, s in sorted(r["learned"].items(), key=lambda kv: int(kv[0])):
            lines.append(
                f"| | | PPO seed {seed} | {s['return']:.1f} ± {s['return_std']:.1f} | {s['length']:.0f} | "
                f"{s['success']:.0%} | {s['wall']:.0f} |"
            )
    (RESULTS / "learn_payload_tasks.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()

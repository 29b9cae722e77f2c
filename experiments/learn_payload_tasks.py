"""Are the payload and camera tasks learnable?  Short PPO runs over seeds against a random policy.

For each task (``--tasks``, env config names), trains PPO exactly as ``pyflyt train
env=<task> algo=ppo seed=<s> train.total_timesteps=<budget>`` does: with the task's own
tuning ``conf/hparams/<task>_ppo.yaml`` when there is one (``--tuning shipped``, the
default), or with the QuadX-Hover PPO tuning applied to every task (``--tuning hover``:
``conf/hparams/quadx_hover_ppo.yaml``'s algorithm settings, 2 envs; how the first runs
were made).  Budgets: ``--budget`` (steps per run; ``task=steps`` for one task).  The final
policy of every seed is evaluated like ``pyflyt eval`` (deterministic, ``--episodes``
episodes seeded ``seed + 1000 + i``); a uniformly random policy in the agent's action
space flies the same episode seeds (one batch of episodes per training seed), so every
trained seed has a random counterpart on identical starts.  Dense rewards.

Reported per task, following Agarwal et al. (2021) (``pyflyt_cli.plotting.stats``, rliable):
the interquartile mean (IQM) and the mean of the per-seed scores (a seed's score: the
mean return of its evaluation episodes) with 95 % stratified-bootstrap confidence
intervals, for PPO and for the random policy, the success rate over all evaluation
episodes, and each seed's numbers.  Written to ``experiments/results/learn_payload_tasks.md``
(tables) and ``.png`` (figure); raw numbers accumulate in ``learn_payload_tasks.json`` (a task
run again replaces its entry; ``--report-only`` redraws from it; ``--random-only``
re-flies only the random policy of the given tasks, keeping their trained entries).

    python experiments/learn_payload_tasks.py [--tasks quadx_pole_waypoints ...] [--seeds 0 1 2]
        [--budget 300000 quadx_gates=100000] [--episodes 10] [--tuning shipped|hover]
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from pyflyt_cli.plotting import stats
from pyflyt_cli.training import compose_config, evaluate_run, train
from pyflyt_cli.training.envs import EnvFactory
from pyflyt_engine.paths import conf_dir

RESULTS = Path(__file__).resolve().parent / "results"
TASKS = ["quadx_pole_balance", "quadx_pole_waypoints", "quadx_ball_in_cup", "quadx_gates"]
#: evaluation episodes of a run with seed s are seeded s + EVAL_OFFSET + i (as pyflyt eval)
EVAL_OFFSET = 1000
#: conf/hparams/quadx_hover_ppo.yaml's algorithm settings, applied to every task (--tuning hover)
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


def tuning_of(task: str, tuning: str) -> tuple[list[str], str]:
    """(overrides, description) of the PPO settings a task is trained with."""
    if tuning == "hover":
        return list(HOVER_PPO), "QuadX-Hover PPO tuning (conf/hparams/quadx_hover_ppo.yaml's algo settings, 2 envs)"
    own = conf_dir() / "hparams" / f"{task}_ppo.yaml"
    if own.is_file():
        return [], f"conf/hparams/{task}_ppo.yaml"
    return [], "conf/algo/ppo.yaml defaults (no conf/hparams file for this task)"


def random_policy(task: str, episodes: int, seed: int, overrides: list[str]) -> dict:
    """Uniform random actions in the agent's action space ([-1, 1] after rescaling) on the
    episode seeds a run with ``seed`` is evaluated on; actions drawn from a generator seeded ``seed``."""
    cfg = compose_config(env=task, algo="ppo", overrides=overrides)
    env = EnvFactory(cfg.env, monitor=False)()
    rng = np.random.default_rng(seed)
    returns, lengths, successes = [], [], []
    for i in range(episodes):
        env.reset(seed=seed + EVAL_OFFSET + i)
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
    return summary(returns, lengths, successes)


def summary(returns: list[float], lengths: list[int], successes: list[bool]) -> dict:
    return {
        "return": float(np.mean(returns)),
        "return_std": float(np.std(returns)),
        "length": float(np.mean(lengths)),
        "success": float(np.mean(successes)),
        "returns": [float(r) for r in returns],
        "lengths": [int(n) for n in lengths],
        "successes": [bool(s) for s in successes],
    }


def learned_policy(task: str, seed: int, budget: int, episodes: int, output: Path, overrides: list[str]) -> dict:
    run = [
        *overrides,
        f"seed={seed}",
        f"train.total_timesteps={budget}",
        f"train.output_dir={output}",
        "train.progress_bar=false",
        "train.eval_freq=0",
        f"train.checkpoint_freq={budget}",
    ]
    cfg = compose_config(env=task, algo="ppo", overrides=run)
    start = time.perf_counter()
    result = train(cfg, overrides=run, command=["experiments/learn_payload_tasks.py"])
    wall = time.perf_counter() - start
    report = evaluate_run(result.run_dir, {"episodes": episodes, "record": False, "model": "final"})
    eps = report.episodes
    out = summary([e.ret for e in eps], [e.length for e in eps], [e.success for e in eps])
    load = Path("/proc/loadavg").read_text().split()[0] if Path("/proc/loadavg").exists() else "?"
    out.update(steps=result.num_timesteps, wall=wall, load=load, eval_seed=report.seed)
    return out


def parse_budgets(values: list[str]) -> tuple[int, dict[str, int]]:
    default, per_task = 50_000, {}
    for value in values:
        if "=" in value:
            task, _, steps = value.partition("=")
            per_task[task] = int(float(steps))
        else:
            default = int(float(value))
    return default, per_task


# ---------------------------------------------------------------------- statistics


def seed_scores(entry: dict) -> tuple[np.ndarray, np.ndarray]:
    """(PPO, random) per-seed scores, shape (n_seeds, 1): mean evaluation return per seed."""
    seeds = sorted(entry["learned"], key=int)
    ppo = np.array([[entry["learned"][s]["return"] for s in seeds]]).T
    rnd = entry["random"]
    if "runs" in rnd:  # one random batch per training seed, on the same episode seeds
        random = np.array([[rnd["runs"][s]["return"] for s in seeds]]).T
    else:  # a single batch: its mean for every seed
        random = np.full_like(ppo, rnd["return"])
    return ppo, random


def task_statistics(entry: dict, reps: int = 2000, seed: int = 0) -> dict:
    """IQM and mean of the per-seed scores with 95 % bootstrap CIs; success rates; lengths."""
    ppo, random = seed_scores(entry)
    agg = stats.aggregates({"ppo": ppo, "random": random}, reps=reps, seed=seed)
    out = {}
    for name, runs in (("ppo", list(entry["learned"].values())), ("random", _random_runs(entry))):
        successes = [s for r in runs for s in r.get("successes", [])] or [r["success"] for r in runs]
        out[name] = {
            "iqm": _est(agg[name]["iqm"]),
            "mean": _est(agg[name]["mean"]),
            "success": float(np.mean(successes)),
            "length": float(np.mean([r["length"] for r in runs])),
        }
    return out


def _random_runs(entry: dict) -> list[dict]:
    rnd = entry["random"]
    return list(rnd["runs"].values()) if "runs" in rnd else [rnd]


def _est(e: stats.Estimate) -> list[float]:
    return [float(np.ravel(e.value)[0]), float(np.ravel(e.low)[0]), float(np.ravel(e.high)[0])]


def verdict(st: dict) -> str:
    """'beats random' when PPO's IQM interval lies wholly above the random policy's."""
    if st["ppo"]["iqm"][1] > st["random"]["iqm"][2]:
        return "beats random (CIs disjoint)"
    if st["ppo"]["iqm"][0] > st["random"]["iqm"][0]:
        return "above random, CIs overlap"
    return "not above random"


# ---------------------------------------------------------------------- outputs


def figure(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = list(results)
    fig, axes = plt.subplots(2, len(tasks), figsize=(3.3 * len(tasks), 6.2), squeeze=False,
                             gridspec_kw={"height_ratios": [3, 2]})  # fmt: skip
    for ax, task in zip(axes[1], tasks):  # episode lengths: how long each policy keeps flying
        r = results[task]
        seeds = sorted(r["learned"], key=int)
        runs = r["random"].get("runs", {})
        random = [runs.get(s, r["random"])["length"] for s in seeds]
        ppo = [r["learned"][s]["length"] for s in seeds]
        jitter = np.linspace(-0.12, 0.12, len(seeds))
        ax.scatter(0 + jitter, random, color="0.5", s=14)
        ax.scatter(1 + jitter, ppo, color="C0", s=14)
        ax.set_xticks([0, 1], ["random", "PPO"])
        ax.set_xlim(-0.5, 1.6)
        ax.set_ylim(0, None)
    axes[1][0].set_ylabel("mean episode length\n[agent steps] per seed")
    for ax, task in zip(axes[0], tasks):
        r = results[task]
        st = task_statistics(r)
        ppo, random = seed_scores(r)
        for x, name, colour, scores in ((0, "random", "0.5", random), (1, "ppo", "C0", ppo)):
            value, low, high = st[name]["iqm"]
            ax.errorbar([x], [value], yerr=[[value - low], [high - value]], fmt="o", color=colour, capsize=6,
                        markersize=8, label="IQM, 95 % CI" if x == 1 else None)  # fmt: skip
            jitter = np.linspace(-0.12, 0.12, len(scores))
            ax.scatter(x + 0.25 + jitter, scores[:, 0], color=colour, s=14, alpha=0.8,
                       label="seed score" if x == 1 else None)  # fmt: skip
            ax.annotate(f"success {st[name]['success']:.0%}", (x, low), textcoords="offset points",
                        xytext=(0, -14), ha="center", fontsize=7)  # fmt: skip
        ax.set_xticks([0, 1], ["random", "PPO"])
        ax.set_xlim(-0.5, 1.6)
        steps = max(s["steps"] for s in r["learned"].values())
        ax.set_title(f"{task}\n{steps / 1000:.0f}k steps x {len(r['learned'])} seeds", fontsize=9)
        ax.margins(y=0.15)
    axes[0][0].set_ylabel("evaluation return (dense)")
    axes[0][-1].legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def write_table(results: dict) -> None:
    lines = [
        "# Learnability of the payload and camera tasks (`experiments/learn_payload_tasks.py`)",
        "",
        (
            "PPO, dense rewards; each seed's final policy evaluated deterministically on 10 seeded episodes "
            f"(seed + {EVAL_OFFSET} + i, as `pyflyt eval`); random: uniform actions on the same episode seeds. "
            "A seed's score is the mean return of its episodes; IQM and mean over seeds with 95 % "
            "stratified-bootstrap CIs (rliable, 2000 replicates, `pyflyt_cli.plotting.stats`). "
            f"Machine: {platform.machine()}, 2 cores shared with other jobs (load average at the end of each "
            "run in the last column; wall-clock includes the load)."
        ),
        "",
        "| task | steps x seeds | tuning | policy | IQM [95 % CI] | mean [95 % CI] | episode length | success | verdict |",
        "|---|---:|---|---|---:|---:|---:|---:|---|",
    ]
    for task, r in results.items():
        st = task_statistics(r)
        steps = max(s["steps"] for s in r["learned"].values())
        head = [task, f"{steps:,} x {len(r['learned'])}", r.get("tuning", "QuadX-Hover PPO tuning")]
        for name, label in (("random", "random"), ("ppo", "PPO")):
            s = st[name]
            cells = head if name == "random" else ["", "", ""]
            cells = [*cells, label, _ci(s["iqm"]), _ci(s["mean"]), f"{s['length']:.0f}", f"{s['success']:.0%}"]
            lines.append("| " + " | ".join([*cells, verdict(st) if name == "ppo" else ""]) + " |")
    lines += [
        "",
        "## Per seed",
        "",
        "| task | seed | PPO return (mean ± std) | length | success | random return | random length | train wall [s] | load |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for task, r in results.items():
        runs = r["random"].get("runs", {})
        for seed, s in sorted(r["learned"].items(), key=lambda kv: int(kv[0])):
            rnd = runs.get(seed, r["random"])
            lines.append(
                f"| {task} | {seed} | {s['return']:.1f} ± {s['return_std']:.1f} | {s['length']:.0f} | "
                f"{s['success']:.0%} | {rnd['return']:.1f} ± {rnd['return_std']:.1f} | {rnd['length']:.0f} | "
                f"{s['wall']:.0f} | {s.get('load', '')} |"
            )
    (RESULTS / "learn_payload_tasks.md").write_text("\n".join(lines) + "\n")


def _ci(e: list[float]) -> str:
    return f"{e[0]:.1f} [{e[1]:.1f}, {e[2]:.1f}]"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tasks", nargs="+", default=TASKS)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--budget", nargs="+", default=["50000"], help="steps per run; task=steps for one task")
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--tuning", choices=["shipped", "hover"], default="shipped")
    parser.add_argument("--output", type=Path, default=None, help="run directories (default: a temporary one)")
    parser.add_argument(
        "--report-only", action="store_true", help="rewrite the tables and figure from the JSON results"
    )
    parser.add_argument(
        "--random-only", action="store_true", help="re-fly the random policy only, keep trained entries"
    )
    args = parser.parse_args()
    raw = RESULTS / "learn_payload_tasks.json"
    results = json.loads(raw.read_text()) if raw.exists() else {}
    if not args.report_only:
        default, per_task = parse_budgets(args.budget)
        unknown = sorted(set(per_task) - set(args.tasks))
        if unknown:
            parser.error(f"--budget names tasks not in --tasks: {', '.join(unknown)}")
        RESULTS.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory() as tmp:
            output = args.output or Path(tmp)
            for task in args.tasks:
                if args.random_only:
                    entry = results[task]
                    seeds = sorted(entry["learned"], key=int)
                    overrides = entry.get("overrides", HOVER_PPO)
                else:
                    overrides, description = tuning_of(task, args.tuning)
                    entry = {"budget": per_task.get(task, default), "episodes": args.episodes, "learned": {},
                             "tuning": description, "overrides": overrides}  # fmt: skip
                    seeds = [str(s) for s in args.seeds]
                runs = {s: random_policy(task, entry["episodes"], int(s), overrides) for s in seeds}
                entry["random"] = {**summary(*_pooled(runs)), "runs": runs}
                print(f"{task}: random {entry['random']['return']:.1f}", flush=True)
                if not args.random_only:
                    for seed in seeds:
                        entry["learned"][seed] = learned_policy(
                            task, int(seed), entry["budget"], args.episodes, output, overrides
                        )
                        s = entry["learned"][seed]
                        print(f"{task}: seed {seed} return {s['return']:.1f} length {s['length']:.0f}", flush=True)
                results[task] = entry
                raw.write_text(json.dumps(results, indent=1))
    write_table(results)
    figure(results, RESULTS / "learn_payload_tasks.png")


def _pooled(runs: dict) -> tuple[list, list, list]:
    return (
        [x for r in runs.values() for x in r["returns"]],
        [x for r in runs.values() for x in r["lengths"]],
        [x for r in runs.values() for x in r["successes"]],
    )


if __name__ == "__main__":
    main()

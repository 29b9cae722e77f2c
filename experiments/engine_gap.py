"""Does a policy trained on the batched backend fly the same in the PyBullet engine?

For each run directory given, the run's policy (``--model``: best, the default, or final)
flies ``--episodes`` deterministic episodes in the PyBullet engine (what ``pyflyt eval``
flies: seeds ``run seed + 1000 + i``) and as many in the batched backend (one env per
episode, advanced together, each env's first episode counted; its spawns and waypoints come
from the batched env's own generators, so the episodes are other draws of the same task).
Printed per run and engine: the success rate, the mean return and, for waypoint tasks, the
mean waypoints reached and the fraction reaching all of them.  The two engines' rates are
two samples of the same policy on the same task: compare their gap with the spread across
seeds (``experiments/results/learn_waypoints.md``).

    python experiments/engine_gap.py RUN_DIR [RUN_DIR ...] [--episodes 50] [--model best] [--write FILE.md]
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

from pyflyt_cli.training import rundir
from pyflyt_cli.training.batched import fly_episodes
from pyflyt_cli.training.envs import EnvFactory
from pyflyt_cli.training.evaluation import EVAL_SEED_OFFSET, policy_predict, run_episodes
from pyflyt_cli.training.models import load_policy


def pybullet_episodes(predict, normalize, env, episodes: int, seed: int) -> dict:
    eps = run_episodes(predict, env, episodes, seed, True, normalize_obs=normalize)
    out = {
        "success_rate": float(np.mean([e.success for e in eps])),
        "mean_return": float(np.mean([e.ret for e in eps])),
    }
    if "num_targets_reached" in eps[0].final_info:
        reached = np.array([int(e.final_info["num_targets_reached"]) for e in eps])
        k = int(env.unwrapped.task.options.num_targets)
        out.update(waypoints_reached=float(reached.mean()), all_reached=float(np.mean(reached >= k)))
    return out


def compare(run_dir: Path, episodes: int, which: str) -> dict:
    path = rundir.check_run_dir(run_dir)
    cfg = rundir.load_run_config(path)
    model_path, which = rundir.find_model(path, which)
    env = EnvFactory(cfg.env.model_copy(update={"backend": "pybullet"}), monitor=False)()
    model, normalize = load_policy(model_path, cfg, env)
    predict = policy_predict(model)
    seed = cfg.seed + EVAL_SEED_OFFSET
    t0 = time.process_time()
    pyb = pybullet_episodes(predict, normalize, env, episodes, seed)
    t1 = time.process_time()
    bat = fly_episodes(predict, normalize, cfg.env, episodes, seed)  # what `pyflyt eval` adds for such a run
    t2 = time.process_time()
    env.close()
    return {
        "run": str(path),
        "model": f"{model_path.name} ({which})",
        "seed": cfg.seed,
        "backend": cfg.env.backend,
        "pybullet": pyb,
        "batched": bat,
        "cpu": (t1 - t0, t2 - t1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", type=Path, nargs="+")
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--model", default="best", choices=("best", "final"))
    parser.add_argument("--write", type=Path, help="append the table to this Markdown file")
    args = parser.parse_args()
    rows = [compare(r, args.episodes, args.model) for r in args.runs]
    waypoints = "waypoints_reached" in rows[0]["pybullet"]
    head = "| run seed | model | engine | success [%] | mean return |" + (
        " mean reached | all reached [%] |" if waypoints else ""
    )
    lines = [
        f"## Both engines, {args.episodes} deterministic episodes each ({time.strftime('%Y-%m-%d %H:%M')}, "
        f"{platform.machine()}, Python {platform.python_version()})",
        "",
        "`python experiments/engine_gap.py " + " ".join(str(r) for r in args.runs) + f" --episodes {args.episodes}`",
        "",
        head,
        "|---" * (7 if waypoints else 5) + "|",
    ]
    for r in rows:
        for engine in ("pybullet", "batched"):
            e = r[engine]
            cells = (
                f"| {r['seed']} | {r['model']} | {engine} | {100 * e['success_rate']:.0f} | {e['mean_return']:.1f} |"
            )
            if waypoints:
                cells += f" {e['waypoints_reached']:.2f} | {100 * e['all_reached']:.0f} |"
            lines.append(cells)
    for key in ("pybullet", "batched"):
        rates = [100 * r[key]["success_rate"] for r in rows]
        lines.append("")
        lines.append(f"{key}: success across runs {np.mean(rates):.0f} % (min {min(rates):.0f}, max {max(rates):.0f})")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.write:
        with open(args.write, "a", encoding="utf-8") as f:
            f.write("\n" + text)


if __name__ == "__main__":
    sys.exit(main())

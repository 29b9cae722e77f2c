"""Where a training run's time goes: measured cost per collected step and of updates per step,
and the wall-clock time the shipped configuration needs for a budget, per algorithm.

    python experiments/time_budget.py [--env quadx_hover] [--steps 60000] [--algos sac ppo ...]

Uses the same measurement as the ETA ``pyflyt train`` prints at start
(:func:`pyflyt_cli.training.timing.measure_costs`: a throw-away copy of the configured model
on the run's in-process envs or one env, a few updates).  The figures are estimates for this machine at this moment
(other processes share the CPU); they say nothing about what a policy learns.
"""

from __future__ import annotations

import argparse
import platform

import torch

from pyflyt_cli.training.compose import compose_config
from pyflyt_cli.training.timing import estimate_seconds, format_duration, measure_costs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="quadx_hover")
    parser.add_argument("--steps", type=int, default=60_000)
    parser.add_argument("--algos", nargs="+", default=["ppo", "sac", "tqc", "crossq", "trpo", "td3"])
    args = parser.parse_args()
    torch.set_num_threads(1)
    print(
        f"# {args.env}, {args.steps} steps, shipped configuration per algorithm ({platform.processor() or platform.machine()})"
    )
    print()
    print("| algo | n_envs | collect [ms/step] | updates [ms/step] | update share | estimated time |")
    print("|---|---|---|---|---|---|")
    for algo in args.algos:
        cfg = compose_config(env=args.env, algo=algo, overrides=[f"train.total_timesteps={args.steps}"])
        costs = measure_costs(cfg)
        if costs is None:
            print(f"| {algo} | {cfg.train.n_envs} | - | - | - | not measurable |")
            continue
        seconds = estimate_seconds(cfg, costs)
        share = costs.update / (costs.collect + costs.update)
        print(
            f"| {algo} | {cfg.train.n_envs} | {1e3 * costs.collect:.2f} | {1e3 * costs.update:.2f} | "
            f"{100 * share:.0f} % | {format_duration(seconds)} |"
        )


if __name__ == "__main__":
    main()

"""How each shipped agent's recorded evaluation episodes end: return, length, success,
waypoints reached, and why the episode ended (crash, out of bounds, time limit, done).

Flies ``pyflyt eval zoo:<name>``'s episodes (the recorded count, seeds 1000+,
deterministic) through the same evaluation code and prints one Markdown table per agent;
``experiments/results/zoo.md`` quotes them.  For waypoint tasks ``--approach`` adds how
close each episode came to the waypoint it was after (ground truth from the task's
tracker, every agent step), the speed there, and how often the distance switched
between shrinking and growing (a policy that swings to and fro near a waypoint).

    python experiments/zoo_outcomes.py [--approach] [NAME ...]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from pyflyt_cli import zoo
from pyflyt_cli.training import evaluate_run, rundir
from pyflyt_cli.training.envs import EnvFactory
from pyflyt_cli.training.evaluation import policy_predict, run_episodes
from pyflyt_cli.training.models import load_policy


def ending(info: dict, length: int, max_steps: int) -> str:
    if info.get("success"):
        return "success"
    for key in ("collision", "out_of_bounds"):
        if info.get(key):
            return key.replace("_", " ")
    return "time limit" if length >= max_steps else "ended"


def approaches(run, episodes: int, seed: int) -> list[dict]:
    """Per episode: closest distance to the waypoint being sought [m], the speed there [m/s], the
    waypoints reached and the sign changes of the distance's rate (the recorded evaluation's episodes)."""
    cfg = rundir.load_run_config(run)
    env = EnvFactory(cfg.env, monitor=False)()
    model, normalize = load_policy(rundir.find_model(run)[0], cfg, env)
    trace: list[list[tuple[float, float]]] = []
    terms: list[dict[str, float]] = []

    def on_step(e, i) -> None:
        base = e.unwrapped
        for name, value in (base.last_reward_terms or {}).items():
            terms[i][name] = terms[i].get(name, 0.0) + float(value)
        tracker = base.task.tracker
        if tracker.all_reached:
            return
        target = tracker.targets[tracker.num_reached]
        trace[i].append(
            (float(np.linalg.norm(np.asarray(base.state.lin_pos) - target)), float(np.linalg.norm(base.state.lin_vel)))
        )

    try:
        run_episodes(
            policy_predict(model),
            env,
            episodes,
            seed,
            True,
            normalize_obs=normalize,
            on_step=on_step,
            on_reset=lambda e, i: (trace.append([]), terms.append({})),
        )
    finally:
        env.close()
    rows = []
    for steps, split in zip(trace, terms):
        d, v = np.array([x[0] for x in steps]), np.array([x[1] for x in steps])
        k = int(d.argmin())
        flips = int(np.sum(np.diff(np.sign(np.diff(d))) != 0))
        rows.append(
            {
                "closest": float(d[k]),
                "step": k,
                "speed": float(v[k]),
                "mean_speed": float(v.mean()),
                "flips": flips,
                "terms": split,
            }
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="agents (default: all shipped)")
    parser.add_argument("--approach", action="store_true", help="waypoint tasks: closest approach and speed there")
    args = parser.parse_args()
    names = args.names or [a.name for a in zoo.agents()]
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            recorded = zoo.agent(name).summary["evaluation"]
            run = zoo.materialise(name, Path(tmp) / name)
            report = evaluate_run(run, {"episodes": recorded["episodes"], "record": False})
            steps = rundir.load_run_config(run).env.max_steps
            max_steps = int(steps() if callable(steps) else steps)
            print(f"\n### {name}\n")
            near = (
                approaches(run, recorded["episodes"], report.seed)
                if args.approach and "num_targets_reached" in report.episodes[0].final_info
                else None
            )
            extra = " closest to the sought waypoint [m] (step) | speed there [m/s] | mean speed [m/s] | approach/recede switches | return by reward term |"
            print("| seed | return | length | waypoints reached | ending |" + (extra if near else ""))
            print("|---|---|---|---|---|" + ("---|---|---|---|---|" if near else ""))
            for i, e in enumerate(report.episodes):
                reached = e.final_info.get("num_targets_reached", "-")
                line = (
                    f"| {e.seed} | {e.ret:.1f} | {e.length} | {reached} | {ending(e.final_info, e.length, max_steps)} |"
                )
                if near:
                    a = near[i]
                    line += f" {a['closest']:.2f} ({a['step']}) | {a['speed']:.1f} | {a['mean_speed']:.1f} | {a['flips']} | "
                    line += ", ".join(f"{k} {v:.0f}" for k, v in a["terms"].items()) + " |"
                print(line)
            s = report.summary
            print(
                f"\nmean return {s['mean_return']:.2f} ± {s['std_return']:.2f}, success {100 * s['success_rate']:.0f} %"
                f" (recorded: {recorded['mean_return']:.2f})"
            )


if __name__ == "__main__":
    main()

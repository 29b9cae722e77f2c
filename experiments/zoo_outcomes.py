"""How each shipped agent's recorded evaluation episodes end: return, length, success,
waypoints reached, and why the episode ended (crash, out of bounds, time limit, done).

Flies ``pyflyt eval zoo:<name>``'s episodes (the recorded count, seeds 1000+,
deterministic) through the same evaluation code and prints one Markdown table per agent;
``experiments/results/zoo.md`` quotes them.

    python experiments/zoo_outcomes.py [NAME ...]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from pyflyt_cli import zoo
from pyflyt_cli.training import evaluate_run, rundir


def ending(info: dict, length: int, max_steps: int) -> str:
    if info.get("success"):
        return "success"
    for key in ("collision", "out_of_bounds"):
        if info.get(key):
            return key.replace("_", " ")
    return "time limit" if length >= max_steps else "ended"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="agents (default: all shipped)")
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
            print("| seed | return | length | waypoints reached | ending |")
            print("|---|---|---|---|---|")
            for e in report.episodes:
                reached = e.final_info.get("num_targets_reached", "-")
                print(
                    f"| {e.seed} | {e.ret:.1f} | {e.length} | {reached} | {ending(e.final_info, e.length, max_steps)} |"
                )
            s = report.summary
            print(
                f"\nmean return {s['mean_return']:.2f} ± {s['std_return']:.2f}, success {100 * s['success_rate']:.0f} %"
                f" (recorded: {recorded['mean_return']:.2f})"
            )


if __name__ == "__main__":
    main()

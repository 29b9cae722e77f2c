"""Learning through the firmware: QuadX-Hover trained with Betaflight's SITL in the loop
(ACRO sticks as the action) and evaluated through it -- the figures docs/firmware.md quotes.

Runs ``pyflyt train env=quadx_hover env.controller=betaflight`` (the shipped hover PPO
settings; the firmware at 1000 Hz, a 50 Hz agent) to ``--budget`` steps, resuming the run in
stages of ``--stage`` steps so that each stage's policy is evaluated (``pyflyt eval``,
``--episodes`` deterministic episodes from seed 1000, flown through the firmware), and writes
what each stage's evaluation measured with the training time and the load to
experiments/results/learn_hover_firmware.md (``--write``).

    python experiments/learn_hover_firmware.py [--budget 300000] [--stage 150000] [--episodes 10] [--write]

Needs the patched SITL (python -m pyflyt_engine.firmware.build).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

from pyflyt_cli.studies.runs import pyflyt_command
from pyflyt_engine.numerics import platform_info

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--budget", type=int, default=300_000)
    parser.add_argument("--stage", type=int, default=150_000)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--write", action="store_true", help="write experiments/results/learn_hover_firmware.md")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="pyflyt-firmware-train-") as tmp:
        work = Path(tmp)
        run: Path | None = None
        for budget in range(args.stage, args.budget + 1, args.stage):
            start, load = time.perf_counter(), os.getloadavg()[0]
            if run is None:
                out = pyflyt_command(
                    [
                        "train",
                        "env=quadx_hover",
                        "env.controller=betaflight",
                        f"seed={args.seed}",
                        f"train.total_timesteps={budget}",
                    ],
                    work,
                )
                (run,) = work.glob("runs/quadx_hover/ppo/*")
            else:
                out = pyflyt_command(["train", f"resume={run}", f"train.total_timesteps={budget}"], work)
            wall = time.perf_counter() - start
            trained = next((line for line in out.splitlines() if line.startswith("done:")), "")
            pyflyt_command(["eval", str(run), f"episodes={args.episodes}", "record=false"], work)
            result = json.loads((run / "eval.json").read_text())
            row = (
                f"| {budget} | {100 * result['success_rate']:.0f} % | {result['mean_return']:.2f} +- "
                f"{result['std_return']:.2f} | {result['mean_length']:.0f} | "
                f"{result['measures']['distance_mean']:.3f} / {result['measures']['distance_max']:.3f} | "
                f"{wall:.0f} | {load:.1f}-{os.getloadavg()[0]:.1f} |"
            )
            print(row, trained, flush=True)
            rows.append(row)
    lines = [
        "# QuadX-Hover trained through Betaflight's firmware",
        "",
        f"`python experiments/learn_hover_firmware.py --budget {args.budget} --stage {args.stage} "
        f"--episodes {args.episodes} --write` ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
        f"{platform.machine()}, {platform_info()['cpu']}, {os.cpu_count()} CPUs).",
        "",
        "`pyflyt train env=quadx_hover env.controller=betaflight` (the shipped hover PPO settings, 64 envs each with",
        "its own SITL, ACRO sticks, firmware at 1000 Hz, 50 Hz agent), resumed stage by stage; each stage's policy",
        f"evaluated by `pyflyt eval` through the firmware, {args.episodes} deterministic episodes from seed 1000.",
        "",
        "| steps | success | return (mean +- std) | length | distance held, mean / max [m] | stage wall [s] | load |",
        "|---|---|---|---|---|---|---|",
        *rows,
        "",
    ]
    if args.write:
        out_path = ROOT / "experiments" / "results" / "learn_hover_firmware.md"
        out_path.write_text("\n".join(lines))
        print(f"wrote {out_path}")


if __name__ == "__main__":
    main()

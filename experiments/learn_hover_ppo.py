"""Does the shipped QuadX-Hover configuration learn to hover, and how fast?

Trains exactly what ``pyflyt train`` (no overrides) trains — ``conf/train.yaml`` with
``env=quadx_hover algo=ppo`` and its tuning ``conf/hparams/quadx_hover_ppo.yaml`` — at
the shipped budget (or ``--budget``), and every ``--probe-every`` steps flies the current
policy (deterministic) for ``--episodes`` seeded episodes.  **Hovering** (the issue's
target) means, in every episode: no crash for the whole 10 s episode (it reaches the time
limit) and a mean distance to the hover point (0, 0, 1) m below 0.1 m.

Reported: the first probe at which the policy hovers (environment steps, wall-clock
time of the run so far, and that time without the probes' own cost), the training
throughput, the final policy's numbers, and the IQM over the seeds with 95 % stratified-
bootstrap intervals (rliable, through ``pyflyt_cli.plotting.stats``).  Results are
appended to ``experiments/results/learn_hover_ppo.md``; the curve goes to
``learn_hover_ppo.png`` and the raw probes to ``learn_hover_ppo.json``.

    python experiments/learn_hover_ppo.py [--seeds 0 1 2] [--budget N] [--probe-every 5000]

Searching: ``--set key=value ...`` adds training overrides to every run, ``--algo`` picks
another algorithm, ``--stop-on-hover`` ends a run at its first hovering probe and
``--no-write`` leaves the results alone (how the shipped tuning was chosen).

Yardstick (task brief): the reference PyFlyt QuadX-Hover with SB3 PPO defaults hovers
after ~160-200k steps, 250-310 s on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path


from pyflyt_cli.studies.probes import HOVER_DISTANCE
from pyflyt_cli.studies.report import iqm_summary, plot_curve
from pyflyt_cli.studies.runs import hover_run
from pyflyt_cli.training import compose_config

RESULTS = Path(__file__).resolve().parent / "results" / "learn_hover_ppo.md"


def rliable_summary(rows: list[dict], budget: int, reps: int = 2000) -> tuple[list[str], dict]:
    """:func:`iqm_summary` of the steps to the first hovering probe (a run that never hovers
    counts as the budget, a lower bound), the final probe's return and mean distance, and the
    return curve over the probes."""
    never = sum(1 for r in rows if not r["hover_at"])
    return iqm_summary(
        rows,
        [
            (
                f"steps to the first hovering probe{' (never = budget)' if never else ''}",
                [r["hover_at"][0] if r["hover_at"] else budget for r in rows],
                0,
            ),
            (
                f"final return ({rows[0]['history'][-1][0] if rows[0]['history'] else '-'} steps)",
                [r["final"]["mean_return"] for r in rows],
                2,
            ),
            ("final mean distance [m]", [r["final"]["mean_distance"] for r in rows], 3),
        ],
        reps,
        curve="mean_return",
        of="",
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--budget", type=int, default=None, help="steps per run (default: the shipped default budget)")
    parser.add_argument("--probe-every", type=int, default=10_000)
    parser.add_argument("--episodes", type=int, default=10, help="episodes per probe")
    parser.add_argument("--no-write", action="store_true", help="do not append to the results file")
    parser.add_argument("--algo", default="ppo")
    parser.add_argument("--set", nargs="*", default=[], help="training overrides (key=value) for every run")
    parser.add_argument("--stop-on-hover", action="store_true", help="end a run at its first hovering probe")
    parser.add_argument(
        "--max-distance", type=float, default=HOVER_DISTANCE, help="hovering: mean distance below this [m]"
    )
    args = parser.parse_args()

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            print(f"seed {seed}:", flush=True)
            rows.append(
                hover_run(
                    seed,
                    args.budget,
                    args.probe_every,
                    args.episodes,
                    Path(tmp),
                    args.algo,
                    args.set,
                    args.stop_on_hover,
                    args.max_distance,
                )
            )

    cfg = compose_config()
    lines = [
        (
            f"\n## {time.strftime('%Y-%m-%d %H:%M')} — {platform.machine()}, {platform.python_version()}, "
            f"budget {rows[0]['budget']} steps, {rows[0]['n_envs']} envs, "
            f"probe every {args.probe_every} steps x {args.episodes} episodes, hovering below {args.max_distance} m\n"
        ),
        f"Shipped default budget (`pyflyt train`): {cfg.train.total_timesteps} steps.\n",
        "| seed | hovers at [steps] | wall-clock then [s] | without probes [s] | CPU time then, without probes [s] | final: survived | final: mean / worst distance [m] | training steps/s | run wall-clock [s] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        h = r["hover_at"]
        f = r["final"]
        lines.append(
            f"| {r['seed']} | {h[0] if h else 'not within budget'} | {f'{h[1]:.0f}' if h else '-'} | "
            f"{f'{h[2]:.0f}' if h else '-'} | {f'{h[3]:.1f}' if h and len(h) > 3 else '-'} | "
            f"{100 * f.get('survived', 0):.0f} % | "
            f"{f.get('mean_distance', float('nan')):.3f} / {f.get('worst_distance', float('nan')):.3f} | "
            f"{r['steps_per_second']:.0f} | {r['wall']:.0f} |"
        )
    summary, data = rliable_summary(rows, rows[0]["budget"])
    lines += summary
    if not args.no_write and "curve" in data:
        plot_curve(
            data, RESULTS.with_suffix(".png"), f"QuadX-Hover, {args.algo}, seeds {', '.join(map(str, args.seeds))}"
        )
        lines.append(
            f"\nCurve: `{RESULTS.with_suffix('.png').name}` (IQM and 95 % CI of the probe return; grey: each seed)."
        )
    if not args.no_write:
        data["command"] = " ".join(sys.argv)
        RESULTS.with_suffix(".json").write_text(json.dumps(data, indent=1) + "\n")
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_write:
        RESULTS.parent.mkdir(exist_ok=True)
        if not RESULTS.exists():
            RESULTS.write_text(
                "# PPO learns to hover (experiments/learn_hover_ppo.py)\n\n"
                "Hovering = in every probe episode (deterministic policy, 10 s): no crash and mean distance to\n"
                "the hover point below 0.1 m.  Wall-clock includes environment start-up and evaluations.\n"
            )
        with RESULTS.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()

"""How many gates in a row does a QuadX-Gates agent fly from state, within a CPU-time budget?

Trains what ``pyflyt train env=quadx_gates_state`` trains (``conf/train.yaml`` with the
env's tuning ``conf/hparams/quadx_gates_state_ppo.yaml``; the only overrides are the seed,
the output folder, no progress bar, the run's own evaluations off, and ``--set key=value``
when given) and every ``--probe-every`` steps flies the current policy (deterministic) for
``--episodes`` seeded episodes (seeds 10 000+, the same courses for every run), counting
per episode the gates passed in order (``info["num_targets_reached"]``; gates count only in
order, so this is the run of consecutive gates from the start) and how it ended (every
gate passed, a crash on a gate or the ground, out of the flight dome, the 10 s limit).

**The target** (a stretch target of the project): >= 3 consecutive gates in >= 50 % of the
evaluation episodes within 60 minutes of training on 2 cores, from the state observation.
A probe's ``success`` is the fraction of its episodes passing at least 3 gates (:data:`GATES`).

**CPU-time budget** (``--cpu-minutes M``, default 60): as ``experiments/learn_obstacles.py``
(the training process's CPU time, every thread, minus the probes'; a conservative reading
of "M minutes on 2 cores" on a shared machine).  Every probe is written to ``--save-rows``
as it comes; ``--from-rows`` reports saved runs (one file per seed when seeds run side by
side).  Across seeds: IQM with 95 % stratified-bootstrap intervals (rliable, through
``pyflyt_cli.plotting.stats``) of the final probe's fraction and mean gates passed.
``--write`` appends a section to ``experiments/results/learn_gates.md`` and writes the raw
probes and the curve beside it (``.json``, ``.png``).

    python experiments/learn_gates.py [--seeds 0 1 2] [--cpu-minutes 60] [--probe-every 250000] \\
        [--episodes 20] [--set KEY=VALUE ...] [--save-rows FILE] [--keep-runs DIR] [--write]
    python experiments/learn_gates.py --from-rows rows_0.json rows_1.json ... [--write]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from pyflyt_cli.studies.probes import GATES, GatesProbe
from pyflyt_cli.studies.report import iqm_summary, plot_curve, section_head
from pyflyt_cli.studies.runs import run_seeds

ENV = "quadx_gates_state"
RESULTS = Path(__file__).resolve().parent / "results" / "learn_gates.md"
TARGET = 0.5  # the target: >= 50 % of the episodes ...


def table(rows: list[dict]) -> list[str]:
    lines = [
        "| seed | ended by | steps | training CPU [min] | wall-clock [min] | load min / mean / max | steps per CPU-s | "
        f"final >= {GATES} gates [%] | final >= 1..5 gates [%] | final mean gates | final endings | "
        f"best >= {GATES} gates [%] | first >= {100 * TARGET:.0f} % [steps, CPU min] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        f, t = r["final"], r["target_at"]
        cpu = r["training_cpu"]
        lines.append(
            f"| {r['seed']} | {r['status']} | {r['steps']} | {cpu / 60:.1f} | {r.get('wall', 0) / 60:.1f} | "
            f"{r['load'][0]:.1f} / {r['load'][1]:.1f} / {r['load'][2]:.1f} | {r['steps'] / max(cpu, 1e-9):.0f} | "
            f"{100 * f.get('success', 0):.0f} | {' / '.join(f'{100 * a:.0f}' for a in f.get('at_least', []))} | "
            f"{f.get('mean_reached', 0):.2f} | {', '.join(f'{k} {v}' for k, v in f.get('endings', {}).items())} | "
            f"{100 * r['best_success']:.0f} | {f'{t[0]}, {t[2] / 60:.1f}' if t else 'not reached'} |"
        )
    return lines


def summary(rows: list[dict], reps: int = 2000) -> tuple[list[str], dict]:
    final = [r["final"] for r in rows]
    return iqm_summary(
        rows,
        [
            (f"fraction passing >= {GATES} gates", [f["success"] for f in final], 2),
            (f"best probe's fraction passing >= {GATES} gates", [r["best_success"] for r in rows], 2),
            ("mean gates passed (of 5)", [f["mean_reached"] for f in final], 2),
            ("fraction passing all 5", [f["all"] for f in final], 2),
            ("probe return", [f["mean_return"] for f in final], 1),
        ],
        reps,
    )


def probes_text(rows: list[dict]) -> list[str]:
    lines = ["", "Probes per seed (steps: % passing >= 1..5 gates / endings):", ""]
    for r in rows:
        parts = [
            f"{h[0] // 1000}k: "
            + "/".join(f"{100 * a:.0f}" for a in h[2]["at_least"])
            + " "
            + " ".join(f"{k} {v}" for k, v in h[2]["endings"].items())
            for h in r["history"]
        ]
        lines.append(f"- seed {r['seed']}: " + "; ".join(parts))
    return lines + ["", "(raw: `learn_gates.json`)"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument(
        "--cpu-minutes", type=float, default=60.0, help="training CPU-time budget per run [min] (0: none)"
    )
    parser.add_argument("--probe-every", type=int, default=250_000)
    parser.add_argument("--episodes", type=int, default=20, help="episodes per probe")
    parser.add_argument("--set", nargs="*", default=[], help="training overrides (key=value) for every run")
    parser.add_argument("--write", action="store_true", help="append to the results file, write .json and .png")
    parser.add_argument("--save-rows", type=Path, help="write each run's results here (JSON) at every probe")
    parser.add_argument("--keep-runs", type=Path, help="keep the run directories here (default: a temporary folder)")
    parser.add_argument("--from-rows", type=Path, nargs="+", help="no training: report the runs saved by --save-rows")
    parser.add_argument("--title", default="", help="a few words for the results section's heading")
    args = parser.parse_args()
    cpu_minutes = args.cpu_minutes or None

    if args.from_rows:
        rows = sorted((r for path in args.from_rows for r in json.loads(path.read_text())), key=lambda r: r["seed"])
    else:
        rows = run_seeds(args, cpu_minutes, env=ENV, target=TARGET, probe_cls=GatesProbe)
    lines = [*section_head("learn_gates.py", args, rows), *table(rows)]
    more, data = summary(rows)
    lines += more + probes_text(rows)
    if args.write and "curve" in data:
        png = RESULTS.with_suffix(".png")
        plot_curve(
            data,
            png,
            f"QuadX-Gates from state, PPO, seeds {', '.join(str(r['seed']) for r in rows)}",
            key="success",
            ylabel=f"fraction passing >= {GATES} gates, probe",
            legend="upper left",
        )
        lines.append(f"\nCurve: `{png.name}` (IQM and 95 % CI of the probe fraction; grey: each seed).")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.write:
        data["command"] = "python experiments/learn_gates.py " + " ".join(sys.argv[1:])
        RESULTS.with_suffix(".json").write_text(json.dumps(data, indent=1) + "\n")
        if not RESULTS.exists():
            RESULTS.write_text("# QuadX-Gates from state: how many gates in a row (experiments/learn_gates.py)\n")
        with RESULTS.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()

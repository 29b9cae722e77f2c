"""How often does a QuadX-Obstacles agent reach its goal through the forest, within a CPU-time budget?

Trains what ``pyflyt train env=quadx_obstacles`` trains (``conf/train.yaml`` with the
env's tuning ``conf/hparams/quadx_obstacles_ppo.yaml``; the only overrides are the seed,
the output folder, no progress bar, the run's own evaluations off, and ``--set key=value``
when given) and every ``--probe-every`` steps flies the current policy (deterministic) for
``--episodes`` seeded episodes (seeds 10 000+, the same forests and goals for every run).
**Success** is the task's ``info["success"]``: the goal reached without any contact
(``pyflyt_engine/envs/tasks/goal.py``; a contact is a crash and ends the episode).  Per
probe: the success fraction, how the episodes ended (reached, a trunk touched, the
ground touched, out of the flight dome, the 20 s limit), the closest approach to the goal,
the mean speed and the return.

**CPU-time budget** (``--cpu-minutes M``): training stops once the training process's
CPU time (``time.process_time()``, every thread) since training was called (a tuning's
imitation stage included), minus the CPU time of the probes, reaches M minutes.  A run
whose tuning imitates an oracle first (``train.imitation``) is also probed when
reinforcement learning starts (step 0: the imitated policy).  On a shared machine (2 cores, other jobs) M
CPU-minutes are at most what one run alone on the 2 cores would get in M minutes of
wall-clock (training uses one torch thread; the environments step in the same process),
so a target "within M minutes" met on CPU time is met conservatively.  Wall-clock, CPU
time and the load average are reported per seed.

Reported per seed: the probes, the first probe at which ``--target`` of the episodes
succeed (steps, CPU minutes), where the training time went (as
``experiments/learn_waypoints.py``); across seeds: IQM with 95 % stratified-bootstrap
intervals (rliable, through ``pyflyt_cli.plotting.stats``) of the final probe's success
fraction, closest approach and return.  Every probe is written to ``--save-rows`` as it
comes, so a run stopped early loses nothing; ``--from-rows`` reports saved runs (one
file per seed when seeds run side by side).  ``--write`` appends a section to
``experiments/results/learn_obstacles.md`` and writes the raw probes and the curve beside
it (``.json``, ``.png``).

    python experiments/learn_obstacles.py [--seeds 0 1 2] [--cpu-minutes 30] [--probe-every 100000] \\
        [--episodes 10] [--set KEY=VALUE ...] [--save-rows FILE] [--keep-runs DIR] [--write]
    python experiments/learn_obstacles.py --from-rows rows_0.json rows_1.json ... [--keep-runs DIR] [--write]
    python experiments/learn_obstacles.py --diagnose RUN_DIR ... [--episodes 10]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from pyflyt_cli.studies.probes import PROBE_SEED, obstacle_probe
from pyflyt_cli.studies.report import iqm_summary, plot_curve, section_head
from pyflyt_cli.studies.runs import SavedPolicy, budgeted_run, checkpoint_policies, run_seeds, training_success

RESULTS = Path(__file__).resolve().parent / "results" / "learn_obstacles.md"
ENV = "quadx_obstacles"
TARGET = 0.7  # the target: >= 70 % of the episodes succeed
SHORT = {"reached": "R", "trunk": "T", "ground": "G", "out": "O", "time": "L"}  # L: the time limit


def run(seed: int, cpu_minutes: float | None, every: int, episodes: int, output: Path, extra=(), save=None) -> dict:
    """One seed of QuadX-Obstacles under the CPU budget (:func:`pyflyt_cli.studies.runs.budgeted_run`)."""
    return budgeted_run(seed, cpu_minutes, every, episodes, output, extra, save, env=ENV, target=TARGET)


def diagnose(run_dir: Path, episodes: int) -> list[str]:
    """The run's newest checkpoint flown on the probe episodes four ways: the full task and the
    curriculum's task where the run stopped, each with deterministic and with sampled actions
    (sampling from seed 0 of torch's generator): is a gap between the probes and the training
    episodes the distance to the goal or the action noise?"""
    import warnings

    import torch

    from pyflyt_engine.telemetry import read_metrics

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stages = read_metrics(run_dir).get("/train/curriculum", [])
    last = dict(stages[-1]) if stages else {}
    eased = {"goal_reach_distance": last["goal_reach_distance"]} if "goal_reach_distance" in last else {}
    if "goal_x_range[0]" in last:
        eased["goal_x_range"] = [last["goal_x_range[0]"], last["goal_x_range[1]"]]
    from pyflyt_cli.training import rundir

    newest = max(c.step for c in rundir.checkpoints(run_dir))
    lines = []
    for step, model, normalize, _, env in checkpoint_policies(run_dir, after=newest - 1):  # the newest alone
        policy = SavedPolicy(model, normalize)
        lines += [
            f"{run_dir.name}, checkpoint at {step} steps, {episodes} episodes (seeds {PROBE_SEED}+):",
            "",
            "| task | actions | success [%] | endings | closest [m] | speed [m/s] | length [s] |",
            "|---|---|---|---|---|---|---|",
        ]
        for name, task in (("full", None), (f"curriculum at the stop: {eased}", eased)):
            for deterministic in (True, False):
                torch.manual_seed(0)
                p = obstacle_probe(policy, env, episodes, PROBE_SEED, task=task, deterministic=deterministic)
                lines.append(
                    f"| {name} | {'deterministic' if deterministic else 'sampled'} | {100 * p['success']:.0f} | "
                    f"{', '.join(f'{k} {v}' for k, v in p['endings'].items())} | {p['mean_closest']:.2f} | "
                    f"{p['mean_speed']:.2f} | {p['mean_length']:.2f} |"
                )
    return lines


def rliable_summary(rows: list[dict], reps: int = 2000) -> tuple[list[str], dict]:
    """:func:`iqm_summary` of the final probe's success, closest approach and return."""
    final = [r["final"] for r in rows]
    return iqm_summary(
        rows,
        [
            ("success fraction (goal reached without contact)", [f["success"] for f in final], 2),
            ("best probe's success fraction", [r["best_success"] for r in rows], 2),
            ("closest approach to the goal [m] (0 when reached)", [f["mean_closest"] for f in final], 2),
            ("probe return", [f["mean_return"] for f in final], 1),
        ],
        reps,
    )


def table(rows: list[dict]) -> list[str]:
    lines = [
        "| seed | ended by | steps | training CPU [min] | wall-clock [min] | load min / mean / max | steps per CPU-s | "
        f"final success [%] | final endings | best success [%] | first >= {100 * TARGET:.0f} % [steps, CPU min] | "
        "env / other collect / update, wall-clock [s] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        f, t, s = r["final"], r["target_at"], r.get("split") or {}
        status = r["status"]
        if status == "step budget" and r["steps"] < r.get("step_budget", 0):  # SIGTERM before the label existed
            status = "stopped"
        cpu = r["training_cpu"]
        lines.append(
            f"| {r['seed']} | {status} | {r['steps']} | {cpu / 60:.1f} | {r.get('wall', 0) / 60:.1f} | "
            f"{r['load'][0]:.1f} / {r['load'][1]:.1f} / {r['load'][2]:.1f} | {r['steps'] / max(cpu, 1e-9):.0f} | "
            f"{100 * f.get('success', 0):.0f} | {', '.join(f'{k} {v}' for k, v in f.get('endings', {}).items())} | "
            f"{100 * r['best_success']:.0f} | {f'{t[0]}, {t[2] / 60:.1f}' if t else 'not reached'} | "
            + (f"{s['env']:.0f} / {s['collect_other']:.0f} / {s['update']:.0f}" if s else "-")
            + " |"
        )
    return lines


def probes_text(rows: list[dict]) -> list[str]:
    lines = ["", "Probes per seed (steps: success % / closest approach m / endings):", ""]
    for r in rows:
        parts = [
            f"{h[0] // 1000}k: {100 * h[2]['success']:.0f} / {h[2]['mean_closest']:.2f} / "
            + " ".join(f"{SHORT[k]}{v}" for k, v in h[2]["endings"].items())
            for h in r["history"]
        ]
        lines.append(f"- seed {r['seed']}: " + "; ".join(parts))
    if any(r.get("training") for r in rows):
        lines += [
            "",
            "Training episodes per window (the curriculum's task, stochastic actions; steps: success % "
            "of the episodes ended in the window / mean length in steps / goal x m / reach sphere m):",
            "",
        ]
        for r in rows:
            parts = [
                f"{t['step'] // 1000}k: {100 * t['success']:.0f} / {t['length']:.0f} / "
                + (f"{t['goal_x']:.2f} / {t['reach']:.2f}" if t["goal_x"] is not None else "- / -")
                for t in r.get("training", [])
            ]
            lines.append(f"- seed {r['seed']}: " + "; ".join(parts))
    lines.append("")
    lines.append("(endings: " + ", ".join(f"{v} = {k}" for k, v in SHORT.items()) + "; raw: `learn_obstacles.json`)")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument(
        "--cpu-minutes", type=float, default=30.0, help="training CPU-time budget per run [min] (0: none)"
    )
    parser.add_argument("--probe-every", type=int, default=100_000)
    parser.add_argument("--episodes", type=int, default=10, help="episodes per probe")
    parser.add_argument("--set", nargs="*", default=[], help="training overrides (key=value) for every run")
    parser.add_argument("--write", action="store_true", help="append to the results file, write .json and .png")
    parser.add_argument("--save-rows", type=Path, help="write each run's results here (JSON) at every probe")
    parser.add_argument(
        "--keep-runs",
        type=Path,
        help="keep the run directories here (default: a temporary folder); with --from-rows: read them from here",
    )
    parser.add_argument("--from-rows", type=Path, nargs="+", help="no training: report the runs saved by --save-rows")
    parser.add_argument("--title", default="", help="a few words for the results section's heading")
    parser.add_argument(
        "--diagnose", type=Path, nargs="+", help="no training: fly these runs' newest checkpoints four ways"
    )
    args = parser.parse_args()
    cpu_minutes = args.cpu_minutes or None
    if args.diagnose:
        for run_dir in args.diagnose:
            print("\n".join(diagnose(run_dir, args.episodes)) + "\n", flush=True)
        return

    rows: list[dict] = []
    if args.from_rows:
        for path in args.from_rows:
            rows += json.loads(path.read_text())
        rows.sort(key=lambda r: r["seed"])
        for r in rows:  # runs saved before they finished: their training episodes from the kept run directory
            if not r.get("training") and args.keep_runs:
                found = sorted((args.keep_runs / ENV / "ppo").glob(f"*-seed{r['seed']}"))
                if found:
                    r["run_dir"], r["training"] = str(found[-1]), training_success(found[-1], r["probe_every"])
    else:
        rows = run_seeds(args, cpu_minutes, env=ENV, target=TARGET)
    lines = [*section_head("learn_obstacles.py", args, rows), *table(rows)]
    summary, data = rliable_summary(rows)
    lines += summary
    lines += probes_text(rows)
    if args.write and "curve" in data:
        png = RESULTS.with_suffix(".png")
        plot_curve(
            data,
            png,
            f"QuadX-Obstacles, PPO, seeds {', '.join(str(r['seed']) for r in rows)}",
            key="success",
            ylabel="success fraction, probe",
            legend="upper left",
        )
        lines.append(f"\nCurve: `{png.name}` (IQM and 95 % CI of the probe success fraction; grey: each seed).")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.write:
        data["command"] = "python experiments/learn_obstacles.py " + " ".join(sys.argv[1:])
        RESULTS.with_suffix(".json").write_text(json.dumps(data, indent=1) + "\n")
        if not RESULTS.exists():
            RESULTS.write_text(
                "# QuadX-Obstacles: how often the goal is reached through the forest (experiments/learn_obstacles.py)\n"
            )
        with RESULTS.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()

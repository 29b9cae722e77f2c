"""How many waypoints does a waypoint-task agent reach, and after how much training?

Trains what ``pyflyt train env=<env> algo=<algo>`` trains (``--env quadx_waypoints``, the
default, ``quadx_waypoints_velocity`` or ``fixedwing_waypoints``; ``conf/train.yaml`` with the env's tuning
``conf/hparams/<env>_<algo>.yaml`` when there is one; ``--set key=value ...`` adds
overrides) and every ``--probe-every`` steps flies the
current policy (deterministic) for ``--episodes`` seeded episodes (seeds 10 000+),
counting per episode the waypoints reached (of 5) and how it ended (crash, left the
flight dome, time limit, all reached).  Progress is the fraction of probe episodes that
reach at least 1, 2, ..., 5 waypoints, not the return: the dense reward pays for
approaching a waypoint whether or not it is ever reached.  The targets: >= 80 % of the
episodes reach every waypoint within 30 minutes of training on 2 cores (QuadX), >= 50 %
within 60 minutes (Fixedwing).

Reported per seed: the probes, the first probe at which the target fraction reaches every waypoint
(steps, wall-clock, and wall-clock without the probes' cost), and where the training
time went: stepping the environments (timed at the vector env), the rest of the
collection (policy forward passes, buffers, callbacks), the updates and the run's own
evaluations (the probes' cost taken out); across seeds: IQM with 95 % stratified-
bootstrap intervals (rliable, through ``pyflyt_cli.plotting.stats``) of the final
policy's mean waypoints reached and fractions reaching 1 and all 5.  ``--write`` appends
a section to ``experiments/results/learn_waypoints.md`` (velocity mode:
``learn_waypoints_velocity.md``; Fixedwing: ``learn_fixedwing_waypoints.md``) and writes the raw probes and the curve beside it
(``.json``, ``.png``).

    python experiments/learn_waypoints.py [--env quadx_waypoints] [--algo ppo] [--seeds 0 1 2] [--budget N] \\
        [--probe-every 100000] [--episodes 10] [--set KEY=VALUE ...] [--keep-runs DIR] [--write]
    python experiments/learn_waypoints.py --probe-run RUN_DIR [--after STEPS] [--episodes 10]
    python experiments/learn_waypoints.py --probe-run RUN_DIR --as-evaluations [--probe-every 100000] [--eval-episodes N] [--after STEPS]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pyflyt_cli.studies.probes import PROBE_SEED, WaypointProbe, waypoint_probe
from pyflyt_cli.studies.report import iqm_summary, plot_curve
from pyflyt_cli.studies.runs import SavedPolicy, checkpoint_policies, phase_split
from pyflyt_cli.training import compose_config, train

RESULTS_DIR = Path(__file__).resolve().parent / "results"
#: env -> (results file, fraction of the evaluation episodes that must reach every waypoint, title)
TASKS = {
    "quadx_waypoints": (RESULTS_DIR / "learn_waypoints.md", 0.8, "QuadX-Waypoints"),
    "quadx_waypoints_velocity": (
        RESULTS_DIR / "learn_waypoints_velocity.md",
        0.8,
        "QuadX-Waypoints, velocity flight mode",
    ),
    "fixedwing_waypoints": (RESULTS_DIR / "learn_fixedwing_waypoints.md", 0.5, "Fixedwing-Waypoints"),
}


def probe_run(run_dir: Path, episodes: int, after: int = 0) -> list[tuple[int, dict]]:
    """The probe of every checkpoint of a run directory after step ``after`` (e.g. a run extended
    with ``pyflyt train resume=<run> train.total_timesteps=N``), on the env the run trained on."""
    out = []
    for step, model, normalize, _, env in checkpoint_policies(run_dir, after):
        probe = waypoint_probe(SavedPolicy(model, normalize), env, episodes, seed=PROBE_SEED)
        out.append((step, probe))
        at_least = " ".join(f"{100 * f:3.0f}" for f in probe["at_least"])
        print(
            f"  {step:>8} steps  >=k reached [%]: {at_least}  mean {probe['mean_reached']:.1f}  "
            f"endings {probe['endings']}  return {probe['mean_return']:8.1f}",
            flush=True,
        )
    return out


def replay_evaluations(
    run_dir: Path, every: int, after: int = 0, episodes: int | None = None
) -> list[tuple[int, dict]]:
    """Every checkpoint after ``after`` at a multiple of ``every`` steps flown as the run's own
    evaluation flies it (``train.eval_episodes``, or ``episodes``, from seed + 1000,
    deterministic as configured), and which one ``best_model.pt`` keeps under each
    ``train.best_by`` (the training loop's own ranking).  Evaluations do not change training,
    so this is what a run evaluating at the checkpoints' steps would have recorded."""
    from pyflyt_cli.training.callbacks import BEST_BY, better_evaluation
    from pyflyt_cli.training.evaluation import EVAL_SEED_OFFSET, policy_predict, run_episodes, summarize

    out = []
    for step, model, normalize, cfg, env in checkpoint_policies(run_dir, after, every):
        flown = run_episodes(
            policy_predict(model),
            env,
            episodes or cfg.train.eval_episodes,
            cfg.seed + EVAL_SEED_OFFSET,
            cfg.train.eval_deterministic,
            normalize_obs=normalize,
        )
        summary = summarize(flown)
        out.append((step, summary))
        print(
            f"  {step:>8} steps  success {100 * summary['success_rate']:3.0f} %  return {summary['mean_return']:8.1f}",
            flush=True,
        )
    if out:
        kept = {}
        for best_by in BEST_BY:  # in step order, as the run's evaluations come
            best_return, best_success = -np.inf, None
            for step, summary in out:
                if better_evaluation(summary, best_return, best_success, best_by):
                    best_return, best_success, kept[best_by] = summary["mean_return"], summary["success_rate"], step
        print("best_model.pt: " + ", ".join(f"step {kept[b]} with best_by={b}" for b in BEST_BY))
    return out


def run(
    env: str,
    seed: int,
    algo: str,
    budget: int | None,
    every: int,
    episodes: int,
    output: Path,
    extra: tuple[str, ...] | list[str] = (),
) -> dict:
    overrides = [*extra, f"seed={seed}", f"train.output_dir={output}", "train.progress_bar=false"]
    if budget is not None:
        overrides.append(f"train.total_timesteps={budget}")
    cfg = compose_config(env=env, algo=algo, overrides=overrides)
    probe = WaypointProbe(cfg, every, episodes, TASKS[env][1])
    start = time.perf_counter()
    result = train(cfg, callbacks=[probe], log=lambda line: print(f"    {line}", flush=True))
    wall = time.perf_counter() - start
    split = phase_split(Path(result.run_dir))
    if split:
        # the probes run inside the collection phase (from a callback's on_step): take them out
        collect = split.get("collect", 0.0) - probe.probe_time
        split = {
            "env": probe.env_time,
            "collect_other": collect - probe.env_time,
            "update": split.get("update", 0.0),
            "eval": split.get("eval", 0.0),
            "checkpoint": split.get("checkpoint", 0.0),
        }
    # else: a run stopped before its budget records no split of its time (its metrics end at the checkpoint)
    trained = result.elapsed - probe.probe_time  # learn() alone, without the run's set-up
    return {
        "env": env,
        "seed": seed,
        "algo": algo,
        "overrides": list(extra),
        "budget": cfg.train.total_timesteps,
        "probe_every": every,
        "episodes": episodes,
        "steps": result.num_timesteps,
        "target_at": probe.hover_at,
        "final": probe.history[-1][2] if probe.history else {},
        "best_mean_reached": max((h[2]["mean_reached"] for h in probe.history), default=0.0),
        "split": split,
        "steps_per_second": result.num_timesteps / max(trained, 1e-9),
        "wall": wall,  # the whole run: set-up, training, probes, final files
        "trained_wall": trained,
        "load": [min(probe.loads, default=0.0), max(probe.loads, default=0.0)],
        "history": probe.history,
    }


def rliable_summary(rows: list[dict], reps: int = 2000) -> tuple[list[str], dict]:
    """:func:`iqm_summary` of the final probe's waypoint measures, and the mean-waypoints-reached curve."""
    final = [r["final"] for r in rows]
    return iqm_summary(
        rows,
        [
            ("mean waypoints reached (of 5)", [f["mean_reached"] for f in final], 2),
            ("fraction reaching >= 1 waypoint", [f["at_least"][0] for f in final], 2),
            ("fraction reaching all 5", [f["all"] for f in final], 2),
            ("probe return", [f["mean_return"] for f in final], 1),
        ],
        reps,
        curve="mean_reached",
    )


def table(rows: list[dict], target: float) -> list[str]:
    lines = [
        "| seed | steps | final: >= 1 / 2 / 3 / 4 / 5 reached [%] | final: mean reached | final endings | best mean reached | "
        f">= {100 * target:.0f} % all at [steps] | CPU time to it [s] | training wall-clock [s] | steps/s | env / other collect / update / eval [s] | load |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        f, s, t = r["final"], r["split"], r["target_at"]
        cpu_to = f"{t[3]:.0f}" if t and len(t) > 3 else "-"  # rows saved before the CPU time was recorded: -
        lines.append(
            f"| {r['seed']} | {r['steps']} | {' / '.join(f'{100 * x:.0f}' for x in f['at_least'])} | "
            f"{f['mean_reached']:.1f} | {', '.join(f'{k} {v}' for k, v in f['endings'].items())} | "
            f"{r['best_mean_reached']:.1f} | {t[0] if t else 'not within budget'} | {cpu_to} | {r['trained_wall']:.0f} | "
            f"{r['steps_per_second']:.0f} | "
            + (
                f"{s['env']:.0f} / {s['collect_other']:.0f} / {s['update']:.0f} / {s['eval']:.0f}"
                if s
                else "- (stopped)"
            )
            + f" | {r['load'][0]:.1f}-{r['load'][1]:.1f} |"
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default="quadx_waypoints", choices=sorted(TASKS))
    parser.add_argument("--algo", default="ppo")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--budget", type=int, default=None, help="steps per run (default: the tuning's budget)")
    parser.add_argument("--probe-every", type=int, default=100_000)
    parser.add_argument("--episodes", type=int, default=10, help="episodes per probe")
    parser.add_argument("--set", nargs="*", default=[], help="training overrides (key=value) for every run")
    parser.add_argument("--write", action="store_true", help="append to the results file, write .json and .png")
    parser.add_argument("--save-rows", type=Path, help="also write each run's raw results here (JSON), seed by seed")
    parser.add_argument("--keep-runs", type=Path, help="keep the run directories here (default: a temporary folder)")
    parser.add_argument(
        "--from-rows", type=Path, nargs="+", help="no training: report the runs saved by earlier --save-rows"
    )
    parser.add_argument(
        "--probe-run", type=Path, help="no training: probe every checkpoint of this run directory (after --after steps)"
    )
    parser.add_argument("--after", type=int, default=0)
    parser.add_argument(
        "--as-evaluations",
        action="store_true",
        help="with --probe-run: fly each checkpoint as the run's own evaluation would, and say which best_by keeps",
    )
    parser.add_argument(
        "--eval-episodes", type=int, help="with --as-evaluations: episodes per evaluation (default: the run's)"
    )
    args = parser.parse_args()

    if args.probe_run and args.as_evaluations:
        from pyflyt_engine.errors import PyFlytError

        print(f"{args.probe_run}: its checkpoints every {args.probe_every} steps flown as its own evaluations")
        try:
            if not replay_evaluations(args.probe_run, args.probe_every, args.after, args.eval_episodes):
                sys.exit(f"{args.probe_run}: no checkpoint after step {args.after} (checkpoints/model_<N>_steps.pt)")
        except PyFlytError as exc:
            sys.exit(f"error: {exc}")
        return
    if args.probe_run:
        from pyflyt_engine.errors import PyFlytError

        print(f"{args.probe_run}: probes of its checkpoints ({args.episodes} episodes, seeds {PROBE_SEED}+)")
        try:
            if not probe_run(args.probe_run, args.episodes, args.after):
                sys.exit(f"{args.probe_run}: no checkpoint after step {args.after} (checkpoints/model_<N>_steps.pt)")
        except PyFlytError as exc:  # not a run directory, an unreadable config or checkpoint
            sys.exit(f"error: {exc}")
        return

    rows = []
    if args.from_rows:
        for path in args.from_rows:
            rows += json.loads(path.read_text())
        args.algo = rows[0]["algo"]
        args.env = rows[0].get("env", "quadx_waypoints")
        args.seeds = [r["seed"] for r in rows]
    else:
        with tempfile.TemporaryDirectory() as tmp:
            output = args.keep_runs or Path(tmp)
            for seed in args.seeds:
                print(f"seed {seed}:", flush=True)
                rows.append(
                    run(args.env, seed, args.algo, args.budget, args.probe_every, args.episodes, output, args.set)
                )
                if args.save_rows:  # a long study survives an interruption seed by seed
                    args.save_rows.write_text(json.dumps(rows, indent=1) + "\n")

    results, target, title = TASKS[args.env]
    command = "python experiments/learn_waypoints.py " + " ".join(sys.argv[1:])
    lines = [
        (
            f"\n## {time.strftime('%Y-%m-%d %H:%M')} — {title}, {args.algo}, budget {rows[0]['budget']} steps, "
            f"probe every {rows[0]['probe_every']} steps x {rows[0]['episodes']} episodes ({platform.machine()}, "
            f"{platform.python_version()})\n"
        ),
        f"```bash\n{command}\n```\n",
        *table(rows, target),
    ]
    summary, data = rliable_summary(rows)
    lines += summary
    if args.write and "curve" in data:
        png = results.with_suffix(".png")
        plot_curve(
            data,
            png,
            f"{title}, {args.algo}, seeds {', '.join(map(str, args.seeds))}",
            key="mean_reached",
            ylabel="waypoints reached (of 5), probe mean",
            legend="upper left",
        )
        lines.append(
            f"\nCurve: `{png.name}` (IQM and 95 % CI of the mean waypoints reached per probe; grey: each seed)."
        )
    text = "\n".join(lines) + "\n"
    print(text)
    if args.write:
        data["command"] = command
        results.with_suffix(".json").write_text(json.dumps(data, indent=1) + "\n")
        with results.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()

"""What one run of each env-algorithm pair of ``experiment=paper_rl`` costs, in CPU seconds.

Each of the 6 pairs of the preset (SAC on the two dense tasks; AWAC and CCGE on the sparse
ones) is trained once, seed 0, with exactly the settings the preset plans for it (the
run's ``pyflyt train`` line from the benchmark's plan), but for a short budget:
``learning_starts`` plus ``--steps`` steps; its reach-sphere curriculum is cut to that
budget (``pyflyt train`` refuses one that outlasts it).  AWAC and CCGE start from the final
policy of the short SAC run of their env (the preset starts them from SAC's checkpoint at
``partial_step``: same shapes, other weights).  The runs go one at a time, each in a fresh
process, in which ``time.perf_counter`` is the process's CPU clock, so every figure the run
itself prints (its time in training, the collect / update / eval / checkpoint split) is
CPU seconds of that process, not wall time on a shared machine.

The cost of a run at the preset's budget is extrapolated phase by phase, each from what
drives it:

- start-up (imports, composing, building the envs and the model, the ETA probe): once;
- collect: per env step (``train.total_timesteps``);
- update: per gradient step (``gradient_steps`` per round of ``n_envs x train_freq`` steps
  after ``learning_starts``);
- eval: per PyBullet step flown by the evaluations (their number from the preset's
  ``eval_freq``; ``eval_episodes`` each).  Episode lengths grow as a policy learns to stay
  up, so two figures: at the short run's mean episode length (low) and with every episode
  flown to the time limit (the bound);
- checkpoint: per replay-buffer transition written (each checkpoint writes the whole
  buffer, up to ``buffer_size``) -- measured on the short run's final checkpoint.

Usage (one training process at a time; nice it on a shared machine)::

    nice -n 10 python experiments/paper_rl_cost.py                   # paper preset, 64 000 steps each
    nice -n 10 python experiments/paper_rl_cost.py --steps 6400 --out /tmp/cost.md   # a quick look

writes ``experiments/results/paper_rl_cost.md`` (the table docs/benchmarks.md quotes).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "experiments" / "results" / "paper_rl_cost.md"
#: keys of a run's line this script sets itself
_REPLACED = ("run_dir=", "train.output_dir=", "init_from=", "train.total_timesteps=",
             "train.curriculum.goal_reach_distance.steps=")  # fmt: skip


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


# ------------------------------------------------------------------ one run (child)


def child(spec_file: Path, result_file: Path) -> None:
    """Train one short run in this process and write what it cost (CPU seconds)."""
    cpu_at_start = _cpu()
    from pyflyt_cli.training import loop
    from pyflyt_cli.training.compose import compose_run
    from pyflyt_engine.telemetry import read_metrics

    spec = json.loads(spec_file.read_text())

    lines: list[str] = []

    def log(message: str) -> None:
        lines.append(message)
        print(message, file=sys.stderr, flush=True)

    cfg, run_dir = compose_run(spec["line"])
    called = _cpu()
    # the run's own ledger, on this process's CPU clock: start-up, learn(), each checkpoint and evaluation
    result = loop.train(cfg, run_dir=run_dir, log=log, progress_bar=False, clock=time.process_time)
    cpu_total = _cpu() - cpu_at_start
    costs = result.costs
    assert costs is not None
    evals = read_metrics(result.run_dir)["/eval"]
    buffers = sorted((Path(result.run_dir) / "checkpoints").glob("replay_buffer_*.npz"))
    out = {
        "id": spec["id"],
        "steps": int(result.num_timesteps),
        "cpu_total": cpu_total,
        "cpu_startup": called - cpu_at_start + costs.startup,  # the imports and composing, then the run's start-up
        "cpu_learn": costs.learn,
        "split": costs.split,
        "checkpoints": [
            {"cpu": c.seconds, "buffer_cpu": c.buffer_seconds, "transitions": c.transitions} for c in costs.checkpoints
        ],
        "eval_cpu": costs.evaluations,
        "evals": [{"step": int(e["step"]), "mean_length": float(e["mean_length"])} for e in evals],
        "buffer_bytes": buffers[-1].stat().st_size if buffers else 0,
        "max_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "lines": lines,
        "config": cfg.model_dump(mode="json"),
    }
    result_file.write_text(json.dumps(out, indent=1))


# ------------------------------------------------------------------ the plan (parent)


def _rounds_after(cfg: dict, total: int) -> int:
    """Gradient steps a run of ``total`` steps takes (SB3 trains once ``num_timesteps > learning_starts``)."""
    a, t = cfg["algo"], cfg["train"]
    per_round = int(a.get("train_freq", 1)) * int(t["n_envs"])
    rounds = max(0, (total - int(a["learning_starts"])) // per_round)
    return rounds * int(a["gradient_steps"])


def _checkpoint_transitions(cfg: dict, total: int) -> tuple[int, int]:
    """The checkpoints a from-scratch run saves (every ``checkpoint_freq`` and the end) and the replay-buffer
    transitions they write together (each the whole buffer, at most ``buffer_size``)."""
    t = cfg["train"]
    freq, cap = int(t["checkpoint_freq"]), int(cfg["algo"]["buffer_size"])
    steps = [*(range(freq, total, freq) if freq > 0 else []), total]
    return len(steps), sum(min(s, cap) for s in steps)


def extrapolate(measured: dict, full: dict, short: dict, max_steps: int) -> dict:
    """CPU seconds of a run at ``full``'s budget, phase by phase, from the short run ``measured``."""
    from pyflyt_cli.benchmark.plan import evaluation_steps

    split, steps = measured["split"], measured["steps"]
    total_full = int(full["train"]["total_timesteps"])
    grad_short, grad_full = _rounds_after(short, steps), _rounds_after(full, total_full)
    episodes = int(full["train"]["eval_episodes"])
    eval_steps_short = sum(e["mean_length"] for e in measured["evals"]) * int(short["train"]["eval_episodes"])
    per_eval_step = sum(measured["eval_cpu"]) / eval_steps_short
    n_evals_full = len(evaluation_steps(full))
    mean_len = sum(e["mean_length"] for e in measured["evals"]) / len(measured["evals"])
    cks = measured["checkpoints"]
    per_transition = sum(c["buffer_cpu"] for c in cks) / max(1, sum(c["transitions"] for c in cks))
    fixed = sum(c["cpu"] - c["buffer_cpu"] for c in cks) / len(cks)  # the model, optimisers, state, metrics
    n_ck_full, trans_full = _checkpoint_transitions(full, total_full)
    out = {
        "startup": measured["cpu_startup"],
        "collect": split["collect"] / steps * total_full,
        "update": split["update"] / grad_short * grad_full,
        "eval_low": per_eval_step * n_evals_full * episodes * mean_len,
        "eval_high": per_eval_step * n_evals_full * episodes * max_steps,
        "checkpoint": n_ck_full * fixed + per_transition * trans_full,
        "n_checkpoints": n_ck_full,
        "n_evals": n_evals_full,
        "grad_steps": grad_full,
        "mean_eval_length": mean_len,
        "per_update_ms": 1000 * split["update"] / grad_short,
        "per_eval_step_ms": 1000 * per_eval_step,
    }
    base = out["startup"] + out["collect"] + out["update"] + out["checkpoint"]
    out["total_low"], out["total_high"] = base + out["eval_low"], base + out["eval_high"]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--preset", default="paper", help="benchmark.preset of experiment=paper_rl (default paper)")
    parser.add_argument("--steps", type=int, default=64_000, help="steps each short run trains after learning_starts")
    parser.add_argument("--seeds", type=int, default=50, help="seeds per pair the total is given for")
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--work", type=Path, default=None, help="where the short runs go (default: a temporary folder)")
    parser.add_argument("--child", nargs=2, type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(*args.child)
        return

    from pyflyt_cli.benchmark.plan import plan_benchmark
    from pyflyt_cli.training.schema import parse_train_config

    work = args.work or Path(tempfile.mkdtemp(prefix="paper_rl_cost-"))
    work.mkdir(parents=True, exist_ok=True)
    plan = plan_benchmark("paper_rl", [f"benchmark.preset={args.preset}", "seeds=1", f"benchmark.output_dir={work}"])
    load = os.getloadavg()
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    rows, sac_model = [], {}
    for job in plan.jobs:  # SAC first: the plan's order
        full = job.config
        short_total = int(full["algo"]["learning_starts"]) + args.steps
        line = [o for o in job.overrides if not o.startswith(_REPLACED)]
        run_dir = work / "short" / job.task / job.algo
        line += [f"run_dir={run_dir}", f"train.output_dir={work / 'short'}", f"train.total_timesteps={short_total}"]
        if full["train"].get("curriculum"):
            line.append(f"train.curriculum.goal_reach_distance.steps={short_total}")
        if job.depends_on is not None:
            line.append(f"init_from={sac_model[job.env]}")
        spec, result = work / f"{job.task}-{job.algo}.json", work / f"{job.task}-{job.algo}.result.json"
        spec.write_text(json.dumps({"id": job.id, "line": line}))
        print(f"== {job.id}: {short_total} steps", flush=True)
        proc = subprocess.run([sys.executable, __file__, "--child", str(spec), str(result)], cwd=ROOT, check=False)
        if proc.returncode != 0:
            raise SystemExit(f"{job.id}: the short run failed (exit {proc.returncode})")
        measured = json.loads(result.read_text())
        if job.algo == "sac":
            sac_model[job.env] = run_dir / "model.pt"
        short = measured["config"]
        max_steps = parse_train_config(full).env.max_steps
        rows.append((job, measured, extrapolate(measured, full, short, max_steps)))
    load_end = os.getloadavg()
    _write(args, plan, rows, started, load, load_end)


def _write(args, plan, rows, started, load, load_end) -> None:
    cpu = platform.processor() or platform.machine()
    try:
        cpu = next(
            x.split(":", 1)[1].strip()
            for x in Path("/proc/cpuinfo").read_text().splitlines()
            if x.startswith("model name")
        )
    except (OSError, StopIteration):
        pass
    preset = plan.spec["presets"][args.preset]
    seeds = args.seeds
    out = [
        f"# `experiment=paper_rl`, preset `{args.preset}`: CPU cost per run",
        "",
        f"Measured {started} on {os.cpu_count()} cores ({cpu}), shared with other jobs: load average "
        f"{load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} at the start, {load_end[0]:.2f} / {load_end[1]:.2f} / "
        f"{load_end[2]:.2f} at the end (/proc/loadavg, 1 / 5 / 15 min).  Produced by",
        "",
        "```bash",
        f"nice -n 10 python experiments/paper_rl_cost.py --preset {args.preset} --steps {args.steps}",
        "```",
        "",
        f"Each pair trained once (seed 0) with the preset's settings (backend `{preset.get('backend')}`, "
        f"{preset.get('n_envs')} envs, {preset.get('gradient_steps')} gradient steps per vector step, SAC "
        f"{preset.get('sac_n_steps')}-step returns) for `learning_starts` + {args.steps} steps, in its own "
        "process, with CPU seconds on every clock the run reads; the cost at the preset's budget is extrapolated "
        "per phase from what drives it (experiments/paper_rl_cost.py's docstring).  Eval: low at the short run's "
        "mean evaluation episode length, high with every episode flown to the time limit.",
        "",
        "| pair | short run: steps, CPU s | its split: collect / update / eval / checkpoint | ms per update | "
        "per run at the preset: start-up + collect + update + checkpoint + eval (low-high) | CPU s per run |",
        "|---|---|---|---:|---|---:|",
    ]
    low = high = 0.0
    for job, m, e in rows:
        s = m["split"]
        tot = sum(s.values())
        pct = " / ".join(f"{100 * s[k] / tot:.0f} %" for k in ("collect", "update", "eval", "checkpoint"))
        out.append(
            f"| {job.task}/{job.algo} | {m['steps']}, {m['cpu_total']:.0f} | {pct} | {e['per_update_ms']:.2f} | "
            f"{e['startup']:.0f} + {e['collect']:.0f} + {e['update']:.0f} + {e['checkpoint']:.0f} + "
            f"{e['eval_low']:.0f}-{e['eval_high']:.0f} ({e['n_evals']} evaluations) | "
            f"{e['total_low']:.0f}-{e['total_high']:.0f} |"
        )
        low, high = low + e["total_low"], high + e["total_high"]
    n = len(rows)
    out += [
        "",
        f"One seed of all {n} pairs: {low:.0f}-{high:.0f} CPU s ({low / 3600:.2f}-{high / 3600:.2f} CPU-hours); "
        f"{seeds} seeds x {n} pairs ({seeds * n} runs): **{seeds * low / 3600:.0f}-{seeds * high / 3600:.0f} CPU-hours** "
        "(one core per run).",
        "",
    ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(out))
    print("\n".join(out))


if __name__ == "__main__":
    main()

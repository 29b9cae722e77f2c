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
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from learn_hover_ppo import plot_curve, probe_curve  # this folder: the IQM curve and its plot
from learn_waypoints import PROBE_SEED, WaypointProbe, _phase_split, iqm_cell  # probe schedule, env timing, IQM cells

from pyflyt_cli.training import compose_config, train

RESULTS = Path(__file__).resolve().parent / "results" / "learn_obstacles.md"
ENV = "quadx_obstacles"
TARGET = 0.7  # the target: >= 70 % of the episodes succeed
ENDINGS = ("reached", "trunk", "ground", "out", "time")
SHORT = {"reached": "R", "trunk": "T", "ground": "G", "out": "O", "time": "L"}  # L: the time limit


def ending(info: dict, truncated: bool) -> str:
    """How an episode ended, from its last ``info``: reached (success), trunk, ground, out (of the dome) or time."""
    if info.get("success"):
        return "reached"
    if info.get("obstacle_contact"):
        return "trunk"
    if info.get("collision"):
        return "ground"
    if info.get("out_of_bounds"):
        return "out"
    return "time" if truncated else "ground"


def obstacle_probe(model, env, episodes: int, seed: int, task: dict | None = None, deterministic: bool = True) -> dict:
    """Fly ``episodes`` episodes (seeds ``seed``, ``seed + 1``, ...; deterministic actions unless told;
    the configured task, or other values of its episode options ``task``): success fraction,
    endings, closest approach to the goal [m], mean speed [m/s], episode length [s] and return."""
    vec = model.get_vec_normalize_env()
    base = env.unwrapped
    successes, endings, closest, speeds, lengths, returns = [], [], [], [], [], []
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i, options={"task": task} if task else None)
        goal = [float(v) for v in base.task.goal]
        done, total, info, truncated, steps = False, 0.0, {}, False, 0
        nearest, speed_sum = math.inf, 0.0
        while not done:
            x = vec.normalize_obs(obs) if vec is not None and vec.norm_obs else obs
            action, _ = model.predict(x, deterministic=deterministic)
            obs, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            steps += 1
            nearest = min(nearest, math.dist([float(v) for v in base.state.lin_pos], goal))
            speed_sum += math.hypot(*(float(v) for v in base.state.lin_vel))
            done = terminated or truncated
        successes.append(bool(info.get("success")))
        endings.append(ending(info, truncated))
        closest.append(0.0 if info.get("success") else nearest)
        speeds.append(speed_sum / steps)
        lengths.append(steps / base.config.agent_hz)
        returns.append(total)
    return {
        "success": float(np.mean(successes)),
        "successes": successes,
        "endings": {e: endings.count(e) for e in ENDINGS if e in endings},
        "episode_endings": endings,
        "closest": [round(c, 3) for c in closest],
        "mean_closest": float(np.mean(closest)),
        "mean_speed": float(np.mean(speeds)),
        "mean_length": float(np.mean(lengths)),
        "mean_return": float(np.mean(returns)),
    }


class ObstacleProbe(WaypointProbe):
    """:class:`learn_waypoints.WaypointProbe` (schedule, env timing, load) with :func:`obstacle_probe`,
    a CPU-time budget (``cpu_budget`` seconds of training, the probes' CPU time excluded) and a
    ``save`` hook called after every probe (the partial results on disk)."""

    def __init__(self, cfg, every: int, episodes: int, target: float, cpu_budget: float | None, save=None) -> None:
        super().__init__(cfg, every, episodes, target)
        self.probe_fn = obstacle_probe
        self.cpu_budget, self.save = cpu_budget, save
        self.env_name = cfg.env_name
        self.imitates = cfg.train.imitation is not None and cfg.train.imitation.oracle is not None
        # the clocks start here, just before `train`: a tuning's imitation stage (DAgger, run
        # before learning starts) is part of the budget and of the wall-clock
        self.cpu_started = time.process_time()
        self.started = time.perf_counter()
        self.probe_cpu = 0.0
        self.stopped_by_budget = False

    def _on_training_start(self) -> None:
        started = self.started
        super()._on_training_start()
        self.started = started
        if self.imitates:
            self.probe()  # the policy the imitation stage left, before reinforcement learning

    def training_cpu(self) -> float:
        """CPU seconds of this process since learning started, without the probes'."""
        return time.process_time() - self.cpu_started - self.probe_cpu

    def _on_step(self) -> bool:
        if not super()._on_step():
            return False
        if self.cpu_budget is not None and self.training_cpu() >= self.cpu_budget:
            self.stopped_by_budget = True
            return False
        return True

    def describe(self, probe: dict) -> str:
        """The task's measures of one probe, for its progress line."""
        return (
            f"success {100 * probe['success']:3.0f} %  endings {probe['endings']}  "
            f"closest {probe['mean_closest']:.2f} m  speed {probe['mean_speed']:.2f} m/s  "
            f"length {probe['mean_length']:.1f} s  return {probe['mean_return']:8.1f}"
        )

    def probe(self) -> None:
        t0, c0 = time.perf_counter(), time.process_time()
        probe = self.probe_fn(self.model, self.env, self.episodes, seed=PROBE_SEED)
        self.probe_time += time.perf_counter() - t0
        self.probe_cpu += time.process_time() - c0
        wall = time.perf_counter() - self.started
        cpu = self.training_cpu()
        load = os.getloadavg()[0]
        self.loads.append(load)
        probe.update(cpu=cpu, load=load)
        self.history.append((self.num_timesteps, wall, probe))
        print(
            f"  {self.num_timesteps:>8} steps  CPU {cpu / 60:5.1f} min  wall {wall / 60:5.1f} min (load {load:.1f})  "
            + self.describe(probe),
            flush=True,
        )
        if self.hover_at is None and probe["success"] >= self.target:
            self.hover_at = (self.num_timesteps, wall, cpu)
        if self.save is not None:
            self.save(self)


def row(probe: ObstacleProbe, seed: int, every: int, episodes: int, extra, cpu_minutes, status: str, **more) -> dict:
    """One seed's results from its probe callback (partial while ``status`` is ``running``)."""
    history = probe.history
    return {
        "env": probe.env_name,
        "seed": seed,
        "overrides": list(extra),
        "cpu_minutes": cpu_minutes,
        "probe_every": every,
        "episodes": episodes,
        "status": status,
        "steps": history[-1][0] if history else 0,
        "target_at": probe.hover_at,  # (steps, wall [s], training CPU [s]) of the first probe >= target
        "final": history[-1][2] if history else {},
        "best_success": max((h[2]["success"] for h in history), default=0.0),
        "training_cpu": probe.training_cpu(),
        "probe_cpu": probe.probe_cpu,
        "load": [min(probe.loads, default=0.0), float(np.mean(probe.loads)) if probe.loads else 0.0,
                 max(probe.loads, default=0.0)],
        "history": history,
        **more,
    }


def run(
    seed: int, cpu_minutes: float | None, every: int, episodes: int, output: Path, extra=(), save=None,
    env: str = ENV, target: float = TARGET, probe_cls: type[ObstacleProbe] | None = None,
) -> dict:
    """Train one seed of ``env`` (PPO, its shipped tuning and ``extra`` overrides) under the CPU
    budget, probing with ``probe_cls`` (default :class:`ObstacleProbe`); ``save`` gets the row
    after every probe."""
    overrides = [*extra, f"seed={seed}", f"train.output_dir={output}", "train.progress_bar=false", "train.eval_freq=0"]
    cfg = compose_config(env=env, algo="ppo", overrides=overrides)
    budget = None if cpu_minutes is None else 60.0 * cpu_minutes

    def partial(p: ObstacleProbe) -> None:
        if save is not None:
            save(row(p, seed, every, episodes, extra, cpu_minutes, "running", wall=time.perf_counter() - start))

    start, cpu0 = time.perf_counter(), time.process_time()  # before the probe's clocks start
    probe = (probe_cls or ObstacleProbe)(cfg, every, episodes, target, budget, save=partial)
    result = train(cfg, callbacks=[probe], log=lambda line: print(f"    {line}", flush=True))
    wall, process_cpu = time.perf_counter() - start, time.process_time() - cpu0
    split = _phase_split(Path(result.run_dir))
    if split:  # the probes run inside the collection phase (from a callback's on_step): take them out
        collect = split.get("collect", 0.0) - probe.probe_time
        split = {"env": probe.env_time, "collect_other": collect - probe.env_time, "update": split.get("update", 0.0)}
    status = "cpu budget" if probe.stopped_by_budget else "stopped" if result.interrupted else "step budget"
    training = training_success(Path(result.run_dir), every)
    out = row(
        probe, seed, every, episodes, extra, cpu_minutes, status,
        wall=wall, process_cpu=process_cpu, step_budget=cfg.train.total_timesteps, split=split,
        cpu_steps_per_second=result.num_timesteps / max(probe.training_cpu(), 1e-9),
        run_dir=str(result.run_dir), training=training,
    )
    if save is not None:
        save(out)
    return out


def training_success(run_dir: Path, every: int) -> list[dict]:
    """The run's own training episodes (``/train/episode`` of its metrics: the curriculum's task,
    stochastic actions) per window of ``every`` steps: episodes ended, success fraction, mean
    length [steps], and the curriculum's goal x and reach sphere at the window's end."""
    import warnings

    from pyflyt_engine.telemetry import read_metrics

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        metrics = read_metrics(run_dir)
    episodes = [dict(e) for e in metrics.get("/train/episode", [])]
    stages = [dict(c) for c in metrics.get("/train/curriculum", [])]
    out = []
    for end in range(every, (max((e["step"] for e in episodes), default=0) // every + 1) * every + 1, every):
        window = [e for e in episodes if end - every < e["step"] <= end]
        if not window:
            continue
        stage = [c for c in stages if c["step"] <= end]
        out.append({
            "step": end,
            "episodes": len(window),
            "success": sum(bool(e["success"]) for e in window) / len(window),
            "length": sum(e["length"] for e in window) / len(window),
            "goal_x": stage[-1].get("goal_x_range[0]") if stage else None,
            "reach": stage[-1].get("goal_reach_distance") if stage else None,
        })
    return out


def diagnose(run_dir: Path, episodes: int) -> list[str]:
    """The run's newest checkpoint flown on the probe episodes four ways: the full task and the
    curriculum's task where the run stopped, each with deterministic and with sampled actions
    (sampling from seed 0 of torch's generator): is a gap between the probes and the training
    episodes the distance to the goal or the action noise?"""
    import warnings

    import torch
    from learn_waypoints import _checkpoint_policies, _SavedPolicy

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
    for step, model, normalize, _, env in _checkpoint_policies(run_dir, after=newest - 1):  # the newest alone
        policy = _SavedPolicy(model, normalize)
        lines += [
            f"{run_dir.name}, checkpoint at {step} steps, {episodes} episodes (seeds {PROBE_SEED}+):", "",
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


def common_prefix(rows: list[dict]) -> list[dict]:
    """The rows with their histories cut to the probe steps every run shares (runs stopped by a
    CPU budget stop at different steps; the regular probes are at the same multiples)."""
    steps = [[h[0] for h in r["history"]] for r in rows]
    n = 0
    while all(len(s) > n for s in steps) and len({s[n] for s in steps}) == 1:
        n += 1
    return [{**r, "history": r["history"][:n]} for r in rows]


def iqm_summary(rows: list[dict], measures: list[tuple[str, list[float], int]], reps: int = 2000) -> tuple[list[str], dict]:
    """IQM over seeds with 95 % stratified-bootstrap CIs of each measure ``(label, one value per
    seed, decimals)``, and the probe ``success`` curve over the probe steps every seed reached."""
    lines = [
        "",
        f"IQM over {len(rows)} seeds of the final policy's probe, 95 % stratified-bootstrap CI ({reps} replicates, rliable):",
        "",
        "| measure | IQM [95 % CI] |",
        "|---|---|",
        *(f"| {label} | {iqm_cell(values, digits, reps)} |" for label, values, digits in measures),
    ]
    data: dict = {"rows": rows}
    curve = probe_curve(common_prefix(rows), "success", reps)
    if curve is not None:
        data["curve"] = curve
    return lines, data


def rliable_summary(rows: list[dict], reps: int = 2000) -> tuple[list[str], dict]:
    """:func:`iqm_summary` of the final probe's success, closest approach and return."""
    final = [r["final"] for r in rows]
    return iqm_summary(rows, [
        ("success fraction (goal reached without contact)", [f["success"] for f in final], 2),
        ("best probe's success fraction", [r["best_success"] for r in rows], 2),
        ("closest approach to the goal [m] (0 when reached)", [f["mean_closest"] for f in final], 2),
        ("probe return", [f["mean_return"] for f in final], 1),
    ], reps)


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
        lines += ["", "Training episodes per window (the curriculum's task, stochastic actions; steps: success % "
                  "of the episodes ended in the window / mean length in steps / goal x m / reach sphere m):", ""]
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


def run_seeds(args: argparse.Namespace, cpu_minutes: float | None, **run_kwargs) -> list[dict]:
    """:func:`run` for every seed of ``args.seeds`` in turn (run folders in ``args.keep_runs`` or a
    temporary one), each seed's row written to ``args.save_rows`` after every probe."""
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        output = args.keep_runs or Path(tmp)
        for seed in args.seeds:
            print(f"seed {seed}:", flush=True)

            def save(current: dict, done: list[dict] = list(rows)) -> None:
                if args.save_rows:  # every probe: a stopped run keeps what it measured
                    args.save_rows.write_text(json.dumps([*done, current], indent=1) + "\n")

            rows.append(run(seed, cpu_minutes, args.probe_every, args.episodes, output, args.set, save, **run_kwargs))
    return rows


def section_head(script: str, args: argparse.Namespace, rows: list[dict]) -> list[str]:
    """A results section's heading (date, budget, probes, machine), the command and the overrides."""
    command = f"python experiments/{script} " + " ".join(sys.argv[1:])
    r0 = rows[0]
    return [
        (
            f"\n## {time.strftime('%Y-%m-%d %H:%M')} — {args.title + ', ' if args.title else ''}PPO, "
            f"{r0['cpu_minutes']} CPU-minutes per seed, probe every {r0['probe_every']} steps x {r0['episodes']} "
            f"episodes ({platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()})\n"
        ),
        f"```bash\n{command}\n```\n",
        f"Overrides beyond the shipped tuning: {', '.join(r0['overrides']) or 'none'}.\n",
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--cpu-minutes", type=float, default=30.0, help="training CPU-time budget per run [min] (0: none)")
    parser.add_argument("--probe-every", type=int, default=100_000)
    parser.add_argument("--episodes", type=int, default=10, help="episodes per probe")
    parser.add_argument("--set", nargs="*", default=[], help="training overrides (key=value) for every run")
    parser.add_argument("--write", action="store_true", help="append to the results file, write .json and .png")
    parser.add_argument("--save-rows", type=Path, help="write each run's results here (JSON) at every probe")
    parser.add_argument(
        "--keep-runs", type=Path,
        help="keep the run directories here (default: a temporary folder); with --from-rows: read them from here",
    )
    parser.add_argument("--from-rows", type=Path, nargs="+", help="no training: report the runs saved by --save-rows")
    parser.add_argument("--title", default="", help="a few words for the results section's heading")
    parser.add_argument("--diagnose", type=Path, nargs="+", help="no training: fly these runs' newest checkpoints four ways")
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
        rows = run_seeds(args, cpu_minutes)
    lines = [*section_head("learn_obstacles.py", args, rows), *table(rows)]
    summary, data = rliable_summary(rows)
    lines += summary
    lines += probes_text(rows)
    if args.write and "curve" in data:
        png = RESULTS.with_suffix(".png")
        plot_curve(
            data, png, f"QuadX-Obstacles, PPO, seeds {', '.join(str(r['seed']) for r in rows)}",
            key="success", ylabel="success fraction, probe", legend="upper left",
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

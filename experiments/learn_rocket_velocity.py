"""Does an agent learn Rocket-Landing through a rocket autopilot mode, within 60 CPU-minutes?

Trains what ``pyflyt train env=<env> algo=ppo`` trains (``--env``: ``rocket_landing_velocity``,
the velocity mode, or ``rocket_landing_descent``, the descent mode; ``conf/train.yaml`` with
the shipped tuning ``conf/hparams/<env>_ppo.yaml`` when there is one; ``--set key=value
...`` adds overrides), and at fixed points flies the current policy
(deterministic) for ``--episodes`` seeded drops (seeds 10 000+): after the run's start
(the imitation stage, if the tuning has one, is then done), every ``--probe-every``
steps and at the end.  Progress is the fraction of safe landings (the paper's criterion,
the task's ``safe_landing``), not the return; each probe also says how the other
episodes ended (fatal touchdown on the pad, ground contact beside it, dome exit, time
limit), the touchdown speeds, the distance to the pad centre at the end and the fuel left.

Each run stops at ``--cpu-minutes`` of CPU time of its process (``time.process_time()``:
all threads, the imitation stage included, the probes' own cost taken out), or earlier
at the configured ``train.total_timesteps``.  The target (a stretch target of the
project): >= 50 % safe landings within 60 minutes of training on 2 cores; the machine
is shared, so the CPU-time budget of one process is conservative against it.  Across
seeds: IQM with 95 % stratified-bootstrap intervals (rliable, through
``pyflyt_cli.plotting.stats``) of the final probe's safe-landing fraction.  ``--write``
appends a section to ``experiments/results/learn_rocket_landing.md`` and writes the raw
probes beside it (``learn_<env>.json``).

    python experiments/learn_rocket_velocity.py [--env rocket_landing_descent] [--seeds 0 1 2] [--cpu-minutes 60] [--probe-every 100000] \\
        [--episodes 20] [--set KEY=VALUE ...] [--save-rows FILE] [--keep-runs DIR] [--write]
    python experiments/learn_rocket_velocity.py --from-rows FILE [FILE ...] [--write]   # report saved runs
    python experiments/learn_rocket_velocity.py --probe-model RUN_DIR [--model best|final|latest] [--episodes 20]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from pyflyt_cli.studies.report import iqm_summary
from pyflyt_cli.training import compose_config, train
from pyflyt_cli.training.envs import EnvFactory

#: the envs this script trains, each with the oracle its probes compare the policy with
ORACLE = {"rocket_landing_velocity": "rocket_velocity_lander", "rocket_landing_descent": "rocket_descent_lander"}
RESULTS = Path(__file__).resolve().parent / "results" / "learn_rocket_landing.md"
PROBE_SEED = 10_000
TARGET = 0.5
#: the Rocket's booster tank [kg] (conf/uav/rocket.yaml; the fuel state is a fraction of it)
TANK_KG = 410.9
#: the height [m] below which the rocket_velocity_lander oracle stops aiming and only approaches the
#: pad (pyflyt_engine/envs/oracles.py): how far off the pad axis an episode crosses it says how well it aimed
AIM_HEIGHT = 120.0
OUTCOMES = ("safe", "fatal", "ground", "dome exit", "time limit")


def outcome(info: dict) -> str:
    """How a Rocket-Landing episode ended, from its last ``info``."""
    for key, name in (
        ("safe_landing", "safe"),
        ("fatal_landing", "fatal"),
        ("ground_contact", "ground"),
        ("out_of_bounds", "dome exit"),
    ):
        if info.get(key):
            return name
    return "time limit"


#: height bands [m] of the comparison with the oracle: its aim, its approach, the last 10 m
BANDS = (
    ("aim (> 120 m)", AIM_HEIGHT, float("inf")),
    ("approach (10-120 m)", 10.0, AIM_HEIGHT),
    ("last 10 m", -float("inf"), 10.0),
)


def rocket_probe(predict, normalize, env, episodes: int, seed: int = PROBE_SEED, oracle=None) -> dict:
    """Fly ``episodes`` deterministic episodes (seeds ``seed``, ``seed + 1``, ...) with ``predict``
    (an SB3 model's ``predict``) on observations passed through ``normalize`` (or as they are).

    ``oracle`` (the ``rocket_velocity_lander`` built for ``env``): also compare, on the states
    the policy flies, its setpoint with the oracle's, per height band (:data:`BANDS`): the RMS
    difference of vx, vy, vz [m/s] and how often the two disagree on the ignition permission."""
    space = env.unwrapped.action_space
    low, span = space.low.astype(float), (space.high - space.low).astype(float)
    diffs: dict[str, list[np.ndarray]] = {name: [] for name, _, _ in BANDS}
    flights = []
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + i)
        done, total, info, steps, offset = False, 0.0, {}, 0, None
        while not done:
            if offset is None and obs[12] < AIM_HEIGHT:  # obs[10:13]: the position (as the oracles read it)
                offset = float(np.hypot(obs[10], obs[11]))
            action, _ = predict(normalize(obs) if normalize is not None else obs, deterministic=True)
            if oracle is not None:  # the policy's action in the env's units (the agent's [-1, 1] rescaled)
                flown = low + (np.clip(np.asarray(action, dtype=float), -1.0, 1.0) + 1.0) / 2.0 * span
                label = np.asarray(oracle(obs), dtype=float)
                band = next(name for name, lo, hi in BANDS if lo < obs[12] <= hi)
                diffs[band].append(np.append(flown[:3] - label[:3], float((flown[3] > 0.5) != (label[3] > 0.5))))
            obs, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            steps += 1
            done = terminated or truncated
        flights.append(
            {
                "seed": seed + i,
                "outcome": outcome(info),
                "steps": steps,
                "touchdown_speed": float(info["touchdown_speed"]),
                "pad_distance": float(info["pad_distance"]),
                "fuel_left_kg": float(env.unwrapped.vehicle.aux_state[4]) * TANK_KG,
                "offset_at_aim_height": offset,
                "return": total,
            }
        )
    ends = [f["outcome"] for f in flights]
    versus = {}
    for name, rows in diffs.items():
        if rows:
            d = np.asarray(rows)
            rms = np.sqrt(np.mean(d[:, :3] ** 2, axis=0))
            versus[name] = {
                "steps": len(d),
                "rms_vx": float(rms[0]),
                "rms_vy": float(rms[1]),
                "rms_vz": float(rms[2]),
                "ignition_disagrees": float(np.mean(d[:, 3])),
            }
    offsets = [f["offset_at_aim_height"] for f in flights if f["offset_at_aim_height"] is not None]
    touchdowns = [f["touchdown_speed"] for f in flights if f["touchdown_speed"] >= 0.0]
    return {
        "safe": float(np.mean([e == "safe" for e in ends])),
        "outcomes": {name: ends.count(name) for name in OUTCOMES if name in ends},
        "touchdown_speed_median": float(np.median(touchdowns)) if touchdowns else None,
        "pad_distance_median": float(np.median([f["pad_distance"] for f in flights])),
        "fuel_left_kg_mean": float(np.mean([f["fuel_left_kg"] for f in flights])),
        "offset_at_aim_height_median": float(np.median(offsets)) if offsets else None,
        "mean_return": float(np.mean([f["return"] for f in flights])),
        "versus_oracle": versus,
        "flights": flights,
    }


def describe(probe: dict) -> str:
    speed, offset = probe["touchdown_speed_median"], probe["offset_at_aim_height_median"]
    return (
        f"safe {100 * probe['safe']:3.0f} %  endings {probe['outcomes']}  touchdown (median) "
        + (f"{speed:.1f} m/s" if speed is not None else "-")
        + (f"  off the pad axis at {AIM_HEIGHT:.0f} m (median) {offset:.1f} m" if offset is not None else "")
        + f"  pad distance (median) {probe['pad_distance_median']:.1f} m  fuel left {probe['fuel_left_kg_mean']:.2f} kg"
        f"  return {probe['mean_return']:.0f}"
    )


class RocketProbe(BaseCallback):
    """Probes the policy when training starts (after any imitation stage), every ``every`` steps
    and at the end; stops the run once the process has used ``cpu_seconds`` of CPU outside the probes."""

    def __init__(self, cfg, every: int, episodes: int, cpu_seconds: float) -> None:
        super().__init__()
        self.env = EnvFactory(cfg.env, monitor=False)()
        self.every, self.episodes, self.cpu_seconds = every, episodes, cpu_seconds
        self.next = every
        self.cpu0 = time.process_time()
        self.probe_cpu = 0.0
        self.started = time.perf_counter()
        self.history: list[dict] = []
        self.loads: list[float] = []
        self.target_at: dict | None = None
        self.stopped_by_budget = False

    def training_cpu(self) -> float:
        return time.process_time() - self.cpu0 - self.probe_cpu

    def _on_training_start(self) -> None:
        self.probe()  # the policy the imitation stage (if any) left

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next:
            self.next += self.every
            self.probe()
        if self.training_cpu() >= self.cpu_seconds:
            self.stopped_by_budget = True
            return False
        return True

    def _on_training_end(self) -> None:
        if not self.history or self.history[-1]["step"] != self.num_timesteps:
            self.probe()

    def probe(self) -> None:
        c0 = time.process_time()
        vec = self.model.get_vec_normalize_env()
        normalize = vec.normalize_obs if vec is not None and vec.norm_obs else None
        probe = rocket_probe(self.model.predict, normalize, self.env, self.episodes)
        self.probe_cpu += time.process_time() - c0
        load = os.getloadavg()[0]
        self.loads.append(load)
        point = {
            "step": self.num_timesteps,
            "cpu_minutes": self.training_cpu() / 60.0,
            "wall": time.perf_counter() - self.started,
            "load": load,
            **probe,
        }
        self.history.append(point)
        if self.target_at is None and probe["safe"] >= TARGET:
            self.target_at = {"step": point["step"], "cpu_minutes": point["cpu_minutes"]}
        print(
            f"  {point['step']:>8} steps  {point['cpu_minutes']:5.1f} CPU-min  load {load:.1f}  {describe(probe)}",
            flush=True,
        )


def run(
    seed: int,
    every: int,
    episodes: int,
    cpu_minutes: float,
    output: Path,
    extra: list[str],
    env: str = "rocket_landing_velocity",
) -> dict:
    overrides = [*extra, f"seed={seed}", f"train.output_dir={output}", "train.progress_bar=false"]
    cfg = compose_config(env=env, algo="ppo", overrides=overrides)
    probe = RocketProbe(cfg, every, episodes, cpu_minutes * 60.0)
    result = train(cfg, callbacks=[probe], log=lambda line: print(f"    {line}", flush=True))
    return {
        "seed": seed,
        "env": env,
        "overrides": extra,
        "budget_steps": cfg.train.total_timesteps,
        "cpu_minutes_budget": cpu_minutes,
        "steps": result.num_timesteps,
        "cpu_minutes": probe.training_cpu() / 60.0,
        "probe_cpu_minutes": probe.probe_cpu / 60.0,
        "stopped_by_budget": probe.stopped_by_budget,
        "target_at": probe.target_at,
        "history": probe.history,
        "final": probe.history[-1],
        "load": [min(probe.loads, default=0.0), max(probe.loads, default=0.0)],
        "run_dir": str(result.run_dir),
    }


def probe_model(run_dir: Path, which: str, episodes: int) -> dict:
    """Probe a saved policy of a run directory (``auto``, ``best``, ``final`` or ``latest``) on the env
    it trained on, compared with that env's oracle (:data:`ORACLE`) on the states it flies."""
    from pyflyt_engine.envs.oracles import ORACLES, make_oracle

    from pyflyt_cli.training import rundir
    from pyflyt_cli.training.models import load_policy

    cfg = rundir.load_run_config(run_dir)
    env = EnvFactory(cfg.env, monitor=False)()
    path, _ = rundir.find_model(run_dir, which)
    model, normalize = load_policy(path, cfg, env)
    try:
        name = next(n for n, cls in ORACLES.items() if cfg.env.id in cls.env_ids and n in ORACLE.values())
        oracle = make_oracle(name, env)
        return rocket_probe(model.predict, normalize, env, episodes, oracle=oracle)
    finally:
        env.close()


def rliable_summary(rows: list[dict], reps: int = 2000) -> list[str]:
    """:func:`iqm_summary` of the final probe's safe-landing fraction and return, and of each
    run's best probe's safe-landing fraction."""
    final = [r["final"] for r in rows]
    return iqm_summary(
        rows,
        [
            (f"safe landings (fraction of {len(final[0]['flights'])} probe episodes)", [f["safe"] for f in final], 2),
            ("probe return", [f["mean_return"] for f in final], 0),
            ("safe landings at each run's best probe", [max(p["safe"] for p in r["history"]) for r in rows], 2),
        ],
        reps,
        curve=None,
        of="of the final probe",
    )[0]


def table(rows: list[dict]) -> list[str]:
    lines = [
        "| seed | steps | CPU-min (training) | safe landings at each probe [%] (step) | final endings | "
        f">= {100 * TARGET:.0f} % safe at | load |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        probes = ", ".join(f"{100 * p['safe']:.0f} ({p['step']})" for p in r["history"])
        t = r["target_at"]
        lines.append(
            f"| {r['seed']} | {r['steps']} | {r['cpu_minutes']:.1f} | {probes} | {r['final']['outcomes']} | "
            + (f"{t['step']} steps, {t['cpu_minutes']:.1f} CPU-min" if t else "not within budget")
            + f" | {r['load'][0]:.1f}-{r['load'][1]:.1f} |"
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", choices=sorted(ORACLE), default="rocket_landing_velocity")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument(
        "--cpu-minutes", type=float, default=60.0, help="CPU budget of each run (its process, all threads)"
    )
    parser.add_argument("--probe-every", type=int, default=100_000)
    parser.add_argument("--episodes", type=int, default=20, help="episodes per probe")
    parser.add_argument("--set", nargs="*", default=[], help="training overrides (key=value) for every run")
    parser.add_argument("--write", action="store_true", help="append to the results file and write the .json")
    parser.add_argument("--save-rows", type=Path, help="also write each run's raw results here (JSON), seed by seed")
    parser.add_argument("--keep-runs", type=Path, help="keep the run directories here (default: a temporary folder)")
    parser.add_argument("--from-rows", type=Path, nargs="+", help="no training: report runs saved by --save-rows")
    parser.add_argument("--probe-model", type=Path, help="no training: probe a saved policy of this run directory")
    parser.add_argument("--model", default="auto", help="with --probe-model: auto, best, final or latest")
    args = parser.parse_args()

    if args.probe_model:
        probe = probe_model(args.probe_model, args.model, args.episodes)
        print(describe(probe))
        for f in probe["flights"]:
            offset = f["offset_at_aim_height"] if f["offset_at_aim_height"] is not None else float("nan")
            print(
                f"  seed {f['seed']}: {f['outcome']:10s} {f['steps']:4d} steps  "
                f"touchdown {f['touchdown_speed']:5.1f} m/s  off axis at {AIM_HEIGHT:.0f} m {offset:5.1f} m  "
                f"pad distance {f['pad_distance']:6.1f} m  fuel left {f['fuel_left_kg']:.2f} kg  "
                f"return {f['return']:.0f}"
            )
        print("the policy's setpoint against the oracle's on the states it flies (RMS [m/s]; ignition: disagreements):")
        for name, v in probe["versus_oracle"].items():
            print(
                f"  {name:20s} {v['steps']:6d} steps  "
                f"vx {v['rms_vx']:5.2f}  vy {v['rms_vy']:5.2f}  vz {v['rms_vz']:6.2f}  "
                f"ignition {100 * v['ignition_disagrees']:3.0f} %"
            )
        return

    rows: list[dict] = []
    if args.from_rows:
        for path in args.from_rows:
            rows += json.loads(path.read_text())
    else:
        with tempfile.TemporaryDirectory() as tmp:
            output = args.keep_runs or Path(tmp)
            for seed in args.seeds:
                print(f"seed {seed}:", flush=True)
                rows.append(run(seed, args.probe_every, args.episodes, args.cpu_minutes, output, args.set, args.env))
                if args.save_rows:
                    args.save_rows.write_text(json.dumps(rows, indent=1) + "\n")

    command = "python experiments/learn_rocket_velocity.py " + " ".join(sys.argv[1:])
    lines = [
        (
            f"\n## {time.strftime('%Y-%m-%d %H:%M')} — Rocket-Landing, {rows[0].get('env', 'rocket_landing_velocity')}, ppo, "
            f"{rows[0]['cpu_minutes_budget']:.0f} CPU-minutes per seed, probes of {args.episodes} episodes "
            f"({platform.machine()}, {os.cpu_count()} cores, "
            f"Python {platform.python_version()})\n"
        ),
        f"```bash\n{command}\n```\n",
        *table(rows),
        *rliable_summary(rows),
    ]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.write:
        raw = RESULTS.with_name(
            "learn_rocket_velocity.json" if args.env == "rocket_landing_velocity" else f"learn_{args.env}.json"
        )
        raw.write_text(json.dumps({"command": command, "rows": rows}, indent=1) + "\n")
        with RESULTS.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()

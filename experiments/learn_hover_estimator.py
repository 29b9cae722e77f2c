"""Hover PPO trained on the flight controller's estimated state (``env=quadx_hover_sensors``).

Trains hover PPO with ``pyflyt train`` (``conf/hparams/quadx_hover_sensors_ppo.yaml``: the
hover tuning, unchanged) on ``conf/env/quadx_hover_sensors.yaml`` in two variants with the
same noisy sensors (BMI088 IMU at 1 kHz, motion capture at 100 Hz):

* ``estimated``: the observation's attitude, velocity and position from the estimator
  (``sensors.estimator: complementary``, the shipped config);
* ``true_attitude``: the same sensors with ``estimator: none`` (attitude and velocity true,
  rates from the gyro, position from the fixes): the observation layout is the same.

Every final policy then flies ``--episodes`` seeded deterministic episodes on the
``estimated`` env: what a flight controller would feed it.  Hovering (as in
``learn_hover_ppo.md``) = every episode reaches the time limit without a crash with a
mean true distance to the hover point below 0.1 m.  One JSON file per run in
``experiments/results/learn_hover_estimator/``; ``--report`` appends the table of all runs
to ``experiments/results/learn_hover_estimator.md``.

    nice -n 5 python experiments/learn_hover_estimator.py --variants estimated --seeds 0
    python experiments/learn_hover_estimator.py --report
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

from pyflyt_cli.studies.probes import HOVER_DISTANCE as MAX_DISTANCE
from pyflyt_cli.studies.probes import HoverProbe, hover_probe
from pyflyt_cli.training import compose_config, train
from pyflyt_cli.training.envs import EnvFactory

RESULTS = Path(__file__).resolve().parent / "results" / "learn_hover_estimator.md"
RUNS = RESULTS.with_suffix("")
EVAL_SEED = 20_000
VARIANTS = {"estimated": [], "true_attitude": ["env.sensors.estimator.type=none"]}


def run(variant: str, seed: int, budget: int | None, every: int, episodes: int, output: Path) -> dict:
    overrides = [*VARIANTS[variant], f"seed={seed}", f"train.output_dir={output}", "train.progress_bar=false"]
    if budget is not None:
        overrides.append(f"train.total_timesteps={budget}")
    if variant == "true_attitude":  # estimator none takes no gains
        overrides += [f"~env.sensors.estimator.{k}" for k in ("k_p", "k_i", "alpha", "beta")]
    cfg = compose_config(env="quadx_hover_sensors", algo="ppo", overrides=overrides)
    probe = HoverProbe(cfg, every, episodes)
    load_before = os.getloadavg()
    start = time.perf_counter()
    result = train(cfg, callbacks=[probe])
    wall = time.perf_counter() - start
    flown = compose_config(env="quadx_hover_sensors", algo="ppo", overrides=[]).env  # the estimator's observation
    env = EnvFactory(flown, monitor=False)()
    evaluation = hover_probe(probe.model, env, episodes, seed=EVAL_SEED)
    env.close()
    return {
        "variant": variant,
        "seed": seed,
        "budget": cfg.train.total_timesteps,
        "steps": result.num_timesteps,
        "wall": wall,
        "load_before": load_before,
        "load_after": os.getloadavg(),
        "finished": time.strftime("%Y-%m-%d %H:%M"),
        "machine": f"{platform.machine()}, Python {platform.python_version()}",
        "hover_at": probe.hover_at,
        "history": probe.history,
        "eval": evaluation,
        "episodes": episodes,
    }


def hovers(e: dict) -> bool:
    return e["survived"] == 1.0 and e["worst_distance"] < MAX_DISTANCE


def report() -> str:
    rows = [json.loads(p.read_text()) for p in sorted(RUNS.glob("*.json"))]
    if not rows:
        raise SystemExit(f"no runs in {RUNS}")
    ends = [r.get("finished", r.get("started", "")) for r in rows]  # the first runs named it "started"
    lines = [
        f"\n## runs finished {min(ends)} to {max(ends)} — {rows[0]['machine']}, {rows[0]['episodes']} evaluation "
        f"episodes (seeds {EVAL_SEED}+) on the estimated observation\n",
        "| trained on | seed | steps | wall-clock [s] | load (1 min) before / after | on its training env: "
        "survived, mean / worst distance [m] | on the estimated observation: survived, mean / worst distance [m] "
        "| return |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        e, own = r["eval"], r["history"][-1][2]  # the last probe flies the training env
        lines.append(
            f"| {r['variant']} | {r['seed']} | {r['steps']} | {r['wall']:.0f} | {r['load_before'][0]:.1f} / "
            f"{r['load_after'][0]:.1f} | {100 * own['survived']:.0f} %, {own['mean_distance']:.3f} / "
            f"{own['worst_distance']:.3f}{' (hovers)' if hovers(own) else ''} | {100 * e['survived']:.0f} %, "
            f"{e['mean_distance']:.3f} / {e['worst_distance']:.3f}{' (hovers)' if hovers(e) else ''} | "
            f"{e['mean_return']:.1f} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--variants", nargs="+", choices=list(VARIANTS), default=list(VARIANTS))
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--budget", type=int, default=None, help="steps per run (default: the shipped budget)")
    parser.add_argument("--probe-every", type=int, default=50_000)
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--report", action="store_true", help="append the table of every stored run")
    args = parser.parse_args()
    if args.report:
        text = report()
        print(text)
        if not RESULTS.exists():
            RESULTS.write_text(
                "# Hover PPO on the estimated state (experiments/learn_hover_estimator.py)\n\n"
                "Hovering = in every evaluation episode (deterministic policy, 10 s, observation from the\n"
                "estimator): no crash and mean true distance to (0, 0, 1) m below 0.1 m.\n"
            )
        with RESULTS.open("a") as fh:
            fh.write(text)
        return
    RUNS.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for variant in args.variants:
            for seed in args.seeds:
                print(f"{variant}, seed {seed}:", flush=True)
                row = run(variant, seed, args.budget, args.probe_every, args.episodes, Path(tmp))
                e = row["eval"]
                print(f"  survived {100 * e['survived']:.0f} %, distance {e['mean_distance']:.3f} m", flush=True)
                (RUNS / f"{variant}_{seed}.json").write_text(json.dumps(row, indent=1) + "\n")


if __name__ == "__main__":
    main()

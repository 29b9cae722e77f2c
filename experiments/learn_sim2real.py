"""Does training with ``env.randomize=sim2real`` make a hover policy survive a different airframe?

Trains hover PPO exactly as ``learn_hover_ppo.py`` does (``pyflyt train`` with the shipped
``conf/hparams/quadx_hover_ppo.yaml`` and budget) for every ``--seeds`` seed twice: on
the nominal airframe, and with ``env.randomize=sim2real`` (``conf/randomize/sim2real.yaml``),
at the same budget.  Then flies every final policy (deterministic, ``--episodes`` seeded
episodes) on

* the nominal cf2x, and
* a held-out perturbed cf2x outside the training distribution (:data:`HELD_OUT`: mass
  x1.3, thrust coefficient x0.85, motor time constant x2, body drag x1.5; the sim2real
  preset reaches at most x1.15, x0.9, x1.5, x1.3),

reporting survival and the mean distance to the hover point.  The preset also draws the
action and observation delays (training and its probes fly them); both evaluation
airframes fly without latency (:func:`airframe_env` replaces the randomisation).  Hovering (as in
``learn_hover_ppo.md``) = every episode reaches the time limit without a crash and its
mean distance is below 0.1 m.  IQM over seeds with 95 % stratified-bootstrap CIs
(rliable, ``pyflyt_cli.plotting.stats``).  Appends to ``experiments/results/learn_sim2real.md``
and writes the raw numbers to ``learn_sim2real.json``.

    nice -n 5 python experiments/learn_sim2real.py [--seeds 0 1 2] [--budget N]
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

from pyflyt_cli.studies.probes import HOVER_DISTANCE as MAX_DISTANCE
from pyflyt_cli.studies.probes import HoverProbe, hover_probe
from pyflyt_cli.training import compose_config, train
from pyflyt_cli.training.envs import EnvFactory
from pyflyt_engine.envs.config import EnvConfig
from pyflyt_engine.envs.randomization import Distribution

RESULTS = Path(__file__).resolve().parent / "results" / "learn_sim2real.md"
#: the held-out airframe: fixed factors on the nominal cf2x, each beyond the sim2real preset's range
HELD_OUT = {"mass": 1.3, "motor_kf": 0.85, "motor_tau": 2.0, "drag": 1.5}
EVAL_SEED = 20_000  # evaluation episodes: seeds 20 000 ... (training probes use 10 000 ...)
VARIANTS = {"nominal": [], "sim2real": ["env.randomize=sim2real"]}


def airframe_env(env: EnvConfig, factors: dict[str, float]) -> EnvConfig:
    """``env`` without its randomisation, on the airframe scaled by ``factors`` (a randomise
    entry whose range is one point: the same airframe in every episode)."""
    entries = {k: Distribution(distribution="uniform", low=f, high=f) for k, f in factors.items()}
    return env.model_copy(update={"randomize": entries})


def run(variant: str, seed: int, budget: int | None, every: int, episodes: int, output: Path) -> dict:
    overrides = [*VARIANTS[variant], f"seed={seed}", f"train.output_dir={output}", "train.progress_bar=false"]
    if budget is not None:
        overrides.append(f"train.total_timesteps={budget}")
    cfg = compose_config(env="quadx_hover", algo="ppo", overrides=overrides)
    probe = HoverProbe(cfg, every, episodes)  # probes on the training distribution
    start = time.perf_counter()
    result = train(cfg, callbacks=[probe])
    wall = time.perf_counter() - start
    evals = {}
    for name, factors in (("nominal", {}), ("held_out", HELD_OUT)):
        env = EnvFactory(airframe_env(cfg.env, factors), monitor=False)()
        evals[name] = hover_probe(probe.model, env, episodes, seed=EVAL_SEED)
        env.close()
        e = evals[name]
        print(
            f"  {variant} seed {seed} on {name}: survived {100 * e['survived']:.0f} %, distance mean "
            f"{e['mean_distance']:.3f} / worst {e['worst_distance']:.3f} m, return {e['mean_return']:.2f}",
            flush=True,
        )
    return {
        "variant": variant,
        "seed": seed,
        "budget": cfg.train.total_timesteps,
        "steps": result.num_timesteps,
        "wall": wall,
        "hover_at": probe.hover_at,
        "history": probe.history,
        "eval": evals,
    }


def hovers(e: dict) -> bool:
    return e["survived"] == 1.0 and e["worst_distance"] < MAX_DISTANCE


def summary(rows: list[dict], reps: int = 2000) -> list[str]:
    """IQM over seeds [95 % CI] of survival and mean distance, per variant and airframe."""
    from pyflyt_cli.plotting import stats

    lines = [
        "",
        f"IQM over seeds, 95 % stratified-bootstrap CI ({reps} replicates, rliable); per seed the "
        "value is over its evaluation episodes:",
        "",
        "| trained | flown on | hovering seeds | survived [%] IQM [95 % CI] | mean distance [m] IQM [95 % CI] |",
        "|---|---|---|---|---|",
    ]
    for variant in VARIANTS:
        for airframe in ("nominal", "held_out"):
            evals = [r["eval"][airframe] for r in rows if r["variant"] == variant]
            scores = {
                "s": np.asarray([100 * e["survived"] for e in evals], dtype=float)[:, None],
                "d": np.asarray([e["mean_distance"] for e in evals], dtype=float)[:, None],
            }
            est = stats.iqm(scores, reps=reps, seed=0)
            fmt = {
                k: f"{float(v.value[0]):.{p}f} [{float(v.low[0]):.{p}f}, {float(v.high[0]):.{p}f}]"
                for (k, v), p in zip(est.items(), (0, 3))
            }
            lines.append(
                f"| {variant} | {airframe.replace('_', '-')} | {sum(map(hovers, evals))} of {len(evals)} | "
                f"{fmt['s']} | {fmt['d']} |"
            )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--budget", type=int, default=None, help="steps per run (default: the shipped budget)")
    parser.add_argument("--probe-every", type=int, default=50_000, help="training-distribution probes")
    parser.add_argument("--episodes", type=int, default=10, help="episodes per probe and per evaluation")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()

    load_before = os.getloadavg()
    started = time.strftime("%Y-%m-%d %H:%M")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for variant in VARIANTS:
            for seed in args.seeds:
                print(f"{variant}, seed {seed}:", flush=True)
                rows.append(run(variant, seed, args.budget, args.probe_every, args.episodes, Path(tmp)))
    load_after = os.getloadavg()

    lines = [
        f"\n## {started} — {platform.machine()}, Python {platform.python_version()}, budget {rows[0]['budget']} "
        f"steps per run, {args.episodes} evaluation episodes (seeds {EVAL_SEED}+)\n",
        f"Command: `{' '.join(['python', *sys.argv])}`  ",
        f"Load average (1/5/15 min) before {'/'.join(f'{x:.1f}' for x in load_before)}, "
        f"after {'/'.join(f'{x:.1f}' for x in load_after)}.  ",
        f"Held-out airframe: factors {HELD_OUT} on the nominal cf2x.\n",
        "| trained | seed | steps | run wall-clock [s] | nominal: survived / mean / worst distance [m] | held-out: survived / mean / worst distance [m] |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        cells = [
            f"{100 * e['survived']:.0f} % / {e['mean_distance']:.3f} / {e['worst_distance']:.3f}{' (hovers)' if hovers(e) else ''}"
            for e in (r["eval"]["nominal"], r["eval"]["held_out"])
        ]
        lines.append(f"| {r['variant']} | {r['seed']} | {r['steps']} | {r['wall']:.0f} | {cells[0]} | {cells[1]} |")
    lines += summary(rows)
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_write:
        RESULTS.with_suffix(".json").write_text(
            json.dumps({"command": " ".join(sys.argv), "held_out": HELD_OUT, "rows": rows}, indent=1) + "\n"
        )
        if not RESULTS.exists():
            RESULTS.write_text(
                "# Sim-to-real randomisation: hover on a held-out airframe (experiments/learn_sim2real.py)\n\n"
                "Hovering = in every evaluation episode (deterministic policy, 10 s): no crash and mean\n"
                "distance to the hover point (0, 0, 1) m below 0.1 m (as `learn_hover_ppo.md`).\n"
            )
        with RESULTS.open("a") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()

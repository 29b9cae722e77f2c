"""Study runs: one seed trained with a probe callback, and what its run directory holds.

- :func:`hover_run`: QuadX-Hover with a :class:`~pyflyt_cli.studies.probes.HoverProbe`;
- :func:`budgeted_run`, :func:`run_seeds`: a PPO run under a CPU-time budget with an
  :class:`~pyflyt_cli.studies.probes.ObstacleProbe` (or a subclass), its row saved after every probe;
- :func:`checkpoint_policies`, :class:`SavedPolicy`: a finished run's checkpoints as probe-able policies;
- :func:`phase_split`, :func:`training_success`: where a run's time went, its own training episodes;
- :func:`pyflyt_command`: a ``pyflyt`` command run in a fresh process, for studies of what the CLI does.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pyflyt_cli.studies.probes import HOVER_DISTANCE, HoverProbe, ObstacleProbe
from pyflyt_cli.training import compose_config, train


class SavedPolicy:
    """A saved policy with the probe's interface (``predict``; its normaliser applied inside)."""

    def __init__(self, model, normalize) -> None:
        self.model, self.normalize = model, normalize

    def get_vec_normalize_env(self):
        return None

    def predict(self, obs, deterministic: bool = True):
        return self.model.predict(
            self.normalize(obs) if self.normalize is not None else obs, deterministic=deterministic
        )


def checkpoint_policies(run_dir: Path, after: int = 0, every: int = 1):
    """(step, model, observation normaliser, run config, env) for each checkpoint of a run
    directory after step ``after`` at a multiple of ``every`` steps, on the env the run trained on."""
    from pyflyt_cli.training import rundir
    from pyflyt_cli.training.envs import EnvFactory
    from pyflyt_cli.training.models import load_policy

    cfg = rundir.load_run_config(run_dir)
    env = EnvFactory(cfg.env, monitor=False)()
    try:
        for checkpoint in rundir.checkpoints(run_dir):
            if checkpoint.step > after and checkpoint.step % every == 0:
                model, normalize = load_policy(checkpoint.model, cfg, env)
                yield checkpoint.step, model, normalize, cfg, env
    finally:
        env.close()


def phase_split(run_dir: Path) -> dict[str, float]:
    import warnings

    from pyflyt_engine.telemetry import read_metrics

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        records = read_metrics(run_dir).get("/train/progress", [])
    last = dict(records[-1]) if records else {}
    return {k[: -len("_seconds")]: float(v) for k, v in last.items() if k.endswith("_seconds")}


def hover_run(
    seed: int,
    budget: int | None,
    every: int,
    episodes: int,
    output: Path,
    algo: str = "ppo",
    extra: tuple[str, ...] | list[str] = (),
    stop_on_hover: bool = False,
    max_distance: float = HOVER_DISTANCE,
) -> dict:
    """Train QuadX-Hover (``algo`` and its tuning, ``extra`` overrides) with a :class:`HoverProbe`
    every ``every`` steps; the run's probes, first hovering probe and throughput."""
    overrides = [
        *extra,
        f"seed={seed}",
        f"train.output_dir={output}",
        "train.progress_bar=false",
    ]
    if budget is not None:
        overrides.append(f"train.total_timesteps={budget}")
    cfg = compose_config(env="quadx_hover", algo=algo, overrides=overrides)
    probe = HoverProbe(cfg, every, episodes, stop_on_hover, max_distance=max_distance)
    start = time.perf_counter()
    result = train(cfg, callbacks=[probe])
    total = time.perf_counter() - start
    final = probe.history[-1][2] if probe.history else {}
    return {
        "seed": seed,
        "budget": cfg.train.total_timesteps,
        "steps": result.num_timesteps,
        "hover_at": probe.hover_at,
        "final": final,
        "steps_per_second": result.num_timesteps / max(total - probe.probe_time, 1e-9),
        "wall": total,
        "n_envs": cfg.train.n_envs,
        "history": [(steps, wall, probe) for steps, wall, probe in probe.history],
    }


def budget_row(
    probe: ObstacleProbe, seed: int, every: int, episodes: int, extra, cpu_minutes, status: str, **more
) -> dict:
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
        "load": [
            min(probe.loads, default=0.0),
            float(np.mean(probe.loads)) if probe.loads else 0.0,
            max(probe.loads, default=0.0),
        ],
        "history": history,
        **more,
    }


def budgeted_run(
    seed: int,
    cpu_minutes: float | None,
    every: int,
    episodes: int,
    output: Path,
    extra=(),
    save=None,
    *,
    env: str,
    target: float,
    probe_cls: type[ObstacleProbe] | None = None,
) -> dict:
    """Train one seed of ``env`` (PPO, its shipped tuning and ``extra`` overrides) under the CPU
    budget, probing with ``probe_cls`` (default :class:`ObstacleProbe`); ``save`` gets the row
    after every probe."""
    overrides = [*extra, f"seed={seed}", f"train.output_dir={output}", "train.progress_bar=false", "train.eval_freq=0"]
    cfg = compose_config(env=env, algo="ppo", overrides=overrides)
    budget = None if cpu_minutes is None else 60.0 * cpu_minutes

    def partial(p: ObstacleProbe) -> None:
        if save is not None:
            save(budget_row(p, seed, every, episodes, extra, cpu_minutes, "running", wall=time.perf_counter() - start))

    start, cpu0 = time.perf_counter(), time.process_time()  # before the probe's clocks start
    probe = (probe_cls or ObstacleProbe)(cfg, every, episodes, target, budget, save=partial)
    result = train(cfg, callbacks=[probe], log=lambda line: print(f"    {line}", flush=True))
    wall, process_cpu = time.perf_counter() - start, time.process_time() - cpu0
    split = phase_split(Path(result.run_dir))
    if split:  # the probes run inside the collection phase (from a callback's on_step): take them out
        collect = split.get("collect", 0.0) - probe.probe_time
        split = {"env": probe.env_time, "collect_other": collect - probe.env_time, "update": split.get("update", 0.0)}
    status = "cpu budget" if probe.stopped_by_budget else "stopped" if result.interrupted else "step budget"
    training = training_success(Path(result.run_dir), every)
    out = budget_row(
        probe,
        seed,
        every,
        episodes,
        extra,
        cpu_minutes,
        status,
        wall=wall,
        process_cpu=process_cpu,
        step_budget=cfg.train.total_timesteps,
        split=split,
        cpu_steps_per_second=result.num_timesteps / max(probe.training_cpu(), 1e-9),
        run_dir=str(result.run_dir),
        training=training,
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
        out.append(
            {
                "step": end,
                "episodes": len(window),
                "success": sum(bool(e["success"]) for e in window) / len(window),
                "length": sum(e["length"] for e in window) / len(window),
                "goal_x": stage[-1].get("goal_x_range[0]") if stage else None,
                "reach": stage[-1].get("goal_reach_distance") if stage else None,
            }
        )
    return out


def run_seeds(args: argparse.Namespace, cpu_minutes: float | None, **run_kwargs) -> list[dict]:
    """:func:`budgeted_run` for every seed of ``args.seeds`` in turn (run folders in ``args.keep_runs`` or a
    temporary one), each seed's row written to ``args.save_rows`` after every probe."""
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        output = args.keep_runs or Path(tmp)
        for seed in args.seeds:
            print(f"seed {seed}:", flush=True)

            def save(current: dict, done: list[dict] = list(rows)) -> None:
                if args.save_rows:  # every probe: a stopped run keeps what it measured
                    args.save_rows.write_text(json.dumps([*done, current], indent=1) + "\n")

            rows.append(
                budgeted_run(seed, cpu_minutes, args.probe_every, args.episodes, output, args.set, save, **run_kwargs)
            )
    return rows


def pyflyt_command(args: list[str], cwd: Path) -> str:
    """``pyflyt <args>`` in a fresh process in ``cwd``; its standard output.

    Raises:
        SystemExit: the command failed (names it, with the end of its output).
    """
    done = subprocess.run([sys.executable, "-m", "pyflyt_cli.main", *args], cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(
            f"pyflyt {' '.join(args)} failed ({done.returncode}):\n{done.stdout[-2000:]}{done.stderr[-2000:]}"
        )
    return done.stdout

"""``normalisation.yaml`` of a benchmark: per task, the score of a random policy (0) and a reference (1).

The random score is measured here: a uniformly random policy (actions sampled from the
agent's action space, seeded) for ``random_episodes`` episodes of the task's env.  The
reference score comes from the experiment (``benchmark.reference``) with its source;
without one it is ``null`` and ``pyflyt plot`` takes the best mean evaluation return in
the benchmark as 1 (and says so).  Entries already in the file are kept, never
recomputed or overwritten; delete an entry to measure it again.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from pyflyt_cli.benchmark.plan import NORMALISATION_FILE, Job, Plan
from pyflyt_engine.safe_load import load_yaml_file

#: seed of the random policy's episodes (episode i: reset(seed=RANDOM_SEED + i)) and action sampler
RANDOM_SEED = 1000


def random_score(job: Job, episodes: int) -> float:
    """Mean return of a uniformly random policy on ``job``'s env, as the agent sees it."""
    from pyflyt_cli.training.envs import EnvFactory
    from pyflyt_cli.training.evaluation import run_episodes
    from pyflyt_cli.training.schema import parse_train_config

    cfg = parse_train_config(job.config)
    env = EnvFactory(cfg.env, monitor=False)()
    try:
        env.action_space.seed(RANDOM_SEED)
        results = run_episodes(lambda obs, det: env.action_space.sample(), env, episodes, RANDOM_SEED)
    finally:
        env.close()
    return float(sum(r.ret for r in results) / len(results))


def update_normalisation(plan: Plan, jobs: Sequence[Job] | None = None, echo: Any = None) -> Path:
    """Add missing tasks to ``<benchmark>/normalisation.yaml``; returns its path."""
    from pyflyt_cli.training.rundir import atomic_write

    path = plan.root / NORMALISATION_FILE
    existing: dict[str, Any] = {}
    if path.is_file():
        loaded = load_yaml_file(path, what="normalisation file")
        existing = loaded if isinstance(loaded, dict) else {}
    references = plan.spec.get("reference") or {}
    episodes = int(plan.spec.get("random_episodes", 10))
    first: dict[str, Job] = {}
    for job in jobs if jobs is not None else plan.jobs:
        first.setdefault(job.task, job)
    added = False
    for task, job in first.items():
        if task in existing:
            continue
        if echo is not None:
            echo(f"measuring the random-policy score of {task} ({episodes} episodes)")
        ref = references.get(task)
        existing[task] = {
            "random": round(random_score(job, episodes), 6),
            "reference": None if ref is None else float(ref["score"]),
            "source": f"random: uniformly random actions, mean of {episodes} episodes (seeds {RANDOM_SEED}+i); "
            + (f"reference: {ref['source']}" if ref is not None else "no reference score given"),
        }
        added = True
    if added:
        header = (
            "# Per task: normalised score = (return - random) / (reference - random), read by pyflyt plot.\n"
            "# Written by pyflyt benchmark; existing entries are kept (delete one to measure it again).\n"
        )
        plan.root.mkdir(parents=True, exist_ok=True)
        atomic_write(path, header + yaml.safe_dump(existing, sort_keys=True, width=100))
    return path

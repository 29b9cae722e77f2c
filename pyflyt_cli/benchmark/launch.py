"""Benchmark runs through a Hydra launcher: Ray, Slurm (submitit), joblib, ...

``pyflyt benchmark experiment=paper_rl hydra/launcher=ray`` sweeps the Hydra app
``conf/benchmark_launch.yaml`` over the runs to do (``job=<index in plan.json>``) with
the chosen launcher plugin; each Hydra job calls :func:`hydra_task`, which trains its run
in a worker process exactly as the local launcher does.  The launcher is configured
with Hydra's own overrides (``hydra.launcher.ray.init.address=auto``,
``hydra.launcher.partition=gpu`` ...): see docs/benchmarks.md.  Runs that start from
another run's policy are launched in a second sweep, after the first.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from pyflyt_cli.benchmark.plan import Job, Plan, levels
from pyflyt_cli.benchmark.run import Echo, Outcome, outcome_of
from pyflyt_cli.errors import UsageError


def hydra_task(cfg: Any) -> int:
    """One Hydra job: train run number ``cfg.job`` of the plan in ``cfg.bench_dir``; returns its exit code."""
    from pyflyt_cli.benchmark.plan import read_plan
    from pyflyt_cli.benchmark.run import run_job

    plan = read_plan(cfg.bench_dir)
    return run_job(plan.root, plan.jobs[int(cfg.job)].id)


def run_hydra(plan: Plan, jobs: Sequence[Job], hydra_overrides: Sequence[str], echo: Echo) -> list[Outcome]:
    """Launch ``jobs`` with the Hydra launcher the overrides choose, in dependency waves."""
    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.utils import JobStatus
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    from pyflyt_engine.paths import conf_dir

    from pyflyt_cli.benchmark.launchers import plugin_overrides

    index = {j.id: i for i, j in enumerate(plan.jobs)}
    outcomes: list[Outcome] = []
    launcher = [*hydra_overrides, *plugin_overrides(hydra_overrides)]
    for wave in levels(list(jobs)):
        numbers = [index[j.id] for j in wave]
        overrides = [f"bench_dir={plan.root}", "job=" + ",".join(str(n) for n in numbers), *launcher]
        echo(f"launching {len(wave)} run(s) with {' '.join(launcher)}")
        started = time.monotonic()
        GlobalHydra.instance().clear()
        try:
            # Hydra's public compose API sets up the same Hydra as its @hydra.main would, over conf/
            with initialize_config_dir(config_dir=str(conf_dir()), job_name="pyflyt_benchmark", version_base="1.3"):
                hydra = GlobalHydra.instance().hydra
                assert hydra is not None
                results = hydra.multirun(config_name="benchmark_launch", task_function=hydra_task, overrides=overrides)
        except (HydraException, OmegaConfBaseException) as exc:
            raise UsageError(f"the Hydra launcher failed: {str(exc).splitlines()[0]}") from None
        finally:
            GlobalHydra.instance().clear()
        elapsed = time.monotonic() - started
        codes: dict[int, int | None] = {}
        for batch in results or []:
            for ret in batch if isinstance(batch, list) else [batch]:
                number = dict(o.split("=", 1) for o in ret.overrides if "=" in o).get("job")
                if number is not None and ret.status == JobStatus.COMPLETED:
                    codes[int(number)] = ret.return_value
        for job in wave:
            out = outcome_of(plan, job, codes.get(index[job.id]), elapsed)
            outcomes.append(out)
            echo(f"{out.status:<8} {job.id}" + (f"  {out.detail}" if out.status != "complete" else ""))
    return outcomes

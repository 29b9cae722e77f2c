"""``pyflyt benchmark``: the runs of an experiment's grid (tasks x algorithms x seeds), resumable.

From Python::

    from pyflyt_cli.benchmark import plan_benchmark, run_benchmark

    plan = plan_benchmark("smoke_benchmark", ["seeds=2", "benchmark.output_dir=benchmarks"])
    result = run_benchmark(plan, log=print)      # result.summary, result.outcomes, result.complete

* :mod:`~pyflyt_cli.benchmark.plan` — the ``benchmark:`` section of an experiment and
  every run it declares, each one ``pyflyt train`` line, composed and validated before
  anything trains (``plan.json``): :func:`plan_benchmark`.
* :mod:`~pyflyt_cli.benchmark.sweep` — one invocation: the runs' states
  (:func:`survey`), changed runs refused or restarted, the rest trained, the summary:
  :func:`run_benchmark`; the ``--dry-run`` script.
* :mod:`~pyflyt_cli.benchmark.worker` — one run in its own process: train, resume,
  extend or skip; a run directory with other settings than planned is never reused.
* :mod:`~pyflyt_cli.benchmark.run` — the directory lock, run states, restarts, the local
  launcher (``jobs`` processes) and the summary.
* :mod:`~pyflyt_cli.benchmark.launch` — the same runs through a Hydra launcher (Ray,
  Slurm); :mod:`~pyflyt_cli.benchmark.launchers` — which launchers, and the only settings
  passed on to them (checked when the plan is made).
* :mod:`~pyflyt_cli.benchmark.normalise` — random-policy and reference scores for ``pyflyt plot``.
"""

from pyflyt_cli.benchmark.plan import Job, Plan, plan_benchmark, read_plan
from pyflyt_cli.benchmark.sweep import BenchmarkResult, Survey, check_restarts, dry_run_script, run_benchmark, survey

__all__ = [
    "BenchmarkResult",
    "Job",
    "Plan",
    "Survey",
    "check_restarts",
    "dry_run_script",
    "plan_benchmark",
    "read_plan",
    "run_benchmark",
    "survey",
]

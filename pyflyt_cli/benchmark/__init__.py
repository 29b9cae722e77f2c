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
  Slurm), which gets only the launcher's own settings.
* :mod:`~pyflyt_cli.benchmark.normalise` — random-policy and reference scores for ``pyflyt plot``.
"""

from __future__ import annotations

from typing import Any

# imported on first use: ``python -m pyflyt_cli.benchmark.worker`` imports this package first
_LAZY = {
    "Plan": "pyflyt_cli.benchmark.plan",
    "Job": "pyflyt_cli.benchmark.plan",
    "plan_benchmark": "pyflyt_cli.benchmark.plan",
    "read_plan": "pyflyt_cli.benchmark.plan",
    "BenchmarkResult": "pyflyt_cli.benchmark.sweep",
    "Survey": "pyflyt_cli.benchmark.sweep",
    "check_restarts": "pyflyt_cli.benchmark.sweep",
    "dry_run_script": "pyflyt_cli.benchmark.sweep",
    "run_benchmark": "pyflyt_cli.benchmark.sweep",
    "survey": "pyflyt_cli.benchmark.sweep",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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

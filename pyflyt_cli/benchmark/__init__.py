"""``pyflyt benchmark``: the runs of an experiment's grid (tasks x algorithms x seeds), resumable.

* :mod:`~pyflyt_cli.benchmark.plan` — the ``benchmark:`` section of an experiment and
  every run it declares, each one ``pyflyt train`` line, composed and validated before
  anything trains (``plan.json``).
* :mod:`~pyflyt_cli.benchmark.worker` — one run in its own process: train, resume,
  extend or skip; a run directory with other settings than planned is never reused.
* :mod:`~pyflyt_cli.benchmark.run` — the directory lock, run states, restarts, the local
  launcher (``jobs`` processes) and the summary.
* :mod:`~pyflyt_cli.benchmark.launch` — the same runs through a Hydra launcher (Ray,
  Slurm), which gets only the launcher's own settings.
* :mod:`~pyflyt_cli.benchmark.normalise` — random-policy and reference scores for ``pyflyt plot``.
"""

"""``pyflyt benchmark experiment=<name> [seeds=N] [jobs=J] [overrides] [hydra/launcher=...]``.

Plans every run of the experiment's grid (all configurations validated first), records
the random-policy and reference scores, skips complete runs, resumes interrupted ones,
trains the rest locally or through a Hydra launcher, and ends with a summary (also
``<benchmark>/summary.md``).  Exit code 0 when every run is complete, 1 if a run failed,
130 if interrupted.
"""

from __future__ import annotations

import shlex
import sys
import time
from typing import TYPE_CHECKING

import typer

from pyflyt_cli.config import CLIError, parse_overrides

if TYPE_CHECKING:
    from pyflyt_cli.benchmark.plan import Plan

FAILED = 1
INTERRUPTED = 130


def _echo(message: str) -> None:
    typer.echo(message, err=True)


def run_benchmark(overrides: list[str], dry_run: bool = False) -> int:
    from pyflyt_cli.benchmark.launch import launcher_name
    from pyflyt_cli.benchmark.plan import build_plan
    from pyflyt_cli.benchmark.run import hold_benchmark

    overrides = parse_overrides(overrides)
    experiments = [o.partition("=")[2] for o in overrides if o.partition("=")[0] == "experiment"]
    if not experiments or not experiments[-1]:
        raise CLIError("choose the benchmark: pyflyt benchmark experiment=<name> (e.g. experiment=paper_rl)")
    experiment = experiments[-1]
    rest = [o for o in overrides if o.partition("=")[0] != "experiment"]
    plan, hydra_overrides = build_plan(experiment, rest, command=["pyflyt", "benchmark", *overrides])
    launcher = launcher_name(hydra_overrides)
    if dry_run:
        return _run(plan, launcher, hydra_overrides, dry_run=True)
    with hold_benchmark(plan.root, plan.command):  # a second benchmark on this directory stops here
        return _run(plan, launcher, hydra_overrides, dry_run=False)


def _run(plan: Plan, launcher: str | None, hydra_overrides: list[str], dry_run: bool) -> int:
    from pyflyt_cli.benchmark.launch import run_hydra
    from pyflyt_cli.benchmark.normalise import update_normalisation
    from pyflyt_cli.benchmark.plan import levels
    from pyflyt_cli.benchmark.run import BUSY, COMPLETE, Outcome, run_local, run_state, summary
    from pyflyt_cli.training.rundir import atomic_write

    parallel = int(plan.spec["jobs"])
    states = {j.id: run_state(plan, j) for j in plan.jobs}
    skipped = [j for j in plan.jobs if states[j.id] == COMPLETE]
    busy = [j for j in plan.jobs if states[j.id] == BUSY]
    todo = [j for wave in levels(plan.jobs) for j in wave if states[j.id] not in (COMPLETE, BUSY)]
    _echo(
        f"benchmark {plan.root}: {len(plan.jobs)} runs; {len(skipped)} complete (skipped), "
        f"{sum(states[j.id] == 'partial' for j in todo)} to resume, "
        f"{sum(states[j.id] == 'new' for j in todo)} to start"
        + (f", {len(busy)} being trained by another process" if busy else "")
    )
    if dry_run:  # stdout: a script of one pyflyt train line per run, sources first
        for j in [j for wave in levels(plan.jobs) for j in wave]:
            typer.echo(f"# {states[j.id]:<9} {j.id}")
            typer.echo(shlex.join(["pyflyt", "train", *j.overrides]))
        return 0
    plan.write()
    started = time.monotonic()
    update_normalisation(plan, echo=_echo)
    if not todo:
        outcomes: list[Outcome] = []
    elif launcher is None:
        _echo(f"training {len(todo)} run(s), {parallel} at a time; logs in {plan.root / 'logs'}")
        outcomes = run_local(plan, todo, parallel, _echo)
    else:
        outcomes = run_hydra(plan, todo, hydra_overrides, _echo)
    outcomes += [Outcome(j, "busy", detail="being trained by another process") for j in busy]
    text = summary(plan, outcomes, skipped, time.monotonic() - started)
    atomic_write(plan.root / "summary.md", text)
    _echo("\n" + text.rstrip())
    _echo(f"\nreport: pyflyt plot {plan.root}")
    statuses = {o.status for o in outcomes}
    if statuses & {"interrupted", "not started"}:
        return INTERRUPTED
    if statuses - {"complete"}:
        return FAILED
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(run_benchmark(sys.argv[1:]))

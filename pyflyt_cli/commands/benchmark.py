"""``pyflyt benchmark experiment=<name> [seeds=N] [jobs=J] [overrides] [hydra/launcher=...]``.

Plans every run of the experiment's grid (all configurations validated first), takes
the benchmark directory's lock, refuses run directories trained with other settings
than planned (or, with ``--restart-changed``, moves them aside and trains them afresh),
records the random-policy and reference scores, skips complete runs, resumes
interrupted ones, trains the rest locally or through a Hydra launcher, and ends with a
summary (also ``<benchmark>/summary.md``).  Exit code 0 when every run is complete, 1
if a run failed, 130 if interrupted, 2 for a user error (nothing trained).
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


def run_benchmark(overrides: list[str], dry_run: bool = False, restart_changed: bool = False) -> int:
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
        return _run(plan, launcher, hydra_overrides, dry_run=True, restart_changed=restart_changed)
    with hold_benchmark(plan.root, plan.command):  # a second benchmark on this directory stops here
        return _run(plan, launcher, hydra_overrides, dry_run=False, restart_changed=restart_changed)


def _run(plan: Plan, launcher: str | None, hydra_overrides: list[str], dry_run: bool, restart_changed: bool) -> int:
    from pyflyt_cli.benchmark.launch import run_hydra
    from pyflyt_cli.benchmark.normalise import update_normalisation
    from pyflyt_cli.benchmark.plan import levels
    from pyflyt_cli.benchmark.run import (
        BUSY,
        COMPLETE,
        NEW,
        PARTIAL,
        Outcome,
        move_aside,
        run_local,
        run_state,
        summary,
        to_restart,
    )
    from pyflyt_cli.training.rundir import atomic_write

    parallel = int(plan.spec["jobs"])
    states = {j.id: run_state(plan, j) for j in plan.jobs}
    restart = to_restart(plan, states)
    if restart and not restart_changed:
        if dry_run:
            _script(plan, states, {})
        raise CLIError(_changed_message(plan, restart))
    busy_restarts = [i for i in restart if states[i] == BUSY]
    if busy_restarts:
        raise CLIError(f"cannot restart {', '.join(busy_restarts)}: being trained by another process; stop it first")
    skipped = [j for j in plan.jobs if states[j.id] == COMPLETE and j.id not in restart]
    busy = [j for j in plan.jobs if states[j.id] == BUSY]
    todo = [j for wave in levels(plan.jobs) for j in wave if j.id in restart or states[j.id] not in (COMPLETE, BUSY)]
    _echo(
        f"benchmark {plan.root}: {len(plan.jobs)} runs; {len(skipped)} complete (skipped), "
        f"{sum(states[j.id] == PARTIAL and j.id not in restart for j in todo)} to resume, "
        f"{sum(states[j.id] == NEW for j in todo)} to start"
        + (f", {len(restart)} to restart (settings changed)" if restart else "")
        + (f", {len(busy)} being trained by another process" if busy else "")
    )
    if dry_run:
        _script(plan, states, restart)
        return 0
    if restart:
        move_aside(plan, [plan.job(i) for i in restart], _echo)
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


def _script(plan: Plan, states: dict[str, str], restart: dict[str, str]) -> None:
    """--dry-run on stdout: one ``pyflyt train`` line per run, sources first, after a comment: its state,
    or ``restart`` for the runs ``--restart-changed`` trains afresh."""
    from pyflyt_cli.benchmark.plan import levels

    for wave in levels(plan.jobs):
        for job in wave:
            state = "restart" if job.id in restart else states[job.id]
            typer.echo(f"# {state:<9} {job.id}")
            typer.echo(shlex.join(["pyflyt", "train", *job.overrides]))


def _changed_message(plan: Plan, restart: dict[str, str]) -> str:
    from pyflyt_cli.benchmark.run import REPLACED_DIR
    from pyflyt_cli.benchmark.worker import run_differences

    lines = [f"{len(restart)} run(s) in {plan.root} differ from this plan and are not reused:"]
    for run_id, why in restart.items():
        diffs = run_differences(plan, plan.job(run_id))
        lines += [f"  {run_id}  {d}" for d in diffs] if diffs else [f"  {run_id}  {why}"]
    lines.append(
        "(saved value -> planned value.)  Keep those runs and write this benchmark elsewhere "
        "(benchmark.name=<new name> or benchmark.output_dir=<dir>), or start them afresh with --restart-changed: "
        f"their directories move to {plan.root / REPLACED_DIR}/<time>/, nothing is deleted"
    )
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(run_benchmark(sys.argv[1:]))

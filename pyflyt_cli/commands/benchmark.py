"""``pyflyt benchmark experiment=<name> [seeds=N] [jobs=J] [overrides] [hydra/launcher=...]``.

Plans the experiment's grid (:func:`pyflyt_cli.benchmark.plan_benchmark`) and runs it
(:func:`pyflyt_cli.benchmark.run_benchmark`), or with ``--dry-run`` prints one
``pyflyt train`` line per run.  Progress and the summary go to stderr, the dry-run
script to stdout.  Exit code 0 when every run is complete, 1 if a run failed, 130 if
interrupted, 2 for a user error (nothing trained).
"""

from __future__ import annotations

import sys

import typer

from pyflyt_cli.benchmark import check_restarts, dry_run_script, plan_benchmark, run_benchmark, survey
from pyflyt_cli.commands import parse_overrides
from pyflyt_cli.errors import UsageError

FAILED = 1
INTERRUPTED = 130


def _echo(message: str) -> None:
    typer.echo(message, err=True)


def benchmark_command(overrides: list[str], dry_run: bool = False, restart_changed: bool = False) -> int:
    """What ``pyflyt benchmark`` does; returns the exit code."""
    overrides = parse_overrides(overrides)
    experiments = [o.partition("=")[2] for o in overrides if o.partition("=")[0] == "experiment"]
    if not experiments or not experiments[-1]:
        from pyflyt_engine.suggest import closest

        misspelt = [
            o for o in overrides if o.partition("=")[0] != "experiment" and closest(o.partition("=")[0], ["experiment"])
        ]
        hint = (
            f" ({misspelt[0]}: Did you mean 'experiment'? Use experiment={misspelt[0].partition('=')[2]}.)"
            if misspelt
            else ""
        )
        raise UsageError(f"choose the benchmark: pyflyt benchmark experiment=<name> (e.g. experiment=paper_rl){hint}")
    rest = [o for o in overrides if o.partition("=")[0] != "experiment"]
    plan = plan_benchmark(experiments[-1], rest, command=["pyflyt", "benchmark", *overrides])
    if dry_run:
        found = survey(plan)
        if found.restart and not restart_changed:  # the script first, then why it cannot run
            typer.echo("\n".join(dry_run_script(plan, found.states, {})))
        check_restarts(plan, found, restart_changed)
        _echo(found.headline(plan))
        typer.echo("\n".join(dry_run_script(plan, found.states, found.restart)))
        return 0
    result = run_benchmark(plan, restart_changed=restart_changed, log=_echo)
    _echo("\n" + result.summary.rstrip())
    _echo(f"\nreport: pyflyt plot {plan.root}")
    if result.interrupted:
        return INTERRUPTED
    return 0 if result.complete else FAILED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(benchmark_command(sys.argv[1:]))

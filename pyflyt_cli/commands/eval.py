"""``pyflyt eval <run dir> [key=value ...]``: compose ``conf/eval.yaml``, evaluate, print the table."""

from __future__ import annotations

import typer

from pyflyt_cli.config import compose, parse_overrides, to_container


def run_eval(run_dir: str, overrides: list[str]) -> object:
    """Evaluate ``run_dir`` with ``overrides`` of ``conf/eval.yaml``; print and return the report."""
    from pyflyt_cli.training.evaluate import evaluate_run
    from pyflyt_cli.training.rundir import check_run_dir
    from pyflyt_cli.training.schema import parse_eval_options

    check_run_dir(run_dir)  # a missing run directory is reported before anything else
    options = parse_eval_options(to_container(compose("eval", parse_overrides(overrides))))
    report = evaluate_run(run_dir, options)
    typer.echo(report.table())
    return report

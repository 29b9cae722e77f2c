"""``pyflyt eval <run dir> [key=value ...]``: compose ``conf/eval.yaml``, evaluate, print the table."""

from __future__ import annotations

import typer

from pyflyt_cli.config import compose, parse_overrides, to_container


def run_eval(run_dir: str, overrides: list[str]) -> object:
    """Evaluate ``run_dir`` with ``overrides`` of ``conf/eval.yaml``; print and return the report."""
    from pyflyt_cli.training.evaluate import evaluate_run
    from pyflyt_cli.training.rundir import check_run_dir
    from pyflyt_cli.training.schema import parse_eval_options

    shipped = None
    if run_dir.startswith("zoo:"):  # a shipped agent: copied to zoo/<name>/ here, evaluated there
        from pyflyt_cli.zoo import agent, materialise

        shipped = agent(run_dir[len("zoo:") :])
        run_dir = str(materialise(shipped.name))
    check_run_dir(run_dir)  # a missing run directory is reported before anything else
    options = parse_eval_options(to_container(compose("eval", parse_overrides(overrides))))
    report = evaluate_run(run_dir, options)
    typer.echo(report.table())
    if shipped is not None:
        recorded = shipped.summary.get("evaluation", {})
        same = (
            options.episodes == recorded.get("episodes")
            and report.seed == recorded.get("seed")
            and options.deterministic
        )
        typer.echo(
            f"recorded:      return {recorded.get('mean_return', float('nan')):.2f} ± "
            f"{recorded.get('std_return', float('nan')):.2f} over {recorded.get('episodes')} episodes from seed "
            f"{recorded.get('seed')}"
            + (
                f" ({'matches' if report.summary['mean_return'] == recorded.get('mean_return') else 'DIFFERS'})"
                if same
                else " (other episodes or seeds than recorded: not comparable)"
            )
        )
    return report

"""``pyflyt tune env=<task> algo=<algo> [trials=N jobs=J ...] [training overrides]``: an Optuna study
(:func:`pyflyt_cli.training.tune.tune`)."""

from __future__ import annotations

import typer

from pyflyt_cli.commands import parse_overrides
from pyflyt_cli.errors import UsageError
from pyflyt_cli.training.tune import TUNE_KEYS, tune

INTERRUPTED = 130


def run_tune(overrides: list[str]) -> int:
    """Returns the exit code (0 done, 130 interrupted)."""
    overrides = parse_overrides(overrides)
    env = algo = None
    options: dict[str, str] = {}
    training: list[str] = []
    for item in overrides:
        key, _, value = item.partition("=")
        if key == "env":
            env = value
        elif key == "algo":
            algo = value
        elif key in TUNE_KEYS:
            options[key] = None if value == "null" else value  # type: ignore[assignment]
        elif key in ("resume", "run_dir", "init_from"):
            raise UsageError(f"{key}= is not a tuning setting: every trial is a new run in the study directory")
        else:
            training.append(item)
    if not env or not algo:
        raise UsageError("pyflyt tune needs env=<task> and algo=<algorithm>, e.g. pyflyt tune env=quadx_hover algo=sac trials=20")

    def echo(message: str) -> None:
        typer.echo(message, err=True)

    try:
        report = tune(env, algo, options, training, log=echo)
    except KeyboardInterrupt:
        echo("interrupted: the study keeps its finished trials; the same command continues it")
        return INTERRUPTED
    echo(f"{report.finished} trials finished ({report.ran} now); study: {report.storage}")
    if report.best_file is not None:
        echo(f"best settings: {report.best_file}")
        echo(f"train with them: pyflyt train env={env} algo={algo} experiment={report.best_file} {' '.join(training)}".rstrip())
    for plot in report.plots:
        echo(f"plot: {plot}")
    return 0

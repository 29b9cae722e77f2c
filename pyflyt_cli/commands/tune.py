"""``pyflyt tune env=<task> algo=<algo> [trials=N jobs=J ...] [training overrides]``: an Optuna study
(:func:`pyflyt_cli.training.tune.tune`)."""

from __future__ import annotations

import typer

from pyflyt_cli.commands import parse_overrides
from pyflyt_cli.errors import UsageError
from pyflyt_cli.training.tune import TUNE_KEYS, tune

INTERRUPTED = 130


def _check_top_keys(training: list[str]) -> None:
    """A key that is neither a tuning setting nor a training key (``trails=3``) is refused
    here, with the closest of both kinds (:func:`pyflyt_engine.suggest.closest`): passed on,
    it would be taken for a misspelt training key."""
    from pyflyt_cli.compose import compose
    from pyflyt_engine.paths import conf_dir
    from pyflyt_engine.suggest import did_you_mean

    tops = {o.lstrip("+~").partition("=")[0].partition(".")[0] for o in training}
    if not tops:
        return
    known = {str(k) for k in compose("train", [])} | {p.name for p in conf_dir().iterdir() if p.is_dir()}
    for top in sorted(tops - known):
        options = sorted({*TUNE_KEYS, "env", "algo", *known})
        raise UsageError(
            f"unknown key '{top}' for pyflyt tune.{did_you_mean(top, options)} Tuning settings: {', '.join(TUNE_KEYS)}; "
            "every other key is a training key (pyflyt train --cfg lists them)"
        )


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
    _check_top_keys(training)
    if not env or not algo:
        raise UsageError(
            "pyflyt tune needs env=<task> and algo=<algorithm>, e.g. pyflyt tune env=quadx_hover algo=sac trials=20"
        )

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
        echo(
            f"train with them: pyflyt train env={env} algo={algo} experiment={report.best_file} {' '.join(training)}".rstrip()
        )
    for plot in report.plots:
        echo(f"plot: {plot}")
    return 0

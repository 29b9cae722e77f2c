"""``pyflyt uav validate`` and ``pyflyt uav show``: the work is :mod:`pyflyt_cli.airframes`.

Nothing here writes over its input: output images must be new files or existing PNGs,
checked before anything is printed or rendered.
"""

from __future__ import annotations

from pathlib import Path

import typer

from pyflyt_cli.airframes import (
    describe,
    describe_payloads,
    drawable_payloads,
    plot_surface_curves,
    render_airframe,
    resolve_file,
    validate_uav,
)
from pyflyt_cli.errors import UsageError
from pyflyt_cli.outputs import check_output, parse_size
from pyflyt_engine.errors import PyFlytError
from pyflyt_engine.spec import UAVSpec, load_uav_spec


def run_validate(files: list[str]) -> int:
    """Check every file, print ``ok: ...`` or the error for each; return the number of failures."""
    failures = 0
    for name in files:
        try:
            valid = validate_uav(name)
        except PyFlytError as exc:
            failures += 1
            typer.secho(f"error: {exc}", err=True, fg=typer.colors.RED)
            continue
        except Exception as exc:  # noqa: BLE001 - a bug must still not print a traceback here
            failures += 1
            typer.secho(
                f"error: {name}: internal error while checking it ({type(exc).__name__}: {exc}); please report it",
                err=True,
                fg=typer.colors.RED,
            )
            continue
        typer.echo(f"ok: {valid.path}: {valid.spec.name} ({valid.summary})")
        for warning in valid.warnings:
            typer.secho(f"  warning: {warning}", err=True, fg=typer.colors.YELLOW)
    if len(files) > 1:
        typer.echo(f"{len(files) - failures} of {len(files)} files valid")
    return failures


def run_show(
    name_or_path: str | None,
    png: Path | None = None,
    size: str = "640x480",
    curves: Path | None = None,
    env: str | None = None,
) -> UAVSpec:
    """Print the airframe's numbers; optionally write its picture and coefficient curves.

    ``env``: an env config (shipped name in ``conf/env`` or YAML path) whose payloads are
    printed after the airframe and drawn in its picture; without ``name_or_path`` the
    airframe is the env's own (its ``uav``).  Output paths are checked before anything is
    printed or rendered.
    """
    config = None
    if env is not None:
        from pyflyt_engine.envs.config import load_env_config

        config = load_env_config(env)
    if name_or_path is None:
        if config is None:
            raise UsageError(
                "give an airframe (a YAML file or a shipped name), or --env <env> to show an env's airframe"
            )
        name_or_path = config.uav
    path = resolve_file(name_or_path)
    width, height = parse_size(size)
    for target, option in ((png, "--png"), (curves, "--curves")):
        if target is not None:
            check_output(
                target, option, (".png",), [path] + ([Path(config.source)] if config and config.source else [])
            )
    if png is not None and curves is not None and png.resolve() == curves.resolve():
        raise UsageError(f"--png and --curves name the same file {png}; give two different files")
    spec = load_uav_spec(path)
    if curves is not None and not spec.surfaces:
        raise UsageError(f"{spec.name} has no lifting surfaces: nothing to plot for --curves")
    for line in describe(spec):
        typer.echo(line)
    payloads = list(config.payloads) if config is not None else []
    if config is not None:
        for line in describe_payloads(config, spec):
            typer.echo(line)
    if png is not None:
        render_airframe(spec, png, width, height, payloads=payloads)
        typer.echo(
            f"picture: {png} ({width}x{height}; body axes red X forward, green Y left, blue Z up; "
            "motor thrust axes orange CCW, blue CW; boosters magenta)"
        )
        drawn = [p.name for p in drawable_payloads(payloads)]
        if drawn:
            typer.echo(f"  payloads drawn at their reset poses: {', '.join(drawn)}")
        skipped = [p.name for p in payloads if p.name not in drawn]
        if skipped:
            typer.echo(f"  not drawn (placed in the world, not on the vehicle): {', '.join(skipped)}")
    if curves is not None:
        plot_surface_curves(spec, curves)
        typer.echo(f"coefficient curves: {curves}")
    return spec

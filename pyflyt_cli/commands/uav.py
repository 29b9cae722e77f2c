"""``pyflyt uav validate`` and ``pyflyt uav show``: the work is :mod:`pyflyt_cli.airframes`.

Nothing here writes over its input: output images must be new files or existing PNGs,
checked before anything is printed or rendered.
"""

from __future__ import annotations

from pathlib import Path

import typer

from pyflyt_cli.airframes import describe, plot_surface_curves, render_airframe, resolve_file, validate_uav
from pyflyt_cli.config import CLIError
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


def run_show(name_or_path: str, png: Path | None = None, size: str = "640x480", curves: Path | None = None) -> UAVSpec:
    """Print the airframe's numbers; optionally write its picture and coefficient curves.

    Output paths are checked before anything is printed or rendered.
    """
    path = resolve_file(name_or_path)
    width, height = parse_size(size)
    for target, option in ((png, "--png"), (curves, "--curves")):
        if target is not None:
            check_output(target, option, (".png",), [path])
    if png is not None and curves is not None and png.resolve() == curves.resolve():
        raise CLIError(f"--png and --curves name the same file {png}; give two different files")
    spec = load_uav_spec(path)
    if curves is not None and not spec.surfaces:
        raise CLIError(f"{spec.name} has no lifting surfaces: nothing to plot for --curves")
    for line in describe(spec):
        typer.echo(line)
    if png is not None:
        render_airframe(spec, png, width, height)
        typer.echo(
            f"picture: {png} ({width}x{height}; body axes red X forward, green Y left, blue Z up; "
            "motor thrust axes orange CCW, blue CW; boosters magenta)"
        )
    if curves is not None:
        plot_surface_curves(spec, curves)
        typer.echo(f"coefficient curves: {curves}")
    return spec

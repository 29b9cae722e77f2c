"""The ``pyflyt`` command line.

Commands take Hydra-style ``key=value`` overrides of the configs in ``conf/``; every
user error prints one clear message and exits with code 2, never a traceback.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, Optional

import typer

from pyflyt_engine.errors import PyFlytError

app = typer.Typer(
    name="pyflyt",
    help="UAV simulation and reinforcement-learning toolkit (PyFlyt paper).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def user_errors(func: Callable[..., Any]) -> Callable[..., Any]:
    """Turn library errors into a one-line message on stderr and exit code 2."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except PyFlytError as exc:
            typer.secho(f"error: {exc}", err=True, fg=typer.colors.RED)
            raise typer.Exit(code=2) from None

    return wrapper


@app.command(
    context_settings={"allow_extra_args": False},
    help="Fly one vehicle toward a setpoint and print a trajectory summary.\n\n"
    "Overrides (key=value) of conf/fly.yaml, e.g.:\n\n"
    "  pyflyt fly uav=quadx_cf2x mode=position_yaw setpoint=[0,0,0,1] duration=10\n\n"
    "  pyflyt fly uav=quadx_f450 mode=velocity_yawrate 'setpoint={vx:1}'",
)
@user_errors
def fly(overrides: Optional[list[str]] = typer.Argument(None, help="key=value overrides")) -> None:
    from pyflyt_cli.commands.fly import run_fly

    run_fly(overrides or [])


@app.command(help="List the flight modes, their PyFlyt numbers and setpoint layouts.")
def modes() -> None:
    from pyflyt_engine.control.modes import MODE_ALIASES, MULTIROTOR_MODES

    typer.echo(f"{'mode':<22}{'PyFlyt':>7}  setpoint")
    for mode in MULTIROTOR_MODES.values():
        pid = "" if mode.pyflyt_id is None else str(mode.pyflyt_id)
        layout = "one throttle per motor" if mode.name == "motors" else ", ".join(mode.setpoint)
        typer.echo(f"{mode.name:<22}{pid:>7}  [{layout}]  {mode.description}")
    typer.echo("aliases: " + ", ".join(f"{k} -> {v}" for k, v in MODE_ALIASES.items()))


@app.command(help="List the Gymnasium environments: spaces, reward presets and defaults.")
@user_errors
def envs() -> None:
    from pyflyt_cli.commands.envs import list_envs

    typer.echo(list_envs())


uav_app = typer.Typer(
    help="Check and inspect airframe (UAV) YAML files: shipped names (quadx_cf2x) or paths.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
app.add_typer(uav_app, name="uav")


@uav_app.command(
    "validate",
    help="Load, validate and build (offline) each airframe; print 'ok: ...' or what to fix. "
    "Exits 2 if any file is invalid.\n\n  pyflyt uav validate quadx_cf2x my_hexacopter.yaml",
)
def uav_validate(files: list[str] = typer.Argument(..., help="YAML files or shipped names")) -> None:
    from pyflyt_cli.commands.uav import run_validate

    if run_validate(files):
        raise typer.Exit(code=2)


@uav_app.command(
    "show",
    help="Print mass, centre of mass, inertia, thrust-to-weight, components, channels and "
    "controller; optionally render a picture (offscreen) and the surfaces' C_L/C_D/C_M curves.\n\n"
    "  pyflyt uav show quadx_f450 --png f450.png --size 800x600",
)
@user_errors
def uav_show(
    file: str = typer.Argument(..., help="YAML file or shipped name"),
    png: Optional[Path] = typer.Option(None, "--png", help="write a 3/4-view picture to this .png file"),
    size: str = typer.Option("640x480", "--size", help="picture size WIDTHxHEIGHT in pixels"),
    curves: Optional[Path] = typer.Option(None, "--curves", help="plot every lifting surface's coefficients to this .png"),
) -> None:
    from pyflyt_cli.commands.uav import run_show

    run_show(file, png=png, size=size, curves=curves)


@uav_app.command("schema", help="Print the reference of every airframe YAML field (Markdown: key, type, default, meaning).")
def uav_schema() -> None:
    from pyflyt_cli.commands.uav_schema import schema_markdown

    typer.echo(schema_markdown(), nl=False)


def main() -> None:  # pragma: no cover - console entry
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(app())

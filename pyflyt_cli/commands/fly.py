"""``pyflyt fly``: a scripted flight from the command line (parse, :func:`pyflyt_cli.flying.plan_flight`,
fly, print)."""

from __future__ import annotations

import math

import numpy as np
import typer

from pyflyt_cli.commands import parse_overrides
from pyflyt_cli.flying import plan_flight
from pyflyt_engine.flight import Trajectory, fly

__all__ = ["print_summary", "run_fly"]


def run_fly(overrides: list[str]) -> Trajectory:
    """Compose ``conf/fly.yaml`` with ``overrides``, validate, fly, print the summary."""
    flight = plan_flight(parse_overrides(overrides))
    traj = fly(flight.spec, wind=flight.wind, **flight.fly_kwargs())
    print_summary(flight.spec.name, traj, flight.options.rows)
    if not flight.wind.calm:
        # the preset's description no longer holds once one of its values is overridden
        about = (
            f"with {' '.join(flight.wind_overrides)}"
            if flight.wind_overrides
            else (flight.wind.description or "custom")
        )
        typer.echo(f"wind: {flight.wind.name} ({about})")
    return traj


def print_summary(name: str, traj: Trajectory, rows: int) -> None:
    """Print a table of the trajectory at ``rows`` evenly spaced times plus totals."""
    typer.echo(f"{name} in mode {traj.mode}, setpoint {np.round(traj.setpoint, 4).tolist()}")
    typer.echo(f"{'t [s]':>7}{'x':>9}{'y':>9}{'z':>9}{'roll':>8}{'pitch':>8}{'yaw':>8}{'speed':>8}  throttle")
    picks = np.unique(np.linspace(0, len(traj.time) - 1, max(rows, 2)).round().astype(int))
    for i in picks:
        x, y, z = traj.position[i]
        r, p, yw = np.degrees(traj.attitude[i])
        speed = float(np.linalg.norm(traj.velocity[i]))
        thr = " ".join(f"{t:.2f}" for t in traj.throttle[i])
        typer.echo(f"{traj.time[i]:>7.2f}{x:>9.3f}{y:>9.3f}{z:>9.3f}{r:>8.1f}{p:>8.1f}{yw:>8.1f}{speed:>8.2f}  {thr}")
    path = float(np.sum(np.linalg.norm(np.diff(traj.position, axis=0), axis=1)))
    last = traj.position[-1]
    typer.echo(
        f"flight: {traj.time[-1]:.2f} s, path length {path:.2f} m, max altitude {traj.position[:, 2].max():.3f} m, "
        f"final position ({last[0]:.3f}, {last[1]:.3f}, {last[2]:.3f}) m, "
        f"contacts in {int(traj.collided.sum())} of {len(traj.collided)} steps"
    )
    if not all(math.isfinite(v) for v in last):
        typer.echo("warning: the state diverged (non-finite values)")

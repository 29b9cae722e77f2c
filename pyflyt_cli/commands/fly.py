"""``pyflyt fly``: a scripted flight from the command line."""

from __future__ import annotations

import math

import numpy as np
import typer

from pyflyt_cli.config import compose, parse_overrides, to_container
from pyflyt_engine.flight import Trajectory, fly
from pyflyt_engine.spec import parse_uav_spec


def run_fly(overrides: list[str]) -> Trajectory:
    """Compose ``conf/fly.yaml`` with ``overrides``, fly, print the summary."""
    cfg = to_container(compose("fly", parse_overrides(overrides)))
    spec = parse_uav_spec(cfg["uav"], source=f"uav={cfg['uav'].get('name', '?')}")
    traj = fly(
        spec,
        cfg["mode"],
        cfg["setpoint"],
        float(cfg["duration"]),
        position=cfg["position"],
        orientation=cfg["orientation"],
        seed=cfg["seed"],
        physics_hz=cfg["physics_hz"],
        control_hz=cfg["control_hz"],
        agent_hz=cfg["agent_hz"],
        render=bool(cfg["render"]),
    )
    print_summary(spec.name, traj, int(cfg["rows"]))
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

"""``pyflyt fly``: a scripted flight from the command line.

``conf/fly.yaml`` plus the command's overrides are validated by :class:`FlyOptions`
before anything flies, so a bad value (``duration=abc``, ``seed=-1``, ``position=[nan,0,0]``)
is one message naming the key, not a traceback.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Optional

import numpy as np
import typer
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from pyflyt_cli.commands import parse_overrides
from pyflyt_cli.compose import compose, names_file, to_container
from pyflyt_engine import limits
from pyflyt_engine.atmosphere import parse_wind_config
from pyflyt_engine.flight import Trajectory, fly
from pyflyt_engine.loading import validate
from pyflyt_engine.spec import parse_uav_spec

Vec3 = tuple[float, float, float]


def _mode(value: Any) -> Any:
    if isinstance(value, bool) or not isinstance(value, (int, str)):
        raise ValueError(f"give a flight mode name or PyFlyt integer -1 ... 7 (see `pyflyt modes`), got {value!r}")
    return value


def _setpoint(value: Any) -> Any:
    if value is None:
        return value
    numbers = list(value.values()) if isinstance(value, dict) else value
    if isinstance(numbers, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in numbers):
        if all(math.isfinite(v) for v in numbers):
            for v in numbers:
                limits.check("fly.magnitude", abs(v), name="a setpoint value of size")
            return value
        raise ValueError(f"every value must be a finite number, got {value!r}")
    raise ValueError(
        f"give a list of numbers in the mode's layout (setpoint=[0,0,0,1]) or a mapping by name "
        f"(setpoint={{z:1}}), got {value!r}"
    )


class FlyOptions(BaseModel):
    """The keys of ``conf/fly.yaml`` (see the comments there); every number finite."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    uav: dict[str, Any] = Field(description="the airframe (conf/uav group), validated as a UAV spec")
    wind: dict[str, Any] = Field(description="the atmosphere (conf/wind group), validated as a wind config")
    mode: Annotated[Any, BeforeValidator(_mode)] = Field(description="flight mode: a name or a PyFlyt integer -1 ... 7")
    setpoint: Annotated[Any, BeforeValidator(_setpoint)] = Field(
        description="setpoint in the mode's layout, a mapping by name, or null (hover 1 m above the spawn point)"
    )
    duration: float = Field(gt=0, description="simulated seconds")
    position: Vec3 = Field(description="spawn position [x, y, z] [m]")
    orientation: Vec3 = Field(description="spawn attitude [roll, pitch, yaw] [rad]")
    seed: Optional[int] = Field(ge=0, description="seed of the actuator noise (null: random)")
    physics_hz: float = Field(gt=0, description="physics rate [Hz]")
    control_hz: float = Field(gt=0, description="controller rate [Hz]")
    agent_hz: float = Field(gt=0, description="rate of the printed trajectory samples [Hz]")
    rows: int = Field(ge=1, description="rows of the printed trajectory table")
    render: bool = Field(description="open the PyBullet GUI (needs a display)")
    ground_effect: bool = Field(description="rotor thrust times the ground-effect ratio (docs/atmosphere.md)")
    downwash: bool = Field(description="wakes of rotorcraft above as wind (docs/atmosphere.md)")

    @field_validator("rows", "duration")
    @classmethod
    def _bounded(cls, value: float, info: ValidationInfo) -> float:
        return limits.check(f"fly.{info.field_name}", value, name=info.field_name)

    @field_validator("position", "orientation")
    @classmethod
    def _placed(cls, value: Any, info: ValidationInfo) -> Any:
        for v in value:
            limits.check("fly.magnitude", abs(v), name=f"a {info.field_name} value of size")
        return value

    @field_validator("physics_hz", "control_hz", "agent_hz")
    @classmethod
    def _rate(cls, value: float, info: ValidationInfo) -> float:
        return limits.check(info.field_name, value)

    @model_validator(mode="after")
    def _steps(self) -> FlyOptions:
        limits.check("episode_physics_steps", self.physics_hz * self.duration, name="physics_hz x duration")
        return self


def run_fly(overrides: list[str]) -> Trajectory:
    """Compose ``conf/fly.yaml`` with ``overrides``, validate, fly, print the summary."""
    options: FlyOptions = validate(
        FlyOptions, to_container(compose("fly", parse_overrides(overrides))), "fly options", "pyflyt fly"
    )
    given = [o.partition("=")[2] for o in overrides if o.partition("=")[0].lstrip("+") == "uav"]
    if given and names_file(given[-1]):  # the file's own path: meshes are found beside it
        source = str(Path(given[-1]).expanduser().resolve())
    else:
        source = f"uav={options.uav.get('name', '?')}"
    spec = parse_uav_spec(options.uav, source=source)
    wind = parse_wind_config(options.wind, source="wind", name=_chosen_wind(overrides))
    # every other option is an argument of fly() of the same name
    traj = fly(spec, wind=wind, **{key: value for key, value in options if key not in ("uav", "rows", "wind")})
    print_summary(spec.name, traj, options.rows)
    if not wind.calm:
        changed = _wind_overrides(overrides)
        # the preset's description no longer holds once one of its values is overridden
        about = f"with {' '.join(changed)}" if changed else (wind.description or "custom")
        typer.echo(f"wind: {wind.name} ({about})")
    return traj


def _wind_overrides(overrides: list[str]) -> list[str]:
    """The command line's changes to the chosen wind preset (``wind.<key>=<value>``)."""
    return [item.lstrip("+") for item in overrides if item.lstrip("+").startswith("wind.")]


def _chosen_wind(overrides: list[str]) -> str:
    """The wind preset named on the command line (``wind=<preset>``), else the default."""
    for item in reversed(overrides):
        key, sep, value = item.partition("=")
        if sep and key.lstrip("+") == "wind":
            return value
    return "calm"


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

"""What a ``pyflyt fly`` command line asks for: :class:`FlyOptions` (``conf/fly.yaml`` plus the
overrides), the airframe and the wind they name, validated before anything flies.

A bad value (``duration=abc``, ``seed=-1``, ``position=[nan,0,0]``) is one message naming the
key, not a traceback.  The command (:mod:`pyflyt_cli.commands.fly`) calls :func:`plan_flight`,
flies (:func:`pyflyt_engine.flight.fly`) and prints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, Optional

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from pyflyt_cli.compose import compose, names_file, to_container
from pyflyt_engine import limits
from pyflyt_engine.atmosphere import WindConfig, parse_wind_config
from pyflyt_engine.loading import validate
from pyflyt_engine.spec import UAVSpec, parse_uav_spec

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
    controller: Literal["own", "betaflight"] = Field(
        "own", description="own (the airframe's cascade) or betaflight (its firmware in the loop, docs/firmware.md)"
    )

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
        assert info.field_name is not None  # a field validator is always given its field's name
        return limits.check(info.field_name, value)

    @model_validator(mode="after")
    def _steps(self) -> FlyOptions:
        limits.check("episode_physics_steps", self.physics_hz * self.duration, name="physics_hz x duration")
        return self


@dataclass(frozen=True)
class Flight:
    """A validated ``pyflyt fly`` request: its options, the airframe and the wind."""

    options: FlyOptions
    spec: UAVSpec
    wind: WindConfig
    #: the command line's changes to the chosen wind preset (``wind.<key>=<value>``)
    wind_overrides: list[str]

    def fly_kwargs(self) -> dict[str, Any]:
        """Every option but the airframe, the wind and the table's rows: an argument of ``fly()`` of the same name."""
        return {key: value for key, value in self.options if key not in ("uav", "rows", "wind")}


def plan_flight(overrides: list[str]) -> Flight:
    """Compose ``conf/fly.yaml`` with ``overrides`` (key=value) and validate all of it."""
    options: FlyOptions = validate(
        FlyOptions, to_container(compose("fly", list(overrides))), "fly options", "pyflyt fly"
    )
    given = [o.partition("=")[2] for o in overrides if o.partition("=")[0].lstrip("+") == "uav"]
    if given and names_file(given[-1]):  # the file's own path: meshes are found beside it
        source = str(Path(given[-1]).expanduser().resolve())
    else:
        source = f"uav={options.uav.get('name', '?')}"
    spec = parse_uav_spec(options.uav, source=source)
    wind = parse_wind_config(options.wind, source="wind", name=_chosen_wind(overrides))
    return Flight(options, spec, wind, _wind_overrides(overrides))


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

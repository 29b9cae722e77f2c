"""The wind config (``conf/wind/*.yaml``): a typed schema, presets by name, clear errors.

A wind config has three optional parts that add up::

    mean:        steady wind, uniform or sheared with height (log or power law)
    gust:        a discrete 1-cosine gust (MIL-F-8785C, discrete gusts)
    turbulence:  Dryden continuous turbulence (MIL-F-8785C, low altitude)

``calm`` (every part absent) is the default and changes nothing.  A config is named by a
shipped preset (``constant``, ``dryden_light`` ...), a YAML path, or given as a mapping,
whose optional ``preset`` key names a base preset the rest of the mapping overrides
(``{"preset": "constant", "mean": {"speed": 5}}``).  Files are read with
the bounded YAML reader of :mod:`pyflyt_engine.safe_load`; every number must be finite; unknown keys are refused.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from pyflyt_engine import limits
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.paths import conf_dir
from pyflyt_engine.loading import load, unknown_name, validate

KNOT = 0.514444  # [m/s] (1852 m / 3600 s)

#: the smallest positive gust length or speed, turbulence wind speed or airspeed [m, m/s]: a
#: subnormal one (1e-320) underflowed the gust's cosine argument to a math domain error and the
#: turbulence filter's poles to a division by zero; far below anything physical
SMALLEST_POSITIVE = 1e-6


def _not_tiny(value: float, name: str) -> None:
    if 0 < value < SMALLEST_POSITIVE:
        raise ValueError(
            f"{name} {value:g} is positive but below {SMALLEST_POSITIVE:g} (its filters would underflow); "
            f"give 0 where 0 is allowed, or a value of at least {SMALLEST_POSITIVE:g}"
        )


class _Config(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class MeanWind(_Config):
    """Steady wind: ``speed`` toward ``direction``, varying with height by ``profile``."""

    speed: float = Field(ge=0, description="horizontal wind speed [m/s] (at reference_height unless uniform)")
    direction: float = Field(
        0.0,
        description="direction the wind blows TOWARD [deg], from +x (east) counter-clockwise (90: toward +y, north)",
    )
    vertical: float = Field(0.0, description="vertical wind [m/s], + up; uniform in height")
    profile: Literal["uniform", "log", "power"] = Field(
        "uniform", description="uniform, log law u(z) = u_ref ln(z/z0)/ln(h_ref/z0), or power law u_ref (z/h_ref)^alpha"
    )
    reference_height: float = Field(10.0, gt=0, description="height h_ref [m] where speed is measured (log, power)")
    roughness_length: float = Field(
        0.03,
        gt=0,
        description="surface roughness z0 [m] of the log law (0.03: open flat terrain, Davenport-Wieringa roughness class 'open', WMO-No. 8)",
    )
    exponent: float = Field(1 / 7, ge=0, description="power-law exponent alpha (1/7: neutral air over open land)")

    @model_validator(mode="after")
    def _heights(self) -> MeanWind:
        if self.profile == "log" and not self.reference_height > self.roughness_length:
            raise ValueError("reference_height must be above roughness_length for the log profile")
        limits.check("wind_speed", self.speed, name="mean.speed")
        limits.check("wind_speed", abs(self.vertical), name="mean.vertical (its size)")
        return self


class Gust(_Config):
    """A discrete gust, the MIL-F-8785C, discrete gusts "1-cosine" shape, uniform in space.

    ``x = speed (t - start)`` is the distance the gust front has travelled past the vehicle;
    the gust velocity is ``amplitude / 2 (1 - cos(pi x / length))`` for ``0 <= x <= length``,
    then ``amplitude`` (shape ``step``, as MIL-F-8785C) or falling back along the mirrored
    curve to zero at ``x = 2 length`` (shape ``pulse``).
    """

    amplitude: tuple[float, float, float] = Field(description="gust velocity at its peak (x, y, z) [m/s], ground frame")
    length: float = Field(gt=0, description="gust length d_m [m] (distance to reach the peak)")
    speed: float = Field(gt=0, description="speed at which the gust front passes [m/s]")
    start: float = Field(0.0, ge=0, description="time the gust front arrives [s] after a reset")
    shape: Literal["step", "pulse"] = Field("step", description="step: hold the peak; pulse: back to 0 after 2 length")

    @model_validator(mode="after")
    def _bounded(self) -> Gust:
        limits.check("wind_speed", max(abs(v) for v in self.amplitude), name="gust.amplitude (its largest component)")
        limits.check("wind_speed", self.speed, name="gust.speed")
        _not_tiny(self.length, "gust.length")
        _not_tiny(self.speed, "gust.speed")
        return self


class Turbulence(_Config):
    """Dryden turbulence at a reference height (see :mod:`pyflyt_engine.atmosphere.dryden`)."""

    model: Literal["dryden"] = Field("dryden", description="the spectral model (Dryden forms of MIL-F-8785C)")
    wind_speed_20ft: float = Field(
        ge=0,
        description="wind speed W20 [m/s] 20 ft above ground that sets the intensities (light 15 kt, moderate 30 kt, severe 45 kt)",
    )
    height: float = Field(
        10.0, gt=0, description="height [m] the scales and intensities are evaluated at (clamped to 10..1000 ft)"
    )
    airspeed: float | None = Field(
        None, gt=0, description="speed V [m/s] at which the frozen field passes the vehicles; null: W20"
    )
    direction: float | None = Field(
        None,
        description="direction [deg] of the turbulence x axis (from +x, counter-clockwise); null: the mean wind's, else 0",
    )
    angular: bool = Field(True, description="also the rotary gusts p, q, r (per vehicle span)")
    rotary_min_span: float = Field(
        1.0,
        ge=0,
        description="vehicles of smaller span [m] get no rotary gusts: the MIL-F-8785C forms are for aeroplane "
        "spans and grow as b^(-2/3) below them (docs/atmosphere.md); 0: every vehicle",
    )

    @model_validator(mode="after")
    def _bounded(self) -> Turbulence:
        limits.check("wind_speed", self.wind_speed_20ft, name="turbulence.wind_speed_20ft")
        limits.check("wind_speed", self.advection_speed, name="turbulence.airspeed")
        _not_tiny(self.wind_speed_20ft, "turbulence.wind_speed_20ft")
        _not_tiny(self.advection_speed, "turbulence.airspeed")
        _not_tiny(self.height, "turbulence.height")
        return self

    @property
    def advection_speed(self) -> float:
        """V [m/s]: ``airspeed`` or, when null, W20."""
        return float(self.airspeed if self.airspeed is not None else self.wind_speed_20ft)


class WindConfig(_Config):
    """An atmosphere: a steady ``mean`` wind, a discrete ``gust`` and ``turbulence``, each optional."""

    name: str = Field("inline", description="preset name (the file name without .yaml)")
    description: str = Field("", description="one line of free text")
    mean: MeanWind | None = Field(None, description="steady wind (null: none)")
    gust: Gust | None = Field(None, description="discrete 1-cosine gust (null: none)")
    turbulence: Turbulence | None = Field(None, description="Dryden turbulence (null: none)")

    @property
    def calm(self) -> bool:
        """No wind at all: the world adds nothing (bit-identical to a world without wind)."""
        mean_zero = self.mean is None or (self.mean.speed == 0 and self.mean.vertical == 0)
        gust_zero = self.gust is None or not any(self.gust.amplitude)
        turb_zero = self.turbulence is None or self.turbulence.wind_speed_20ft == 0
        return mean_zero and gust_zero and turb_zero


CALM = WindConfig(name="calm", description="still air")


def available_winds() -> list[str]:
    """Names of the shipped wind presets (``conf/wind``)."""
    return sorted(p.stem for p in (conf_dir() / "wind").glob("*.yaml"))


def parse_wind_config(data: Any, source: str = "<dict>", name: str = "inline") -> WindConfig:
    """Validate a mapping as a :class:`WindConfig` (a ``preset`` key: a base preset to override)."""
    if data is None:
        return CALM
    if not isinstance(data, Mapping):
        raise ConfigError(f"{source}: a wind config must be a preset name or a mapping, got {type(data).__name__}")
    data = dict(data)
    base = data.pop("preset", None)
    if base is not None:
        merged = load_wind_config(str(base)).model_dump(mode="json")
        for key, value in data.items():
            if isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
                merged[key] = {**merged[key], **value}
            else:
                merged[key] = value
        data = merged
        data.setdefault("name", f"{base}+overrides")
    data.setdefault("name", name)
    config = validate(WindConfig, data, "wind config", source, prefix="wind.")
    for key in ("mean", "gust", "turbulence"):  # a NaN hidden in a nested tuple is refused above; belt and braces
        part = getattr(config, key)
        if part is not None and not all(math.isfinite(v) for v in _numbers(part.model_dump())):
            raise ConfigError(f"{source}: wind.{key}: every number must be finite")
    return config


def _numbers(value: Any) -> list[float]:
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return []
    if isinstance(value, (int, float)):
        return [float(value)]
    if isinstance(value, Mapping):
        return [x for v in value.values() for x in _numbers(v)]
    if isinstance(value, (list, tuple)):
        return [x for v in value for x in _numbers(v)]
    return []


def load_wind_config(wind: str | Path | Mapping[str, Any] | WindConfig | None) -> WindConfig:
    """A :class:`WindConfig` from a preset name (``conf/wind``), a YAML path, a mapping or None (calm)."""
    if wind is None:
        return CALM
    return load(wind, group="wind", model=WindConfig, parse=parse_wind_config, what="wind", unknown=_unknown_wind)


def _unknown_wind(name: Any) -> str:
    return unknown_name(name, available_winds(), "wind preset")

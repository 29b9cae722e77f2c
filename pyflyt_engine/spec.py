"""Typed vehicle (UAV) specs, loaded from YAML and validated at load.

A vehicle is data: a YAML file under ``conf/uav/`` (or anywhere) that declares the body,
its components and its controller.  :func:`load_uav_spec` reads it with
``yaml.safe_load`` (no tags, no code), checks every field against the schema below and
raises :class:`~pyflyt_engine.errors.SpecError` naming the file, the field and the fix.

The schema is written as pydantic models with ``extra="forbid"``, so a misspelt key is
an error (with a "did you mean"), not a silently ignored value.  Every field is
documented where it is declared; ``docs/uav_authoring.md`` walks through a full example.
"""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from pyflyt_engine.errors import SpecError
from pyflyt_engine.paths import uav_dir

Vec3 = tuple[float, float, float]
Color = tuple[float, float, float, float]
PositiveFloat = Annotated[float, Field(gt=0)]
NonNegativeFloat = Annotated[float, Field(ge=0)]


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


# --------------------------------------------------------------------------- body


class ShapeSpec(_Spec):
    """One collision and/or visual primitive of the body, placed in the body frame."""

    type: Literal["box", "cylinder", "sphere", "mesh"] = Field(description="primitive kind")
    size: Vec3 | None = Field(None, description="box: full edge lengths along x, y, z [m]")
    radius: float | None = Field(None, description="cylinder/sphere radius [m]")
    length: float | None = Field(None, description="cylinder length along its local z [m]")
    mesh: str | None = Field(None, description="mesh file (obj/dae/stl), relative to the spec file")
    scale: Vec3 = Field((1.0, 1.0, 1.0), description="mesh scale")
    position: Vec3 = Field((0.0, 0.0, 0.0), description="shape origin in the body frame [m]")
    rpy: Vec3 = Field((0.0, 0.0, 0.0), description="shape roll, pitch, yaw in the body frame [rad]")
    color: Color = Field((0.5, 0.5, 0.5, 1.0), description="RGBA in [0, 1]")
    collision: bool = Field(True, description="part of the collision geometry")
    visual: bool = Field(True, description="drawn")

    @model_validator(mode="after")
    def _dimensions(self) -> ShapeSpec:
        needed = {"box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",), "mesh": ("mesh",)}
        for name in needed[self.type]:
            if getattr(self, name) is None:
                raise ValueError(f"a {self.type} needs '{name}'")
        for name in ("radius", "length"):
            value = getattr(self, name)
            if value is not None and value <= 0:
                raise ValueError(f"'{name}' must be > 0 m, got {value}")
        if self.size is not None and min(self.size) <= 0:
            raise ValueError(f"every 'size' entry must be > 0 m, got {list(self.size)}")
        return self


class BodySpec(_Spec):
    """Rigid-body properties of the airframe, about its centre of mass (the body origin)."""

    mass: float = Field(description="total mass [kg], > 0")
    inertia: list[float] = Field(
        description="inertia about the centre of mass in the body frame [kg m^2]: "
        "[Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]"
    )
    shapes: list[ShapeSpec] = Field(default_factory=list, description="collision/visual primitives")
    urdf: str | None = Field(
        None, description="use this URDF instead of generating one (relative to the spec file)"
    )

    @field_validator("mass")
    @classmethod
    def _mass(cls, value: float) -> float:
        if not value > 0:
            raise ValueError(f"mass must be a positive number of kilograms, got {value}")
        return value

    @field_validator("inertia")
    @classmethod
    def _inertia(cls, value: list[float]) -> list[float]:
        if len(value) not in (3, 6):
            raise ValueError(
                f"inertia needs 3 values [Ixx, Iyy, Izz] or 6 [Ixx, Iyy, Izz, Ixy, Ixz, Iyz], got {len(value)}"
            )
        tensor = inertia_tensor(value)
        eig = np.linalg.eigvalsh(tensor)
        if eig.min() <= 0:
            raise ValueError(
                f"inertia tensor is not positive definite (principal moments {eig.round(9).tolist()}); "
                "every principal moment must be > 0 kg m^2"
            )
        a, b, c = (float(x) for x in sorted(eig))
        if a + b < c * (1 - 1e-9):
            raise ValueError(
                f"principal moments {[round(a, 12), round(b, 12), round(c, 12)]} violate the triangle inequality (I1 + I2 >= I3) "
                "that every real rigid body satisfies; check the units and the values"
            )
        return value


class DragSpec(_Spec):
    """Quadratic body drag per body axis: F_i = -1/2 rho C_d,i A_i v_i |v_i|, T_i = -c w_i |w_i|."""

    coefficients: Vec3 = Field((0.0, 0.0, 0.0), description="drag coefficient per body axis")
    areas: Vec3 = Field((0.0, 0.0, 0.0), description="reference area per body axis [m^2]")
    angular_damping: NonNegativeFloat = Field(
        0.0, description="rotational drag coefficient c: torque -c w |w| per body axis [N m s^2]"
    )

    @field_validator("coefficients", "areas")
    @classmethod
    def _non_negative(cls, value: Vec3) -> Vec3:
        if min(value) < 0:
            raise ValueError(f"drag coefficients and areas must be >= 0, got {list(value)}")
        return value


# ------------------------------------------------------------------------- motors


ScalarOrList = Union[float, list[float]]


class MotorsSpec(_Spec):
    """Motor-driven propellers.  One entry per motor in every list; scalars apply to all."""

    positions: list[Vec3] = Field(description="hub position of each motor in the body frame [m]")
    thrust_axes: list[Vec3] | None = Field(
        None, description="unit thrust direction of each motor, body frame (default +z for all)"
    )
    spin: list[Literal[-1, 1]] = Field(
        description="+1: propeller turns counter-clockwise about its thrust axis; -1: clockwise"
    )
    tau: ScalarOrList = Field(description="motor time constant [s]")
    max_rpm: ScalarOrList = Field(description="RPM at full throttle")
    kf: ScalarOrList = Field(description="thrust coefficient [N / RPM^2]")
    kt: ScalarOrList = Field(description="reaction torque coefficient [N m / RPM^2]")
    noise_ratio: ScalarOrList = Field(0.0, description="std of the multiplicative throttle noise")

    @model_validator(mode="after")
    def _consistent(self) -> MotorsSpec:
        n = len(self.positions)
        if n == 0:
            raise ValueError("motors.positions is empty: list one [x, y, z] per motor")
        lists = {"spin": self.spin, "thrust_axes": self.thrust_axes}
        for name in ("tau", "max_rpm", "kf", "kt", "noise_ratio"):
            value = getattr(self, name)
            if isinstance(value, list):
                lists[name] = value
        for name, value in lists.items():
            if value is not None and len(value) != n:
                scalar_ok = "" if name in ("spin", "thrust_axes") else " (or a single number for all)"
                raise ValueError(
                    f"'{name}' has {len(value)} entries but 'positions' has {n}: "
                    f"give one {name} entry per motor{scalar_ok}"
                )
        for name, lower, strict in (
            ("tau", 0.0, False),
            ("max_rpm", 0.0, True),
            ("kf", 0.0, True),
            ("kt", 0.0, False),
            ("noise_ratio", 0.0, False),
        ):
            arr = np.atleast_1d(np.asarray(getattr(self, name), dtype=float))
            bad = arr <= lower if strict else arr < lower
            if bad.any():
                relation = ">" if strict else ">="
                raise ValueError(f"'{name}' must be {relation} {lower}, got {arr.tolist()}")
        if self.thrust_axes is not None:
            norms = np.linalg.norm(np.asarray(self.thrust_axes, dtype=float), axis=1)
            if np.any(np.abs(norms - 1.0) > 1e-6):
                raise ValueError(
                    f"thrust_axes must be unit vectors, got norms {norms.round(6).tolist()}: normalise them"
                )
        return self

    def to_array(self, name: str) -> np.ndarray:
        """A per-motor array of field ``name`` (scalars broadcast to every motor)."""
        n = len(self.positions)
        if name == "thrust_axes":
            if self.thrust_axes is None:
                return np.tile([0.0, 0.0, 1.0], (n, 1))
            return np.asarray(self.thrust_axes, dtype=float)
        return np.broadcast_to(np.asarray(getattr(self, name), dtype=float), (n,)).copy()


# ------------------------------------------------------------------------ control


class RateGains(_Spec):
    """Body-rate loop: angular acceleration command = kp e + ki int(e) - kd d(omega)/dt."""

    kp: Vec3 = Field((25.0, 25.0, 15.0), description="[1/s] per body axis (roll, pitch, yaw)")
    ki: Vec3 = Field((50.0, 50.0, 30.0), description="[1/s^2]")
    kd: Vec3 = Field((0.0, 0.0, 0.0), description="[-], on the measured rate")
    integral_limit: Vec3 = Field((20.0, 20.0, 20.0), description="clamp on ki * int(e) [rad/s^2]")


class AttitudeGains(_Spec):
    """Attitude loop: body-rate setpoint = kp * angle error."""

    kp: Vec3 = Field((8.0, 8.0, 4.0), description="[1/s] roll, pitch, yaw")
    max_rate: Vec3 = Field((6.0, 6.0, 3.0), description="limit on the rate setpoint [rad/s]")


class VelocityGains(_Spec):
    """Velocity loop (ground frame): acceleration command = kp e + ki int(e)."""

    kp: Vec3 = Field((3.0, 3.0, 4.0), description="[1/s] x, y, z")
    ki: Vec3 = Field((0.5, 0.5, 1.0), description="[1/s^2]")
    integral_limit: Vec3 = Field((2.0, 2.0, 3.0), description="clamp on the integral term [m/s^2]")
    integral_window: float = Field(
        0.5, gt=0, description="integrate only while |error| is below this [m/s] (anti-windup in transients)"
    )
    max_tilt: float = Field(0.6, gt=0, lt=1.5, description="largest roll/pitch the loop may ask [rad]")


class PositionGains(_Spec):
    """Position loop (ground frame): velocity setpoint = kp * position error."""

    kp: Vec3 = Field((1.5, 1.5, 2.0), description="[1/s] x, y, z")
    max_velocity: Vec3 = Field((3.0, 3.0, 2.0), description="limit on the velocity setpoint [m/s]")


class MultirotorControlSpec(_Spec):
    """Cascaded PID flight controller for multirotors (position > velocity > attitude > rate)."""

    type: Literal["multirotor"] = "multirotor"
    mode: str = Field("rates_thrust", description="flight mode at spawn (name or PyFlyt integer)")
    rate: RateGains = RateGains()
    attitude: AttitudeGains = AttitudeGains()
    velocity: VelocityGains = VelocityGains()
    position: PositionGains = PositionGains()


class NoControlSpec(_Spec):
    """No onboard controller: the setpoint drives the actuators directly."""

    type: Literal["none"] = "none"


ControlSpec = Annotated[Union[MultirotorControlSpec, NoControlSpec], Field(discriminator="type")]


# ------------------------------------------------------------------------ vehicle


class UAVSpec(_Spec):
    """A complete vehicle: body, drag, actuators and controller."""

    name: str = Field(description="identifier, usually the file name without .yaml")
    description: str = Field("", description="free text")
    body: BodySpec
    drag: DragSpec = DragSpec()
    motors: MotorsSpec | None = None
    control: ControlSpec = Field(default_factory=NoControlSpec)
    source: str | None = Field(None, exclude=True, description="file the spec was loaded from")

    @model_validator(mode="after")
    def _controllable(self) -> UAVSpec:
        if isinstance(self.control, MultirotorControlSpec) and self.motors is None:
            raise ValueError("control.type 'multirotor' needs a 'motors' section")
        return self


def inertia_tensor(values: list[float] | tuple[float, ...]) -> np.ndarray:
    """3 x 3 inertia tensor from [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]."""
    ixx, iyy, izz = values[:3]
    ixy, ixz, iyz = values[3:] if len(values) == 6 else (0.0, 0.0, 0.0)
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)


# ------------------------------------------------------------------------ loading

_FIX_HINTS = {
    "extra_forbidden": "remove it or check its spelling",
    "missing": "add it",
    "float_parsing": "give a number",
    "float_type": "give a number",
    "int_parsing": "give an integer",
    "bool_parsing": "give true or false",
    "list_type": "give a list, e.g. [1, 2, 3]",
    "tuple_type": "give a list, e.g. [1, 2, 3]",
    "literal_error": "use one of the allowed values",
    "too_short": "give the expected number of values",
    "too_long": "give the expected number of values",
    "greater_than": "give a larger value",
    "less_than": "give a smaller value",
    "union_tag_invalid": "use one of the allowed values",
}


def _model_at(loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The pydantic model that holds the field at ``loc`` (for listing valid keys)."""
    model: Any = UAVSpec
    for part in loc[:-1]:
        if isinstance(part, int) or model is None:
            continue
        field = model.model_fields.get(part)
        if field is None:
            # discriminated unions appear in loc as their tag, e.g. ('control', 'multirotor', ...)
            candidates = [MultirotorControlSpec, NoControlSpec]
            model = next((c for c in candidates if c.model_fields["type"].default == part), None)
            continue
        annotation = field.annotation
        model = _first_model(annotation)
    return model


def _first_model(annotation: Any) -> Any:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in getattr(annotation, "__args__", ()):
        found = _first_model(arg)
        if found is not None:
            return found
    return None


def _describe(error: dict[str, Any]) -> str:
    loc = tuple(error["loc"])
    where = ".".join(str(p) for p in loc if p not in ("multirotor", "none")) or "(top level)"
    kind = error["type"]
    if kind == "extra_forbidden":
        model = _model_at(loc)
        allowed = sorted(model.model_fields) if model is not None else []
        allowed = [a for a in allowed if a != "source"]
        key = str(loc[-1])
        close = difflib.get_close_matches(key, allowed, n=1)
        hint = f"did you mean '{close[0]}'? " if close else ""
        return f"{where}: unknown key '{key}'. {hint}Allowed keys here: {', '.join(allowed)}"
    message = error["msg"].removeprefix("Value error, ")
    hint = _FIX_HINTS.get(kind)
    value = error.get("input")
    shown = "" if kind == "missing" or isinstance(value, dict) or "got" in message else f" (got {value!r})"
    return f"{where}: {message}{shown}" + (f"; fix: {hint}" if hint else "")


def parse_uav_spec(data: Any, source: str = "<dict>") -> UAVSpec:
    """Validate an already-parsed mapping as a :class:`UAVSpec`.

    Raises:
        SpecError: listing every problem found, each with its field and a fix.
    """
    if not isinstance(data, dict):
        raise SpecError(f"{source}: a UAV spec must be a mapping of keys to values, got {type(data).__name__}")
    try:
        spec = UAVSpec.model_validate({**data, "source": source})
    except ValidationError as exc:
        problems = "\n".join(f"  - {_describe(e)}" for e in exc.errors())
        raise SpecError(f"{source}: invalid UAV spec:\n{problems}") from None
    return spec


def resolve_uav_path(name_or_path: str | Path) -> Path:
    """A shipped airframe name (``quadx_cf2x``) or a path to a YAML file, as a path."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml") or candidate.exists():
        if not candidate.is_file():
            raise SpecError(f"{candidate}: no such UAV file; check the path")
        return candidate
    shipped = uav_dir() / f"{name_or_path}.yaml"
    if shipped.is_file():
        return shipped
    choices = available_uavs()
    close = difflib.get_close_matches(str(name_or_path), choices, n=1)
    hint = f" Did you mean '{close[0]}'?" if close else ""
    raise SpecError(
        f"unknown UAV '{name_or_path}'.{hint} Shipped airframes: {', '.join(choices)}; "
        "or give the path to a .yaml file"
    )


def available_uavs() -> list[str]:
    """Names of the airframes shipped in ``conf/uav``."""
    return sorted(p.stem for p in uav_dir().glob("*.yaml"))


def load_uav_spec(name_or_path: str | Path) -> UAVSpec:
    """Load and validate a UAV spec from a shipped name or a YAML path.

    The file is parsed with ``yaml.safe_load``: YAML tags that would construct Python
    objects are rejected, so loading a spec never runs code from it.

    Raises:
        SpecError: the file is missing, is not valid YAML, or does not match the schema.
    """
    path = resolve_uav_path(name_or_path)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise SpecError(f"{path}: not valid YAML: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"{path}: cannot read the file: {exc}") from None
    return parse_uav_spec(data, source=str(path))

"""Typed vehicle (UAV) specs, loaded from YAML and validated at load.

A vehicle is data: a YAML file under ``conf/uav/`` (or anywhere) that declares the body,
its components and its controller.  :func:`load_uav_spec` reads it with the bounded YAML reader of
:mod:`pyflyt_engine.safe_load` (no tags, no code), checks every field against the schema below and
raises :class:`~pyflyt_engine.errors.SpecError` naming the file, the field and the fix.

The schema is written as pydantic models with ``extra="forbid"``, so a misspelt key is
an error (with a "did you mean"), not a silently ignored value.  Every field is
documented where it is declared; ``docs/uav_authoring.md`` walks through a full example.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    SerializerFunctionWrapHandler,
    ValidationInfo,
    field_validator,
    model_serializer,
    model_validator,
)

from pyflyt_engine import exact
from pyflyt_engine.allocation import Tilt, require_controllable, tilted_allocation
from pyflyt_engine.errors import SpecError
from pyflyt_engine.frames import rpy_matrix
from pyflyt_engine.paths import uav_dir
from pyflyt_engine.loading import load, resolve, unknown_name, validate

Vec3 = tuple[float, float, float]
Color = tuple[float, float, float, float]
PositiveFloat = Annotated[float, Field(gt=0)]
NonNegativeFloat = Annotated[float, Field(ge=0)]

#: the form of every name read from a file (airframe, surface, gimbal, camera): such names
#: end up in generated files, recordings and messages, so they may never carry a path
IDENTIFIER_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_-]{0,63}")


def check_identifier(value: str) -> str:
    """``value`` if it is a plain identifier (:data:`IDENTIFIER_PATTERN`), else ValueError saying how to fix it."""
    if not IDENTIFIER_PATTERN.fullmatch(value):
        raise ValueError(
            f"must be a plain identifier, got {value!r}: use 1 to 64 letters, digits, '_' or '-', starting "
            "with a letter or '_' (no '/', '.' or spaces), e.g. 'my_hexacopter'"
        )
    return value


def check_finite(value: Any) -> Any:
    """``value`` unless it is, or is a list/tuple holding, a non-finite float (ValueError).

    For union-typed fields (a number or a list of numbers), where the schema's own
    finiteness check would report every alternative of the union separately.
    """
    items = value if isinstance(value, (list, tuple)) else [value]
    for item in items:
        if isinstance(item, float) and not math.isfinite(item):
            raise ValueError(f"must be a finite number, got {value!r}; give a real number (not .inf or .nan)")
    return value


#: a name read from a file: see :func:`check_identifier`
Identifier = Annotated[str, AfterValidator(check_identifier)]


class _Spec(BaseModel):
    # allow_inf_nan=False: every float, also inside tuples, lists and mappings, must be
    # finite (YAML's .inf and .nan would otherwise reach the physics as silent NaN)
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)


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
    mass: float | None = Field(
        None, ge=0, description="mass of this part [kg], uniform density; used when body.mass/inertia are left out"
    )

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


#: the smallest body mass accepted [kg]
MIN_MASS = 1e-6


class BodySpec(_Spec):
    """Rigid-body properties of the airframe.

    Either give ``mass`` and ``inertia`` (about the centre of mass), or give shapes a
    ``mass`` each and leave them out: they are then computed from the parts as uniform
    solids (parallel-axis theorem).  Positions anywhere in the spec may be measured from
    any reference point: the body origin is moved to the centre of mass when the vehicle
    is built (see :meth:`UAVSpec.center_of_mass`).
    """

    mass: float | None = Field(None, description="total mass [kg], > 0 (default: sum of the parts' masses)")
    inertia: list[float] | None = Field(
        None,
        description="inertia about the centre of mass in the body frame [kg m^2]: "
        "[Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] (default: computed from the parts)",
    )
    center_of_mass: Vec3 | None = Field(
        None, description="centre of mass in the spec's coordinates [m] (default: from the parts, else the origin)"
    )
    shapes: list[ShapeSpec] = Field(default_factory=list, description="collision/visual primitives")
    urdf: str | None = Field(None, description="use this URDF instead of generating one (relative to the spec file)")

    @field_validator("mass")
    @classmethod
    def _mass(cls, value: float | None) -> float | None:
        if value is not None and not value > 0:
            raise ValueError(f"mass must be a positive number of kilograms, got {value}")
        if value is not None and value < MIN_MASS:
            # a mass of 1e-320 kg flew through the ground; 1 mg is below any flying machine
            raise ValueError(f"mass {value:g} kg is below {MIN_MASS:g} kg (1 mg): give the mass in kilograms")
        from pyflyt_engine import limits

        return value if value is None else limits.check("mass", value, name="mass")

    @field_validator("inertia")
    @classmethod
    def _inertia(cls, value: list[float] | None) -> list[float] | None:
        if value is None:
            return value
        if len(value) not in (3, 6):
            raise ValueError(
                f"inertia needs 3 values [Ixx, Iyy, Izz] or 6 [Ixx, Iyy, Izz, Ixy, Ixz, Iyz], got {len(value)}"
            )
        _check_inertia(inertia_tensor(value))
        return value

    @model_validator(mode="after")
    def _mass_source(self) -> BodySpec:
        part_mass = sum(s.mass or 0.0 for s in self.shapes)
        if part_mass > 0:
            from pyflyt_engine import limits

            limits.check("mass", part_mass, name="the shapes' masses (their sum)")
            if self.mass is None and part_mass < MIN_MASS:
                raise ValueError(f"the shapes' masses sum to {part_mass:g} kg, below {MIN_MASS:g} kg (1 mg)")
        if (self.mass is None or self.inertia is None) and part_mass <= 0:
            missing = " and ".join(n for n in ("mass", "inertia") if getattr(self, n) is None)
            raise ValueError(f"body.{missing} missing: give it, or give the shapes a 'mass' each to compute it")
        if self.mass is not None and part_mass > 0 and abs(part_mass - self.mass) > 1e-6 * self.mass:
            raise ValueError(
                f"body.mass {self.mass} kg disagrees with the sum of the shapes' masses {part_mass:.6g} kg: "
                "remove one of them or make them agree"
            )
        if self.urdf is None and not any(s.collision for s in self.shapes):
            raise ValueError("body.shapes has no collision shape: add one (collision: true) or give a urdf")
        return self

    # ------------------------------------------------------------- mass properties

    def total_mass(self) -> float:
        """Mass [kg]: ``mass`` when given, else the sum of the shapes' masses."""
        if self.mass is not None:
            return self.mass
        return float(sum(s.mass or 0.0 for s in self.shapes))

    def mass_center(self) -> np.ndarray:
        """Centre of mass in the body's coordinates [m]: ``center_of_mass`` when given,
        else the mass-weighted mean of the shapes' positions."""
        if self.center_of_mass is not None:
            return np.asarray(self.center_of_mass, dtype=float)
        parts = [s for s in self.shapes if s.mass]
        if not parts:
            return np.zeros(3)
        masses = [float(s.mass) for s in parts]  # type: ignore[arg-type]
        total = math.fsum(masses)
        return np.array([exact.dot(masses, [s.position[axis] for s in parts]) / total for axis in range(3)])

    def lowest_point(self) -> float | None:
        """The lowest point of the collision primitives along body z [m], in the body's
        coordinates (what the airframe stands on when upright), or None when the collision
        geometry is not all boxes, cylinders and spheres (a mesh or a URDF)."""
        if self.urdf is not None:
            return None
        lows = []
        for shape in self.shapes:
            if not shape.collision:
                continue
            if shape.type == "mesh":
                return None
            z = shape.position[2]
            if shape.type == "sphere":
                lows.append(z - shape.radius)  # type: ignore[operator]
                continue
            row = rpy_matrix(shape.rpy)[2].tolist()  # the body z of each of the shape's axes
            if shape.type == "box":
                sx, sy, sz = shape.size  # type: ignore[misc]
                lows.append(z - 0.5 * (abs(row[0]) * sx + abs(row[1]) * sy + abs(row[2]) * sz))
            else:  # cylinder along its local z: the end disc's rim
                az = row[2]
                rim = math.sqrt(max(0.0, 1.0 - az * az))
                lows.append(z - 0.5 * shape.length * abs(az) - shape.radius * rim)  # type: ignore[operator]
        return min(lows) if lows else None

    def inertia_matrix(self) -> np.ndarray:
        """3 x 3 inertia about the centre of mass, body axes [kg m^2]: ``inertia`` when
        given, else the shapes' own inertias moved there (parallel-axis theorem)."""
        if self.inertia is not None:
            return inertia_tensor(self.inertia)
        com = self.mass_center().tolist()
        terms: list[list[list[float]]] = []  # per shape: its inertia about the centre of mass
        for shape in self.shapes:
            if not shape.mass:
                continue
            rot = rpy_matrix(shape.rpy)
            own = exact.matmul(exact.matmul(rot, shape_inertia(shape)), exact.transpose(rot))
            r = [float(p) - c for p, c in zip(shape.position, com)]
            r2 = exact.dot(r, r)
            m = float(shape.mass)
            terms.append(
                [[own[i][j] + m * ((r2 if i == j else 0.0) - r[i] * r[j]) for j in range(3)] for i in range(3)]
            )
        return np.array([[math.fsum(t[i][j] for t in terms) for j in range(3)] for i in range(3)])


def _check_inertia(tensor: np.ndarray) -> None:
    eig = exact.eigvalsh3(tensor)
    if min(eig) <= 0:
        raise ValueError(
            f"inertia tensor is not positive definite (principal moments {[round(x, 9) for x in eig]}); "
            "every principal moment must be > 0 kg m^2"
        )
    a, b, c = eig
    if a + b < c * (1 - 1e-9):
        raise ValueError(
            f"principal moments {[round(a, 12), round(b, 12), round(c, 12)]} violate the triangle inequality "
            "(I1 + I2 >= I3) that every real rigid body satisfies; check the units and the values"
        )


def shape_inertia(shape: ShapeSpec) -> np.ndarray:
    """Inertia [kg m^2] of a uniform solid shape about its own centre, in its own axes."""
    m = shape.mass or 0.0
    # ShapeSpec._dimensions has required the dimensions of each shape type: the asserts only narrow
    if shape.type == "box":
        assert shape.size is not None
        x, y, z = shape.size
        return np.diag([m * (y * y + z * z), m * (x * x + z * z), m * (x * x + y * y)]) / 12.0
    if shape.type == "cylinder":
        r, h = shape.radius, shape.length
        assert r is not None and h is not None
        side = m * (3 * r * r + h * h) / 12.0
        return np.diag([side, side, m * r * r / 2.0])
    if shape.type == "sphere":
        assert shape.radius is not None
        return np.eye(3) * 0.4 * m * shape.radius**2
    raise ValueError("a mesh shape cannot carry a mass: give body.mass and body.inertia instead")


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


# ------------------------------------------------------------------- unit vectors

#: How far from length 1 a direction typed by hand may be: four decimals ([0.7071, 0,
#: 0.7071] has length 0.99998) are accepted and normalised; further off is a mistake.
UNIT_TOLERANCE = 1e-3
#: Closer to length 1 than this, a direction is used exactly as given.
_UNIT_EXACT = 1e-6


def unit_vector(value: Vec3, key: str) -> Vec3:
    """``value`` scaled to length 1 (as given when within 1e-6 of it).

    Raises:
        ValueError: naming ``key`` and the length, when it is more than
            :data:`UNIT_TOLERANCE` from 1.
    """
    norm = math.sqrt(sum(v * v for v in value))
    if abs(norm - 1.0) <= _UNIT_EXACT:
        return tuple(value)  # type: ignore[return-value]
    if abs(norm - 1.0) > UNIT_TOLERANCE:
        raise ValueError(
            f"'{key}' must be a unit vector, got {list(value)} of length {norm:.6g} (accepted: within "
            f"{UNIT_TOLERANCE:g} of 1, then normalised); divide each component by the length"
        )
    return tuple(v / norm for v in value)  # type: ignore[return-value]


def _unit_field(value: Vec3, info: ValidationInfo) -> Vec3:
    return unit_vector(value, info.field_name or "axis")


#: a direction in the body frame, normalised at load (see :func:`unit_vector`)
UnitVec3 = Annotated[Vec3, AfterValidator(_unit_field)]


# ------------------------------------------------------------------------- motors


ScalarOrList = Annotated[Union[float, list[float]], BeforeValidator(check_finite)]


def _drop_unset(data: Any, keys: tuple[str, ...]) -> Any:
    """A dumped spec without the optional models in ``keys`` that are off (None): a spec that
    does not use them dumps, and is recorded, exactly as before they existed."""
    if isinstance(data, dict):
        for key in keys:
            if data.get(key, 0) is None:
                del data[key]
    return data


class InflowSpec(_Spec):
    """Blade-element parameters of the rotors for the axial-inflow model (docs/engine.md,
    "Motor models and battery"): thrust coefficient ``C_T = (sigma a / 4)(theta_tip - lambda)`` of an
    ideally twisted blade (Leishman, Principles of Helicopter Aerodynamics, 2nd ed., 2006,
    section 3.3), closed with momentum theory."""

    solidity: float = Field(gt=0, lt=1, description="rotor solidity sigma = blades * chord / (pi * radius)")
    lift_slope: float = Field(
        2 * math.pi, gt=0, le=2 * math.pi, description="blade-section lift-curve slope a [1/rad] (thin aerofoil: 2 pi)"
    )


#: the optional motor models: off (absent from the spec and its dump) unless given
_MOTOR_MODELS = ("tau_fall", "rotor_drag", "inflow")


class MotorsSpec(_Spec):
    """Motor-driven propellers.  One entry per motor in every list; scalars apply to all."""

    positions: list[Vec3] = Field(description="hub position of each motor in the body frame [m]")
    thrust_axes: list[UnitVec3] | None = Field(
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
    prop_radius: ScalarOrList | None = Field(
        None, description="propeller radius [m], for ground effect and downwash (null: those effects skip the motor)"
    )
    mix: list[dict[str, float] | None] | None = Field(
        None,
        description="per motor: channel weights driving it directly (e.g. {thrust: 1.0} for a pusher), "
        "or null for motors flown by the multirotor controller",
    )
    tau_fall: ScalarOrList | None = Field(
        None,
        description="time constant while the rotor slows down [s] ('tau' is then the spin-up one); null: 'tau' both ways",
    )
    rotor_drag: ScalarOrList | None = Field(
        None,
        description="rotor drag (H-force) per rotor at full speed [N / (m/s)]: force -rotor_drag * |x| * v_inplane "
        "at the hub; null: none",
    )
    inflow: InflowSpec | None = Field(
        None,
        description="thrust and torque respond to the axial air speed through the disc (needs prop_radius); null: static",
    )

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> Any:
        return _drop_unset(handler(self), _MOTOR_MODELS)

    @model_validator(mode="after")
    def _consistent(self) -> MotorsSpec:
        n = len(self.positions)
        if n == 0:
            raise ValueError("motors.positions is empty: list one [x, y, z] per motor")
        if self.inflow is not None and self.prop_radius is None:
            raise ValueError("motors.inflow needs motors.prop_radius (the rotor radius sets the inflow ratio)")
        lists = {"spin": self.spin, "thrust_axes": self.thrust_axes, "mix": self.mix}
        for name in ("tau", "max_rpm", "kf", "kt", "noise_ratio", "prop_radius", "tau_fall", "rotor_drag"):
            value = getattr(self, name)
            if isinstance(value, list):
                lists[name] = value
        for name, value in lists.items():
            if value is not None and len(value) != n:
                scalar_ok = "" if name in ("spin", "thrust_axes", "mix") else " (or a single number for all)"
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
            ("prop_radius", 0.0, True),
            ("tau_fall", 0.0, False),
            ("rotor_drag", 0.0, False),
        ):
            if getattr(self, name) is None:
                continue
            arr = np.atleast_1d(np.asarray(getattr(self, name), dtype=float))
            bad = arr <= lower if strict else arr < lower
            if bad.any():
                relation = ">" if strict else ">="
                raise ValueError(f"'{name}' must be {relation} {lower}, got {arr.tolist()}")
        from pyflyt_engine import limits

        for name in ("max_rpm", "noise_ratio"):
            limits.check(name, float(np.max(self.to_array(name))), name=f"motors.{name}")
        return self

    def to_array(self, name: str) -> np.ndarray:
        """A per-motor array of field ``name`` (scalars broadcast to every motor)."""
        n = len(self.positions)
        if name == "thrust_axes":
            if self.thrust_axes is None:
                return np.tile([0.0, 0.0, 1.0], (n, 1))
            return np.asarray(self.thrust_axes, dtype=float)
        return np.broadcast_to(np.asarray(getattr(self, name), dtype=float), (n,)).copy()


# --------------------------------------------------------------- other actuators


class SurfaceSpec(_Spec):
    """A (flapped) lifting surface: Khan & Nahon performance profile (see docs/uav_authoring.md)."""

    name: Identifier = Field(description="identifier, unique within the vehicle (letters, digits, '_', '-')")
    position: Vec3 = Field(description="aerodynamic centre in the spec's coordinates [m]")
    chord_axis: UnitVec3 = Field((1.0, 0.0, 0.0), description="unit vector, trailing edge to leading edge, body frame")
    normal_axis: UnitVec3 = Field((0.0, 0.0, 1.0), description="unit vector on the positive-lift side, body frame")
    chord: float = Field(gt=0, description="chord [m]")
    span: float = Field(gt=0, description="span [m]")
    flap_to_chord: float = Field(0.0, ge=0, le=1, description="movable fraction of the chord")
    alpha_0_deg: float = Field(0.0, description="zero-lift angle of attack, undeflected [deg]")
    stall_pos_deg: float = Field(15.0, description="positive stall angle, undeflected [deg]")
    stall_neg_deg: float = Field(-15.0, description="negative stall angle, undeflected [deg]")
    cd_0: float = Field(0.01, ge=0, description="zero-lift drag coefficient")
    cl_alpha_2d: float = Field(6.283, gt=0, description="2-D lift slope [1/rad] (thin aerofoil: 2 pi)")
    eta: float = Field(0.65, ge=0, description="flap viscosity correction factor")
    max_deflection_deg: float = Field(0.0, ge=0, description="flap deflection limit [deg] (0: no flap)")
    tau: float = Field(0.05, ge=0, description="flap time constant [s]")
    mix: dict[str, float] = Field(default_factory=dict, description="channel weights driving the flap command")
    visual: bool = Field(True, description="draw the surface as a thin plate")
    color: Color = Field((0.85, 0.85, 0.85, 1.0), description="RGBA of the drawn plate")

    @field_validator("chord", "span", mode="before")
    @classmethod
    def _positive_size(cls, value: Any, info: ValidationInfo) -> Any:
        if isinstance(value, (int, float)) and not value > 0:
            raise ValueError(
                f"{info.field_name} must be > 0 m, got {value}: a lifting surface needs a positive area "
                "(chord x span); give its real size or remove the surface"
            )
        return value

    @field_validator("normal_axis")
    @classmethod
    def _normal(cls, value: Vec3, info: ValidationInfo) -> Vec3:
        """A unit vector perpendicular to ``chord_axis``: within :data:`UNIT_TOLERANCE` of
        it, the chord-wise part is removed (typed decimals); further off is refused."""
        normal = value
        chord = info.data.get("chord_axis")
        if chord is None:  # chord_axis itself is invalid: reported on its own
            return normal
        dot = sum(n * c for n, c in zip(normal, chord))
        if abs(dot) <= _UNIT_EXACT:
            return normal
        if abs(dot) > UNIT_TOLERANCE:
            raise ValueError(
                f"chord_axis and normal_axis must be perpendicular, got a dot product of {dot:.4g} (accepted: "
                f"within {UNIT_TOLERANCE:g} of 0, then corrected); the normal points to the lift side, across the chord"
            )
        corrected = [n - dot * c for n, c in zip(normal, chord)]
        length = math.sqrt(sum(v * v for v in corrected))  # >= sqrt(1 - dot**2): never near 0
        return tuple(v / length for v in corrected)

    @model_validator(mode="after")
    def _geometry(self) -> SurfaceSpec:
        if not self.stall_neg_deg < self.alpha_0_deg < self.stall_pos_deg:
            raise ValueError(
                f"need stall_neg_deg < alpha_0_deg < stall_pos_deg, got {self.stall_neg_deg} / "
                f"{self.alpha_0_deg} / {self.stall_pos_deg}"
            )
        if self.mix and self.max_deflection_deg == 0:
            raise ValueError("a surface with 'mix' needs max_deflection_deg > 0 (it has no movable flap)")
        return self


class BoostersSpec(_Spec):
    """Fueled boosters (columnar like motors: one entry per booster, scalars apply to all)."""

    positions: list[Vec3] = Field(description="thrust point of each booster [m]")
    thrust_axes: list[UnitVec3] | None = Field(None, description="unit thrust directions (default +z)")
    fuel_tank_positions: list[Vec3] | None = Field(None, description="tank centres [m] (default: the thrust point)")
    total_fuel: ScalarOrList = Field(description="fuel mass when full [kg]")
    max_fuel_rate: ScalarOrList = Field(description="fuel mass flow at full duty [kg/s]")
    inertia_full: list[Vec3] | None = Field(None, description="tank inertia diagonal at full fuel [kg m^2]")
    min_thrust: ScalarOrList = Field(0.0, description="thrust at minimum throttle when lit [N]")
    max_thrust: ScalarOrList = Field(description="thrust at full throttle [N]")
    reignitable: bool | list[bool] = Field(True, description="whether the booster can be put out and relit")
    tau: ScalarOrList = Field(0.01, description="time constant of the duty cycle [s]")
    noise_ratio: ScalarOrList = Field(0.0, description="std of the multiplicative duty noise")
    initial_fuel: float = Field(1.0, ge=0, le=1, description="fuel fraction at spawn")
    ignition_channel: str | list[str] = Field("ignition", description="channel(s) that light the boosters (> 0.5)")
    throttle_channel: str | list[str] = Field("throttle", description="channel(s) setting throttle in [0, 1]")

    @model_validator(mode="after")
    def _consistent(self) -> BoostersSpec:
        n = len(self.positions)
        if n == 0:
            raise ValueError("boosters.positions is empty: list one [x, y, z] per booster")
        for name in (
            "thrust_axes",
            "fuel_tank_positions",
            "inertia_full",
            "total_fuel",
            "max_fuel_rate",
            "min_thrust",
            "max_thrust",
            "reignitable",
            "tau",
            "noise_ratio",
            "ignition_channel",
            "throttle_channel",
        ):
            value = getattr(self, name)
            if isinstance(value, list) and len(value) != n:
                raise ValueError(f"'{name}' has {len(value)} entries but 'positions' has {n}: give one per booster")
        return self

    def per_booster(self, name: str) -> list:
        """Field ``name`` as one entry per booster."""
        value = getattr(self, name)
        return list(value) if isinstance(value, list) else [value] * len(self.positions)


class GimbalSpec(_Spec):
    """A two-axis gimbal vectoring the thrust of one motor or booster."""

    name: Identifier = Field(description="identifier (letters, digits, '_', '-')")
    target: str = Field(description="'booster:<index>' or 'motor:<index>' whose thrust axis it rotates")
    axis_a: UnitVec3 = Field(description="first rotation axis, unit vector in the body frame")
    axis_b: UnitVec3 = Field(description="second rotation axis, unit vector in the body frame")
    max_angle_a_deg: float = Field(ge=0, description="deflection limit about axis a [deg]")
    max_angle_b_deg: float = Field(ge=0, description="deflection limit about axis b [deg]")
    tau: float = Field(0.01, ge=0, description="actuator time constant [s]")
    channels: tuple[str, str] = Field(
        ("gimbal_a", "gimbal_b"), description="channels commanding axes a and b in [-1, 1]"
    )
    mixer: bool = Field(
        False,
        description="true: the multirotor mixer flies axis a (a tilting motor: tricopter tail, tilt-rotor); the "
        "target is a mixer motor, axis_a is perpendicular to its thrust axis, max_angle_b_deg is 0, channels unused",
    )

    @model_validator(mode="after")
    def _axes(self) -> GimbalSpec:
        kind, _, index = self.target.partition(":")
        if kind not in ("booster", "motor") or not index.isdigit():
            raise ValueError(f"target must look like 'booster:0' or 'motor:2', got '{self.target}'")
        return self

    @property
    def target_kind(self) -> str:
        return self.target.partition(":")[0]

    @property
    def target_index(self) -> int:
        return int(self.target.partition(":")[2])


CameraOutput = Literal["rgba", "depth", "segmentation"]
_CAMERA_OUTPUTS: tuple[CameraOutput, ...] = ("rgba", "depth", "segmentation")


class CameraSpec(_Spec):
    """An onboard camera (see :class:`pyflyt_engine.components.camera.CameraParams`)."""

    name: Identifier = Field(description="identifier (letters, digits, '_', '-')")
    position: Vec3 = Field((0.0, 0.0, 0.0), description="camera origin in the spec's coordinates [m]")
    orientation_deg: Vec3 = Field((0.0, 0.0, 0.0), description="roll, pitch, yaw relative to the body [deg]")
    fov: float = Field(90.0, gt=0, lt=180, description="vertical field of view [deg]")
    width: int = Field(128, ge=1, description="pixels")
    height: int = Field(128, ge=1, description="pixels")
    near: float = Field(0.1, gt=0, description="near clip distance [m]")
    far: float = Field(100.0, gt=0, description="far clip distance [m]")
    horizon_lock: bool = Field(False, description="follow body yaw only (gimbal-stabilised)")
    capture_hz: float = Field(30.0, gt=0, description="image refresh rate [Hz]")
    outputs: list[CameraOutput] = Field(
        default_factory=lambda: list(_CAMERA_OUTPUTS), min_length=1, description="images to compute"
    )

    @field_validator("width", "height", mode="before")
    @classmethod
    def _resolution(cls, value: Any, info: ValidationInfo) -> Any:
        if isinstance(value, (int, float)) and value < 1:
            raise ValueError(
                f"camera {info.field_name} must be at least 1 pixel, got {value}: an image needs a "
                "non-zero resolution; give e.g. 128"
            )
        if isinstance(value, (int, float)):
            from pyflyt_engine import limits

            limits.check("image_side", value, name=f"camera {info.field_name}")
        return value

    @model_validator(mode="after")
    def _clip(self) -> CameraSpec:
        if not self.near < self.far:
            raise ValueError(f"need near < far, got near {self.near} and far {self.far}")
        return self


class _RangeSensorSpec(_Spec):
    name: Identifier = Field(description="identifier; also the sensor's observation key")
    position: Vec3 = Field((0.0, 0.0, 0.0), description="sensor origin in the spec's coordinates [m]")
    orientation_deg: Vec3 = Field((0.0, 0.0, 0.0), description="roll, pitch, yaw relative to the body [deg]")
    min_range: float = Field(
        0.05, gt=0, description="rays start this far from the origin [m] (outside the airframe: it never sees itself)"
    )
    max_range: float = Field(10.0, gt=0, description="reading where nothing is hit [m]")
    noise_std: float = Field(
        0.0, ge=0, description="standard deviation of the zero-mean Gaussian added to each hit [m]"
    )
    rate_hz: float = Field(30.0, gt=0, description="scan refresh rate [Hz] (the last scan is returned in between)")

    @model_validator(mode="after")
    def _ranges(self) -> _RangeSensorSpec:
        if not self.min_range < self.max_range:
            raise ValueError(f"need min_range < max_range, got {self.min_range} and {self.max_range}")
        return self


class LidarSpec(_RangeSensorSpec):
    """A scanning range finder: ``vertical_beams`` x ``horizontal_beams`` rays (ray casting).

    Beam centres split each field of view into equal sectors: azimuth ``-h/2 + (k + 1/2) h / n``
    (counter-clockwise about the sensor's z, 0 along its +x), elevation
    ``-v/2 + (j + 1/2) v / m`` (up positive).  Reading: distance along the ray [m].
    """

    type: Literal["lidar"] = "lidar"
    horizontal_beams: int = Field(64, ge=1, le=4096, description="beams per revolution / sweep")
    vertical_beams: int = Field(1, ge=1, le=128, description="scan lines")
    horizontal_fov_deg: float = Field(360.0, gt=0, le=360, description="horizontal field of view [deg]")
    vertical_fov_deg: float = Field(0.0, ge=0, lt=180, description="vertical field of view [deg] (0: one plane)")

    @model_validator(mode="after")
    def _lines(self) -> LidarSpec:
        if self.vertical_beams > 1 and self.vertical_fov_deg == 0:
            raise ValueError(f"{self.vertical_beams} vertical_beams need a vertical_fov_deg > 0")
        return self


class DepthSensorSpec(_RangeSensorSpec):
    """A low-resolution depth camera computed by ray casting (one ray through each pixel centre).

    Camera convention of :mod:`pyflyt_engine.components.camera`: looks along its +x, row 0
    is the top, column 0 the left.  Reading: depth along the optical axis [m] (as the
    rendered camera's ``depth``), ``max_range`` where nothing is hit within ``max_range``
    along the ray.
    """

    type: Literal["depth"] = "depth"
    width: int = Field(16, ge=1, le=256, description="pixels")
    height: int = Field(12, ge=1, le=256, description="pixels")
    fov: float = Field(90.0, gt=0, lt=180, description="vertical field of view [deg]")


RangeSensorSpec = Annotated[Union[LidarSpec, DepthSensorSpec], Field(discriminator="type")]


class InertialAxisSpec(_Spec):
    """One triad of an IMU (gyroscope or accelerometer), the same for its three axes
    (docs/engine.md, "Sensors").  Output per axis, at each sample:
    ``clip(scale * x + b + (noise_density * sqrt(rate_hz)) * eta, -range, range)``, the bias
    ``b`` starting at ``bias + bias_initial_std * eta0`` (drawn per episode) and walking
    ``b += bias_random_walk * sqrt(1 / rate_hz) * eta`` per sample (``eta`` ~ N(0, 1))."""

    noise_density: float = Field(
        0.0, ge=0, description="white noise density N [unit/sqrt(Hz)] (gyro rad/s/sqrt(Hz), accel m/s^2/sqrt(Hz))"
    )
    bias_random_walk: float = Field(
        0.0, ge=0, description="bias random walk K [unit/s/sqrt(Hz)] (rate of the bias's diffusion)"
    )
    bias: float = Field(0.0, description="constant bias on every axis [unit]")
    bias_initial_std: float = Field(
        0.0, ge=0, description="standard deviation of the bias drawn per axis at each episode start [unit]"
    )
    scale: float = Field(1.0, gt=0, description="scale factor on the true value [-] (1: none)")
    range: float = Field(1.0e9, gt=0, description="saturation: readings are clipped to [-range, range] [unit]")
    rate_hz: float = Field(1000.0, gt=0, description="sample rate [Hz]; the reading is held between samples")


class ImuSpec(_Spec):
    """A 6-axis IMU at the centre of mass, axes along the body's (x forward, y left, z up)."""

    gyro: InertialAxisSpec = Field(default_factory=InertialAxisSpec, description="angular rate [rad/s]")
    accel: InertialAxisSpec = Field(
        default_factory=InertialAxisSpec, description="specific force (acceleration minus gravity) [m/s^2]"
    )


class PositionSensorSpec(_Spec):
    """A position fix (GPS-like or motion capture), ground frame."""

    noise_std: Vec3 = Field((0.0, 0.0, 0.0), description="standard deviation of the Gaussian noise per axis [m]")
    rate_hz: float = Field(10.0, gt=0, description="fix rate [Hz]; the reading is held between fixes")
    dropout: float = Field(
        0.0, ge=0, lt=1, description="probability that a fix is lost (the last reading is held, valid = 0)"
    )

    @field_validator("noise_std")
    @classmethod
    def _noise(cls, value: tuple[float, float, float]) -> tuple[float, float, float]:
        if any(v < 0 for v in value):
            raise ValueError(f"noise_std must be >= 0 on every axis, got {list(value)}")
        return value


class BarometerSpec(_Spec):
    """A barometric altimeter: the height above the ground plane (z) with bias and noise."""

    noise_std: float = Field(0.0, ge=0, description="standard deviation of the Gaussian noise [m]")
    bias: float = Field(0.0, description="constant offset [m]")
    bias_initial_std: float = Field(0.0, ge=0, description="standard deviation of an offset drawn per episode [m]")
    rate_hz: float = Field(50.0, gt=0, description="sample rate [Hz]; the reading is held between samples")


class SensorsSpec(_Spec):
    """Onboard sensors with noise (docs/engine.md, "Sensors"); each is absent unless given."""

    imu: ImuSpec | None = None
    position: PositionSensorSpec | None = None
    barometer: BarometerSpec | None = None


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
    ki: Vec3 = Field((2.0, 2.0, 2.0), description="[1/s^2]")
    integral_limit: Vec3 | None = Field(
        None, description="clamp on the integral term [m/s^2]; null: the airframe's thrust margin (docs/atmosphere.md)"
    )
    integral_window: float | None = Field(
        None, gt=0, description="also integrate only while |error| is below this [m/s]; null: no window"
    )
    max_tilt: float = Field(0.6, gt=0, lt=1.5, description="largest roll/pitch the loop may ask [rad]")


class PositionGains(_Spec):
    """Position loop (ground frame): velocity setpoint = kp * position error."""

    kp: Vec3 = Field((1.5, 1.5, 2.0), description="[1/s] x, y, z")
    max_velocity: Vec3 = Field((3.0, 3.0, 2.0), description="limit on the velocity setpoint [m/s]")


#: CLI commands a firmware configuration may not carry: they save, reboot or reset the firmware
_FIRMWARE_CLI_REFUSED = ("save", "exit", "defaults", "bl", "dfu", "msc", "batch", "diff", "dump")


class BetaflightSpec(_Spec):
    """Betaflight 4.6's own firmware (its SITL target, in lockstep) as the flight
    controller: the setpoint is the sticks (docs/firmware.md)."""

    mode: Literal["acro", "angle"] = Field(
        "acro", description="acro: sticks command body rates (Betaflight's rate curve); angle: sticks command tilt"
    )
    rc_rate: list[int] = Field(
        [7, 7, 7], description="ACTUAL rates' centre sensitivity, roll/pitch/yaw, in 10 deg/s (CLI roll_rc_rate ...)"
    )
    super_rate: list[int] = Field(
        [67, 67, 67], description="ACTUAL rates' maximum rate, roll/pitch/yaw, in 10 deg/s (CLI roll_srate ...)"
    )
    expo: list[int] = Field([0, 0, 0], description="ACTUAL rates' expo, roll/pitch/yaw, in % (CLI roll_expo ...)")
    angle_limit: int = Field(60, ge=10, le=90, description="ANGLE mode's tilt at full stick [deg] (CLI angle_limit)")
    pids: Literal["matched", "firmware"] = Field(
        "matched",
        description=(
            "matched: the firmware's rate PIDs set to give the airframe's own rate loop (control.rate) at hover, "
            "feedforward, D boost, anti-gravity, throttle boost, TPA, I-term relax and RC smoothing off; "
            "firmware: Betaflight's defaults (tuned for 5-inch racing quads)"
        ),
    )
    cli: list[str] = Field(
        [], description="further Betaflight CLI commands (e.g. 'set p_roll = 50'), run after the project's own"
    )

    @field_validator("rc_rate", "super_rate", "expo")
    @classmethod
    def _three(cls, value: list[int]) -> list[int]:
        if len(value) != 3 or not all(0 <= v <= 255 for v in value):
            raise ValueError("needs 3 whole numbers (roll, pitch, yaw) from 0 to 255, as Betaflight's CLI takes them")
        return value

    @field_validator("cli")
    @classmethod
    def _commands(cls, value: list[str]) -> list[str]:
        for command in value:
            word = command.strip().split(" ", 1)[0].lower() if command.strip() else ""
            if not word or "\n" in command or "\r" in command or word in _FIRMWARE_CLI_REFUSED:
                raise ValueError(
                    f"'{command}' is not a configuration command: one CLI line each, without "
                    f"{', '.join(_FIRMWARE_CLI_REFUSED)} (the bridge saves and restarts the firmware itself)"
                )
        return value


class MultirotorControlSpec(_Spec):
    """Cascaded PID flight controller for multirotors (position > velocity > attitude > rate),
    or, with ``firmware``, Betaflight's own firmware in its place."""

    type: Literal["multirotor"] = "multirotor"
    mode: str = Field("rates_thrust", description="flight mode at spawn (name or PyFlyt integer)")
    rate: RateGains = RateGains()
    attitude: AttitudeGains = AttitudeGains()
    velocity: VelocityGains = VelocityGains()
    position: PositionGains = PositionGains()
    mixer_motors: list[int] | None = Field(
        None, description="indices of the motors the controller flies (default: every motor without 'mix')"
    )
    firmware: BetaflightSpec | None = Field(
        None, description="fly the firmware instead of the cascade: its modes acro and angle take sticks"
    )


class AxisGains(_Spec):
    """One autopilot loop: channel = kp e + ki int(e) - kd * rate."""

    kp: float = 0.0
    ki: float = 0.0
    kd: float = 0.0
    integral_limit: float = Field(0.5, ge=0, description="clamp on ki * int(e) (channel units)")


class FixedwingControlSpec(_Spec):
    """Fixed-wing control: raw channels (the paper's action) or an attitude/airspeed autopilot.

    Modes: ``channels`` (setpoint = the channel values in declaration order) and
    ``attitude_airspeed`` (setpoint = [roll rad, pitch rad, yaw rate rad/s, airspeed m/s]).
    The autopilot writes the channels named by ``roll_channel`` ... ``thrust_channel``.
    """

    type: Literal["fixedwing"] = "fixedwing"
    mode: str = Field("channels", description="mode at spawn: channels or attitude_airspeed")
    roll: AxisGains = AxisGains(kp=1.0, kd=0.2)
    pitch: AxisGains = AxisGains(kp=1.5, kd=0.3, ki=0.3)
    yaw: AxisGains = AxisGains(kp=0.5)
    airspeed: AxisGains = AxisGains(kp=0.2, ki=0.05)
    cruise_thrust: float = Field(0.5, ge=0, le=1, description="thrust feed-forward of the airspeed loop")
    roll_channel: str = "roll"
    pitch_channel: str = "pitch"
    yaw_channel: str = "yaw"
    thrust_channel: str = "thrust"


class NoControlSpec(_Spec):
    """No onboard controller: the setpoint is the channel vector (mode ``channels``)."""

    type: Literal["none"] = "none"


ControlSpec = Annotated[Union[MultirotorControlSpec, FixedwingControlSpec, NoControlSpec], Field(discriminator="type")]


# ------------------------------------------------------------------------ battery


class BatterySpec(_Spec):
    """The battery that drives the motors: an internal-resistance (Rint) equivalent circuit
    (docs/engine.md, "Motor models and battery").  Its terminal voltage sets the rotors' top speed: a motor at
    throttle ``x`` turns at ``x * max_rpm * V / V_full``."""

    capacity_mah: float = Field(gt=0, description="charge when full [mAh], > 0")
    internal_resistance: float = Field(ge=0, description="series resistance of the pack [ohm]")
    open_circuit_voltage: list[tuple[float, float]] = Field(
        description="[[state of charge, volts], ...] from charge 0 to 1, linearly interpolated; the voltage at "
        "charge 1 is V_full, at which the motors reach max_rpm"
    )
    efficiency: float = Field(
        1.0, gt=0, le=1, description="motors and speed controllers: shaft power / electrical power"
    )
    avionics_power: float = Field(0.0, ge=0, description="constant draw of everything but the motors [W]")
    initial_charge: float = Field(1.0, gt=0, le=1, description="state of charge at spawn (0, 1]")

    @field_validator("open_circuit_voltage")
    @classmethod
    def _curve(cls, value: list[tuple[float, float]]) -> list[tuple[float, float]]:
        if len(value) < 2:
            raise ValueError("open_circuit_voltage needs at least two points [[0, V_empty], [1, V_full]]")
        charges = [c for c, _ in value]
        if charges[0] != 0 or charges[-1] != 1 or any(b <= a for a, b in zip(charges, charges[1:])):
            raise ValueError(
                f"open_circuit_voltage: the states of charge must rise strictly from 0 to 1, got {charges}"
            )
        volts = [v for _, v in value]
        if volts[0] <= 0 or any(b < a for a, b in zip(volts, volts[1:])):
            raise ValueError(
                f"open_circuit_voltage: the voltages must be > 0 and never fall as the charge rises, got {volts}"
            )
        return value


# ------------------------------------------------------------------ propeller guards


class PropGuardSpec(_Spec):
    """Propeller guards: a ring (a duct's band) around each guarded rotor, whose drag opposes
    the air crossing the rotor's disc (docs/uav_authoring.md, "Propeller guards").  The
    guards' mass is the body's: include it in ``body`` (mass and inertia, or a shape)."""

    radius: PositiveFloat = Field(description="ring radius [m]: the propeller's radius plus its clearance")
    height: PositiveFloat = Field(description="ring height along the thrust axis [m]")
    drag_coefficient: PositiveFloat = Field(
        1.2, description="drag coefficient of the ring seen edge-on, on its projected area 2 * radius * height"
    )
    motors: list[int] | None = Field(None, description="indices of the guarded motors (null: every motor)")


# ------------------------------------------------------------------------ vehicle


class UAVSpec(_Spec):
    """A complete vehicle: body, drag, actuators, sensors and controller."""

    name: Identifier = Field(
        description="identifier, usually the file name without .yaml (letters, digits, '_', '-'; no path)"
    )
    description: str = Field("", description="free text")
    body: BodySpec
    drag: DragSpec = DragSpec()
    channels: dict[str, tuple[float, float]] = Field(
        default_factory=dict,
        description="named control inputs and their [min, max] range, in setpoint order (e.g. roll: [-1, 1])",
    )
    motors: MotorsSpec | None = None
    surfaces: list[SurfaceSpec] = Field(default_factory=list)
    boosters: BoostersSpec | None = None
    gimbals: list[GimbalSpec] = Field(default_factory=list)
    cameras: list[CameraSpec] = Field(default_factory=list)
    range_sensors: list[RangeSensorSpec] = Field(
        default_factory=list, description="LiDARs and ray-cast depth cameras (docs/obstacles_and_sensors.md)"
    )
    control: ControlSpec = Field(default_factory=NoControlSpec)
    battery: BatterySpec | None = Field(
        None, description="the battery driving the motors (voltage sag, state of charge); null: an ideal supply"
    )
    sensors: SensorsSpec | None = Field(
        None, description="IMU, position sensor and barometer with noise (docs/engine.md, 'Sensors'); null: none"
    )
    prop_guards: PropGuardSpec | None = Field(
        None,
        description="rings around the rotors that add drag (docs/uav_authoring.md, 'Propeller guards'); null: none",
    )
    source: str | None = Field(None, exclude=True, description="file the spec was loaded from")

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> Any:
        return _drop_unset(handler(self), ("battery", "sensors", "prop_guards"))

    @model_validator(mode="after")
    def _cross_checks(self) -> UAVSpec:
        for name, (low, high) in self.channels.items():
            if not low < high:
                raise ValueError(f"channels.{name}: range [{low}, {high}] is empty; give [min, max] with min < max")
        used: list[tuple[str, str]] = []
        for i, mix in enumerate((self.motors.mix or []) if self.motors else []):
            used += [(f"motors.mix[{i}]", c) for c in (mix or {})]
        used += [(f"surfaces.{s.name}.mix", c) for s in self.surfaces for c in s.mix]
        if self.boosters is not None:
            used += [("boosters.ignition_channel", c) for c in self.boosters.per_booster("ignition_channel")]
            used += [("boosters.throttle_channel", c) for c in self.boosters.per_booster("throttle_channel")]
        used += [(f"gimbals.{g.name}.channels", c) for g in self.gimbals if not g.mixer for c in g.channels]
        if isinstance(self.control, FixedwingControlSpec):
            c = self.control
            used += [("control", n) for n in (c.roll_channel, c.pitch_channel, c.yaw_channel, c.thrust_channel)]
        for where, channel in used:
            if channel not in self.channels:
                declared = ", ".join(self.channels) or "none"
                raise ValueError(
                    f"{where} uses channel '{channel}', which is not declared in 'channels' (declared: {declared})"
                )
        for kind, items in (
            ("surfaces", self.surfaces),
            ("gimbals", self.gimbals),
            ("cameras", self.cameras),
            ("range_sensors", self.range_sensors),
        ):
            names = [i.name for i in items]
            if len(set(names)) != len(names):
                raise ValueError(f"{kind}: names must be unique, got {names}")
        for gimbal in self.gimbals:
            pool = (
                self.boosters.positions
                if gimbal.target_kind == "booster" and self.boosters
                else (self.motors.positions if gimbal.target_kind == "motor" and self.motors else [])
            )
            if gimbal.target_index >= len(pool):
                raise ValueError(
                    f"gimbals.{gimbal.name}: target '{gimbal.target}' does not exist ({len(pool)} {gimbal.target_kind}s)"
                )
        if isinstance(self.control, MultirotorControlSpec):
            if self.motors is None:
                raise ValueError("control.type 'multirotor' needs a 'motors' section")
            n = len(self.motors.positions)
            for index in self.control.mixer_motors or []:
                if not 0 <= index < n:
                    raise ValueError(f"control.mixer_motors: no motor {index} (there are {n})")
        if self.battery is not None and self.motors is None:
            raise ValueError(
                "battery: it drives motors, and the airframe has no 'motors' section; remove it or add motors"
            )
        if self.prop_guards is not None:
            n = len(self.motors.positions) if self.motors is not None else 0
            if n == 0:
                raise ValueError(
                    "prop_guards: they ring rotors, and the airframe has no 'motors' section; remove it or add motors"
                )
            for index in self.prop_guards.motors or []:
                if not 0 <= index < n:
                    raise ValueError(f"prop_guards.motors: no motor {index} (there are {n}: 0 to {n - 1})")
        self._check_mixer_gimbals()
        if self.body.inertia is None or self.body.mass is None:
            _check_inertia(self.inertia_matrix())
        if isinstance(self.control, MultirotorControlSpec):
            self._check_controllable()
        return self

    def _check_mixer_gimbals(self) -> None:
        """A gimbal flown by the mixer turns one mixer motor about one axis across its thrust."""
        tilted: list[int] = []
        for g in self.gimbals:
            if not g.mixer:
                continue
            where = f"gimbals.{g.name}"
            if not isinstance(self.control, MultirotorControlSpec):
                raise ValueError(f"{where}: mixer: true needs control.type 'multirotor' (the mixer flies the servo)")
            if g.target_kind != "motor" or g.target_index not in self.mixer_motor_indices():
                raise ValueError(
                    f"{where}: mixer: true needs a target among the mixer's motors {list(self.mixer_motor_indices())} "
                    f"(motor:<index>), got '{g.target}'"
                )
            if g.target_index in tilted:
                raise ValueError(f"{where}: motor {g.target_index} already has a gimbal flown by the mixer")
            tilted.append(g.target_index)
            if g.max_angle_a_deg <= 0 or g.max_angle_b_deg != 0:
                raise ValueError(
                    f"{where}: the mixer flies axis a only: give max_angle_a_deg > 0 and max_angle_b_deg: 0, got "
                    f"{g.max_angle_a_deg:g} and {g.max_angle_b_deg:g}"
                )
            axis = self.motors.to_array("thrust_axes")[g.target_index]  # type: ignore[union-attr]
            dot = exact.dot(axis, g.axis_a)
            if abs(dot) > _UNIT_EXACT:
                raise ValueError(
                    f"{where}: axis_a {list(g.axis_a)} must be perpendicular to the thrust axis {axis.tolist()} of "
                    f"motor {g.target_index} (dot product {dot:.3g}): the servo tilts the thrust across its own axis"
                )

    def mixer_motor_indices(self) -> tuple[int, ...]:
        """Indices of the motors a multirotor controller flies: ``control.mixer_motors``,
        else every motor without a ``mix`` (empty without multirotor control)."""
        if not isinstance(self.control, MultirotorControlSpec) or self.motors is None:
            return ()
        if self.control.mixer_motors is not None:
            return tuple(self.control.mixer_motors)
        mixes = self.motors.mix or [None] * len(self.motors.positions)
        return tuple(i for i, mix in enumerate(mixes) if not mix)

    def _check_controllable(self) -> None:
        """The mixer motors must reach collective thrust, roll, pitch and yaw independently
        (the mixer's own check, :func:`pyflyt_engine.allocation.require_controllable`, run at load)."""
        assert self.motors is not None  # checked above
        idx = list(self.mixer_motor_indices())
        m = self.motors
        positions = np.asarray(m.positions, dtype=float)[idx] - self.center_of_mass()
        axes, spin, kf, kt = (m.to_array(name)[idx] for name in ("thrust_axes", "spin", "kf", "kt"))
        tilts = [
            Tilt(idx.index(g.target_index), g.axis_a, math.radians(g.max_angle_a_deg)) for g in self.gimbals if g.mixer
        ]
        require_controllable(tilted_allocation(positions, axes, spin, kf, kt, tilts), idx, tilted=bool(tilts))

    # ------------------------------------------------------- mass properties

    def total_mass(self) -> float:
        """Dry mass of the airframe [kg] (booster fuel is added by the vehicle)."""
        return self.body.total_mass()

    def center_of_mass(self) -> np.ndarray:
        """Centre of mass in the spec's coordinates [m]; the vehicle's body origin."""
        return self.body.mass_center()

    def inertia_matrix(self) -> np.ndarray:
        """3 x 3 inertia about the centre of mass, body axes [kg m^2]."""
        return self.body.inertia_matrix()


def inertia_tensor(values: list[float] | tuple[float, ...]) -> np.ndarray:
    """3 x 3 inertia tensor from [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]."""
    ixx, iyy, izz = values[:3]
    ixy, ixz, iyz = values[3:] if len(values) == 6 else (0.0, 0.0, 0.0)
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)


# ------------------------------------------------------------------------ loading


def parse_uav_spec(data: Any, source: str = "<dict>") -> UAVSpec:
    """Validate an already-parsed mapping as a :class:`UAVSpec`.

    Raises:
        SpecError: listing every problem found, each with its field and a fix.
    """
    if not isinstance(data, dict):
        raise SpecError(f"{source}: a UAV spec must be a mapping of keys to values, got {type(data).__name__}")
    return validate(UAVSpec, {**data, "source": source}, "UAV spec", source, error=SpecError)


def _unknown_uav(name: Any) -> str:
    return unknown_name(name, available_uavs(), "UAV", "Shipped airframes", "or give the path to a .yaml file")


def resolve_uav_path(name_or_path: str | Path) -> Path:
    """A shipped airframe name (``quadx_cf2x``) or a path to a YAML file, as a path
    (:func:`pyflyt_engine.loading.resolve`: a shipped name first, so a file or directory
    of that name in the working directory, e.g. a run folder called "rocket", cannot shadow it)."""
    return resolve(name_or_path, "uav", what="UAV", error=SpecError, unknown=_unknown_uav)


def available_uavs() -> list[str]:
    """Names of the airframes shipped in ``conf/uav``."""
    return sorted(p.stem for p in uav_dir().glob("*.yaml"))


def load_uav_spec(name_or_path: str | Path | Mapping[str, Any] | UAVSpec) -> UAVSpec:
    """Load and validate a UAV spec from a shipped name, a YAML path or a mapping
    (:func:`pyflyt_engine.loading.load`).

    The file is read by :func:`pyflyt_engine.safe_load.load_yaml_file`: YAML tags that
    would construct Python objects are rejected, so loading a spec never runs code from it,
    and a special file, an oversized file or an alias-expansion bomb is refused.

    Raises:
        SpecError: the file is missing, is not valid YAML, or does not match the schema.
    """
    return load(
        name_or_path,
        group="uav",
        model=UAVSpec,
        parse=lambda data, source, _name: parse_uav_spec(data, source=source),
        what="UAV",
        error=SpecError,
        unknown=_unknown_uav,
    )

"""What the batched backend flies: an airframe's parameters as arrays, from the same objects
the PyBullet engine builds.

:func:`batched_model` takes a spec and returns a :class:`BatchedModel`: the numbers the
compiled laws (:mod:`pyflyt_engine.batched.kernels`) read, copied out of the engine's own
:class:`~pyflyt_engine.components.motor.Motors`, :class:`~pyflyt_engine.control.mixer.Mixer`,
:class:`~pyflyt_engine.control.multirotor.MultirotorController` and
:class:`~pyflyt_engine.components.drag.DragParams` -- so the parameters are computed once,
by the code the PyBullet engine uses, and cannot drift apart.

What the batched backend cannot simulate is refused here by name
(:class:`UnsupportedByBatched`), never approximated: lifting surfaces, boosters, gimbals
(tilting motors), channels outside the mixer, the optional motor models and the battery,
mesh or URDF collision geometry, and flight modes other than ``rates_thrust`` and
``motors``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyflyt_engine.assembly import assemble
from pyflyt_engine.components.drag import DragParams
from pyflyt_engine.components.kinds import component_kinds
from pyflyt_engine.components.lag import lag_coefficient
from pyflyt_engine.components.motor import motor_wrench_matrix
from pyflyt_engine.control.mixer import Mixer
from pyflyt_engine.control.modes import resolve_mode
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import rpy_matrix
from pyflyt_engine.spec import FixedwingControlSpec, MultirotorControlSpec, UAVSpec

#: the component kinds (pyflyt_engine.components.kinds) the compiled laws simulate; any other
#: kind an airframe declares is refused by its name
SIMULATED_KINDS = frozenset({"motors", "drag"})
#: how a refusal names a kind where its registered name says less
KIND_NAMES = {"surfaces": "lifting surfaces", "gimbals": "gimbals (tilting motors)", "prop_guards": "propeller guards"}

#: flight modes the compiled controller flies (name -> code in kernels)
BATCHED_MODES = {"rates_thrust": 0, "motors": -1}


class UnsupportedByBatched(ConfigError):
    """A config asks for something the batched backend does not simulate."""


def refuse(what: str, fix: str = "") -> UnsupportedByBatched:
    """The one wording of a refusal: what, and that the PyBullet engine flies it."""
    hint = f" ({fix})" if fix else ""
    return UnsupportedByBatched(
        f"env.backend=batched does not simulate {what}{hint}; use env.backend=pybullet (the default), "
        "which flies every config (docs/batched.md lists what the batched backend covers)"
    )


@dataclass(frozen=True)
class BatchedModel:
    """One airframe's parameters for the compiled laws (one row per vehicle when stacked).

    Attributes:
        name: the airframe's name.
        mass: [kg]; inertia: the simulated body's (Jx, Jy, Jz) [kg m^2], as the PyBullet
            engine's URDF gives them (9 significant digits, products of inertia dropped).
        control_inertia: the inertia the flight controller's rate loop uses (the spec's).
        gyro: the rate loop's gyroscopic coefficients (Jz - Jy, Jx - Jz, Jy - Jx).
        lag: (n,) motor lag per physics step; columns: (n, 6) motor wrench at full throttle;
        noise_ratio: (n,) motor noise standard deviation.
        mixer_rows: (n, 5) the mixer's pseudo-inverse rows and full thrusts; max_collective [N].
        rate_gains: (4, 3) rows kp, ki, kd, integral limit of the rate loop;
            rate_derivative: whether the kd term is on.
        drag_factors: (3,) 1/2 rho C_d A per body axis; angular_damping [N m s^2];
            drag: whether body drag is on.
        corners: (k, 8) collision features from the centre of mass: [x, y, z, sphere
            radius, disc radius, disc normal (3)] (box corners, sphere centres, cylinder
            end discs), whose lowest point against the ground is exact.
    """

    name: str
    mass: float
    inertia: np.ndarray
    control_inertia: np.ndarray
    gyro: np.ndarray
    lag: np.ndarray
    columns: np.ndarray
    noise_ratio: np.ndarray
    mixer_rows: np.ndarray
    max_collective: float
    rate_gains: np.ndarray
    rate_derivative: bool
    drag_factors: np.ndarray
    angular_damping: float
    drag: bool
    corners: np.ndarray

    @property
    def motors(self) -> int:
        return len(self.lag)

    @property
    def aux_size(self) -> int:
        return self.motors

    @property
    def hover_thrust_fraction(self) -> float:
        """The collective fraction (rates_thrust's thrust) that holds the weight level."""
        return self.mass * 9.81 / self.max_collective


def _corners(spec: UAVSpec, com: np.ndarray) -> np.ndarray:
    rows = []
    for shape in spec.body.shapes:
        if not shape.collision:
            continue
        if shape.type == "mesh":
            raise refuse(f"mesh collision geometry ({shape.mesh})", "give the airframe boxes, cylinders or spheres")
        centre = np.asarray(shape.position, dtype=np.float64) - com
        rot = rpy_matrix(shape.rpy)
        if shape.type == "sphere":
            rows.append([*centre, shape.radius, 0.0, 0.0, 0.0, 1.0])
        elif shape.type == "box":
            half = 0.5 * np.asarray(shape.size, dtype=np.float64)
            for sx in (-1.0, 1.0):
                for sy in (-1.0, 1.0):
                    for sz in (-1.0, 1.0):
                        corner = centre + rot @ (half * np.array([sx, sy, sz]))
                        rows.append([*corner, 0.0, 0.0, 0.0, 0.0, 1.0])
        else:  # cylinder along its local z: two end discs
            axis = rot[:, 2]
            for side in (-1.0, 1.0):
                rows.append([*(centre + side * 0.5 * shape.length * axis), 0.0, shape.radius, *axis])
    if not rows:
        raise refuse("an airframe without collision geometry")
    return np.asarray(rows, dtype=np.float64)


def batched_model(spec: UAVSpec, physics_dt: float, control_dt: float, drag: bool = True) -> BatchedModel:
    """The :class:`BatchedModel` of a multirotor spec (refuses what the backend lacks)."""
    name = spec.name
    if spec.body.urdf is not None:
        raise refuse(f"a URDF body ({name})")
    if not isinstance(spec.control, MultirotorControlSpec):
        what = "fixed-wing" if isinstance(spec.control, FixedwingControlSpec) else "channel-driven (no multirotor controller)"
        raise refuse(f"the {what} airframe {name}", "the batched backend flies multirotors")
    parts = assemble(spec)
    for kind in component_kinds():  # every registered kind but the ones compiled here, by its name
        if kind.name not in SIMULATED_KINDS and getattr(spec, kind.section, None):
            raise refuse(f"{KIND_NAMES.get(kind.name, kind.name)} (airframe {name}'s {kind.section})")
    for what, present in (
        ("the battery", parts.battery is not None),
        ("actuator channels", bool(parts.channels)),
        ("range sensors", bool(spec.range_sensors)),
        ("noisy sensors (the airframe's sensors section)", getattr(spec, "sensors", None) is not None),
    ):
        if present:
            raise refuse(f"{what} (airframe {name})")
    motors = parts.motors
    assert motors is not None  # a multirotor controller needs motors (spec validator)
    if motors.modelled:
        raise refuse(f"the optional motor models (airframe {name}: tau_fall, rotor_drag or inflow)")
    if len(parts.mixer_motors) != motors.count:
        raise refuse(f"motors outside the mixer (airframe {name})")
    inertia = np.asarray(parts.inertia, dtype=np.float64)
    # the simulated body is the URDF's: mass and the inertia's diagonal written with 9
    # significant digits (pyflyt_engine.urdf.generate_urdf drops the products of inertia);
    # the flight controller keeps the spec's values, as the PyBullet engine's does
    body_mass = float(f"{spec.total_mass():.9g}")
    body_inertia = np.array([float(f"{v:.9g}") for v in np.diag(spec.inertia_matrix())], dtype=np.float64)
    mixer = Mixer(motors)
    controller = MultirotorController(spec.control, parts.mass, np.diag(inertia), mixer, control_dt)
    gains = np.array([list(axis) for axis in controller._rate_axes], dtype=np.float64).T.copy()  # (4, 3)
    drag_params = DragParams(spec.drag.coefficients, spec.drag.areas, spec.drag.angular_damping)
    on = bool(drag and drag_params.active)
    columns = motor_wrench_matrix(motors).T.copy()
    return BatchedModel(
        name=name,
        mass=body_mass,
        inertia=body_inertia,
        control_inertia=np.asarray(controller.inertia, dtype=np.float64),
        gyro=np.asarray(controller._gyro, dtype=np.float64),
        lag=np.asarray(lag_coefficient(physics_dt, motors.tau), dtype=np.float64).reshape(-1),
        columns=columns,
        noise_ratio=np.asarray(motors.noise_ratio, dtype=np.float64).copy(),
        mixer_rows=np.asarray(mixer._rows, dtype=np.float64),
        max_collective=float(mixer.max_collective),
        rate_gains=gains,
        rate_derivative=bool(controller._rate_derivative),
        drag_factors=np.asarray(drag_params.factors, dtype=np.float64),
        angular_damping=float(drag_params.angular_damping),
        drag=on,
        corners=_corners(spec, np.asarray(parts.com, dtype=np.float64)),
    )


def mode_code(mode: str | int) -> int:
    """The compiled controller's code of a flight mode (refuses modes it does not fly)."""
    name = resolve_mode(mode).name
    if name not in BATCHED_MODES:
        raise refuse(f"flight mode {name}", f"it flies {', '.join(BATCHED_MODES)}")
    return BATCHED_MODES[name]

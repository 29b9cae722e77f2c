"""What the batched backend flies: an airframe's parameters as arrays, from the same objects
the PyBullet engine builds.

:func:`batched_model` takes a spec and returns a :class:`BatchedModel`: the numbers the
compiled laws (:mod:`pyflyt_engine.batched.kernels`) read, copied out of the engine's own
:class:`~pyflyt_engine.components.motor.Motors`, :class:`~pyflyt_engine.control.mixer.Mixer`,
:class:`~pyflyt_engine.control.multirotor.MultirotorController`,
:class:`~pyflyt_engine.components.lifting_surface.LiftingSurfaceParams` (its
``constants``), the assembly's channel mixes and :class:`~pyflyt_engine.components.drag.DragParams`
-- so the parameters are computed once, by the code the PyBullet engine uses, and cannot
drift apart.  The optional motor models and the battery likewise: each modelled motor's
row out of the engine's :class:`~pyflyt_engine.components.motor_models.ModelledMotors` (and
its :class:`~pyflyt_engine.components.motor_models.InflowRotor`), the pack's parameters and
its state at a reset out of its :class:`~pyflyt_engine.components.battery.Battery`.

Two kinds of airframe: a multirotor (every flight mode of its controller: ``rates_thrust``
and ``motors`` in :mod:`~pyflyt_engine.batched.kernels`, the outer loops of the others in
:mod:`~pyflyt_engine.batched.modes`, their parameters in :attr:`BatchedModel.cascade`) and a
fixed-wing (a ``fixedwing`` control section: motors and lifting surfaces
driven through the channels, modes ``channels`` and ``attitude_airspeed``, the autopilot).
A multirotor whose actuators the channels route beside the mixer (:attr:`BatchedModel.routed`)
flies through the fixed-wing's kernel (``kernels.advance_channels``) with the multirotor
controller on its tick: a VTOL such as the quadplane (its lift motors on the mixer, a pusher
and lifting surfaces on the setpoint's channels after the mode's values: ``motor_source``,
the channel tables), a tricopter (its tail motor on a gimbal the mixer flies: the mixer's
lateral rows ``lateral``, the controller's trim in :attr:`BatchedModel.cascade`), and gimbals
on channels; each gimbal's rows out of the engine's ``Gimbals`` (``gimbal_constants``) and
``Motors.turn``'s tables (``gimbals``, ``gimbal_source``, ``gimbal_scale``).
What the batched backend cannot simulate is refused here by name
(:class:`UnsupportedByBatched`), never approximated: boosters (and gimbals turning them),
gimbals on a fixed-wing, gimbals with the optional motor models or a battery, mesh or URDF
collision geometry, and a multirotor mode on a fixed-wing (or a fixed-wing mode without a
compiled form); :func:`pyflyt_engine.batched.support.check_keys` refuses an env's latency and
drawn motor factors on an airframe with gimbals.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pyflyt_engine.assembly import assemble
from pyflyt_engine.atmosphere.field import vehicle_span
from pyflyt_engine.batched.kernels import (
    BATTERY_PARAMS,
    BATTERY_STATE,
    GIMBAL_FIELDS,
    LATERAL_FIELDS,
    LAW_BATTERY,
    LAW_INFLOW,
    LAW_MODELLED,
    LAW_ROTOR_DRAG,
    MOTOR_MODEL_FIELDS,
)
from pyflyt_engine.batched.modes import CASCADE_MODES, CascadeParams, cascade_params
from pyflyt_engine.components.drag import DragParams
from pyflyt_engine.components.kinds import component_kinds
from pyflyt_engine.components.lag import lag_coefficient
from pyflyt_engine.components.battery import BatteryParams
from pyflyt_engine.components.motor import MotorParams, motor_wrench_matrix, reaction_per_thrust
from pyflyt_engine.components.routing import mix_rows
from pyflyt_engine.control.fixedwing import FIXEDWING_MODES
from pyflyt_engine.control.mixer import flight_mixer
from pyflyt_engine.control.modes import resolve_mode
from pyflyt_engine.control.multirotor import MultirotorController
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import rpy_matrix
from pyflyt_engine.spec import FixedwingControlSpec, MultirotorControlSpec, UAVSpec

#: the component kinds (pyflyt_engine.components.kinds) the compiled laws simulate; any other
#: kind an airframe declares is refused by its name
SIMULATED_KINDS = frozenset({"motors", "surfaces", "drag", "battery", "gimbals"})
#: how a refusal names a kind where its registered name says less
KIND_NAMES = {"surfaces": "lifting surfaces", "gimbals": "gimbals (tilting motors)", "prop_guards": "propeller guards"}

#: flight modes the compiled controller flies (name -> code in kernels and modes): a multirotor's,
#: every one of MULTIROTOR_MODES
BATCHED_MODES = {"rates_thrust": 0, "motors": -1, **CASCADE_MODES}
#: and a fixed-wing's (its raw channels: the paper's fixed-wing action; the autopilot)
BATCHED_FIXEDWING_MODES = {"channels": 1, "attitude_airspeed": 2}


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
        channel_driven: a fixed-wing: motors and flaps driven by the channels (mode
            ``channels``), no multirotor controller (its fields above are then zeros).
        channel_low, channel_high: (c,) the channels' ranges.
        motor_mix_index, motor_mix_weight: (n, k) per motor the (channel, weight) pairs of
            its mix, in order (``routing.mix_rows``), index -1 past a row's end.
        surfaces: (s, 25) per lifting surface its ``SurfaceConstants``; surface_lag: (s,)
            its flap's lag per physics step; surface_scale: (s,) what its deflection is
            divided by in the auxiliary state (its limit, 1 without a flap);
            surface_mix_index, surface_mix_weight: (s, k) its flap's mix.
        autopilot_gains: (4, 4) the fixed-wing autopilot's loops (roll, pitch, yaw,
            airspeed) as rows kp, ki, kd, integral limit; cruise_thrust: its thrust
            feed-forward; autopilot_index: (4,) its roll, pitch, yaw and thrust channels.
        cascade: a multirotor's outer loops (velocity, position, attitude, tilt, thrust:
            :func:`~pyflyt_engine.batched.modes.cascade_params`); None on a fixed-wing.
        rotors: (n, 5) per motor what ground effect reads (:mod:`pyflyt_engine.batched.air`):
            its hub position (centre-of-mass frame), prop radius (0: none, no ground effect)
            and reaction torque per newton of thrust, as ``RotorInteractions`` and ``Motors`` hold them.
        span: [m] the span the rotary turbulence gusts take (``atmosphere.field.vehicle_span``).
        motor_laws: 0 for the static motors, else the bits (``kernels.LAW_*``) of the optional
            models the engine's ``ModelledMotors`` flies: always ``LAW_MODELLED``, and rotor
            drag, inflow and the battery where declared; motor_model: (n, 18) per motor its
            row (``kernels.MOTOR_MODEL_FIELDS``; zeros for the static motors).
        battery: the pack's parameters (``kernels.BATTERY_PARAMS``: capacity [C], R [ohm],
            eta V_full^3, avionics power [W], V_full [V]; empty without one);
            battery_table: (k, 2) its open-circuit voltage table; battery_reset: its state
            at a reset (``kernels.BATTERY_STATE``: charge, voltage, current, speed ratio).
        routed: a multirotor whose actuators the channels route beside the mixer (channels,
            lifting surfaces, gimbals or motors outside the mixer): it flies through
            ``kernels.advance_channels``, its channel tables filled as a fixed-wing's.
        motor_source: (n,) per motor the mixer output it takes (``Motors.route``), -1 for its mix.
        lateral: (t, ``kernels.LATERAL_FIELDS``) per tilting motor the mixer flies its index
            among the mixer's motors, its servo limit and its lateral row of the pseudo-inverse.
        gimbals: (g, ``kernels.GIMBAL_FIELDS``) per gimbal its ``GimbalConstants`` and its target
            motor's nominal axis, hub, full thrust and reaction torque; gimbal_source: (g, 4) its
            target motor, the channels of its axes (-1: none) and its mixer output (-1: none);
            gimbal_scale: (2 g,) what each angle is divided by in the auxiliary state.
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
    channel_driven: bool = False
    channel_low: np.ndarray = field(default_factory=lambda: np.zeros(0))
    channel_high: np.ndarray = field(default_factory=lambda: np.zeros(0))
    motor_mix_index: np.ndarray = field(default_factory=lambda: np.zeros((0, 1), dtype=np.int64))
    motor_mix_weight: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    surfaces: np.ndarray = field(default_factory=lambda: np.zeros((0, 25)))
    surface_lag: np.ndarray = field(default_factory=lambda: np.zeros(0))
    surface_scale: np.ndarray = field(default_factory=lambda: np.zeros(0))
    surface_mix_index: np.ndarray = field(default_factory=lambda: np.zeros((0, 1), dtype=np.int64))
    surface_mix_weight: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    autopilot_gains: np.ndarray = field(default_factory=lambda: np.zeros((4, 4)))
    cruise_thrust: float = 0.0
    autopilot_index: np.ndarray = field(default_factory=lambda: np.zeros(4, dtype=np.int64))
    cascade: CascadeParams | None = None
    rotors: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    span: float = 0.05
    motor_laws: int = 0
    motor_model: np.ndarray = field(default_factory=lambda: np.zeros((0, MOTOR_MODEL_FIELDS)))
    battery: np.ndarray = field(default_factory=lambda: np.zeros(0))
    battery_table: np.ndarray = field(default_factory=lambda: np.zeros((1, 2)))
    battery_reset: np.ndarray = field(default_factory=lambda: np.zeros(0))
    routed: bool = False
    motor_source: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    lateral: np.ndarray = field(default_factory=lambda: np.zeros((0, LATERAL_FIELDS)))
    gimbals: np.ndarray = field(default_factory=lambda: np.zeros((0, GIMBAL_FIELDS)))
    gimbal_source: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), dtype=np.int64))
    gimbal_scale: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def motors(self) -> int:
        return len(self.lag)

    @property
    def channels(self) -> int:
        return len(self.channel_low)

    @property
    def mixer_outputs(self) -> int:
        """How many outputs the mixer gives: a throttle per mixer motor, a command per tilting motor."""
        return len(self.mixer_rows) + len(self.lateral)

    @property
    def through_channels(self) -> bool:
        """Whether the channels route its actuators (``kernels.advance_channels``): a fixed-wing,
        or a multirotor with channels, lifting surfaces, gimbals or motors outside the mixer."""
        return self.channel_driven or self.routed

    @property
    def has_battery(self) -> bool:
        return self.battery.size > 0

    @property
    def aux_size(self) -> int:
        """The auxiliary state's size: motor throttles, then flap deflections over their limits,
        then the gimbals' angles over their limits (``Gimbals.aux``), then the battery's state
        of charge (``BatteryGauge.aux``)."""
        return self.motors + len(self.surfaces) + len(self.gimbal_scale) + int(self.has_battery)

    @property
    def hover_thrust_fraction(self) -> float:
        """The collective fraction (rates_thrust's thrust) that holds the weight level (a multirotor's)."""
        if self.channel_driven:
            raise ValueError(f"{self.name} is a fixed-wing: it has no multirotor collective thrust")
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
            assert shape.length is not None  # a cylinder's (ShapeSpec requires it)
            axis = rot[:, 2]
            for side in (-1.0, 1.0):
                rows.append([*(centre + side * 0.5 * shape.length * axis), 0.0, shape.radius, *axis])
    if not rows:
        raise refuse("an airframe without collision geometry")
    return np.asarray(rows, dtype=np.float64)


def _rotor_rows(spec: UAVSpec, motors, physics_dt: float) -> np.ndarray:
    """Per motor: hub position, prop radius (0 for none) and reaction torque per newton, read
    as the PyBullet engine's ``Atmosphere.add_vehicle`` and ``Motors`` read them."""
    if motors is None:
        return np.zeros((0, 5))
    hubs = np.asarray(motors.positions, dtype=np.float64).reshape(-1, 3)
    radii = np.zeros(len(hubs))
    if spec.motors is not None and spec.motors.prop_radius is not None:
        radii = np.array([r or 0.0 for r in spec.motors.to_array("prop_radius").tolist()], dtype=np.float64)
    return np.column_stack([hubs, radii, np.asarray(reaction_per_thrust(motors), dtype=np.float64)])


def _motor_laws(parts, physics_dt: float) -> dict:
    """The optional motor models and the battery (``BatchedModel.motor_laws`` ... ``battery_reset``),
    read out of the group the PyBullet engine builds for them (``motor_models.build_motors``:
    ``ModelledMotors`` where the airframe declares a model or a battery) and of its pack."""
    motors = parts.motors
    if motors is None or not (motors.modelled or parts.battery is not None):
        return {}
    return modelled_rows(motors, parts.battery, physics_dt)


def modelled_rows(motors: MotorParams, battery: BatteryParams | None, physics_dt: float) -> dict:
    """The rows of the optional motor models (``motor_laws``, ``motor_model``) and of the pack
    (``battery``, ``battery_table``, ``battery_reset``) for motor parameters ``motors`` and pack
    parameters ``battery`` (None: no pack), read out of the group and the pack the PyBullet
    engine builds from them, so a randomiser's parameters (``dataclasses.replace`` of the
    nominal ones, as the engine's randomiser makes them) give the rows its vehicle flies."""
    from pyflyt_engine.components.battery import Battery
    from pyflyt_engine.components.motor_models import ModelledMotors
    from pyflyt_engine.components.noise import NoiseSource

    pack = Battery(battery, physics_dt) if battery is not None else None
    group = ModelledMotors(motors, physics_dt, NoiseSource(np.random.default_rng(0)), battery=pack)
    rows = np.zeros((motors.count, MOTOR_MODEL_FIELDS), dtype=np.float64)
    for m in range(motors.count):
        inflow = [0.0] * 6
        if group._inflow is not None:
            k = group._inflow[m]
            inflow = [k.radius, k.ct0, k.lambda_h, k.s, k.theta_tip, k.cq_hover]
        rows[m] = [
            group.lag_fall[m],
            *group._positions[m],
            *group._axes[m],
            group._max_thrust[m],
            group._reaction[m],
            group._omega_max[m],
            group._torque_max[m],
            group._rotor_drag[m] if group._rotor_drag is not None else 0.0,
            *inflow,
        ]
    laws = LAW_MODELLED
    laws |= LAW_ROTOR_DRAG if group._rotor_drag is not None else 0
    laws |= LAW_INFLOW if group._inflow is not None else 0
    out: dict = {"motor_laws": laws, "motor_model": rows}
    if pack is not None:
        out.update(
            motor_laws=laws | LAW_BATTERY,
            battery=np.array(
                [pack._coulombs, pack._resistance, pack._load_divisor, pack._avionics, pack._full], dtype=np.float64
            ),
            battery_table=np.array(pack._table, dtype=np.float64).reshape(-1, 2),
            battery_reset=np.array([pack.charge, pack.voltage, pack.current, pack.speed_ratio], dtype=np.float64),
        )
        assert out["battery"].size == BATTERY_PARAMS and out["battery_reset"].size == BATTERY_STATE
    return out


def _mix_tables(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A mix matrix's rows (``routing.mix_rows``) as padded (index, weight) arrays."""
    rows = mix_rows(matrix)
    width = max([len(row) for row in rows] + [1])
    index = np.full((len(rows), width), -1, dtype=np.int64)
    weight = np.zeros((len(rows), width), dtype=np.float64)
    for a, row in enumerate(rows):
        for m, (j, w) in enumerate(row):
            index[a, m], weight[a, m] = j, w
    return index, weight


def batched_model(spec: UAVSpec, physics_dt: float, control_dt: float, drag: bool = True) -> BatchedModel:
    """The :class:`BatchedModel` of a multirotor or fixed-wing spec (refuses what the backend lacks)."""
    name = spec.name
    if spec.body.urdf is not None:
        raise refuse(f"a URDF body ({name})")
    fixedwing = isinstance(spec.control, FixedwingControlSpec)
    if not isinstance(spec.control, MultirotorControlSpec) and not fixedwing:
        raise refuse(
            f"the channel-driven airframe {name} (no multirotor or fixed-wing controller)",
            "the batched backend flies multirotors and fixed-wings",
        )
    parts = assemble(spec)
    for kind in component_kinds():  # every registered kind but the ones compiled here, by its name
        if kind.name not in SIMULATED_KINDS and getattr(spec, kind.section, None):
            raise refuse(f"{KIND_NAMES.get(kind.name, kind.name)} (airframe {name}'s {kind.section})")
    for what, present in (
        (
            "gimbals with the optional motor models or a battery",
            parts.gimbals is not None and parts.motors is not None and (parts.motors.modelled or bool(spec.battery)),
        ),
        ("gimbals on a fixed-wing", parts.gimbals is not None and fixedwing),
    ):
        if present:
            raise refuse(f"{what} (airframe {name})")
    motors = parts.motors
    # the simulated body is the URDF's: mass and the inertia's diagonal written with 9
    # significant digits (pyflyt_engine.urdf.generate_urdf drops the products of inertia);
    # the flight controller keeps the spec's values, as the PyBullet engine's does
    body_mass = float(f"{spec.total_mass():.9g}")
    body_inertia = np.array([float(f"{v:.9g}") for v in np.diag(spec.inertia_matrix())], dtype=np.float64)
    drag_params = DragParams(spec.drag.coefficients, spec.drag.areas, spec.drag.angular_damping)
    on = bool(drag and drag_params.active)
    common = dict(
        rotors=_rotor_rows(spec, parts.motors, physics_dt),
        span=vehicle_span(parts.motors.positions if parts.motors is not None else None, parts.surfaces),
        name=name,
        mass=body_mass,
        inertia=body_inertia,
        drag_factors=np.asarray(drag_params.factors, dtype=np.float64),
        angular_damping=float(drag_params.angular_damping),
        drag=on,
        corners=_corners(spec, np.asarray(parts.com, dtype=np.float64)),
        **_motor_laws(parts, physics_dt),
    )
    common.update(_gimbal_rows(parts, physics_dt))
    if isinstance(spec.control, FixedwingControlSpec):  # fixedwing
        return _fixedwing_model(parts, spec.control, physics_dt, common)
    assert isinstance(spec.control, MultirotorControlSpec)  # the other controllers refused above
    assert motors is not None  # a multirotor controller needs motors (spec validator)
    inertia = np.asarray(parts.inertia, dtype=np.float64)
    mixer = flight_mixer(parts)  # the Vehicle's: the mixer motors, the tilting ones among them
    controller = MultirotorController(spec.control, parts.mass, np.diag(inertia), mixer, control_dt)
    gains = np.array([list(axis) for axis in controller._rate_axes], dtype=np.float64).T.copy()  # (4, 3)
    columns = motor_wrench_matrix(motors).T.copy()
    routed = bool(parts.channels) or bool(parts.surfaces) or parts.gimbals is not None
    routed = routed or len(parts.mixer_motors) != motors.count
    source = np.full(motors.count, -1, dtype=np.int64)  # per motor its mixer output (Motors.route), -1: its mix
    source[list(parts.mixer_motors)] = np.arange(len(parts.mixer_motors))
    lateral = np.array([[motor, limit, *row] for motor, limit, row in mixer._lateral], dtype=np.float64).reshape(
        -1, LATERAL_FIELDS
    )
    if routed:
        common.update(_channel_tables(parts, physics_dt))
    return BatchedModel(
        routed=routed,
        motor_source=source,
        lateral=lateral,
        control_inertia=np.asarray(controller.inertia, dtype=np.float64),
        gyro=np.asarray(controller._gyro, dtype=np.float64),
        lag=np.asarray(lag_coefficient(physics_dt, motors.tau), dtype=np.float64).reshape(-1),
        columns=columns,
        noise_ratio=np.asarray(motors.noise_ratio, dtype=np.float64).copy(),
        mixer_rows=np.asarray(mixer._rows, dtype=np.float64).reshape(-1, 5),
        max_collective=float(mixer.max_collective),
        rate_gains=gains,
        rate_derivative=bool(controller._rate_derivative),
        cascade=cascade_params(controller),
        **common,
    )


def _fixedwing_model(parts, control: FixedwingControlSpec, physics_dt: float, common: dict) -> BatchedModel:
    """A fixed-wing's model: motors and flaps routed from the channels (``Motors.route``,
    ``Surfaces.route``), the surfaces' constants and flap lags as ``Surfaces`` holds them,
    the autopilot's gains and channels as ``FixedwingAutopilot`` reads them."""
    loops = (control.roll, control.pitch, control.yaw, control.airspeed)
    channels = (control.roll_channel, control.pitch_channel, control.yaw_channel, control.thrust_channel)
    motors = parts.motors
    if motors is not None:
        lag = np.asarray(lag_coefficient(physics_dt, motors.tau), dtype=np.float64).reshape(-1)
        columns = motor_wrench_matrix(motors).T.copy()
        noise = np.asarray(motors.noise_ratio, dtype=np.float64).copy()
    else:
        lag, columns, noise = np.zeros(0), np.zeros((0, 6)), np.zeros(0)
    return BatchedModel(
        control_inertia=np.zeros(3),
        gyro=np.zeros(3),
        lag=lag,
        columns=columns,
        noise_ratio=noise,
        mixer_rows=np.zeros((len(lag), 5)),
        max_collective=0.0,
        rate_gains=np.zeros((4, 3)),
        rate_derivative=False,
        channel_driven=True,
        motor_source=np.full(len(lag), -1, dtype=np.int64),
        autopilot_gains=np.array([[g.kp, g.ki, g.kd, g.integral_limit] for g in loops], dtype=np.float64),
        cruise_thrust=float(control.cruise_thrust),
        autopilot_index=np.array([parts.channels.index(c) for c in channels], dtype=np.int64),
        **_channel_tables(parts, physics_dt),
        **common,
    )


def _channel_tables(parts, physics_dt: float) -> dict:
    """What routes the channels to the actuators (``Motors.route``, ``Surfaces.route``): the
    channels' ranges, the motors' and flaps' mixes, and the surfaces' constants and flap lags
    as ``Surfaces`` holds them."""
    motor_index, motor_weight = _mix_tables(parts.motor_mix)
    surface_index, surface_weight = _mix_tables(parts.surface_mix)
    return dict(
        channel_low=np.asarray(parts.channel_low, dtype=np.float64).copy(),
        channel_high=np.asarray(parts.channel_high, dtype=np.float64).copy(),
        motor_mix_index=motor_index,
        motor_mix_weight=motor_weight,
        surfaces=np.array([list(s.constants) for s in parts.surfaces], dtype=np.float64).reshape(-1, 25),
        surface_lag=np.array([float(lag_coefficient(physics_dt, s.tau)) for s in parts.surfaces], dtype=np.float64),
        surface_scale=np.array([s.max_deflection or 1.0 for s in parts.surfaces], dtype=np.float64),
        surface_mix_index=surface_index,
        surface_mix_weight=surface_weight,
    )


def _gimbal_rows(parts, physics_dt: float) -> dict:
    """The gimbals' rows (``BatchedModel.gimbals``, ``gimbal_source``, ``gimbal_scale``) out of the
    engine's own ``Gimbals`` group and ``Motors.turn``'s tables (none without gimbals)."""
    if parts.gimbals is None:
        return {}
    from pyflyt_engine.components.gimbal import gimbal_constants

    motors = parts.motors
    if motors is None or any(kind != "motor" for kind, _ in parts.gimbal_targets):
        raise refuse("a gimbal turning a booster", "the batched backend flies gimbals that turn motors")
    n_mixer = len(parts.mixer_motors)
    flown = {g: n_mixer + k for k, (g, _) in enumerate(parts.mixer_tilts)}  # as build_gimbals routes them
    reaction = (-(motors.spin * motors.max_torque)).tolist()
    thrust, positions, axes = motors.max_thrust.tolist(), motors.positions.tolist(), motors.thrust_axes.tolist()
    rows, source = [], []
    for g, (k, (_, m), (ca, cb)) in enumerate(
        zip(gimbal_constants(parts.gimbals, physics_dt), parts.gimbal_targets, parts.gimbal_channels.tolist())
    ):
        rows.append([*k[:3], *k.W_a, *k.W_a2, *k.W_b, *k.W_b2, *axes[m], *positions[m], thrust[m], reaction[m]])
        source.append([m, ca, cb, flown.get(g, -1)])
    scale = [max(v, 1e-12) for v in parts.gimbals.max_angles.reshape(-1).tolist()]  # Gimbals._scale
    out = {
        "gimbals": np.array(rows, dtype=np.float64).reshape(-1, GIMBAL_FIELDS),
        "gimbal_source": np.array(source, dtype=np.int64).reshape(-1, 4),
        "gimbal_scale": np.array(scale, dtype=np.float64),
    }
    return out


def mode_code(mode: str | int, model: BatchedModel | None = None) -> int:
    """The compiled controller's code of a flight mode on ``model``'s kind of airframe (a
    multirotor without a model; refuses modes it does not fly)."""
    if model is not None and model.channel_driven:
        name = str(mode)
        if name not in BATCHED_FIXEDWING_MODES:
            what = "not compiled" if name in FIXEDWING_MODES else "not a fixed-wing mode"
            flies = ", ".join(BATCHED_FIXEDWING_MODES)
            raise refuse(f"flight mode {name} ({what})", f"on a fixed-wing it flies {flies}")
        return BATCHED_FIXEDWING_MODES[name]
    name = resolve_mode(mode).name
    if name not in BATCHED_MODES:
        raise refuse(f"flight mode {name}", f"it flies {', '.join(BATCHED_MODES)}")
    return BATCHED_MODES[name]

"""Brushless DC motor driven propellers (paper, "Brushless DC Motor Driven Propellers").

State: the normalised throttle ``x`` of each motor, in [-1, 1].  One physics step::

    x[t+1] = (x[t] + a * (zeta - x[t])) * (1 + sigma * eta)      a = 1 - exp(-dt / tau)
    omega  = x * max_rpm
    F      = k_F * omega * |omega|        (thrust along the motor's thrust axis)
    T      = k_T * omega * |omega|        (reaction torque about the same axis)

``eta`` is a standard normal drawn independently for every motor at every step by the
caller (the world's seeded generator), so the noise is zero-mean per motor; the
reference package draws one shared N(4, 1) scalar instead, which biases thrust upward.
``omega * |omega|`` equals the paper's ``omega^2`` for the forward-spinning props it
models and keeps reversed props (negative throttle) pushing the other way.  See
:mod:`pyflyt_engine.components.lag` for the choice of discretisation.

The body-frame wrench of all motors together is linear in ``x * |x|``: column ``i`` of
:func:`motor_wrench_matrix` is motor ``i``'s wrench at full throttle, computed once (and
again by a gimbal that turns the motor), so a physics step costs one multiply-add per
motor and wrench component.  :class:`Motors` holds the state of a vehicle's motors and
steps them (:meth:`Motors.step`: this law, on plain floats).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pyflyt_engine.components import AirVelocity, Wrench
from pyflyt_engine.components.lag import lag_coefficient
from pyflyt_engine.components.noise import NoiseBlocks, NoiseSource
from pyflyt_engine.components.routing import MixRow, mixed


@dataclass(frozen=True)
class MotorParams:
    """Parameters of ``n`` motors of one vehicle (arrays of length n or n x 3).

    Attributes:
        positions: (n, 3) propeller hub positions in the body frame [m].
        thrust_axes: (n, 3) unit thrust directions in the body frame.
        spin: (n,) +1 for a propeller turning counter-clockwise about its thrust axis
            (right-hand rule), -1 for clockwise.  The reaction torque on the body is
            ``-spin * k_T * omega|omega|`` about the thrust axis.
        tau: (n,) motor time constant [s].
        max_rpm: (n,) RPM at full throttle.
        kf: (n,) thrust coefficient [N / RPM^2].
        kt: (n,) torque coefficient [N m / RPM^2].
        noise_ratio: (n,) standard deviation of the multiplicative throttle noise.
        tau_fall: (n,) time constant while a rotor slows down [s] (``tau`` is then the
            spin-up one); None: ``tau`` both ways.
        rotor_drag: (n,) rotor drag coefficient at full speed [N / (m/s)]; None: no rotor drag.
        prop_radius: (n,) propeller radius [m] (None: not given).
        inflow: (solidity, lift slope [1/rad]) of the blades for the axial-inflow model;
            None: static thrust.  The optional models are stepped by
            :class:`pyflyt_engine.components.motor_models.ModelledMotors`.
    """

    positions: np.ndarray
    thrust_axes: np.ndarray
    spin: np.ndarray
    tau: np.ndarray
    max_rpm: np.ndarray
    kf: np.ndarray
    kt: np.ndarray
    noise_ratio: np.ndarray
    tau_fall: np.ndarray | None = None
    rotor_drag: np.ndarray | None = None
    prop_radius: np.ndarray | None = None
    inflow: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        n = len(self.positions)
        for name in ("spin", "tau", "max_rpm", "kf", "kt", "noise_ratio", "tau_fall", "rotor_drag", "prop_radius"):
            if getattr(self, name) is None:
                continue
            value = np.broadcast_to(np.asarray(getattr(self, name), dtype=np.float64), (n,)).copy()
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        for name in ("positions", "thrust_axes"):
            value = np.asarray(getattr(self, name), dtype=np.float64).reshape(n, 3).copy()
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @property
    def modelled(self) -> bool:
        """Whether any optional motor model (asymmetric lag, rotor drag, inflow) is on."""
        return self.tau_fall is not None or self.rotor_drag is not None or self.inflow is not None

    @property
    def count(self) -> int:
        """Number of motors."""
        return len(self.positions)

    @property
    def max_thrust(self) -> np.ndarray:
        """(n,) static thrust at full throttle [N]: k_F * max_rpm^2."""
        return self.kf * self.max_rpm**2

    @property
    def max_torque(self) -> np.ndarray:
        """(n,) reaction torque at full throttle [N m]: k_T * max_rpm^2."""
        return self.kt * self.max_rpm**2


def motor_subset(motors: MotorParams, indices: Sequence[int]) -> MotorParams:
    """The motors ``indices`` of ``motors`` (in that order), e.g. the ones a mixer flies."""
    idx = list(indices)
    return MotorParams(
        positions=motors.positions[idx],
        thrust_axes=motors.thrust_axes[idx],
        spin=motors.spin[idx],
        tau=motors.tau[idx],
        max_rpm=motors.max_rpm[idx],
        kf=motors.kf[idx],
        kt=motors.kt[idx],
        noise_ratio=motors.noise_ratio[idx],
        **{
            name: (getattr(motors, name)[idx] if getattr(motors, name) is not None else None)
            for name in ("tau_fall", "rotor_drag", "prop_radius")
        },
        inflow=motors.inflow,
    )


def motor_lag(params: MotorParams, dt: float) -> np.ndarray:
    """(n,) lag coefficient of every motor for physics step ``dt`` (compute once)."""
    return np.asarray(lag_coefficient(dt, params.tau))


def noise_factors(params: MotorParams, eta: np.ndarray) -> np.ndarray:
    """Multiplicative noise ``1 + noise_ratio * eta`` for standard normals ``eta`` (..., n)."""
    return 1.0 + params.noise_ratio * eta


def motor_wrench_matrix(params: MotorParams) -> np.ndarray:
    """The 6 x n map from ``x * |x|`` to the body wrench [Fx, Fy, Fz, Tx, Ty, Tz]: column i is
    :func:`wrench_column` of motor i."""
    reaction = (-(params.spin * params.max_torque)).tolist()
    columns = [
        wrench_column(position, axis, thrust, gain)
        for position, axis, thrust, gain in zip(
            params.positions.tolist(), params.thrust_axes.tolist(), params.max_thrust.tolist(), reaction
        )
    ]
    return np.array(columns, dtype=np.float64).reshape(-1, 6).T.copy()


def reaction_per_thrust(params: MotorParams) -> list[float]:
    """Per motor, its reaction torque per newton of thrust, ``-spin k_T / k_F`` as
    ``-spin max_torque / max_thrust`` (0 for a motor without thrust): what ground effect
    leaves unscaled (:meth:`Motors._scaled_columns`)."""
    reaction = (-(params.spin * params.max_torque)).tolist()
    return [r / t if t else 0.0 for r, t in zip(reaction, params.max_thrust.tolist())]


def wrench_column(
    position: Sequence[float], axis: Sequence[float], max_thrust: float, reaction: float
) -> tuple[float, float, float, float, float, float]:
    """A motor's body wrench at full throttle (``x |x| = 1``), about the centre of mass.

    The thrust ``F = max_thrust * axis`` [N] (max_thrust = k_F max_rpm^2), its moment
    ``position x F``, and the reaction torque ``reaction * axis`` about the thrust axis,
    with ``reaction = -spin * k_T max_rpm^2`` [N m] (the propeller drags the body the
    other way round).
    """
    px, py, pz = position
    ax, ay, az = axis
    fx, fy, fz = ax * max_thrust, ay * max_thrust, az * max_thrust
    return (
        fx,
        fy,
        fz,
        (py * fz - pz * fy) + reaction * ax,
        (pz * fx - px * fz) + reaction * ay,
        (px * fy - py * fx) + reaction * az,
    )


class Motors:
    """The motors of one vehicle as an actuator group: throttle state, commands, noise, wrench.

    Args:
        params: the motors, in the centre-of-mass body frame.
        physics_dt: physics step [s].
        noise: the vehicle's noise generator (per-motor factors are drawn from it in blocks).
        mix: per motor, the channels that drive it (:mod:`~pyflyt_engine.components.routing`;
            default none).
        mixer_outputs: per motor, the index of the mixer output that drives it, or None
            for a motor driven by its ``mix`` (default: None for every motor).

    Attributes:
        throttle: per motor, the normalised throttle x in [-1, 1] (the state).
        command: per motor, the commanded throttle in [-1, 1] (set at the control rate).
    """

    @property
    def needs_air(self) -> bool:
        """The static thrust model does not read the air (:class:`~pyflyt_engine.components.kinds.ActuatorGroup`);
        a property, as :class:`~pyflyt_engine.components.motor_models.ModelledMotors` computes it."""
        return False

    #: its throttles follow the channels and the mixer
    commanded = True

    def __init__(
        self,
        params: MotorParams,
        physics_dt: float,
        noise: NoiseSource,
        mix: Sequence[MixRow] | None = None,
        mixer_outputs: Sequence[int | None] | None = None,
    ) -> None:
        self.physics_dt = physics_dt
        self.set_params(params)
        n = params.count
        self.throttle = [0.0] * n
        self.command = [0.0] * n
        self._ones = [1.0] * n
        self._noisy = bool(np.any(params.noise_ratio > 0))
        self._noise = NoiseBlocks(noise, n, lambda eta: noise_factors(params, eta))
        #: per motor, (mixer output index or None, channel mix row): where its command comes from
        self._sources = list(zip(mixer_outputs or [None] * n, mix or [()] * n))

    def route(self, channels: Sequence[float], outputs: Sequence[float] | None) -> None:
        """Commands from the channels and the mixer's ``outputs`` (None: none this tick):
        a motor the mixer flies takes its output (0 without), any other its channel mix;
        limited to [-1, 1]."""
        values = [
            (outputs[k] if outputs is not None else 0.0) if k is not None else mixed(channels, row)
            for k, row in self._sources
        ]
        self.command = [1.0 if v > 1.0 else -1.0 if v < -1.0 else v for v in values]  # clamp(v, -1, 1)

    def step(self, air: AirVelocity | None = None, thrust_ratio: Sequence[float] | None = None) -> Wrench:
        """One physics step of every motor (the module docstring): the throttle lags toward its
        command and takes its noise factor, ``x' = (x + a (zeta - x)) (1 + sigma eta)``; returns
        the motors' wrench, column i of :func:`motor_wrench_matrix` times ``x'_i |x'_i|``
        summed over the motors, in N and N m about the centre of mass, body frame.

        Args:
            air: the body's velocity through the air; it does not enter this model (static thrust).
            thrust_ratio: per motor, a factor on its thrust and the thrust's moment (the
                reaction torque is left alone) from the air around it, e.g. ground effect
                (:func:`pyflyt_engine.atmosphere.rotors.ground_effect_ratios`); None: 1
                for every motor.
        """
        factors = self._noise.next() if self._noisy else self._ones  # z = 1 + sigma eta, per motor
        columns = self.columns if thrust_ratio is None else self._scaled_columns(thrust_ratio)
        new = []
        fx = fy = fz = tx = ty = tz = 0.0
        # Plain Python floats: for the handful of motors of one vehicle, stepped at the
        # physics rate, they beat NumPy's per-call overhead.
        for x, c, a, z, (wx, wy, wz, wl, wm, wn) in zip(self.throttle, self.command, self.lag, factors, columns):
            x = (x + a * (c - x)) * z  # lag towards the command, then the noise factor
            new.append(x)
            f = x * abs(x)  # thrust and torque go as throttle squared, signed
            fx += wx * f
            fy += wy * f
            fz += wz * f
            tx += wl * f
            ty += wm * f
            tz += wn * f
        self.throttle = new
        return fx, fy, fz, tx, ty, tz

    def _scaled_columns(self, scale: Sequence[float]) -> list[tuple[float, float, float, float, float, float]]:
        """The wrench columns with each motor's thrust (force and its moment) times ``scale``;
        the reaction torque, ``reaction * axis`` with ``axis = force / max_thrust``, unscaled."""
        out = []
        for (fx, fy, fz, tx, ty, tz), k, r in zip(self.columns, scale, self._reaction_per_thrust):
            rx, ry, rz = r * fx, r * fy, r * fz
            out.append((k * fx, k * fy, k * fz, k * (tx - rx) + rx, k * (ty - ry) + ry, k * (tz - rz) + rz))
        return out

    def set_params(self, params: MotorParams) -> None:
        """Use new parameters (same motors, e.g. constants sampled by domain randomisation);
        the throttles keep their state, and a gimbal re-turns its motor at its next step."""
        self.params = params
        self.lag = motor_lag(params, self.physics_dt).tolist()
        self.columns = [tuple(column) for column in motor_wrench_matrix(params).T.tolist()]
        self._positions = params.positions.tolist()
        self._max_thrust = params.max_thrust.tolist()
        self._reaction = (-(params.spin * params.max_torque)).tolist()
        self._reaction_per_thrust = reaction_per_thrust(params)

    def turn(self, index: int, thrust_axis: Sequence[float]) -> None:
        """Point motor ``index``'s thrust along ``thrust_axis`` (a gimbal moved it)."""
        self.columns[index] = wrench_column(
            self._positions[index], thrust_axis, self._max_thrust[index], self._reaction[index]
        )

    def reset(self) -> None:
        """Idle throttles and commands; buffered noise discarded."""
        self.throttle = [0.0] * len(self.throttle)
        self.command = [0.0] * len(self.command)
        self._noise.discard()

    def reseed(self) -> None:
        """The noise generator was replaced: draw from the new one."""
        self._noise.discard()

    def aux(self) -> list[float]:
        """Throttles, for the vehicle's auxiliary state."""
        return list(self.throttle)

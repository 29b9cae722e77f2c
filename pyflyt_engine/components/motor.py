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

Because every motor is rigidly mounted, the body-frame wrench of all motors together is
linear in ``x * |x|``: :func:`motor_wrench_matrix` precomputes that 6 x n map once, so a
physics step costs one matrix-vector product.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pyflyt_engine.components.lag import lag_coefficient


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
    """

    positions: np.ndarray
    thrust_axes: np.ndarray
    spin: np.ndarray
    tau: np.ndarray
    max_rpm: np.ndarray
    kf: np.ndarray
    kt: np.ndarray
    noise_ratio: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.positions)
        for name in ("spin", "tau", "max_rpm", "kf", "kt", "noise_ratio"):
            value = np.broadcast_to(np.asarray(getattr(self, name), dtype=np.float64), (n,)).copy()
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        for name in ("positions", "thrust_axes"):
            value = np.asarray(getattr(self, name), dtype=np.float64).reshape(n, 3).copy()
            value.setflags(write=False)
            object.__setattr__(self, name, value)

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


def motor_step(
    params: MotorParams,
    throttle: np.ndarray,
    command: np.ndarray,
    lag: float | np.ndarray,
    noise_factor: float | np.ndarray,
) -> np.ndarray:
    """Advance the throttle state of every motor by one physics step.

    Args:
        params: the motors (unused by the arithmetic; names what the arrays belong to).
        throttle: (n,) current normalised throttle x[t].
        command: (n,) commanded throttle zeta, already in [-1, 1] (see
            :func:`clip_command`).
        lag: ``lag_coefficient(dt, params.tau)``, computed once per physics rate.
        noise_factor: (n,) ``1 + noise_ratio * eta`` with eta standard normal, one per
            motor (see :func:`noise_factors`), or 1.0 for no noise.

    Returns:
        (n,) new throttle x[t+1].
    """
    return (throttle + lag * (command - throttle)) * noise_factor


def motor_lag(params: MotorParams, dt: float) -> np.ndarray:
    """(n,) lag coefficient of every motor for physics step ``dt`` (compute once)."""
    return np.asarray(lag_coefficient(dt, params.tau))


def clip_command(command: np.ndarray) -> np.ndarray:
    """Throttle commands limited to the motors' range [-1, 1]."""
    return np.clip(command, -1.0, 1.0)


def noise_factors(params: MotorParams, eta: np.ndarray) -> np.ndarray:
    """Multiplicative noise ``1 + noise_ratio * eta`` for standard normals ``eta`` (..., n)."""
    return 1.0 + params.noise_ratio * eta


def motor_step_wrench(
    throttle: list[float],
    command: list[float],
    lag: list[float],
    noise_factor: list[float],
    wrench_columns: list[tuple[float, float, float, float, float, float]],
) -> tuple[list[float], tuple[float, float, float, float, float, float]]:
    """:func:`motor_step` and the wrench of :func:`motor_wrench_matrix`, on Python floats.

    The same arithmetic as the NumPy functions, element by element: for the handful of
    motors of one vehicle, stepped at the physics rate, plain floats avoid NumPy's
    per-call overhead (a test checks both forms agree to rounding).

    Args:
        throttle, command, lag, noise_factor: per-motor lists (see :func:`motor_step`).
        wrench_columns: per-motor columns of :func:`motor_wrench_matrix` as 6-tuples.

    Returns:
        (new throttle list, body wrench (Fx, Fy, Fz, Tx, Ty, Tz) in N and N m).
    """
    new = [(x + a * (c - x)) * z for x, c, a, z in zip(throttle, command, lag, noise_factor)]
    fx = fy = fz = tx = ty = tz = 0.0
    for (wx, wy, wz, wl, wm, wn), x in zip(wrench_columns, new):
        f = x * abs(x)
        fx += wx * f
        fy += wy * f
        fz += wz * f
        tx += wl * f
        ty += wm * f
        tz += wn * f
    return new, (fx, fy, fz, tx, ty, tz)


def motor_outputs(params: MotorParams, throttle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Thrust [N] and reaction-torque magnitude [N m] of every motor at ``throttle``."""
    omega = throttle * params.max_rpm
    omega_sq = omega * np.abs(omega)
    return params.kf * omega_sq, params.kt * omega_sq


def motor_wrench_matrix(params: MotorParams) -> np.ndarray:
    """The 6 x n map from ``x * |x|`` to the body wrench [Fx, Fy, Fz, Tx, Ty, Tz].

    Column i is the wrench of motor i at full throttle: its thrust along its axis, the
    moment of that thrust about the body origin, and its reaction torque.
    """
    thrust = params.thrust_axes * params.max_thrust[:, None]
    moment = np.cross(params.positions, thrust)
    reaction = -(params.spin * params.max_torque)[:, None] * params.thrust_axes
    return np.concatenate([thrust, moment + reaction], axis=1).T.copy()

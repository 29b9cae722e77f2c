"""The allocation matrix of a multirotor's motors, and the check that it flies the vehicle.

Each motor i pushes with thrust f_i [N] along its unit axis a_i from its position p_i
(relative to the centre of mass), and reacts with torque -s_i (k_T / k_F) f_i a_i.  The
allocation matrix ``A`` (4 x n) maps motor thrusts to [collective thrust along body z,
roll, pitch, yaw torque]::

    A[:, i] = [a_i,z, (p_i x a_i - s_i kappa_i a_i)]       kappa_i = k_T,i / k_F,i

A motor on a servo the mixer flies (:class:`Tilt`) adds a column: its thrust along
``c x n``, ``c`` the servo axis and ``n`` the motor's nominal axis (the change of
variables of :mod:`pyflyt_engine.control.mixer`).  The motors fly the vehicle when ``A``
has rank 4: collective thrust, roll, pitch and yaw independently reachable
(:func:`require_controllable`).

This module sits below the spec and the controller: the spec checks an airframe with it
when the file is loaded, the mixer builds and inverts the same matrix, and neither
imports the other.  Arrays in, NumPy element-wise arithmetic and
:mod:`pyflyt_engine.exact` only (no BLAS or LAPACK).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.errors import ConfigError


class Tilt(NamedTuple):
    """A mixer motor on a servo the mixer flies (see the module docstring)."""

    #: index among the mixer's motors
    motor: int
    #: the servo's rotation axis ``c``, unit, perpendicular to the motor's thrust axis (body frame)
    axis: tuple[float, float, float]
    #: servo deflection limit [rad]; the mixer's output is the angle over this, in [-1, 1]
    max_angle: float


def allocation_matrix(
    positions: np.ndarray, thrust_axes: np.ndarray, spin: np.ndarray, kf: np.ndarray, kt: np.ndarray
) -> np.ndarray:
    """The 4 x n allocation matrix ``A`` of this module's docstring.

    Args:
        positions: (n, 3) motor positions relative to the centre of mass, body frame [m].
        thrust_axes: (n, 3) unit thrust directions, body frame.
        spin: (n,) +1 counter-clockwise / -1 clockwise about the thrust axis.
        kf, kt: (n,) thrust [N/RPM^2] and torque [N m/RPM^2] coefficients.

    Returns:
        Rows [collective thrust along body z, roll, pitch, yaw torque] per newton of
        each motor's thrust.
    """
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    axes = np.asarray(thrust_axes, dtype=float).reshape(-1, 3)
    kappa = np.asarray(kt, dtype=float) / np.asarray(kf, dtype=float)
    torque = np.cross(positions, axes) - (np.asarray(spin, dtype=float) * kappa)[:, None] * axes
    return np.vstack([axes[:, 2], torque.T])


def allocation_rank(allocation: np.ndarray) -> int:
    """Numerical rank of an allocation matrix: 4 when thrust, roll, pitch and yaw are independently reachable.

    Counted as the pivots above ``1e-9 max(1, largest |entry|)`` in Gaussian elimination
    with complete pivoting (:func:`pyflyt_engine.exact.rank`)."""
    if allocation.size == 0:
        return 0
    return exact.rank(allocation, tol=1e-9 * max(1.0, float(np.abs(allocation).max())))


def tilted_allocation(
    positions: np.ndarray,
    thrust_axes: np.ndarray,
    spin: np.ndarray,
    kf: np.ndarray,
    kt: np.ndarray,
    tilts: Sequence[Tilt] = (),
) -> np.ndarray:
    """The allocation matrix with one more column per tilting motor: its thrust along
    ``c x n`` (arguments as :func:`allocation_matrix`, arrays over the mixer's motors)."""
    base = allocation_matrix(positions, thrust_axes, spin, kf, kt)
    if not tilts:
        return base
    idx = [t.motor for t in tilts]
    axes = np.asarray(thrust_axes, dtype=float).reshape(-1, 3)
    lateral = np.cross(np.asarray([t.axis for t in tilts], dtype=float), axes[idx])
    extra = allocation_matrix(
        np.asarray(positions, dtype=float).reshape(-1, 3)[idx], lateral,
        np.asarray(spin)[idx], np.asarray(kf)[idx], np.asarray(kt)[idx],
    )  # fmt: skip
    return np.hstack([base, extra])


def require_controllable(allocation: np.ndarray, motors: Sequence[int], tilted: bool = False) -> None:
    """Raise :class:`~pyflyt_engine.errors.ConfigError` unless ``allocation`` has rank 4.

    Args:
        allocation: :func:`tilted_allocation` of the mixer's motors.
        motors: the airframe's indices of those motors (named in the message).
        tilted: whether the matrix has servo-tilted columns (named in the message).
    """
    rank = allocation_rank(allocation)
    if rank < 4:
        raise ConfigError(
            f"the multirotor motors {list(motors)} cannot control the vehicle: their allocation matrix "
            f"(collective thrust, roll, pitch, yaw torque per motor"
            f"{' and per servo-tilted thrust' if tilted else ''}) has rank {rank} < 4. "
            "Thrust, roll, pitch and yaw must be independently reachable: the motors need positions "
            "not all on one line through the centre of mass, and spin directions that are not all the "
            "same (or tilted thrust axes, or a servo the mixer flies: gimbals with mixer: true); check "
            "motors.positions, motors.spin, motors.thrust_axes and control.mixer_motors"
        )

"""Motor mixer derived from the motor geometry.

Each motor i pushes with thrust f_i [N] along its unit axis a_i from its position p_i,
and reacts with torque -s_i (k_T / k_F) f_i a_i.  The allocation matrix ``A`` (4 x n)
maps motor thrusts to [collective thrust along body z, roll, pitch, yaw torque]::

    A[:, i] = [a_i,z, (p_i x a_i - s_i kappa_i a_i)]       kappa_i = k_T,i / k_F,i

The mixer is its pseudo-inverse, so any airframe whose motors can produce all four
outputs independently (quad, hexa, octo, Y6, ...) needs no hand-written mixing table.
"""

from __future__ import annotations

import math

import numpy as np

from pyflyt_engine.components.motor import MotorParams
from pyflyt_engine.errors import ConfigError


class Mixer:
    """Maps [thrust, tau_x, tau_y, tau_z] (N, N m; body frame) to motor throttles."""

    def __init__(self, motors: MotorParams) -> None:
        axes, positions = motors.thrust_axes, motors.positions
        kappa = motors.kt / motors.kf
        torque = np.cross(positions, axes) - (motors.spin * kappa)[:, None] * axes
        self.allocation = np.vstack([axes[:, 2], torque.T])
        rank = np.linalg.matrix_rank(self.allocation, tol=1e-9 * max(1.0, np.abs(self.allocation).max()))
        if rank < 4:
            raise ConfigError(
                f"the motors cannot control this vehicle: their allocation matrix has rank {rank} < 4 "
                "(collective thrust, roll, pitch and yaw must be independently reachable); "
                "check motor positions, thrust axes and spin directions"
            )
        self.inverse = np.linalg.pinv(self.allocation)
        self._inverse_rows = self.inverse.tolist()
        self.max_thrust = motors.max_thrust.tolist()
        #: Collective thrust along body z with every motor at full throttle [N].
        self.max_collective = float(axes[:, 2] @ motors.max_thrust)

    def throttles(self, thrust: float, tx: float, ty: float, tz: float) -> list[float]:
        """Throttle per motor (in [0, 1]) that best produces the requested wrench.

        Torques have priority: when a motor would exceed full thrust, the collective
        thrust is scaled down until every motor fits, so the vehicle keeps attitude
        authority at full throttle.  Thrusts below zero are clipped to zero.
        """
        rows, fmax = self._inverse_rows, self.max_thrust
        from_thrust = [r[0] * thrust for r in rows]
        from_torque = [r[1] * tx + r[2] * ty + r[3] * tz for r in rows]
        scale = 1.0
        for ft, fq, fm in zip(from_thrust, from_torque, fmax):
            if ft + fq > fm and ft > 0.0:
                scale = min(scale, max(0.0, (fm - fq) / ft))
        out = []
        for ft, fq, fm in zip(from_thrust, from_torque, fmax):
            f = scale * ft + fq
            out.append(0.0 if f <= 0.0 else 1.0 if f >= fm else math.sqrt(f / fm))
        return out

"""Named vehicle state read-outs (paper, "Frame Conventions" and "Observation Spaces")."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class KinematicState(NamedTuple):
    """The rigid-body state of one vehicle, read after a physics step.

    Plain tuples of floats, so reading it in the control loop costs no array
    allocations; :meth:`as_array` gives the paper's stacked form.

    Attributes:
        ang_vel: body angular velocity (p, q, r) [rad/s], body frame.
        ang_pos: attitude as Euler angles (roll, pitch, yaw) [rad], ground frame.
        lin_vel: linear velocity (u, v, w) [m/s], body frame.
        lin_pos: position (x, y, z) [m], ground frame (ENU).
        quaternion: attitude quaternion (x, y, z, w), body-to-ground.
        lin_vel_ground: linear velocity (vx, vy, vz) [m/s], ground frame.
        ang_vel_ground: angular velocity [rad/s], ground frame.
    """

    ang_vel: tuple[float, float, float]
    ang_pos: tuple[float, float, float]
    lin_vel: tuple[float, float, float]
    lin_pos: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]
    lin_vel_ground: tuple[float, float, float]
    ang_vel_ground: tuple[float, float, float]

    def as_array(self) -> np.ndarray:
        """(4, 3) array: rows ang_vel, ang_pos, lin_vel, lin_pos (the paper's order)."""
        return np.array([self.ang_vel, self.ang_pos, self.lin_vel, self.lin_pos], dtype=np.float64)

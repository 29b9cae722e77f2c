"""``PoleHandler``: the reference's free pole for tasks users write (PyFlyt 0.29.0
``gym_envs.utils.pole_handler``), built here without its URDF.

The pole as the reference's ``models/pole.urdf`` describes it: a 1 m cylinder of 5 mm
radius and 0.2 kg, its middle the base link, a massless end link at each end (link 0 the
top, +0.5 m; link 1 the bottom, -0.5 m, with a 1 cm collision sphere the handler gives
friction 1e5 and restitution 0.01).  It rests free wherever :meth:`reset` puts it, e.g. on
an airframe.  (The stock Pole envs of this layer use the native pole payload instead.)
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

__all__ = ["PoleHandler"]

_LENGTH, _RADIUS, _MASS = 1.0, 0.005, 0.2


class PoleHandler:
    """Builds the pole and reads its ends relative to a vehicle (the reference's methods)."""

    def __init__(self) -> None:
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(12,), dtype=np.float64)
        self._leaningness = 0.0

    def reset(self, p: Any, start_location: np.ndarray) -> None:
        """A new pole standing at ``start_location`` (its middle); ``p`` an Aviary."""
        self.p = p
        body = p.createCollisionShape(p.GEOM_CYLINDER, radius=_RADIUS, height=_LENGTH)
        look = p.createVisualShape(p.GEOM_CYLINDER, radius=_RADIUS, length=_LENGTH, rgbaColor=(0.9, 0.9, 0.9, 1.0))
        tip = p.createVisualShape(p.GEOM_SPHERE, radius=0.04, rgbaColor=(0.9, 0.1, 0.1, 1.0))
        foot = p.createCollisionShape(p.GEOM_SPHERE, radius=0.01)
        self.Id = int(
            p.createMultiBody(
                baseMass=_MASS,
                baseCollisionShapeIndex=body,
                baseVisualShapeIndex=look,
                basePosition=list(np.asarray(start_location, dtype=np.float64)),
                linkMasses=[0.0, 0.0],
                linkCollisionShapeIndices=[-1, foot],
                linkVisualShapeIndices=[tip, -1],
                linkPositions=[[0.0, 0.0, 0.5 * _LENGTH], [0.0, 0.0, -0.5 * _LENGTH]],
                linkOrientations=[[0.0, 0.0, 0.0, 1.0]] * 2,
                linkInertialFramePositions=[[0.0, 0.0, 0.0]] * 2,
                linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]] * 2,
                linkParentIndices=[0, 0],
                linkJointTypes=[p.JOINT_FIXED] * 2,
                linkJointAxis=[[0.0, 0.0, 1.0]] * 2,
            )
        )
        p.changeDynamics(self.Id, 1, lateralFriction=1.0e5, restitution=0.01)
        self._leaningness = 0.0

    @property
    def leaningness(self) -> float:
        """Horizontal distance between the ends [m] while the top is above the bottom, else 1."""
        return float(self._leaningness)

    def compute_state(
        self, rotation: np.ndarray, uav_lin_pos: np.ndarray, uav_lin_vel: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(top position, top velocity, bottom position, bottom velocity)`` relative to the vehicle:
        ``rotation`` ground -> body (3, 3), ``uav_lin_vel`` its body-frame velocity."""
        top = self.p.getLinkState(self.Id, 0, computeLinkVelocity=True)
        bottom = self.p.getLinkState(self.Id, 1, computeLinkVelocity=True)
        top_pos, top_vel = np.array(top[0]), np.array(top[6])
        bottom_pos, bottom_vel = np.array(bottom[0]), np.array(bottom[6])
        upright = top_pos[2] > bottom_pos[2]
        self._leaningness = float(np.linalg.norm(top_pos[:2] - bottom_pos[:2])) if upright else 1.0
        return (
            rotation @ (top_pos - uav_lin_pos),
            rotation @ top_vel - uav_lin_vel,
            rotation @ (bottom_pos - uav_lin_pos),
            rotation @ bottom_vel - uav_lin_vel,
        )

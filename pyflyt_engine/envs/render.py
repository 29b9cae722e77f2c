"""The environments' only PyBullet adapter for drawing: target markers and a chase camera.

Markers are visual-only spheres (no collision shape, so they never register contacts).
They are created once, before the world's first reset snapshot, and moved on every
reset and step: nothing is added to or removed from the world during an episode, which
is what lets :meth:`World.reset` restore the saved state instead of rebuilding.
"""

from __future__ import annotations

import math

import numpy as np

from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.state import KinematicState

#: Where unused markers are parked (out of view, below the ground) [m].
_PARKED = (0.0, 0.0, -1000.0)


class Markers:
    """A fixed pool of visual spheres drawn at given ground-frame points."""

    def __init__(self, client: int, count: int, radius: float) -> None:
        self._client = client
        self._ids: list[int] = []
        for _ in range(count):
            shape = p.createVisualShape(
                p.GEOM_SPHERE, radius=radius, rgbaColor=(0.1, 0.8, 0.1, 0.6), physicsClientId=client
            )
            self._ids.append(p.createMultiBody(0.0, -1, shape, basePosition=_PARKED, physicsClientId=client))

    def show(self, points: np.ndarray) -> None:
        """Draw markers at ``points`` (n, 3), the first one brightest; park the rest."""
        n = len(points)
        for i, body in enumerate(self._ids):
            position = tuple(float(v) for v in points[i]) if i < n else _PARKED
            p.resetBasePositionAndOrientation(body, position, (0.0, 0.0, 0.0, 1.0), physicsClientId=self._client)
            if i < n:
                green = 1.0 - 0.7 * i / max(n, 1)
                p.changeVisualShape(body, -1, rgbaColor=(0.1, green, 0.1, 0.6), physicsClientId=self._client)


def chase_camera(
    client: int,
    state: KinematicState,
    resolution: tuple[int, int],
    distance: float,
    height: float,
    fov: float,
) -> np.ndarray:
    """An (H, W, 3) uint8 image from behind and above the vehicle, looking at it.

    Uses PyBullet's software ``ER_TINY_RENDERER``, so it works headless (DIRECT).
    """
    h, w = resolution
    x, y, z = state.lin_pos
    yaw = state.ang_pos[2]
    eye = (x - distance * math.cos(yaw), y - distance * math.sin(yaw), z + height)
    view = p.computeViewMatrix(eye, (x, y, z), (0.0, 0.0, 1.0), physicsClientId=client)
    projection = p.computeProjectionMatrixFOV(fov, w / h, 0.01, 200.0, physicsClientId=client)
    _, _, rgba, _, _ = p.getCameraImage(w, h, view, projection, renderer=p.ER_TINY_RENDERER, physicsClientId=client)
    return np.asarray(rgba, dtype=np.uint8).reshape(h, w, 4)[:, :, :3].copy()


def follow_in_gui(client: int, state: KinematicState, distance: float) -> None:
    """Point the GUI's debug camera at the vehicle (``human`` mode)."""
    yaw_deg = math.degrees(state.ang_pos[2]) - 90.0
    p.resetDebugVisualizerCamera(max(distance * 3, 1.0), yaw_deg, -20.0, state.lin_pos, physicsClientId=client)
